"""Faults mid-way: a bake cancelled, killed or out of disk space leaves the previous maps whole
and the scene as it was; undo restores the scene after each operation; a saved file keeps
materials, maps (relative paths and packed) and keyframed animation.

Undo headless: ``bpy.ops.ed.undo`` works in background mode once there are undo steps, but
an operator run from Python pushes none there (its UNDO flag only acts with a window), so
these tests push a step before and after each operation themselves, as the UI does.
"""

import contextlib
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import replace

import bpy

import numpy as np
import pytest

import porous_weathering
from bad_meshes import cube, noisy_grid, snapshot
from helpers import corner_values, temporary_env
from porous_weathering import ui
from porous_weathering.common import imageio
from porous_weathering.maps import bake, edges, lightmap, rain, runoff
from porous_weathering.samples import studio

ROOT = pathlib.Path(__file__).resolve().parent.parent
FAST = dict(resolution=16, rain_settings=rain.RainSettings(samples=2))


def planes(scene, count=2):
    return [studio.add_plane(scene, name=f"Stone {i}", size=1.0) for i in range(count)]


def place(objects):
    for i, obj in enumerate(objects):
        obj.location.x = 3.0 * i
    bpy.context.view_layer.update()


def cancel_after(steps):
    """A ``cancelled()`` hook that lets ``steps`` steps start, then asks to stop."""
    asked = []

    def cancelled():
        asked.append(None)
        return len(asked) > steps

    return cancelled


def test_cancelled_image_bake_keeps_the_previous_maps_and_the_scene(fresh_scene, tmp_path):
    stones = planes(fresh_scene)
    place(stones)
    out = tmp_path / "maps"
    bake.bake_maps(stones, bake.BakeOptions(out_dir=str(out), **FAST))
    previous = {path.name: path.read_bytes() for path in out.iterdir()}
    before = snapshot(stones)
    changed = bake.BakeOptions(out_dir=str(out), resolution=16, rain_settings=rain.RainSettings(samples=2, cone=30))
    with pytest.raises(bake.BakeCancelled):
        bake.bake_maps(stones, changed, cancelled=cancel_after(1))
    assert snapshot(stones) == before
    assert (out / "Stone 1.rain.exr").read_bytes() == previous["Stone 1.rain.exr"]  # untouched
    assert (out / "Stone 0.rain.exr").read_bytes() != previous["Stone 0.rain.exr"]  # the finished step
    assert sorted(p.name for p in out.iterdir()) == sorted(previous)  # no temporary files
    for path in out.iterdir():
        assert np.isfinite(imageio.read_image(path)[0]).all()


def test_cancelled_attribute_bake_keeps_the_previous_attribute(fresh_scene):
    stones = planes(fresh_scene)
    place(stones)
    bake.bake_maps(stones, bake.BakeOptions(target="attribute", **FAST))
    mesh = stones[1].data
    previous = (
        np.array([c.color[0] for c in mesh.color_attributes[rain.RAIN_ATTRIBUTE].data]),
        mesh[f"{rain.RAIN_ATTRIBUTE}_inputs"],
    )
    before = snapshot(stones)
    changed = bake.BakeOptions(target="attribute", rain_settings=rain.RainSettings(samples=2, cone=30))
    with pytest.raises(bake.BakeCancelled):
        bake.bake_maps(stones, changed, cancelled=cancel_after(1))
    assert snapshot(stones) == before
    assert np.array_equal([c.color[0] for c in mesh.color_attributes[rain.RAIN_ATTRIBUTE].data], previous[0])
    assert mesh[f"{rain.RAIN_ATTRIBUTE}_inputs"] == previous[1]


