"""``bake --workers N`` / ``--scheduler ADDRESS``: real Dask clusters on loopback, against the serial run."""

import contextlib
import logging
import os
import pathlib
import re
import select
import shutil
import signal
import subprocess
import time

import bpy

import dask
import numpy as np
import psutil
import pytest
from distributed import LocalCluster

from helpers import cli_command, run_cli, temporary_env
from porous_weathering.cli import distributed
from porous_weathering.common import imageio
from porous_weathering.maps import registry as maps

ROOT = pathlib.Path(__file__).resolve().parent.parent
FACADE = ROOT / "sample_blends" / "limestone_facade.blend"
SMALL = ["--resolution", "64", "--samples", "4", "--sun-samples", "4"]
TIMEOUT = 240
#: The lines of the bake command that say what it did, or failed to do, with a file or map.
OUTCOME = re.compile(r"^(written|unchanged|planned|saved|error:) ")


def outcomes(result, out):
    """(exit code, sorted outcome and error lines, with ``out`` written OUT): under Dask the
    files finish in any order."""
    lines = re.split(r"[\r\n]", result.stdout + "\n" + result.stderr)
    return result.returncode, sorted(line.replace(str(out), "OUT") for line in lines if OUTCOME.match(line))


def maps_of(folder):
    """{file name: pixels} of the maps in ``folder``; a truncated or broken map fails to read."""
    return {name: imageio.read_image(folder / name)[0] for name in sorted(os.listdir(folder)) if name.endswith(".exr")}


def assert_same_maps(folder, expected):
    baked = maps_of(folder)
    assert baked.keys() == expected.keys()
    for name, pixels in expected.items():
        assert np.array_equal(baked[name], pixels), name


def bake_processes(cli):
    """The bake processes under the command ``cli`` (each a child of a worker)."""
    processes = psutil.Process(cli.pid).children(recursive=True)
    return [p for p in processes if "porous_weathering.cli.dask_worker import serve" in " ".join(p.cmdline())]


def gone(process):
    with contextlib.suppress(psutil.NoSuchProcess):
        process.wait(timeout=10)
    return not process.is_running()


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """scene0 and scene1: a cube Block<i> on a plane "Ground" (the same name in both: their Ground
    maps clash); scene2: a cube alone; broken.blend: no .blend Blender can open (the file fails
    as it is baked: the up-front checks pass a file they cannot open on to the bake)."""
    folder = tmp_path_factory.mktemp("scenes")
    for index in range(3):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bpy.ops.mesh.primitive_cube_add(size=1.0, rotation=(0.3 * index, 0.2, 0))
        bpy.context.object.name = f"Block{index}"
        if index < 2:
            bpy.ops.mesh.primitive_plane_add(size=3.0, location=(0, 0, -0.5))
            bpy.context.object.name = "Ground"
        bpy.ops.wm.save_as_mainfile(filepath=str(folder / f"scene{index}.blend"), copy=True)
    (folder / "broken.blend").write_bytes(b"BLENDER-v500 but nothing after it")
    return folder


@contextlib.contextmanager
def running_scheduler(temporary):
    """The address of a scheduler with one worker process, on loopback, their scratch space in
    ``temporary`` (not Dask's own in the system's temporary folder)."""
    with (
        dask.config.set({"temporary-directory": str(temporary)}),
        LocalCluster(
            n_workers=1,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ) as cluster,
    ):
        yield cluster.scheduler_address


def test_a_name_clash_is_refused_as_in_the_serial_run_and_a_rerun_skips_what_is_done(scenes, tmp_path):
    files = [scenes / f"scene{index}.blend" for index in range(3)]
    serial, dask = tmp_path / "serial", tmp_path / "dask"
    first = run_cli("bake", *files, "--out", serial, *SMALL, timeout=TIMEOUT)
    code, lines = outcomes(first, serial)
    assert code == 3 and any("scene1.blend" in line and "Ground" in line for line in lines if "error:" in line)
    temporary = tmp_path / "tmp"
    on_cluster = run_cli("bake", *files, "--out", dask, "--workers", "2", *SMALL, timeout=TIMEOUT, temporary=temporary)
    assert outcomes(on_cluster, dask) == (code, lines)
    # Blender's notes left out as in the serial run: its bake's report (through Python's stream,
    # which a bake process forwards) and Blender 4's progress lines
    assert not any(note in on_cluster.stdout + on_cluster.stderr for note in ("Baking map saved", "Fra:"))
    assert_same_maps(dask, maps_of(serial))
    assert not os.listdir(temporary)  # no folder of Blender's, multiprocessing's or Dask's left

    stamps = {name: os.stat(dask / name).st_mtime_ns for name in os.listdir(dask)}
    with running_scheduler(tmp_path / "scheduler") as address:
        again = outcomes(run_cli("bake", *files, "--out", dask, "--scheduler", address, *SMALL, timeout=TIMEOUT), dask)
    assert again == outcomes(run_cli("bake", *files, "--out", serial, *SMALL, timeout=TIMEOUT), serial)
    assert again[0] == 3 and "unchanged Block0.rain -> OUT/Block0.rain.exr" in again[1]
    assert all(os.stat(dask / name).st_mtime_ns == stamp for name, stamp in stamps.items())


