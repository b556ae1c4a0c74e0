"""The committed sample scenes: they open, have porous preset materials, render, are what
sample_blends/build_samples.py builds, and, weathered as the main job weathers them
(demo.Sample), show each mode's areas where they belong (pixel regions) and equal model.py
pixel by pixel, with the API's defaults and with the paper-exact settings. The scan-like bust
is baked on the command line and made from the panel once, end to end."""

import math
import pathlib
import shutil
import subprocess
import sys

import bpy

import numpy as np
import pytest

import porous_weathering
from benchmarks import probes
from helpers import (
    assert_matches,
    expected_image,
    rivulets_of,
    stone_glossy_lobe,
    stone_parameters,
    stone_shifted,
    stone_weights,
)
from porous_weathering.blender import render
from porous_weathering.contracts import GROUP_NODE, socket_name
from porous_weathering.core import model, stones
from porous_weathering.samples import demo, studio
from porous_weathering.shading import nodes, weathering
from porous_weathering.ui import panel as ui
from scripts import OLDEST_LINE, load_script

ROOT = pathlib.Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_blends"

build_samples = load_script("sample_blends/build_samples.py")

#: Most bytes and triangles of a sample: small, for the repository and quick tests; but the
#: scan-like bust, whose size is its point (a scan of a bust has 100k-1M triangles): at least
#: 200k triangles, 4.5 MB compressed.
LIMITS = {"bust": (6_000_000, 250_000)}
SMALL = (2_000_000, 40_000)


def meshes(scene):
    return sorted((obj for obj in scene.objects if obj.type == "MESH"), key=lambda obj: obj.name)


def summary(path):
    """What must not change between builds: objects, their sizes and materials, the materials'
    drivers (the key light's, the unit's), the node groups."""
    bpy.ops.wm.open_mainfile(filepath=str(path))
    objects = [
        (obj.name, len(obj.data.vertices), len(obj.data.polygons), [m.name for m in obj.data.materials])
        for obj in meshes(bpy.context.scene)
    ]
    drivers = sorted(
        (material.name, fcurve.data_path, fcurve.array_index)
        for material in bpy.data.materials
        if material.node_tree and material.node_tree.animation_data
        for fcurve in material.node_tree.animation_data.drivers
    )
    return objects, drivers, sorted((group.name, len(group.nodes)) for group in bpy.data.node_groups)


@pytest.mark.parametrize("name", build_samples.SAMPLES)
def test_sample_opens_with_porous_materials_and_renders(name):
    path = SAMPLES / f"{name}.blend"
    most_bytes, most_triangles = LIMITS.get(name, SMALL)
    assert path.stat().st_size < most_bytes
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert bpy.data.version[:2] == OLDEST_LINE, "rebuild it with the bpy module of the oldest line"
    scene = bpy.context.scene
    assert scene.camera is not None and scene.render.engine == "CYCLES"
    assert any(obj.type == "LIGHT" and obj.data.type == "SUN" for obj in scene.objects)
    triangles = 0
    for obj in meshes(scene):
        assert obj.data.materials, f"{obj.name} has no material"
        assert all("pw_preset" in material for material in obj.data.materials), obj.name
        obj.data.calc_loop_triangles()
        triangles += len(obj.data.loop_triangles)
    assert triangles < most_triangles
    if name == "bust":  # a scan: 200k triangles, no UV map, in millimetres
        bust = bpy.data.objects["Bust"].data
        bust.calc_loop_triangles()
        assert len(bust.loop_triangles) >= build_samples.BUST_TRIANGLES
        assert not bpy.data.objects["Bust"].data.uv_layers
        assert scene.unit_settings.scale_length == pytest.approx(0.001)
        assert max(bpy.data.objects["Bust"].dimensions) == pytest.approx(500.0, rel=0.01)
    render.use_cycles(scene, size=32, samples=2, bounces=2)
    image = render.render_array(scene)
    assert np.isfinite(image).all()
    covered = image[..., 3] > 0.5
    assert covered.mean() > 0.25, "the camera must frame the scene"
    assert image[..., :3][covered].mean() > 0.05, "the scene must be lit"