@pytest.mark.parametrize("target", ["image", "attribute"])
def test_a_map_with_nan_or_inf_is_refused_and_the_old_map_kept(fresh_scene, tmp_path, monkeypatch, target):
    """A bug that makes NaN or inf (as an absorption length of 1e308 once did) is reported, never stored."""
    stone = cube(fresh_scene, name="Stone")
    out = tmp_path / "maps"
    options = bake.BakeOptions(maps=("rain", "runoff"), target=target, out_dir=str(out), **FAST)
    bake.bake_maps([stone], options)
    mesh = stone.data
    before = snapshot([stone])
    previous = (
        sorted((p.name, p.read_bytes()) for p in out.iterdir())
        if target == "image"
        else (
            corner_values(stone, runoff.RUNOFF_ATTRIBUTE),
            mesh[f"{runoff.RUNOFF_ATTRIBUTE}_inputs"],
        )
    )

    def broken(bake_function):
        def bake_with_a_bug(*args):
            values = bake_function(*args)
            values.flat[:2] = np.nan, np.inf
            return values

        return bake_with_a_bug

    monkeypatch.setattr(runoff, "bake_runoff_image", broken(runoff.bake_runoff_image))
    monkeypatch.setattr(runoff, "bake_runoff_corners", broken(runoff.bake_runoff_corners))
    changed = replace(options, runoff_settings=runoff.RunoffSettings(drip_angle=40.0))
    with pytest.raises(imageio.NonFiniteMap, match=r"^object 'Stone', run-off map: .*2 of \d+ values are not finite"):
        bake.bake_maps([stone], changed)
    assert snapshot([stone]) == before
    if target == "image":
        assert sorted((p.name, p.read_bytes()) for p in out.iterdir()) == previous  # no temporary file either
    else:
        assert np.array_equal(corner_values(stone, runoff.RUNOFF_ATTRIBUTE), previous[0])
        assert mesh[f"{runoff.RUNOFF_ATTRIBUTE}_inputs"] == previous[1]


def test_an_edge_mask_with_nan_is_refused_and_the_old_attribute_kept(fresh_scene):
    stone = cube(fresh_scene, name="Stone")
    edges.write_edge_attribute(stone, np.full(len(stone.data.vertices), 0.25))
    with pytest.raises(imageio.NonFiniteMap, match="colour attribute 'pw_edges': 1 of 8 values are not finite"):
        edges.write_edge_attribute(stone, [np.nan] + [0.5] * 7)  # was stored as 0
    assert np.array_equal(corner_values(stone, edges.EDGE_ATTRIBUTE), np.full(24, 0.25, np.float32))


def test_cancel_before_any_map_removes_the_new_lightmap(fresh_scene, tmp_path):
    stone = cube(fresh_scene, "Bare")
    assert not stone.data.uv_layers
    before = snapshot([stone])
    with pytest.raises(bake.BakeCancelled):
        bake.bake_maps(
            [stone], bake.BakeOptions(maps=("rain", "edges"), out_dir=str(tmp_path), **FAST), cancelled=cancel_after(0)
        )
    assert snapshot([stone]) == before and list(tmp_path.iterdir()) == []
    with pytest.raises(bake.BakeCancelled):  # one map done: the lightmap it lies on stays
        bake.bake_maps(
            [stone], bake.BakeOptions(maps=("rain", "edges"), out_dir=str(tmp_path), **FAST), cancelled=cancel_after(1)
        )
    assert [layer.name for layer in stone.data.uv_layers] == [lightmap.LIGHTMAP_UV]
    assert [p.name for p in tmp_path.iterdir()] == ["Bare.rain.exr"]


# --- a bake process killed or out of space ---------------------------------------------------

CHILD = r"""
import os, resource, signal, sys, time
import bpy
from porous_weathering import bake, rain
from porous_weathering.common import imageio
from porous_weathering.maps import sky_bake
blend, out, mode = sys.argv[1:4]
progress = None
bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False, use_scripts=False)
if mode == "kill-in-cycles":
    original = sky_bake._bake
    def announced(*args, **kwargs):
        print("BAKING", flush=True)
        time.sleep(0.3)
        return original(*args, **kwargs)
    sky_bake._bake = announced
elif mode == "kill-before-rename":
    def stalled(source, target):
        print("TEMPORARY WRITTEN", flush=True)
        time.sleep(120)
    imageio.os.replace = stalled
elif mode == "kill-in-unwrap":
    def progress(fraction, message):
        if "lightmap: charts" in message:
            print("UNWRAPPING", flush=True)
elif mode == "disk-full":
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a full disk: writes fail with EFBIG, not a signal
    resource.setrlimit(resource.RLIMIT_FSIZE, (64, resource.RLIM_INFINITY))
options = bake.BakeOptions(maps=("rain",), out_dir=out, resolution=64,
                           rain_settings=rain.RainSettings(samples=2, cone=40))
try:
    bake.bake_maps([bpy.data.objects["Stone 0"]], options, progress=progress)
except OSError as error:
    print("ERROR", error, flush=True)
    sys.exit(3)
"""


@pytest.fixture
def baked(fresh_scene, tmp_path):
    """(blend path, map folder, previous map bytes): one plane, its rain map already baked."""
    [stone] = planes(fresh_scene, 1)
    out = tmp_path / "maps"
    [outcome] = bake.bake_maps([stone], bake.BakeOptions(maps=("rain",), out_dir=str(out), **FAST))
    blend = tmp_path / "wall.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    return blend, out, pathlib.Path(outcome.where).read_bytes()


