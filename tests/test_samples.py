"""The committed sample scenes: they open, have porous preset materials, render, and are what
sample_blends/build_samples.py builds."""

import pathlib

import bpy
import numpy as np
import pytest

from porous_weathering import render
from generators import OLDEST_LINE, load_script

SAMPLES = pathlib.Path(__file__).resolve().parent.parent / "sample_blends"

build_samples = load_script("sample_blends/build_samples.py")


def meshes(scene):
    return sorted((obj for obj in scene.objects if obj.type == "MESH"), key=lambda obj: obj.name)


def summary(path):
    """What must not change between builds: objects, their sizes and materials, the node groups."""
    bpy.ops.wm.open_mainfile(filepath=str(path))
    objects = [(obj.name, len(obj.data.vertices), len(obj.data.polygons), [m.name for m in obj.data.materials])
               for obj in meshes(bpy.context.scene)]
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
        assert summary(SAMPLES / f"{name}.blend") == summary(rebuilt), \
            f"sample_blends/{name}.blend is stale: run python sample_blends/build_samples.py"