def test_samples_are_what_the_script_builds(tmp_path):
    for name in build_samples.SAMPLES:
        rebuilt = build_samples.build(name, tmp_path)
        assert summary(SAMPLES / f"{name}.blend") == summary(rebuilt), (
            f"sample_blends/{name}.blend is stale: run python sample_blends/build_samples.py"
        )


# --- weathered as the main job weathers them ----------------------------------------------


class Weathered:
    """A sample weathered in ``mode`` (demo.Sample): the late-over-clean luminance of its
    render at age 0 and ``age``, what model.py predicts for it per pixel (at the stone's
    per-point parameters, read back from its "Stone" node), and each map the mode reads, probed
    per pixel on the weathered objects (the others held out: they still hide what
    lies behind them, as in the renders, but leave their pixels transparent)."""

    def __init__(self, name, mode, age, map_dir, size=48):
        sample = demo.Sample(name, bake_samples=8, map_dir=map_dir)
        scene = sample.scene
        render.use_cycles(scene, size=size, samples=16)  # direct light: no bounce between weathered faces
        scene.render.resolution_x = size * 4 // 3
        self.inputs = {**{n: model.WEATHERING_INPUTS[n][0] for n in model.inputs_of(mode)}, **sample.inputs(mode)}
        sample.show(mode, 0.0)
        clean = render.render_array(scene)
        sample.show(mode, age)
        self.ratio = luminance(render.render_array(scene)) / np.maximum(luminance(clean), 1e-4)
        holdout = probes.holdout_material()
        for obj in scene.objects:
            if obj.type == "MESH" and obj not in sample.objects:
                studio.assign(obj, holdout)
        self.maps = {
            mask: self.probe(sample, mask_probe(sample.sources[map_name]))[..., 0]
            for mask, map_name in sample.recipe.masks[mode].items()
        }
        position = self.probe(sample, probes.position_probe())
        self.covered, self.position = position[..., 3] > 0.999, (position[..., :3] - 0.5) * 10.0
        self.lit = self.covered & (luminance(clean) > 0.02)
        normals = self.probe(sample, probes.normal_probe())[..., :3] * 2.0 - 1.0
        towards_camera = np.array(scene.camera.location) - self.position
        n_dot_v = (normals * towards_camera).sum(-1) / np.linalg.norm(towards_camera, axis=-1)
        n_dot_l = normals @ np.array(sample.sun.matrix_world.to_3x3().col[2])
        # the stone's per-point parameters, each pixel's mean over its samples as the render's is
        stone = stone_parameters(lambda material: self.probe(sample, material), sample.material(mode))
        stone["z_p"] = stone_shifted(lambda material: self.probe(sample, material), sample.material(mode), nodes.FIELD)
        ks = sample.stone["ks"]
        (whole,) = sample.objects  # the place from its origin: the run-off's rivulets (docs/model.md §8.8)
        rivulets = rivulets_of(sample.material(mode), self.position, normals, whole, scene)

        def diffuse(time):
            weights = stone_weights(
                stone,
                ks,
                n_dot_l,
                n_dot_v,
                (mode,),
                stones.DEFAULT_VARIATION,
                rivulets=rivulets,
                **{**self.inputs, "time": time, **self.maps},
            )
            return luminance(weights[0])

        self.expected = diffuse(age) / np.maximum(diffuse(0.0), 1e-6)

    @staticmethod
    def probe(sample, material):
        for obj in sample.objects:
            studio.assign(obj, material)
        return render.render_array(sample.scene)

    def area(self, **bounds):
        """Lit pixels whose map values lie within ``bounds``: {mask: (low, high)}."""
        selected = self.lit.copy()
        for mask, (low, high) in bounds.items():
            selected &= (low <= self.maps[mask]) & (self.maps[mask] <= high)
        return selected

    def water_area(self, low, high):
        """Lit pixels where the water reaching them, W = 1 - (1 - E)(1 - runoff R) (docs/model.md
        §7.2; E alone where the mode reads no run-off map), lies within [low, high]."""
        runoff = self.inputs.get("runoff", 0.0) * self.maps.get("runoff_map", 0.0)
        water = 1.0 - (1.0 - self.maps["rain_map"]) * (1.0 - runoff)
        return self.lit & (low <= water) & (water <= high)

    def change(self, area):
        """(rendered, model.py's) mean late-over-clean luminance in ``area``, which must hold
        enough pixels to judge."""
        assert area.sum() >= 12, "the area must be in view"
        return float(self.ratio[area].mean()), float(self.expected[area].mean())