def start_child(blend, out, mode):
    """The bake child, its temporary folder beside ``blend``: a child killed outright leaves its
    Blender session folder there, not in the system's."""
    return subprocess.Popen(
        [sys.executable, "-c", CHILD, str(blend), str(out), mode],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=temporary_env(blend.parent / "tmp"),
    )


def assert_previous_map_intact(out, previous):
    path = out / "Stone 0.rain.exr"
    assert path.read_bytes() == previous
    pixels, metadata = imageio.read_image(path)
    assert pixels.shape == (16, 16, 1) and bake.HASH_KEY in metadata


@pytest.mark.parametrize(
    "mode, signal_line", [("kill-in-cycles", "BAKING"), ("kill-before-rename", "TEMPORARY WRITTEN")]
)
def test_killed_bake_leaves_the_previous_map_whole(baked, mode, signal_line):
    blend, out, previous = baked
    child = start_child(blend, out, mode)
    try:
        lines = iter(child.stdout.readline, "")  # Blender logs lines of its own first
        assert any(line.strip() == signal_line for line in lines), child.stderr.read()
        child.send_signal(signal.SIGKILL)
    finally:
        child.wait(timeout=60)
        child.stdout.close()
        child.stderr.close()
    assert child.returncode == -signal.SIGKILL
    assert_previous_map_intact(out, previous)
    leftovers = sorted(p.name for p in out.iterdir() if p.name != "Stone 0.rain.exr")
    # killed between writing and renaming, the whole new map is left as a hidden temporary file
    assert all(name.startswith(".pw_") and name.endswith(".exr") for name in leftovers)
    assert len(leftovers) == (mode == "kill-before-rename")


def unwrap_processes(parent):
    """The pids of the unwrap's child processes (maps/lightmap_child.py) of ``parent``."""
    found = []
    for stat in pathlib.Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            command = (stat.parent / "cmdline").read_bytes()
        except OSError:  # ended meanwhile
            continue
        if int(fields[1]) == parent and b"lightmap_child.py" in command:
            found.append(int(stat.parent.name))
    return found


def running(pid):
    """Whether ``pid`` runs (a zombie waiting for its reaper does not)."""
    try:
        return pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_killed_bake_takes_its_unwrap_process_with_it(fresh_scene, tmp_path):
    """SIGKILL while xatlas charts (its C code holds the GIL, so the child's thread that watches
    stdin cannot run): the child ends within seconds, not when xatlas is done."""
    noisy_grid(fresh_scene, "Stone 0")
    blend = tmp_path / "scan.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    child = start_child(blend, tmp_path / "maps", "kill-in-unwrap")
    unwraps = []
    try:
        lines = iter(child.stdout.readline, "")
        assert any(line.strip() == "UNWRAPPING" for line in lines), child.stderr.read()
        unwraps = unwrap_processes(child.pid)
        time.sleep(1.0)  # into xatlas' charting
        assert all(running(pid) for pid in unwraps) and len(unwraps) == 1
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=60)
        deadline = time.monotonic() + 5.0
        while any(running(pid) for pid in unwraps) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(running(pid) for pid in unwraps)
    finally:
        for pid in unwraps:  # no orphan left behind by a failure
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        child.kill()
        child.wait(timeout=60)
        child.stdout.close()
        child.stderr.close()


def test_full_disk_fails_clearly_and_keeps_the_previous_map(baked):
    blend, out, previous = baked
    child = start_child(blend, out, "disk-full")
    stdout, stderr = child.communicate(timeout=120)
    assert child.returncode == 3, stderr[-2000:]
    assert "ERROR cannot write image" in stdout and "Stone 0.rain.exr" in stdout
    assert_previous_map_intact(out, previous)
    assert sorted(p.name for p in out.iterdir()) == ["Stone 0.rain.exr"]  # the temporary file is removed


# --- undo ----------------------------------------------------------------------------------------


OPERATORS = [cls for cls in ui.CLASSES if issubclass(cls, bpy.types.Operator)]


@pytest.mark.parametrize("operator", OPERATORS, ids=[cls.__name__ for cls in OPERATORS])
def test_every_operator_is_undoable(operator):
    assert {"REGISTER", "UNDO"} <= operator.bl_options


