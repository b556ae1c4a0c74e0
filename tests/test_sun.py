"""The sun map S (docs/model.md §9.1, docs/maps.md "Sun exposure"): the year's sun in numpy against
an independent integral, the bake of a box's roof and walls against it at three latitudes and two
north angles, a wall in the shadow of another against a ray test, millimetres and metres alike,
the site taken from the flags, the scene's Sun Position or the default, and bad flags refused
before any work."""

import math
import os
import types

import bpy

import bmesh
import numpy as np
import pytest
from mathutils import Matrix

from helpers import run_cli
from porous_weathering.core import solar
from porous_weathering.maps import neighbours, shadow_rays, sun

#: The box's faces: roof, the four walls (scene frame) and the floor, which no sun reaches.
FACES = {"roof": (0, 0, 1), "+y": (0, 1, 0), "-y": (0, -1, 0), "+x": (1, 0, 0), "-x": (-1, 0, 0), "floor": (0, 0, -1)}
#: Samples of the shadowed wall's bake: its corners within 0.03 of the ray test (a corner's noise
#: at 256 draws, measured, is under 0.01).
WALL_SAMPLES = 256
#: A lone box's faces see every sun nothing shadows: each corner gets its open plane's S exactly, but
#: for the grouping of the suns in ``solar.open_plane_exposures`` (2e-4).
BOX_TOLERANCE = 2e-4


# --- the year in numpy against an independent integral ------------------------------------------------


