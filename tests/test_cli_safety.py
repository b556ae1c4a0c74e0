"""The ``bake`` command and library as a careless user and a render farm meet them: no map is
overwritten silently, interrupts stop at once, files follow the umask, errors are one line,
FILE.blend is never an object name, and every written map lies in [0, 1]."""

import hashlib
import os
import pathlib
import signal
import subprocess
import sys

import bpy

import numpy as np
import pytest

from helpers import run_cli, temporary_env
from porous_weathering.common import imageio, interrupts
from porous_weathering.maps import bake, rain
from porous_weathering.samples import studio

ROOT = pathlib.Path(__file__).resolve().parent.parent
FAST = ["--resolution", "16", "--samples", "4", "--sun-samples", "4"]
FOUR_SAMPLES = rain.RainSettings(samples=4)


def outcome_lines(result):
    return [line.split()[:2] for line in result.stdout.splitlines() if line.startswith(("written", "unchanged"))]


def digest(path):
    return hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()


def save_scene(path):
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return path


@pytest.fixture
def two_files(fresh_scene, tmp_path):
    """Two .blend files with a plane named "Ground" each (the second one bigger)."""
    ground = studio.add_plane(fresh_scene, name="Ground", size=2.0)
    first = save_scene(tmp_path / "first.blend")
    ground.scale = (2.0, 2.0, 1.0)
    return first, save_scene(tmp_path / "second.blend")


# --- no silent overwrite ----------------------------------------------------------------------


def test_a_map_from_another_blend_is_refused_unless_forced(two_files, tmp_path):
    first, second = two_files
    out = tmp_path / "maps"
    assert run_cli("bake", first, "--out", out, "--maps", "rain", *FAST).returncode == 0
    made = digest(out / "Ground.rain.exr")
    for extra in ([], ["--dry-run"]):
        refused = run_cli("bake", second, "--out", out, "--maps", "rain", *FAST, *extra)
        assert refused.returncode == 3, refused.stderr
        [line] = refused.stderr.splitlines()
        assert f"was made from {first} (object 'Ground'), not from {second} (object 'Ground')" in line
        assert "--force" in line and digest(out / "Ground.rain.exr") == made
    forced = run_cli("bake", second, "--out", out, "--maps", "rain", *FAST, "--force")
    assert forced.returncode == 0, forced.stderr
    assert imageio.read_metadata(out / "Ground.rain.exr")[bake.SOURCE_KEY] == str(second)
    # in one run, the second file is refused before it writes anything; the first one's maps stay
    both = run_cli("bake", first, second, "--out", tmp_path / "both", "--maps", "rain", *FAST)
    assert both.returncode == 3 and outcome_lines(both) == [["written", "Ground.rain"]]
    assert imageio.read_metadata(tmp_path / "both" / "Ground.rain.exr")[bake.SOURCE_KEY] == str(first)


def test_the_library_refuses_too_and_takes_force(two_files, tmp_path):
    first, second = two_files
    options = bake.BakeOptions(maps=("rain",), out_dir=str(tmp_path), resolution=16)
    painted = np.full((16, 16), 0.25, dtype=np.float32)  # a rain map painted by hand, say
    imageio.write_image(tmp_path / "Ground.rain.exr", painted)
    bpy.ops.wm.open_mainfile(filepath=str(first))
    ground = bpy.data.objects["Ground"]
    with pytest.raises(bake.OverwriteRefused, match="is an image that Porous Weathering did not write"):
        bake.bake_maps([ground], options)
    assert np.array_equal(imageio.read_image(tmp_path / "Ground.rain.exr")[0][..., 0], painted)
    [outcome] = bake.bake_maps([ground], options, force=True)
    header = imageio.read_metadata(outcome.where)
    assert outcome.status == "written" and header[bake.OBJECT_KEY] == "Ground" and header[bake.MAP_KEY] == "rain"
    assert [o.status for o in bake.bake_maps([ground], options)] == ["unchanged"]
    bpy.ops.wm.open_mainfile(filepath=str(second))
    with pytest.raises(bake.OverwriteRefused, match="first.blend"):
        list(bake.iter_bake([bpy.data.objects["Ground"]], options, dry_run=True))


