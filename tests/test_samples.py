"""The committed sample scenes: they open, have porous preset materials, render, are what
sample_blends/build_samples.py builds, and, weathered as the main job weathers them
(demo.Sample), show each mode's areas where they belong (pixel regions)."""

import pathlib

import bpy

import numpy as np
import pytest

from generators import OLDEST_LINE, load_script
from porous_weathering import compat, demo, model, render, studio, weathering

SAMPLES = pathlib.Path(__file__).resolve().parent.parent / "sample_blends"

build_samples = load_script("sample_blends/build_samples.py")


def meshes(scene):
    return sorted((obj for obj in scene.objects if obj.type == "MESH"), key=lambda obj: obj.name)


def summary(path):
    """What must not change between builds: objects, their sizes and materials, the node groups."""
    bpy.ops.wm.open_mainfile(filepath=str(path))
    objects = [
        (obj.name, len(obj.data.vertices), len(obj.data.polygons), [m.name for m in obj.data.materials])
        for obj in meshes(bpy.context.scene)
    ]
    return objects, sorted((group.name, len(group.nodes)) for group in bpy.data.node_groups)


@pytest.mark.parametrize("name", build_samples.SAMPLES)
def test_sample_opens_with_porous_materials_and_renders(name):
    path = SAMPLES / f"{name}.blend"
    assert path.stat().st_size < 2_000_000
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
    assert triangles < 40_000
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
    render at age 0 and ``age``, what model.py predicts for it per pixel, and each map the mode
    reads, probed per pixel on the weathered objects (the others held out: they still hide what
    lies behind them, as in the renders, but leave their pixels transparent)."""

    def __init__(self, name, mode, age, map_dir, size=48):
        sample = demo.Sample(name, bake_samples=8, map_dir=map_dir)
        scene = sample.scene
        render.use_cycles(scene, size=size, samples=16)  # direct light: no bounce between weathered faces
        scene.render.resolution_x = size * 4 // 3
        self.inputs = {**{n: model.WEATHERING_INPUTS[n][0] for n in model.inputs_of(mode)}, **sample.recipe.inputs}
        sample.show(mode, 0.0)
        clean = render.render_array(scene)
        sample.show(mode, age)
        self.ratio = luminance(render.render_array(scene)) / np.maximum(luminance(clean), 1e-4)
        holdout = holdout_material()
        for obj in scene.objects:
            if obj.type == "MESH" and obj not in sample.objects:
                studio.assign(obj, holdout)
        self.maps = {
            mask: self.probe(sample, mask_probe(sample.sources[map_name]))[..., 0]
            for mask, map_name in sample.recipe.masks[mode].items()
        }
        position = self.probe(sample, studio.position_probe())
        self.covered, self.position = position[..., 3] > 0.999, (position[..., :3] - 0.5) * 10.0
        self.lit = self.covered & (luminance(clean) > 0.02)
        normals = self.probe(sample, studio.normal_probe())[..., :3] * 2.0 - 1.0
        towards_camera = np.array(scene.camera.location) - self.position
        n_dot_v = (normals * towards_camera).sum(-1) / np.linalg.norm(towards_camera, axis=-1)
        n_dot_l = normals @ np.array(sample.sun.matrix_world.to_3x3().col[2])
        stone = sample.recipe.stone

        def diffuse(time):
            weights = model.weathered_coefficients(
                stone["base_color"][:3],
                stone["ks"],
                stone["roughness"],
                stone["porosity"],
                stone["pore_depth_ratio"],
                n_dot_l,
                n_dot_v,
                (mode,),
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

    def change(self, area):
        """(rendered, model.py's) mean late-over-clean luminance in ``area``, which must hold
        enough pixels to judge."""
        assert area.sum() >= 12, "the area must be in view"
        return float(self.ratio[area].mean()), float(self.expected[area].mean())


def mask_probe(source):
    """Emits a mask source (an attribute name or an image path) as the material reads it."""
    mask = weathering.mask_source("efflorescence_map", source)
    return studio.emission_probe("Mask Probe", lambda graph, geometry: weathering.mask_socket(graph, mask))


def holdout_material():
    material = compat.new_material("Holdout")
    material.node_tree.nodes.clear()
    holdout = material.node_tree.nodes.new("ShaderNodeHoldout")
    output = material.node_tree.nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(holdout.outputs[0], output.inputs["Surface"])
    return material


def luminance(image):
    return np.asarray(image)[..., :3] @ np.array([0.2126, 0.7152, 0.0722])


def soiling_areas(weathered):
    """SPEC 4's three areas by the baked maps: white where rain washes (E at or above the
    threshold), grey where it is sheltered and flat, black where sheltered on an edge or cavity."""
    threshold, width = weathered.inputs["rain_threshold"], weathered.inputs["front_width"]
    sheltered = (0.0, threshold - width)
    return {
        "white": weathered.area(rain_map=(threshold + 0.05, 1.0)),
        "grey": weathered.area(rain_map=sheltered, edge_map=(0.0, 0.05)),
        "black": weathered.area(rain_map=sheltered, edge_map=(0.5, 1.0)),
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


def test_brick_wall_effloresces_along_its_joints(tmp_path):
    age = 0.66
    weathered = Weathered("brick_wall", model.EFFLORESCENCE, age, tmp_path)
    salted, bare = weathered.area(efflorescence_map=(0.7, 1.0)), weathered.area(efflorescence_map=(0.0, 0.2))
    assert weathered.change(bare)[0] == pytest.approx(1.0, abs=0.03), "salt has not reached the brick faces yet"
    rendered, expected = weathered.change(salted)
    assert expected > 2.0 and rendered == pytest.approx(expected, rel=0.1), "salt whitens the joints' edges"
    distance = distance_to_joint(weathered.position[..., 0], weathered.position[..., 2])
    assert distance[salted].mean() < 0.5 * distance[bare].mean(), "the salt lies along the joints"


def test_brick_wall_wets_where_rain_reaches(tmp_path):
    """Driven rain reaches the brick faces (E = sin 25 degrees there): dry while the wet front
    is above that, then shining with the water lobe, which the diffuse model lacks."""
    early = Weathered("brick_wall", model.WET, 0.3, tmp_path)
    assert early.change(early.area(rain_map=(0.3, 0.5)))[0] == pytest.approx(1.0, abs=0.03)
    late = Weathered("brick_wall", model.WET, 1.0, tmp_path)
    rendered, diffuse_only = late.change(late.area(rain_map=(0.3, 1.0)))
    assert rendered > diffuse_only + 0.1
