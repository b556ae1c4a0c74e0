"""The corpus benchmark's region classifier (benchmarks/corpus_regions.py) on cases whose answer
is known: given arrays, then small meshes baked with the bake's defaults (a ledge over a wall,
a groove in a block, their open tops), classified at their corners from the baked maps and the
sign of the mean curvature. And the corpus itself (sample_blends/corpus_generator.py): closed
meshes of the promised sizes, the same on every run."""

import numpy as np
import pytest

from benchmarks import corpus_regions as regions
from helpers import corner_values
from porous_weathering.blender import mesh_arrays
from porous_weathering.maps import bake, edges
from scripts import load_script

CORPUS = load_script("sample_blends/corpus_generator.py")
#: The test solids' length along X (m).
LENGTH = 0.3


#: shape -> its height (m), within 2%
HEIGHTS = {"head": 0.3, "draped_figure": 1.74, "relief_panel": 0.7, "column": 2.9, "cornice": 1.0, "gargoyle": 0.49}


@pytest.mark.parametrize("name", sorted(HEIGHTS))
def test_the_corpus_shapes_are_closed_and_of_real_size(name):
    vertices, triangles = CORPUS.shape_mesh(name, "m")
    assert CORPUS.scan_generator.is_closed_manifold(CORPUS.scan_generator.check_mesh(vertices, triangles))
    assert 20_000 <= len(triangles) <= 80_000
    assert vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6)  # standing on z = 0
    assert np.ptp(vertices[:, 2]) == pytest.approx(HEIGHTS[name], rel=0.02)
    again, same = CORPUS.shape_mesh(name, "mm")
    assert np.array_equal(same, triangles) and np.allclose(again * 0.001, vertices)


def test_water_is_rain_or_runoff():
    assert regions.water_reaching([0.0, 0.5, 0.2, 1.0], [0.0, 0.0, 0.5, 0.3]) == pytest.approx([0.0, 0.5, 0.6, 1.0])


def test_streaks_of_given_values():
    """Where rain alone washes (E >= 0.8) there is no streak; below it run-off that brings W to
    0.8 washes a clean streak, weaker run-off (R >= 0.1) leaves a dirty tail, none is neither."""
    rain = np.array([0.9, 0.5, 0.0, 0.0, 0.5, 0.0])
    runoff = np.array([0.0, 0.6, 0.8, 0.4, 0.2, 0.05])
    clean, tails = regions.streak_regions(rain, runoff, 0.8)
    assert clean.tolist() == [False, True, True, False, False, False]
    assert tails.tolist() == [False, False, False, True, True, False]


def test_classes_of_given_values():
    # (E, R, C, H): each line's region
    cases = [
        ((0.02, 0.03, 0.6, -1.0), regions.SHELTERED_HOLLOW),  # dry, in a cavity
        ((0.02, 0.03, 0.6, 1.0), regions.REST),  # dry, but a salient edge (convex)
        ((0.02, 0.03, 0.1, -1.0), regions.REST),  # dry, concave, but hardly curved (C below the cavity part)
        ((0.08, 0.05, 0.6, -1.0), regions.REST),  # W = 0.126: water reaches it
        ((0.9, 0.0, 0.0, 0.0), regions.WASHED),
        ((0.5, 0.6, 0.8, -1.0), regions.WASHED),  # W = 0.8 by the run-off: washed, however hollow
        ((0.5, 0.5, 0.0, 0.0), regions.REST),  # W = 0.75
    ]
    values = np.array([case for case, _ in cases]).T
    assert regions.classify(*values).tolist() == [expected for _, expected in cases]


def add_extruded(name, corners, length=LENGTH, spacing=0.02):
    """The closed solid of the polygon ``corners`` (y, z) in metres, swept along X over
    ``length``, its points about ``spacing`` apart, as an object of the scene."""
    profile = CORPUS.polyline([*corners, corners[0]], spacing)
    vertices, triangles = CORPUS.extrusion(np.linspace(0.0, length, round(length / spacing) + 1), lambda x: profile)
    triangles = CORPUS.outward(vertices, triangles)
    return CORPUS.scan_generator.add_to_scene(name, vertices, triangles)


def baked_regions(obj):
    """(region, corner positions) of every corner of ``obj``, baked with the bake's defaults."""
    bake.bake_maps([obj], bake.BakeOptions(target="attribute"))
    radius = edges.effective_radius(obj, edges.EdgeSettings())
    corner_vertex = mesh_arrays.attribute(obj.data, ".corner_vert", np.int32)
    curvature = edges.curvature(obj, radius)[corner_vertex]
    found = regions.classify(*(corner_values(obj, f"pw_{name}") for name in ("rain", "runoff", "edges")), curvature)
    return found, mesh_arrays.attribute(obj.data, "position", np.float32, 3)[corner_vertex]


def middle(points):
    """Away from the solid's two cut ends."""
    return np.abs(points[:, 0] - LENGTH / 2) < LENGTH / 4


def near(values, target):
    return np.abs(values - target) < 1e-4


@pytest.mark.slow
def test_a_ledge_over_a_wall():
    """A wall (front y = 0, 1.5 m high) with a ledge 0.3 m out at 1.0-1.1 m: the inner corner
    under the ledge gets neither rain nor run-off (the ledge's drip edge) and is concave: a
    sheltered hollow; the wall below, as dry but flat, is none; the ledge's top is washed. (The
    edge mask is sharp at the 17 mm radius of these 1.7 m solids: the corner's own points.)"""
    corners = [(0.3, 0.0), (0.0, 0.0), (0.0, 1.0), (-0.3, 1.0), (-0.3, 1.1), (0.0, 1.1), (0.0, 1.5), (0.3, 1.5)]
    found, at = baked_regions(add_extruded("Ledge", corners))
    y, z = at[:, 1], at[:, 2]
    corner = middle(at) & near(y, 0.0) & near(z, 1.0)
    wall = middle(at) & near(y, 0.0) & (z > 0.6) & (z < 0.94)
    top = middle(at) & near(z, 1.1) & (y < -0.05) & (y > -0.25)
    assert corner.sum() > 10 and wall.sum() > 10 and top.sum() > 10
    assert np.all(found[corner] == regions.SHELTERED_HOLLOW)
    assert not np.any(found[wall] == regions.SHELTERED_HOLLOW)
    assert np.all(found[top] == regions.WASHED)


@pytest.mark.slow
def test_a_groove_and_an_open_top():
    """A block with a groove 0.15 m deep and 0.1 m high across its front: the groove's inner
    corners are sheltered hollows; the block's open top is washed; its plain front, dry but
    flat, is no hollow."""
    corners = [(0.4, 0.0), (0.0, 0.0), (0.0, 0.45), (0.15, 0.45), (0.15, 0.55), (0.0, 0.55), (0.0, 1.0), (0.4, 1.0)]
    found, at = baked_regions(add_extruded("Groove", corners))
    y, z = at[:, 1], at[:, 2]
    inner = middle(at) & near(y, 0.15) & (near(z, 0.45) | near(z, 0.55))
    top = middle(at) & near(z, 1.0) & (y > 0.05) & (y < 0.35)
    front = middle(at) & near(y, 0.0) & (((z > 0.1) & (z < 0.35)) | ((z > 0.65) & (z < 0.9)))
    assert inner.sum() > 10 and top.sum() > 10 and front.sum() > 10
    assert np.all(found[inner] == regions.SHELTERED_HOLLOW)
    assert np.all(found[top] == regions.WASHED)
    assert not np.any(found[front] == regions.SHELTERED_HOLLOW)