def test_a_map_of_an_unsaved_scene_is_replaced_by_its_saved_file(fresh_scene, tmp_path):
    """An unsaved .blend records no source, so saving the scene and baking again is no clash;
    the map is baked again to record its file."""
    plane = studio.add_plane(fresh_scene)
    options = bake.BakeOptions(maps=("rain",), out_dir=str(tmp_path / "maps"), resolution=16)
    [unsaved] = bake.bake_maps([plane], options)
    assert bake.Provenance.from_header(imageio.read_metadata(unsaved.where)).source == ""
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    assert [o.status for o in bake.bake_maps([plane], options)] == ["written"]
    assert imageio.read_metadata(unsaved.where)[bake.SOURCE_KEY] == str(tmp_path / "scene.blend")


def test_attribute_maps_record_what_they_were_made_from(fresh_scene, tmp_path):
    plane = studio.add_plane(fresh_scene)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    bake.bake_maps([plane], bake.BakeOptions(maps=("rain",), target="attribute", rain_settings=FOUR_SAMPLES))
    mesh = plane.data
    assert mesh["pw_rain_source"] == str(tmp_path / "scene.blend") and mesh["pw_rain_object"] == "Plane"
    assert len(mesh["pw_rain_inputs"]) == 64


def test_names_that_sanitise_alike_get_distinct_files(fresh_scene, tmp_path):
    for name, x in (("Wall/1", 0.0), ("Wall_1", 3.0)):
        studio.add_plane(fresh_scene, name=name).location.x = x
    blend = save_scene(tmp_path / "walls.blend")
    suffix = hashlib.sha256(b"Wall/1").hexdigest()[:8]
    expected = sorted([f"Wall_1-{suffix}.rain.exr", "Wall_1.rain.exr"])
    first = run_cli("bake", blend, "--out", tmp_path / "maps", "--maps", "rain", *FAST)
    assert first.returncode == 0, first.stderr
    assert sorted(os.listdir(tmp_path / "maps")) == expected
    again = run_cli("bake", blend, "--out", tmp_path / "maps", "--maps", "rain", *FAST)
    assert sorted(outcome_lines(again)) == [["unchanged", "Wall/1.rain"], ["unchanged", "Wall_1.rain"]]
    assert bake.image_path("d", "a:b", "rain") != bake.image_path("d", "a_b", "rain")  # unsafe on Windows


# --- interrupts -------------------------------------------------------------------------------


@pytest.fixture
def slow_blend(fresh_scene, tmp_path):
    """A plane and a cube on it: the edge map is quick, the rain map at --samples 4000 is not."""
    studio.add_plane(fresh_scene, size=4.0)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
    return save_scene(tmp_path / "scene.blend")