def independent_exposure(latitude, tilt, azimuth, nodes=512):
    """S of an open plane of ``tilt`` (degrees from horizontal) facing ``azimuth`` (degrees from
    south, east negative, west positive: Duffie & Beckman's γ), integrated continuously in the
    hour angle between sunrise and sunset each day (composite Gauss–Legendre), with the angle of
    incidence written in spherical trigonometry (Duffie & Beckman eq. 1.6.2), not as vectors."""
    phi, beta, gamma = map(math.radians, (latitude, tilt, azimuth))
    x, w = np.polynomial.legendre.leggauss(8)
    total_on_plane = total_normal = 0.0
    for day in range(1, 366):
        delta = math.radians(23.44) * math.sin(2 * math.pi * (284 + day) / 365)
        sunset = math.acos(min(1.0, max(-1.0, -math.tan(phi) * math.tan(delta))))
        if sunset == 0.0:
            continue
        panels = np.linspace(-sunset, sunset, nodes // 8 + 1)
        half = (panels[1:] - panels[:-1])[:, None] / 2
        omega = ((panels[1:] + panels[:-1])[:, None] / 2 + half * x).ravel()
        weight = (half * w).ravel()
        cos_zenith = math.sin(phi) * math.sin(delta) + math.cos(phi) * math.cos(delta) * np.cos(omega)
        zenith = np.degrees(np.arccos(np.clip(cos_zenith, -1, 1)))
        mass = 1 / (cos_zenith + 0.50572 * (96.07995 - zenith) ** -1.6364)
        beam = np.where(cos_zenith > 0, 0.7 ** (np.abs(mass) ** 0.678), 0.0)
        incidence = (
            math.sin(delta) * math.sin(phi) * math.cos(beta)
            - math.sin(delta) * math.cos(phi) * math.sin(beta) * math.cos(gamma)
            + math.cos(delta) * math.cos(phi) * math.cos(beta) * np.cos(omega)
            + math.cos(delta) * math.sin(phi) * math.sin(beta) * math.cos(gamma) * np.cos(omega)
            + math.cos(delta) * math.sin(beta) * math.sin(gamma) * np.sin(omega)
        )
        total_on_plane += float(weight @ (beam * np.maximum(incidence, 0.0)))
        total_normal += float(weight @ beam)
    return total_on_plane / total_normal


def plane_normal(tilt, azimuth):
    """The scene-frame normal (north +Y, east +X) of Duffie & Beckman's (β, γ)."""
    beta, gamma = math.radians(tilt), math.radians(azimuth)
    return (-math.sin(beta) * math.sin(gamma), -math.sin(beta) * math.cos(gamma), math.cos(beta))


@pytest.mark.parametrize("latitude", [0.0, 50.0, -35.0, 67.0, -80.0])
@pytest.mark.parametrize("tilt, azimuth", [(0, 0), (90, 0), (90, 180), (90, -90), (90, 90), (35, 20), (120, -60)])
def test_the_years_sum_is_the_continuous_integral(latitude, tilt, azimuth):
    """Every day, 288 instants: S within 1e-4 of the year integrated continuously over each day."""
    exact = independent_exposure(latitude, tilt, azimuth)
    assert solar.open_plane_exposure(plane_normal(tilt, azimuth), latitude) == pytest.approx(exact, abs=1e-4)


def test_the_figures_of_the_model_at_50_north():
    """docs/model.md §9.1: roof 0.51, south wall 0.46, east and west 0.27, north 0.02."""
    figures = {(0, 0, 1): 0.51, (0, -1, 0): 0.46, (1, 0, 0): 0.27, (-1, 0, 0): 0.27, (0, 1, 0): 0.02}
    for normal, figure in figures.items():
        assert solar.open_plane_exposure(normal, 50.0) == pytest.approx(figure, abs=0.006)


def test_the_weights_are_the_suns_share_and_a_plane_facing_each_sun_gets_one():
    directions, weights = solar.year(50.0)
    assert weights.sum() == pytest.approx(1.0) and np.all(weights > 0) and np.all(directions[:, 2] > 0)
    assert np.linalg.norm(directions, axis=1) == pytest.approx(1.0)
    # noon at the equinox (Cooper's δ is 0 on day 81), 50° N: the sun 40° above the southern horizon
    [noon] = solar.sun_vector(50.0, 0.0, 0.0)[None]
    assert noon == pytest.approx((0.0, -math.sin(math.radians(50)), math.cos(math.radians(50))))


def test_the_north_angle_turns_the_site_clockwise_seen_from_above():
    """North 90° clockwise from +Y is +X, so the south wall of the site faces -X."""
    assert solar.site_to_scene(90.0) @ np.array([0.0, 1.0, 0.0]) == pytest.approx((1.0, 0.0, 0.0))
    assert solar.open_plane_exposure((-1, 0, 0), 50.0, 90.0) == pytest.approx(
        solar.open_plane_exposure((0, -1, 0), 50.0), abs=1e-12
    )


def test_the_open_planes_exposure_is_the_years_sum_on_faces_and_on_a_scans_normals():
    """``open_plane_exposures`` against the sum over every sun (``open_plane_exposure``): within 2e-4
    for a few normals (summed over the suns in groups), within 1e-3 for a scan's many (read on the
    octahedral table), and on the axes, the table's nodes, as summed."""
    directions, weights, days = solar.year_by_day(50.0)
    rng = np.random.default_rng(3)
    normals = rng.normal(size=(solar.OCTAHEDRAL_NODES**2 + 1, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    axes = np.array([FACES[name] for name in FACES], dtype=np.float64)
    normals[: len(axes)] = axes
    summed = np.array([solar.open_plane_exposure(n, 50.0) for n in normals[:200]])
    few = solar.open_plane_exposures(normals[:200], directions, weights, days)
    many = solar.open_plane_exposures(normals, directions, weights, days)
    assert np.abs(few - summed).max() < 2e-4
    assert np.abs(many[:200] - summed).max() < 1e-3
    assert many[: len(axes)] == pytest.approx(few[: len(axes)], abs=1e-12)


def test_the_lattices_draws_are_taken_by_weight():
    """Over many random shifts each position is drawn in proportion to its weight, and one shift's
    draws spread over the year: of 64 draws, 6 to 10 fall in each eighth of the year's weight (8 ± 2,
    where independent draws would land all eight eighths there about one time in twenty)."""
    directions, weights, days = solar.year_by_day(50.0)
    drawn = solar.lattice_draws(weights, days, np.random.default_rng(1).random((4000, 2)), 64)
    counts = np.bincount(drawn.ravel(), minlength=len(weights))
    day_share = np.bincount(days, weights=weights) / weights.sum()
    drawn_share = np.bincount(days[drawn.ravel()], minlength=len(day_share)) / drawn.size
    assert np.abs(drawn_share - day_share).max() < 0.002  # each day by its share of the year's beam
    assert counts.sum() == drawn.size and (drawn >= 0).all() and (drawn < len(weights)).all()
    eighths = np.minimum((np.cumsum(day_share)[days[drawn[0]]] * 8).astype(int), 7)
    assert 6 <= np.bincount(eighths, minlength=8).min() <= np.bincount(eighths, minlength=8).max() <= 10


def test_shadow_rays_meet_what_stands_in_their_way_with_or_without_embree(monkeypatch):
    """A unit square at z = 1: rays from below through it are blocked, past it or away from it not;
    the same through mathutils' BVH (the path without Embree's wheel)."""
    square = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=np.float64), [[0, 1, 2], [0, 2, 3]]
    origins = np.array([[0.5, 0.5, 0.0], [2.0, 0.5, 0.0], [0.5, 0.5, 0.0], [0.2, 0.7, 2.0]])
    towards = np.array([[0, 0, 1.0], [0, 0, 1.0], [0, 0, -1.0], [0, 0, -1.0]])
    expected = [True, False, False, True]
    assert shadow_rays.Occluders(*square).blocked(origins, towards).tolist() == expected
    monkeypatch.setattr(shadow_rays, "rtcore_scene", None)
    assert shadow_rays.Occluders(*square).blocked(origins, towards).tolist() == expected
    assert shadow_rays.Occluders(np.zeros((0, 3)), np.zeros((0, 3))).blocked(origins, towards).tolist() == [False] * 4


def test_first_hits_name_the_triangle_a_ray_meets_first_with_or_without_embree(monkeypatch):
    """Two squares at z = 1 and z = 2, two triangles each: a ray up from below meets the lower
    square's triangle on its side of the diagonal, one from between them the upper's, one past
    them or away from them none; the same through mathutils' BVH."""
    points = np.array([[[0, 0, z], [1, 0, z], [1, 1, z], [0, 1, z]] for z in (1.0, 2.0)]).reshape(-1, 3)
    triangles = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]
    origins = np.array([[0.7, 0.3, 0.0], [0.2, 0.7, 0.0], [0.2, 0.7, 1.5], [2.0, 0.5, 0.0], [0.7, 0.3, 0.0]])
    towards = np.array([[0, 0, 1.0], [0, 0, 1.0], [0, 0, 1.0], [0, 0, 1.0], [0, 0, -1.0]])
    expected = [0, 1, 3, -1, -1]
    assert shadow_rays.Occluders(points, triangles).first_hits(origins, towards).tolist() == expected
    monkeypatch.setattr(shadow_rays, "rtcore_scene", None)
    assert shadow_rays.Occluders(points, triangles).first_hits(origins, towards).tolist() == expected


# --- the bake -------------------------------------------------------------------------------------------


def box(name="Box", size=2.0, location=(0.0, 0.0, 0.0)):
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_cube(bm, size=size, calc_uvs=True)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    return obj


def face_names(obj):
    """The FACES name of each polygon of the box, from its normal."""
    return [next(k for k, n in FACES.items() if np.dot(p.normal, n) > 0.99) for p in obj.data.polygons]


@pytest.mark.parametrize("latitude", [0.0, 50.0, -35.0])
@pytest.mark.parametrize("north_angle", [0.0, 90.0])
def test_a_box_bakes_to_the_exact_exposure_of_its_faces(fresh_scene, latitude, north_angle):
    obj = box()
    settings = sun.SunSettings(latitude=latitude, north_angle=north_angle)
    corners = sun.bake_sun_corners(obj, settings)
    corner_face = np.repeat(np.arange(len(obj.data.polygons)), [p.loop_total for p in obj.data.polygons])
    for index, name in enumerate(face_names(obj)):
        exact = solar.open_plane_exposure(FACES[name], latitude, north_angle)
        baked = corners[corner_face == index]
        assert np.abs(baked - exact).max() < BOX_TOLERANCE, name
        if name == "floor":
            assert np.all(baked == 0.0)


def test_a_box_bakes_to_an_image_of_its_faces(fresh_scene):
    """The image target at 50° N: each face's texels (inside its UV rectangle) average to its S."""
    obj = box()
    size = 64
    image = sun.bake_sun_image(obj, "UVMap", size, sun.SunSettings(latitude=50.0, samples=64), margin=0)
    uv = np.empty(len(obj.data.loops) * 2, np.float32)
    obj.data.uv_layers["UVMap"].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    for polygon, name in zip(obj.data.polygons, face_names(obj)):
        corners = uv[polygon.loop_start : polygon.loop_start + polygon.loop_total]
        low, high = np.ceil(corners.min(axis=0) * size) + 1, np.floor(corners.max(axis=0) * size) - 1
        texels = image[::-1][int(low[1]) : int(high[1]), int(low[0]) : int(high[0])]  # bottom row first, as UVs
        assert texels.size > 20
        exact = solar.open_plane_exposure(FACES[name], 50.0)
        assert np.abs(texels - exact).max() < BOX_TOLERANCE, name


def shadowed_wall(scale=1.0):
    """A south wall (1 x 1, facing -Y, a 4 x 4 grid) and 1 m before it a wider wall 0.8 high
    (x from -2 to 3) that shades its lower part when the sun is low in the south."""
    wall = bpy.data.meshes.new("Wall")
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=4, y_segments=4, size=0.5)
    bmesh.ops.rotate(bm, verts=bm.verts, matrix=Matrix.Rotation(math.pi / 2, 3, "X"))
    bmesh.ops.translate(bm, verts=bm.verts, vec=(0.5, 0.0, 0.5))
    bm.to_mesh(wall)
    bm.free()
    wall.transform(Matrix.Scale(scale, 4))
    target = bpy.data.objects.new("Wall", wall)
    screen = bpy.data.meshes.new("Screen")
    screen.from_pydata([(-2, -1, 0), (3, -1, 0), (3, -1, 0.8), (-2, -1, 0.8)], [], [(0, 1, 2, 3)])
    screen.transform(Matrix.Scale(scale, 4))
    for obj in (target, bpy.data.objects.new("Screen", screen)):
        bpy.context.scene.collection.objects.link(obj)
    return target


