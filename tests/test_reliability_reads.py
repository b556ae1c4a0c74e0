"""A map that reads another (the run-off reads the rain) reads only what this run asks for: the
rain map of the same .blend and object, baked with this run's rain settings. One made from
another .blend is refused (exit 3, naming it), one of other settings before any work (exit 2,
naming the setting and ``--maps rain,runoff``), unless the run bakes the rain too (docs/cli.md)."""

import os

import bpy

import pytest

from helpers import run_cli
from porous_weathering.samples import studio

FAST = ["--resolution", "16", "--samples", "2", "--sun-samples", "2"]


def errors(result):
    return [line for line in result.stderr.splitlines() if line.startswith("error:")]


@pytest.fixture
def blends(fresh_scene, tmp_path):
    """Two .blend files, each with a plane named "Plane" leaning under the rain."""
    plane = studio.add_plane(fresh_scene, size=2.0)
    plane.rotation_euler = (0.4, 0.0, 0.0)
    paths = [tmp_path / "first.blend", tmp_path / "second.blend"]
    for path in paths:
        bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return paths


def test_a_rain_map_made_from_another_blend_is_refused(blends, tmp_path):
    first, second = blends
    out = tmp_path / "maps"
    assert run_cli("bake", second, "--maps", "rain", "--out", out, *FAST).returncode == 0
    refused = run_cli("bake", first, "--maps", "runoff", "--out", out, *FAST)
    assert refused.returncode == 3, refused.stderr
    (line,) = errors(refused)
    assert str(second) in line and "--maps rain,runoff" in line
    assert os.listdir(out) == ["Plane.rain.exr"]


@pytest.mark.parametrize("target", ["image", "attribute"])
def test_a_rain_map_of_other_settings_is_refused_before_any_work(blends, tmp_path, target):
    first, _ = blends
    out = tmp_path / "maps"
    where = ["--target", target, "--save"] if target == "attribute" else ["--out", out]
    assert run_cli("bake", first, "--maps", "rain", *where, *FAST).returncode == 0
    made = os.path.getmtime(first)
    refused = run_cli("bake", first, "--maps", "runoff", "--wind-tilt", "60", *where, *FAST)
    assert refused.returncode == 2, refused.stderr
    assert errors(refused) == [
        f"error: {first}: object 'Plane': the rain map the runoff map reads was baked with other settings: "
        "--wind-tilt 60.0 (the map's: 0.0); bake both (--maps rain,runoff)"
    ]
    assert os.path.getmtime(first) == made and (target == "attribute" or os.listdir(out) == ["Plane.rain.exr"])
    both = run_cli("bake", first, "--maps", "rain,runoff", "--wind-tilt", "60", *where, *FAST)
    assert both.returncode == 0, both.stderr
    same = run_cli("bake", first, "--maps", "runoff", "--wind-tilt", "60", *where, *FAST)
    assert same.returncode == 0 and "unchanged" in same.stdout, same.stderr