@pytest.mark.parametrize("sent, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_stops_the_bake_at_once(slow_blend, tmp_path, sent, code):
    out = tmp_path / "maps"
    temporary = tmp_path / "tmp"
    before = digest(slow_blend)
    argv = [slow_blend, "--objects", "Plane", "--maps", "edges,rain", "--out", out, "--resolution", "64"]
    child = subprocess.Popen(
        [sys.executable, "-m", "porous_weathering", "bake", *map(str, argv), "--samples", "4000", "--save"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=temporary_env(temporary),
    )
    try:
        lines = iter(child.stdout.readline, "")
        assert any(line.startswith("written   Plane.edges") for line in lines), child.stderr.read()
        assert child.poll() is None  # the line came as the map finished: stdout is line-buffered
        child.send_signal(sent)  # the rain map is baking now
        stdout, stderr = child.communicate(timeout=120)
    finally:
        child.kill()
    assert child.returncode == code, stderr
    [last] = [line for line in stderr.replace("\r", "\n").splitlines() if line.strip() and "[" not in line]
    assert last.startswith(f"interrupted by {signal.Signals(sent).name}") and "was not saved" in last
    assert not [line for line in stdout.splitlines() if line.startswith(("written", "saved"))]  # nothing more
    assert sorted(os.listdir(out)) == ["Plane.edges.exr"]  # no rain map, no temporary file
    pixels, header = imageio.read_image(out / "Plane.edges.exr")
    assert pixels.shape == (64, 64, 1) and header[bake.MAP_KEY] == "edges"
    assert digest(slow_blend) == before and sorted(os.listdir(tmp_path)) == ["maps", "scene.blend", "tmp"]
    assert not os.listdir(temporary)  # Blender's folder for the session too (common.process_end)


def test_the_end_removes_only_a_folder_made_for_the_process(tmp_path):
    """``process_end.end`` removes the folders given to it that Blender or multiprocessing made
    for the process, and never another (a Blender that could not make one works in the
    temporary folder itself)."""
    session, pool, other = tmp_path / "blender_a1B2c3", tmp_path / "pymp-x_9kd2lq", tmp_path / "blender_data"
    for folder in (session, pool, other):
        (folder / "inside").mkdir(parents=True)
    words = (
        "import sys; from porous_weathering.common import process_end\n"
        "for folder in sys.argv[1:]: process_end.remove_at_end(lambda folder=folder: folder)\n"
        "process_end.end(5)"
    )
    done = subprocess.run([sys.executable, "-c", words, f"{session}/", pool, other, tmp_path], cwd=ROOT, timeout=60)
    assert done.returncode == 5
    assert sorted(os.listdir(tmp_path)) == ["blender_data"] and os.listdir(other) == ["inside"]


def test_a_script_ended_by_compat_leaves_no_session_folder(tmp_path):
    """``compat.end_process`` (the benchmarks', the test session's) removes Blender's folder for
    the session, the one of the end: reading the factory settings makes a new one."""
    words = (
        "import bpy; from porous_weathering.blender import compat\n"
        "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
        "compat.end_process(4)"
    )
    done = subprocess.run([sys.executable, "-c", words], cwd=ROOT, timeout=60, env=temporary_env(tmp_path))
    assert done.returncode == 4 and not os.listdir(tmp_path)


def test_a_run_leaves_nothing_in_the_temporary_folder(slow_blend, tmp_path):
    """Blender makes a folder for its session (blender_XXXXXX) and removes it only on its own exit
    path, which the command line skips: removed all the same, whether a run writes or ends with a
    usage error (from the parser, or once the file is open)."""
    temporary = tmp_path / "tmp"
    runs = [
        (0, ["bake", slow_blend, "--objects", "Plane", "--maps", "edges", "--out", tmp_path / "maps", *FAST]),
        (2, ["bake", slow_blend, "--objects", "Nothing", "--out", tmp_path / "maps"]),
        (2, ["bake", slow_blend, "--resolution", "-1"]),
        (0, ["--version"]),
    ]
    for code, words in runs:
        done = run_cli(*words, temporary=temporary)
        assert done.returncode == code, (words, done.stderr)
        assert not os.listdir(temporary), (words, os.listdir(temporary))


CHILD_STOPPED_WRITING = r"""
import sys, time
from porous_weathering.cli import entry
from porous_weathering.common import imageio
write = imageio._write_file
def stalled(*args):
    write(*args)
    print("TEMPORARY WRITTEN", flush=True)
    time.sleep(120)
imageio._write_file = stalled
entry.exit_with(sys.argv[1:])
"""


def test_an_interrupted_write_leaves_no_temporary_file_and_the_old_map(slow_blend, tmp_path):
    out = tmp_path / "maps"
    common = [slow_blend, "--objects", "Plane", "--maps", "rain", "--out", out, *FAST]
    assert run_cli("bake", *common).returncode == 0
    previous = (out / "Plane.rain.exr").read_bytes()
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD_STOPPED_WRITING, "bake", *map(str, common), "--rain-cone", "20"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert any(line.strip() == "TEMPORARY WRITTEN" for line in iter(child.stdout.readline, ""))
        assert any(name.startswith(".pw_") for name in os.listdir(out))
        child.send_signal(signal.SIGINT)
        child.communicate(timeout=60)
    finally:
        child.kill()
    assert child.returncode == 130
    assert os.listdir(out) == ["Plane.rain.exr"] and (out / "Plane.rain.exr").read_bytes() == previous


CHILD_UNCUT = r"""
import sys, time
from porous_weathering.common import atomic, interrupts
with interrupts.exit_on_signals(lambda name: f"stopped by {name}"):
    with atomic.uncut():
        print("IN", flush=True)
        time.sleep(1.0)
        open(sys.argv[1], "w").write("whole")
    time.sleep(60)
"""


def test_an_interrupt_waits_for_an_uncut_block(tmp_path):
    """What must not be cut in two (saving a .blend) ends before the process does."""
    marker = tmp_path / "saved"
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD_UNCUT, str(marker)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    try:
        assert child.stdout.readline() == b"IN\n"
        child.send_signal(signal.SIGTERM)
        _, stderr = child.communicate(timeout=30)
    finally:
        child.kill()
    assert child.returncode == 143 and stderr.decode().strip() == "stopped by SIGTERM"
    assert marker.read_text() == "whole"


def test_a_refusal_takes_back_the_folders_made_for_it_alone(tmp_path):
    from porous_weathering.common import atomic

    (tmp_path / "empty").mkdir()  # the user's own, empty: kept
    (tmp_path / "full").mkdir()
    for parent in ("empty", "full"):
        with pytest.raises(ValueError), atomic.folders_undone_on_error(tmp_path / parent / "new" / "maps"):
            os.makedirs(tmp_path / parent / "new" / "maps")
            if parent == "full":
                (tmp_path / parent / "new" / "note.txt").write_text("made meanwhile")  # not empty: kept
            raise ValueError("refused")
    assert sorted(os.listdir(tmp_path)) == ["empty", "full"] and os.listdir(tmp_path / "empty") == []
    assert sorted(os.listdir(tmp_path / "full" / "new")) == ["note.txt"]
    with atomic.folders_undone_on_error(tmp_path / "kept"):
        os.makedirs(tmp_path / "kept")
    assert (tmp_path / "kept").is_dir()  # no error: kept


def test_signals_are_given_back_after_the_run():
    before = [signal.getsignal(number) for number in interrupts.SIGNALS]
    with interrupts.exit_on_signals(str):
        assert signal.getsignal(signal.SIGINT) is not before[0]
    assert [signal.getsignal(number) for number in interrupts.SIGNALS] == before


# --- files, messages and arguments --------------------------------------------------------------


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o027, 0o640)])
def test_map_files_follow_the_umask(tmp_path, umask, mode):
    path = tmp_path / "map.exr"
    previous = os.umask(umask)
    try:
        imageio.write_image(path, np.zeros((4, 4), dtype=np.float32))
        assert os.stat(path).st_mode & 0o777 == mode
        imageio.write_image(path, np.ones((4, 4), dtype=np.float32))  # a re-bake keeps it
        assert os.stat(path).st_mode & 0o777 == mode
    finally:
        os.umask(previous)