def shadowed_exposure(points, latitude):
    """S at ``points`` (on the wall, metres) by ray tests against the screen (y = -1, x in [-2, 3],
    z in [0, 0.8]), over the year's suns."""
    directions, weights = solar.year(latitude)
    south = directions[:, 1] < 0
    exposure = []
    for p in points:
        reach = (-1.0 - p[1]) / np.where(south, directions[:, 1], -1.0)  # ray length to the screen's plane
        x, z = p[0] + reach * directions[:, 0], p[2] + reach * directions[:, 2]
        blocked = south & (x > -2) & (x < 3) & (z > 0) & (z < 0.8)
        exposure.append(weights @ (np.maximum(-directions[:, 1], 0.0) * ~blocked))
    return np.array(exposure)


def corner_points(obj):
    positions = np.array([v.co for v in obj.data.vertices])
    return positions[[loop.vertex_index for loop in obj.data.loops]]


def test_a_wall_in_the_shadow_of_another_bakes_to_the_ray_test(fresh_scene):
    wall = shadowed_wall()
    settings = sun.SunSettings(latitude=50.0, samples=WALL_SAMPLES)
    baked = sun.bake_sun_corners(wall, settings, neighbours.default_occluders(wall))
    points = corner_points(wall)
    inside = (points[:, 2] > 0.1) & (points[:, 2] < 0.9) & (points[:, 0] > 0.1) & (points[:, 0] < 0.9)
    exact = shadowed_exposure(points, 50.0)
    assert exact[inside].min() < 0.3 < 0.45 < exact[inside].max()  # the shadow takes a third at the foot
    assert np.abs(baked[inside] - exact[inside]).max() < 0.03
    assert abs(baked[inside].mean() - exact[inside].mean()) < 0.01