def mask_probe(source):
    """Emits a mask source (an attribute name or an image path) as the material reads it."""
    mask = weathering.mask_source("efflorescence_map", source)
    return probes.emission_probe("Mask Probe", lambda graph, geometry: weathering.mask_socket(graph, mask))


def luminance(image):
    return np.asarray(image)[..., :3] @ np.array([0.2126, 0.7152, 0.0722])


def soiling_areas(weathered):
    """docs/model.md §4's three areas by the baked maps: white where water washes (W, rain or
    run-off, at or above the threshold: §7.2), grey where it is sheltered and flat, black where
    sheltered on an edge or cavity."""
    threshold, width = weathered.inputs["rain_threshold"], weathered.inputs["front_width"]
    sheltered = weathered.water_area(0.0, threshold - width)
    return {
        "white": weathered.water_area(threshold + 0.05, 1.0),
        "grey": sheltered & weathered.area(edge_map=(0.0, 0.05)),
        "black": sheltered & weathered.area(edge_map=(0.5, 1.0)),
    }


@pytest.mark.parametrize(
    "name, shaded",
    [("limestone_facade", ("grey", "black")), ("sculpted_stone", ("black",))],
    ids=["limestone_facade", "sculpted_stone"],
)
def test_soiled_sample_shows_its_areas(name, shaded, tmp_path):
    """The façade shows all three areas; the sculpted stone, all relief, its white tops and the
    black crust in its sheltered hollows and edges."""
    weathered = Weathered(name, model.SOILING, 1.0, tmp_path)
    areas = soiling_areas(weathered)
    white, _ = weathered.change(areas["white"])
    assert white == pytest.approx(1.0, abs=0.03), "rain-washed stone stays clean"
    for area in shaded:
        rendered, expected = weathered.change(areas[area])
        assert rendered == pytest.approx(expected, abs=0.05), area
    assert weathered.change(areas["black"])[0] < white - 0.3, "the crust is dark"


def distance_to_joint(x, z):
    """Distance (m) from a point on the brick wall's face to the nearest joint centre line."""
    pitch, course = build_samples.BRICK.x + build_samples.JOINT, build_samples.BRICK.z + build_samples.JOINT
    bed = np.mod(z - build_samples.JOINT / 2, course)
    odd_course = np.floor((z - build_samples.JOINT / 2) / course) % 2
    head = np.mod(x + build_samples.JOINT / 2 - odd_course * pitch / 2, pitch)
    return np.minimum(np.minimum(bed, course - bed), np.minimum(head, pitch - head))


def test_joint_map_follows_the_bond_the_sample_builds():
    assert (demo.JOINT_MAP["rows"], demo.JOINT_MAP["bricks_per_row"]) == (
        build_samples.COURSES,
        build_samples.BRICKS_PER_COURSE,
    )