def test_blend_files_after_objects_are_files(slow_blend, tmp_path):
    result = run_cli("bake", "--maps", "rain", "--objects", "Cube", slow_blend, "--out", tmp_path, "--dry-run", *FAST)
    assert result.returncode == 0, result.stderr
    assert [line.split()[:2] for line in result.stdout.splitlines() if line.startswith("planned")] == [
        ["planned", "Cube.rain"]
    ]


def test_a_failed_save_says_the_maps_were_not_saved(slow_blend):
    pathlib.Path(f"{slow_blend}@").mkdir()  # where Blender writes before renaming: the save fails
    before = digest(slow_blend)
    result = run_cli(
        "bake", slow_blend, "--objects", "Cube", "--maps", "rain", "--target", "attribute", "--save", *FAST
    )
    assert result.returncode == 1
    [error] = [line for line in result.stderr.replace("\r", "\n").splitlines() if line.startswith("error: ")]
    assert "cannot save it" in error and "the 1 attribute map(s) baked into it were NOT saved" in error
    assert "written" not in result.stdout and digest(slow_blend) == before


# --- maps in range ----------------------------------------------------------------------------


def test_written_maps_lie_in_0_1(fresh_scene, tmp_path):
    """A flat open face at 8 samples: the estimate scatters around 1, the maps stop at 1."""
    eight = rain.RainSettings(samples=8)
    plane = studio.add_plane(fresh_scene)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=16, y_subdivisions=16, size=2.0, location=(5, 0, 0))
    grid = bpy.context.active_object
    assert rain.bake_rain_image(plane, "UVMap", 32, eight, occluders=[]).max() > 1.005  # what is clamped
    options = bake.BakeOptions(maps=("rain",), resolution=32, out_dir=str(tmp_path), rain_settings=eight)
    [outcome] = bake.bake_maps([plane], options)
    pixels, _ = imageio.read_image(outcome.where)
    assert pixels.min() > 0.95 and pixels.max() == 1.0
    bake.bake_maps([grid], bake.BakeOptions(maps=("rain",), target="attribute", rain_settings=eight))
    colours = np.empty(len(grid.data.loops) * 4, dtype=np.float32)
    grid.data.color_attributes["pw_rain"].data.foreach_get("color", colours)
    assert colours.min() > 0.95 and colours.max() == 1.0