def test_millimetres_and_metres_bake_the_same(fresh_scene):
    settings = sun.SunSettings(latitude=50.0, samples=16)
    wall = shadowed_wall()
    metres = sun.bake_sun_corners(wall, settings, neighbours.default_occluders(wall))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.unit_settings.scale_length = 0.001
    wall = shadowed_wall(scale=1000.0)
    millimetres = sun.bake_sun_corners(wall, settings, neighbours.default_occluders(wall))
    assert np.abs(metres - millimetres).max() < 1e-3


# --- the site ----------------------------------------------------------------------------------------


def test_the_site_comes_from_the_flags_then_the_sun_position_add_on_then_the_default():
    sun_position = types.SimpleNamespace(sun_pos_properties=types.SimpleNamespace(latitude=-33.9, north_offset=0.5))
    bare = types.SimpleNamespace()
    assert sun.site(sun.SunSettings(), bare) == (sun.DEFAULT_LATITUDE, 0.0)
    assert sun.site(sun.SunSettings(), sun_position) == pytest.approx((-33.9, math.degrees(0.5)))
    assert sun.site(sun.SunSettings(latitude=10.0), sun_position) == pytest.approx((10.0, math.degrees(0.5)))
    assert sun.site(sun.SunSettings(latitude=0.0, north_angle=0.0), sun_position) == (0.0, 0.0)