def test_brick_wall_is_laid_brick_by_brick(tmp_path):
    """Each brick is a block of its own (its loose part, docs/model.md §8.5): the bricks' mean
    porosity differs from brick to brick by far more than within one; the mortar behind them
    weathers as the lime mortar it is, with the same maps."""
    sample = demo.Sample("brick_wall", bake_samples=4, map_dir=tmp_path)
    scene = sample.scene
    assert [obj.name for obj in sample.parts] == ["Mortar"]
    sample.show(model.SOILING, 1.0)
    (mortar,) = sample.parts
    assert sample.material(model.SOILING, "LIME_MORTAR") is mortar.active_material
    time = mortar.active_material.node_tree.nodes[GROUP_NODE].inputs[socket_name("time")]
    assert time.default_value == 1.0
    render.use_cycles(scene, size=96, samples=1)
    for obj in scene.objects:
        if obj.type == "MESH" and obj not in sample.objects:
            studio.assign(obj, probes.holdout_material())

    def shade(material):
        for obj in sample.objects:
            studio.assign(obj, material)
        return render.render_array(scene)

    probe = shade(probes.position_probe())
    position = (probe[..., :3] - 0.5) * 10.0
    alpha = stone_parameters(shade, sample.material(model.SOILING))["alpha"]
    x, z = position[..., 0], position[..., 2]
    pitch, course = build_samples.BRICK.x + build_samples.JOINT, build_samples.BRICK.z + build_samples.JOINT
    rows = np.floor((z - build_samples.JOINT / 2) / course)
    bricks = np.floor((x + build_samples.JOINT / 2 - (rows % 2) * pitch / 2) / pitch)
    inside = (probe[..., 3] > 0.999) & (distance_to_joint(x, z) > 0.015)
    keys = (rows * 100 + bricks)[inside]
    means = [alpha[inside][keys == key].mean() for key in np.unique(keys) if (keys == key).sum() >= 6]
    assert len(means) >= 20, "the picture shows many bricks"
    halves = [alpha[inside][keys == key] for key in np.unique(keys) if (keys == key).sum() >= 6]
    within = np.std([h[: len(h) // 2].mean() - h[len(h) // 2 :].mean() for h in halves])
    # 2.9 here; 0.5 without the blocks (the patches alone)
    assert np.std(means) > 2 * within, "neighbouring bricks differ, each its own draw"


def test_brick_wall_effloresces_along_its_joints(tmp_path):
    age = 0.66
    weathered = Weathered("brick_wall", model.EFFLORESCENCE, age, tmp_path)
    # above the rising damp's tide mark (docs/model.md §9.2), where the salt follows the joints alone
    dry = dict(damp_map=(0.0, 0.01))
    salted = weathered.area(efflorescence_map=(0.7, 1.0), **dry)
    bare = weathered.area(efflorescence_map=(0.0, 0.2), **dry)
    assert weathered.change(bare)[0] == pytest.approx(1.0, abs=0.03), "salt has not reached the brick faces yet"
    rendered, expected = weathered.change(salted)
    assert expected > 2.0 and rendered == pytest.approx(expected, rel=0.1), "salt whitens the joints' edges"
    distance = distance_to_joint(weathered.position[..., 0], weathered.position[..., 2])
    assert distance[salted].mean() < 0.5 * distance[bare].mean(), "the salt lies along the joints"


def test_brick_wall_wets_where_rain_reaches(tmp_path):
    """Driven rain reaches the brick faces (E = sin 25 degrees there) and runs down them: dry
    while the wet front is above the water W there (as the model says, with the run-off's rivulets
    where a feature gathered the flow, docs/model.md §8.8), then darker (the wet darkening), with the
    water lobe's faint reflection of the sky on top, which the diffuse model lacks (water
    reflects 2% face on: docs/weathering.md)."""
    early = Weathered("brick_wall", model.WET, 0.3, tmp_path)
    area = early.water_area(0.3, 0.5)
    rendered, expected = early.change(area)
    ratio = early.ratio[area]
    assert np.median(ratio) > 0.99 and (ratio < 0.9).mean() < 0.25  # dry but the rivulets' cores (§8.8)
    assert rendered == pytest.approx(expected, abs=0.03)
    late = Weathered("brick_wall", model.WET, 1.0, tmp_path)
    rendered, diffuse_only = late.change(late.water_area(0.3, 1.0))
    assert rendered < 0.8, "wet brick is darker than dry"
    assert rendered > diffuse_only + 0.02, "and its water reflects the sky a little"


# --- pixel by pixel against model.py, with the defaults and the paper-exact settings --------------

#: Each mode's inputs beyond the paper (docs/model.md §6) at their paper-exact values.
PAPER_EXACT = {model.SOILING: dict(crust=0.0), model.WET: dict(wet_darkening=0.0)}


#: The rivulets' spacing (metres) of the pixel-by-pixel check: at the stones' 10 cm a rivulet's flank
#: turns a read-back place's float32 rounding into more than the check's 1e-4 (docs/model.md §8.8).
WIDE_RIVULETS = 1.0


def widen_rivulets(material):
    group = material.node_tree.nodes[GROUP_NODE]
    if nodes.RIVULET_SPACING in group.inputs:
        group.inputs[nodes.RIVULET_SPACING].default_value = WIDE_RIVULETS


@pytest.mark.parametrize("name", ["limestone_facade", "sculpted_stone", "brick_wall"])
def test_sample_renders_equal_the_model_pixel_by_pixel(name, tmp_path):
    """Every mode of the sample's recipe at t = 0.66 and 1, with the API's defaults (black crust
    and wet darkening on) and with the paper-exact settings (crust = 0, wet_darkening = 0): each
    pixel of the weathered objects is model.py's k_d D + k_s G + k_water W at the stone's
    per-point k_d, alpha, s_p, m, receptivity and porosity field (read back from the material's "Stone" node),
    D, G and W being renders of a white Lambert, a white GGX of the per-point roughness m and one
    of the water's. The sun alone lights it (no sky, no bounce), so that each pixel is one point
    lit one way."""
    sample = demo.Sample(name, bake_samples=8, map_dir=tmp_path)
    scene = sample.scene
    scene.world = None
    render.use_cycles(scene, size=48, samples=1)
    scene.render.resolution_x = 64
    holdout = probes.holdout_material()
    for obj in scene.objects:
        if obj.type == "MESH" and obj not in sample.objects:
            studio.assign(obj, holdout)

    def shade(material):
        for obj in sample.objects:
            studio.assign(obj, material)
        return render.render_array(scene)

    position = shade(probes.position_probe(0.05))
    covered = position[..., 3] > 0.999
    points = (position[..., :3] - 0.5) / 0.05
    normals = shade(probes.normal_probe())[..., :3] * 2.0 - 1.0
    normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-9)
    towards_camera = np.array(scene.camera.matrix_world.translation) - points
    n_dot_v = (normals * towards_camera).sum(-1) / np.linalg.norm(towards_camera, axis=-1)
    n_dot_l = normals @ np.array(sample.sun.matrix_world.to_3x3().col[2])
    (whole,) = sample.objects  # the place from its origin: the run-off's rivulets (docs/model.md §8.8)
    ks = sample.stone["ks"]
    water = sample.stone.get("water_roughness", nodes.WATER_ROUGHNESS)
    # The stone is the same in every mode's material: its per-point parameters and the white GGX
    # lobe of its per-point roughness, read once.
    first = sample.material(next(iter(sample.recipe.masks)))
    ashlar = isinstance(sample.recipe.masonry, stones.Ashlar)  # joints drawn; a MeshBlocks' are modelled
    stone = stone_parameters(shade, first, extra=("Joint",) if ashlar else ())
    stone["z_p"] = stone_shifted(shade, first, nodes.FIELD)  # the uptake's field (docs/model.md §8.7)
    assert np.ptp(stone["alpha"][covered]) > 0.01, "the sample shows its stone"
    if ashlar:  # some pixels land in the mortar (its share of the wall, ~4%)
        assert 0.01 < (stone["Joint"][covered] > 0.5).mean() < 0.2, "the façade is laid in ashlar"
    lobes = [
        shade(porous_weathering.make_base_material("D", base_color=(1, 1, 1), ks=0.0))[..., :3],
        stone_glossy_lobe(shade, first),
        shade(porous_weathering.make_base_material("W", base_color=(0, 0, 0), ks=1.0, roughness=water))[..., :3],
    ]
    checked = 0
    for mode, masks in sample.recipe.masks.items():
        inputs = sample.inputs(mode)
        assert "water_roughness" not in inputs, "the water roughness is the stone's (a material option)"
        values = {mask: shade(mask_probe(sample.sources[map_name]))[..., 0] for mask, map_name in masks.items()}
        late = []
        for changes in ({}, PAPER_EXACT.get(mode)):
            if changes is None:
                continue
            for age in (0.66, 1.0):
                sample.show(mode, age, **changes)
                widen_rivulets(sample.material(mode, **changes))
                image = render.render_array(scene)
                late += [image] if age == 1.0 else []
                weights = stone_weights(
                    stone,
                    ks,
                    n_dot_l,
                    n_dot_v,
                    (mode,),
                    stones.DEFAULT_VARIATION,
                    rivulets=rivulets_of(sample.material(mode, **changes), points, normals, whole, scene),
                    **{**inputs, **changes, "time": age, **values},
                )
                assert_matches(image, expected_image(weights, lobes), covered)
                checked += 1
        if mode in PAPER_EXACT:  # the defaults go beyond the paper, visibly
            assert np.abs(late[0] - late[1])[covered].max() > 0.02, mode
    assert checked >= 4


# --- the scan-like bust, end to end -------------------------------------------------------------

#: The main job's driven rain (demo.DRIVEN_RAIN) on the command line: 25 degrees from the front.
DRIVEN_RAIN_FLAGS = ["--wind-azimuth", "-90", "--wind-tilt", "25"]


def vertex_values(mesh, name):
    """A colour attribute's first channel per vertex (corner values averaged)."""
    attribute = mesh.color_attributes[name]
    values = np.empty(len(attribute.data) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", values)
    values = values[::4]
    if attribute.domain == "CORNER":
        corners = np.empty(len(mesh.loops), dtype=np.int32)
        mesh.loops.foreach_get("vertex_index", corners)
        sums = np.bincount(corners, weights=values, minlength=len(mesh.vertices))
        values = sums / np.maximum(np.bincount(corners, minlength=len(mesh.vertices)), 1)
    return values


class BustPoints:
    """The bust's vertices (mm) and normals, and where its features are (scan_generator's
    layout: the face looks along -Y, the head is turned 5 degrees, the face is ~105 mm across
    in radius, the eyes 31 mm off its centre line at z = 361, the ears at the sides, z = 350)."""

    def __init__(self, mesh):
        self.points = np.empty((len(mesh.vertices), 3))
        mesh.vertices.foreach_get("co", self.points.ravel())
        self.normals = np.empty((len(mesh.vertices), 3))
        mesh.vertices.foreach_get("normal", self.normals.ravel())
        x, y, self.z = self.points.T
        phi = np.arctan2(y, x) - math.radians(5.0)
        self.alpha = (phi + math.pi / 2 + math.pi) % (2 * math.pi) - math.pi  # 0 at the front
        self.u = self.alpha * 105.0  # mm across the face
        self.radius = np.hypot(x, y)

    def face_under_the_brim(self):
        return (np.abs(self.u) < 50) & (self.z > 300) & (self.z < 400) & (self.normals[:, 1] < -0.7)

    def hat_top(self):
        return (self.z > 420) & (self.normals[:, 2] > 0.6)

    def chest(self):
        return (self.z > 110) & (self.z < 200) & (self.normals[:, 1] < -0.7) & (self.normals[:, 2] > -0.1)

    def brim_edge(self):
        brim = (self.z > 400) & (self.z < 425)
        return brim & (self.radius > 0.95 * self.radius[brim].max())

    def eye_sockets(self):
        socket = np.hypot((np.abs(self.u) - 31.0) / 16.0, (self.z - 361.0) / 11.0) < 1.0
        eyeball = np.hypot((np.abs(self.u) - 31.0) / 7.0, (self.z - 358.5) / 5.0) < 1.0
        return socket & ~eyeball & (self.radius < 120)

    def ears(self):
        behind = (np.abs(self.alpha) - math.pi / 2) * 80.0  # mm from the ear's centre, > 0 towards the back
        return (np.abs(behind) < 14.0) & (np.abs(self.z - 350.0) < 22.0) & (self.radius < 120)

    def cheeks(self):
        return (np.abs(np.abs(self.u) - 45.0) < 8.0) & (self.z > 322) & (self.z < 340) & (self.normals[:, 1] < -0.5)


def test_bust_bakes_on_the_command_line_and_weathers_from_the_panel(tmp_path):
    """The scan-like bust (200k triangles, no UV map, millimetres), as a heritage team would
    weather a scan: ``bake --target attribute --save`` on the command line, then the panel's
    Make with soiling. The maps are sane where the bust's shape says: driven rain washes the hat
    and the chest but not the face under the brim; the brim's edge, the ears and the eye
    sockets light the edge mask and the smooth cheeks do not; and the weathered render is
    darker on the sheltered face than on the washed hat."""
    blend = tmp_path / "bust.blend"
    shutil.copy(SAMPLES / "bust.blend", blend)
    command = [sys.executable, "-m", "porous_weathering", "bake", str(blend), "--target", "attribute", "--save"]
    done = subprocess.run(
        [*command, "--samples", "8", *DRIVEN_RAIN_FLAGS], cwd=ROOT, capture_output=True, text=True, timeout=3600
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]

    bpy.ops.wm.open_mainfile(filepath=str(blend))
    bust = bpy.data.objects["Bust"]
    assert not bust.data.uv_layers, "the attribute bake needs no UV map, and makes none"
    at = BustPoints(bust.data)
    rain, edges = vertex_values(bust.data, "pw_rain"), vertex_values(bust.data, "pw_edges")
    face, hat, chest = rain[at.face_under_the_brim()], rain[at.hat_top()], rain[at.chest()]
    assert face.size > 500 and np.mean(face) < 0.05, "the brim shelters the face from the driven rain"
    assert np.mean(hat) > 0.6 and np.mean(chest) > 0.2, "driven rain washes the hat and reaches the chest"
    cheeks = np.median(edges[at.cheeks()])
    assert cheeks < 0.2, "smooth stone (with scan noise) is not an edge"
    for feature in ("brim_edge", "eye_sockets", "ears"):
        lit = np.percentile(edges[getattr(at, feature)()], 90)
        assert lit > 0.5 and lit > cheeks + 0.4, feature

    porous_weathering.register()
    try:
        for obj in bpy.context.scene.objects:
            obj.select_set(obj is bust)
        bpy.context.view_layer.objects.active = bust
        settings = bpy.context.scene.porous_weathering
        settings.soiling = True
        assert ui.missing_maps(bust, ("soiling",)) == []
        assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
        made = bust.active_material
        group = made.node_tree.nodes["Porous"]
        for socket, attribute in (("Rain Map", "pw_rain"), ("Edge Map", "pw_edges")):
            node = group.inputs[socket].links[0].from_node
            assert node.type == "ATTRIBUTE" and node.attribute_name == attribute
        assert made["pw_light_mode"] == "SUN"
        scene = bpy.context.scene
        render.use_cycles(scene, size=64, samples=4)
        images = {}
        for age in (0.0, 1.0):
            weathering.set_input(group, "time", age)
            images[age] = luminance(render.render_array(scene))
        studio.assign(bust, probes.position_probe(0.001))
        where = render.render_array(scene)
        studio.assign(bust, probes.normal_probe())
        up = render.render_array(scene)[..., 2] * 2.0 - 1.0
    finally:
        porous_weathering.unregister()
    x, y, z = np.moveaxis((where[..., :3] - 0.5) / 0.001, -1, 0)
    covered = where[..., 3] > 0.999
    ratio = images[1.0] / np.maximum(images[0.0], 1e-4)
    face = covered & (z > 300) & (z < 400) & (np.abs(x) < 50) & (y < -60)
    hat = covered & (z > 410) & (up > 0.6)  # the brim's and the crown's tops
    assert face.sum() > 20 and hat.sum() > 5
    assert np.mean(ratio[face]) < 0.9, "the face under the brim greys and blackens"
    assert np.mean(ratio[hat]) == pytest.approx(1.0, abs=0.05), "the rain-washed hat stays clean"