def test_forced_clashes_and_a_failed_file_end_as_in_the_serial_run(scenes, tmp_path):
    files = [scenes / name for name in ("scene0.blend", "broken.blend", "scene1.blend", "scene2.blend")]
    serial, dask = tmp_path / "serial", tmp_path / "dask"
    code, lines = outcomes(run_cli("bake", *files, "--out", serial, "--force", *SMALL, timeout=TIMEOUT), serial)
    # scene1 replaced scene0's: each map of the registry written twice for "Ground"
    assert code == 1 and sum(line.startswith("written   Ground.") for line in lines) == 2 * len(maps.names())
    assert outcomes(
        run_cli("bake", *files, "--out", dask, "--force", "--workers", "2", *SMALL, timeout=TIMEOUT), dask
    ) == (code, lines)
    assert_same_maps(dask, maps_of(serial))


def progress_shows(cli, text, deadline):
    """Read the progress bar of ``cli`` (its stderr) until ``text`` shows; all it read."""
    seen = ""
    while text not in seen:
        assert time.monotonic() < deadline and cli.poll() is None, seen
        if select.select([cli.stderr], [], [], 0.1)[0]:
            seen += os.read(cli.stderr.fileno(), 65536).decode(errors="replace")
    return seen


@pytest.mark.parametrize("victim", ["worker", "bake process"])
def test_a_task_whose_worker_or_bake_process_is_killed_is_retried_and_no_map_is_lost(tmp_path, victim):
    serial = tmp_path / "serial"
    assert run_cli("bake", FACADE, "--out", serial, "--maps", "rain", *SMALL, timeout=TIMEOUT).returncode == 0
    out, temporary = tmp_path / "dask", tmp_path / "tmp"
    cli = subprocess.Popen(
        cli_command("bake", FACADE, "--out", out, "--maps", "rain", "--workers", "2", *SMALL),
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=temporary_env(temporary),
    )
    try:
        seen = progress_shows(cli, "Capitals: rain", time.monotonic() + TIMEOUT)  # the first map of 12
        (baking,) = bake_processes(cli)  # a bake process starts with its worker's first task
        (baking.parent() if victim == "worker" else baking).kill()
        stdout, stderr = cli.communicate(timeout=TIMEOUT)
    finally:
        cli.kill()
    assert cli.returncode == 0, stderr
    assert len([line for line in stdout.splitlines() if line.startswith("retried")]) == 1, stdout
    assert not re.search("Traceback|Compute Failed|KilledWorker|error", seen + stderr), stderr
    assert_same_maps(out, maps_of(serial))
    assert gone(baking)  # a killed worker's bake process goes with it
    # what is left: the Blender session folder of a bake process killed (SIGKILL) itself, no other
    left = os.listdir(temporary)
    assert (len(left), all(name.startswith("blender_") for name in left)) == (victim == "bake process", True)


def test_an_interrupt_cancels_the_bake_and_saves_nothing(tmp_path):
    scene, out, temporary = tmp_path / "facade.blend", tmp_path / "maps", tmp_path / "tmp"
    shutil.copyfile(FACADE, scene)
    cli = subprocess.Popen(
        cli_command("bake", scene, "--out", out, "--maps", "rain", "--save", "--workers", "1", *SMALL),
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=temporary_env(temporary),
    )
    try:
        progress_shows(cli, "Capitals: rain", time.monotonic() + TIMEOUT)
        (baking,) = bake_processes(cli)
        os.killpg(cli.pid, signal.SIGINT)  # as Ctrl-C on a terminal: to the client and its workers
        stdout, stderr = cli.communicate(timeout=60)
    finally:
        cli.kill()
    assert cli.returncode == 130, stderr
    assert "interrupted" in stderr and "Traceback" not in stderr, stderr
    assert scene.read_bytes() == FACADE.read_bytes()
    assert len(os.listdir(out)) < 12 and not [name for name in os.listdir(out) if not name.endswith(".rain.exr")]
    assert gone(baking)
    assert not os.listdir(temporary)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--workers", "0"], "1 or more"),
        (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "not allowed with"),
        (["--scheduler", "not-an-address"], "cannot reach the Dask scheduler not-an-address"),
    ],
)
def test_bad_cluster_options_fail_with_one_line(scenes, args, message):
    result = run_cli("bake", scenes / "scene0.blend", *args, timeout=TIMEOUT)
    assert result.returncode == 2
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1, result.stderr


class _LostFuture:
    """A task the client lost with its scheduler: neither finished nor failed."""

    status, key = "lost", "bake-0"

    @staticmethod
    def exception():
        return None


def test_a_task_lost_with_its_scheduler_says_so():
    """A task that ends with neither a result nor an error (the scheduler was lost) fails its
    files with a line that says so (it read "NoneType: None")."""
    run = object.__new__(distributed._Run)
    run.attempts = {}
    result = run._result(_LostFuture(), ["/data/a.blend"])
    assert result.code == 1
    assert result.stderr == (
        "error: /data/a.blend: its Dask task ended 'lost' with neither a result nor an error: the scheduler was lost",
    )