def test_without_the_add_on_the_scene_has_no_sun_position(fresh_scene):
    """Blender 4.2 and later ship Sun Position as an extension: absent here, and guarded."""
    if hasattr(fresh_scene, "sun_pos_properties"):
        pytest.skip("the Sun Position add-on is installed here")
    assert sun.site(sun.SunSettings(), fresh_scene) == (sun.DEFAULT_LATITUDE, 0.0)


@pytest.fixture
def blend(fresh_scene, tmp_path):
    box()
    path = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return path


@pytest.mark.parametrize(
    "flag, value, message",
    [
        ("--latitude", "91", "latitude must be in [-90, 90] degrees"),
        ("--latitude", "nan", "latitude must be"),
        ("--north-angle", "inf", "north angle must be a finite number"),
        ("--sun-samples", "0", "sun samples must be"),
    ],
)
def test_bad_flags_fail_with_one_line_before_any_work(blend, tmp_path, flag, value, message):
    out = tmp_path / "maps"
    result = run_cli("bake", blend, "--maps", "sun", "--out", out, flag, value)
    assert result.returncode == 2, result.stderr
    [line] = result.stderr.splitlines()
    assert line.startswith("error: ") and message in line
    assert not out.exists() and sorted(os.listdir(tmp_path)) == ["scene.blend"]


def test_the_command_line_bakes_the_sun_map_at_its_site(blend, tmp_path):
    out = tmp_path / "maps"
    result = run_cli("bake", blend, "--maps", "sun", "--out", out, "--resolution", "16", "--latitude", "-35")
    assert result.returncode == 0, result.stderr
    assert sorted(os.listdir(out)) == ["Box.sun.exr"]
    again = run_cli("bake", blend, "--maps", "sun", "--out", out, "--resolution", "16", "--latitude", "50")
    # another latitude is another map: baked again
    assert again.returncode == 0 and any(line.startswith("written   Box.sun") for line in again.stdout.splitlines())