def undo_restores(operation, names):
    """Run ``operation`` between two undo pushes, undo, and compare snapshots of ``names``."""
    before = snapshot([bpy.data.objects[name] for name in names])
    bpy.ops.ed.undo_push(message="before")
    operation()
    bpy.ops.ed.undo_push(message="after")
    changed = snapshot([bpy.data.objects[name] for name in names])
    bpy.ops.ed.undo()
    after = snapshot([bpy.data.objects[name] for name in names])  # objects are new Python objects now
    return before, changed, after


def test_undo_after_adding_a_porous_material(fresh_scene, registered):
    sphere = studio.add_sphere(fresh_scene, segments=8, rings=4)
    bpy.context.view_layer.objects.active = sphere
    before, changed, after = undo_restores(bpy.ops.porous_weathering.add_porous_material, ["Sphere"])
    assert changed != before and after == before


@pytest.mark.parametrize("target", ["attribute", "image"])
def test_undo_after_a_bake(fresh_scene, tmp_path, target):
    cube(fresh_scene, "Bare")  # no UV map: an image bake adds the lightmap

    def bake_it():
        bake.bake_maps(
            [bpy.data.objects["Bare"]],
            bake.BakeOptions(maps=("rain", "edges"), target=target, out_dir=str(tmp_path), **FAST),
        )

    before, changed, after = undo_restores(bake_it, ["Bare"])
    assert changed != before and after == before


# --- saving and reopening ------------------------------------------------------------------------


def test_saved_file_keeps_materials_maps_and_animation(fresh_scene, tmp_path):
    stone = studio.add_plane(fresh_scene, name="Stone", size=1.0)
    sun = studio.add_sun(fresh_scene, (0.3, 0.2, 0.9))
    material = porous_weathering.make_porous_material("Weathered", porosity=0.1, key_light=sun)
    studio.assign(stone, material)
    porosity = material.node_tree.nodes["Porous"].inputs["Porosity"]
    for frame, value in ((1, 0.1), (20, 0.4)):
        porosity.default_value = value
        porosity.keyframe_insert("default_value", frame=frame)
        sun.rotation_euler.x = value
        sun.keyframe_insert("rotation_euler", index=0, frame=frame)

    project = tmp_path / "project"
    options = bake.BakeOptions(maps=("rain", "edges"), out_dir=str(project / "maps"), **FAST)
    bake.bake_maps([stone], options)
    bake.bake_maps([stone], bake.BakeOptions(target="attribute", **FAST))
    bpy.ops.wm.save_as_mainfile(filepath=str(project / "wall.blend"))
    bake.link_images([stone], options)
    edges_image = bpy.data.images[stone["pw_edges_image"]]
    edges_image.pack()
    edges_pixels = np.array(edges_image.pixels[:])
    rain_before = [c.color[0] for c in stone.data.color_attributes[rain.RAIN_ATTRIBUTE].data]
    bpy.ops.wm.save_mainfile()

    moved = tmp_path / "moved elsewhere"
    shutil.move(project, moved)  # relative paths must follow the project
    os.remove(moved / "maps" / "Stone.edges.exr")  # the packed map needs no file
    bpy.ops.wm.open_mainfile(filepath=str(moved / "wall.blend"), load_ui=False, use_scripts=False)

    stone, sun = bpy.data.objects["Stone"], bpy.data.objects["Sun"]
    material = stone.active_material
    assert material.name == "Weathered" and material["pw_light_mode"] == "SUN"
    assert len(material.node_tree.animation_data.drivers) == 3
    rain_image = bpy.data.images[stone["pw_rain_image"]]
    assert rain_image.filepath == "//maps/Stone.rain.exr" and tuple(rain_image.size) == (16, 16)
    assert np.allclose(np.array(rain_image.pixels[:])[0::4], 1.0, atol=0.05)
    edges_image = bpy.data.images[stone["pw_edges_image"]]
    assert edges_image.packed_file is not None and np.array_equal(np.array(edges_image.pixels[:]), edges_pixels)
    assert [c.color[0] for c in stone.data.color_attributes[rain.RAIN_ATTRIBUTE].data] == rain_before
    porosity = material.node_tree.nodes["Porous"].inputs["Porosity"]
    for frame, value in ((1, 0.1), (20, 0.4), (10.5, 0.25)):
        bpy.context.scene.frame_set(int(frame), subframe=frame % 1)
        assert porosity.default_value == pytest.approx(value, abs=0.06 if frame % 1 else 1e-6)
        assert sun.rotation_euler.x == pytest.approx(value, abs=0.06 if frame % 1 else 1e-6)
