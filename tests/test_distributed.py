"""``bake --workers N`` / ``--scheduler ADDRESS``: real Dask clusters on loopback, against the serial run."""

import contextlib
import logging
import os
import pathlib
import signal
import subprocess
import sys
import time

import bpy

import numpy as np
import psutil
import pytest
from distributed import LocalCluster

from porous_weathering import distributed, imageio

ROOT = pathlib.Path(__file__).resolve().parent.parent
TINY = ["--resolution", "16", "--samples", "4"]
FAST = ["--maps", "rain", *TINY]
BOTH_MAPS = ["--maps", "rain,edges", *TINY]
FILES = 3
TIMEOUT = 240


def bake_command(*args):
    return [sys.executable, "-m", "porous_weathering", "bake", *map(str, args)]


def run_cli(*args):
    return subprocess.run(bake_command(*args), cwd=ROOT, capture_output=True, text=True, timeout=TIMEOUT)


def rows(result, status):
    """The ``file: object.map`` of the summary rows with ``status``."""
    return [
        line.split(None, 3)[3].split(" -> ")[0]
        for line in result.stdout.splitlines()
        if line.startswith(status + " ") and " -> " in line
    ]


def maps_of(folder):
    """{file name: pixels} of the maps in ``folder``; a truncated or broken map fails to read."""
    return {name: imageio.read_image(folder / name)[0] for name in sorted(os.listdir(folder)) if name.endswith(".exr")}


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """FILES .blend files, each a cube ``Block<i>`` turned a little more than the last, and the
    maps the serial run bakes from them."""
    folder = tmp_path_factory.mktemp("scenes")
    paths = []
    for index in range(FILES):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bpy.ops.mesh.primitive_cube_add(size=1.0, rotation=(0.3 * index, 0.2, 0))
        bpy.context.object.name = f"Block{index}"
        paths.append(folder / f"scene{index}.blend")
        bpy.ops.wm.save_as_mainfile(filepath=str(paths[-1]), copy=True)
    serial = run_cli(*paths, "--out", folder / "serial", *BOTH_MAPS)
    assert serial.returncode == 0, serial.stderr
    return paths, maps_of(folder / "serial")


def test_two_workers_bake_the_maps_of_the_serial_run_bit_for_bit(scenes, tmp_path):
    paths, serial = scenes
    out = tmp_path / "maps"
    result = run_cli(*paths, "--out", out, "--workers", "2", *BOTH_MAPS)
    assert result.returncode == 0, result.stderr
    assert len(rows(result, "written")) == 2 * FILES and "bake [" in result.stderr  # summary and progress bar
    baked = maps_of(out)
    assert baked.keys() == serial.keys() and len(baked) == 2 * FILES
    for name, pixels in serial.items():
        assert np.array_equal(baked[name], pixels), name


@contextlib.contextmanager
def running_scheduler():
    """The address of a scheduler with one worker process, on loopback."""
    with LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        silence_logs=logging.ERROR,
    ) as cluster:
        yield cluster.scheduler_address


def test_a_rerun_on_a_running_scheduler_skips_the_maps_that_are_done(scenes, tmp_path):
    paths, _ = scenes
    out = tmp_path / "maps"
    with running_scheduler() as address:
        first = run_cli(paths[0], "--out", out, "--scheduler", address, *FAST)
        assert first.returncode == 0, first.stderr
        stamps = {name: os.stat(out / name).st_mtime_ns for name in os.listdir(out)}
        again = run_cli(*paths[:2], "--out", out, "--scheduler", address, *FAST)
    assert again.returncode == 0, again.stderr
    assert rows(again, "unchanged") == ["scene0.blend: Block0.rain"]
    assert rows(again, "written") == ["scene1.blend: Block1.rain"]
    assert all(os.stat(out / name).st_mtime_ns == stamp for name, stamp in stamps.items())


def kill_the_worker_baking(cli, marker, deadline):
    """SIGKILL the Dask worker process (a descendant of ``cli``) whose bake process has ``marker``
    in its command line, as soon as that bake starts; returns the worker's pid."""
    while time.monotonic() < deadline and cli.poll() is None:
        for process in psutil.Process(cli.pid).children(recursive=True):
            with contextlib.suppress(psutil.Error):
                if marker in process.cmdline() and "--dry-run" not in process.cmdline():
                    worker = process.parent()
                    time.sleep(0.3)  # mid-bake, and the worker's previous result has reached the CLI
                    os.kill(worker.pid, signal.SIGKILL)
                    return worker.pid
        time.sleep(0.02)
    raise AssertionError(f"no bake process with {marker} started")


def test_a_task_whose_worker_dies_is_retried_and_no_map_is_lost(scenes, tmp_path):
    paths, serial = scenes
    out = tmp_path / "maps"
    cli = subprocess.Popen(
        bake_command(*paths, "--out", out, "--workers", "2", *BOTH_MAPS),
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        killed = kill_the_worker_baking(cli, "--objects=Block1", time.monotonic() + TIMEOUT)
        stdout, stderr = cli.communicate(timeout=TIMEOUT)
    finally:
        cli.kill()
    assert not psutil.pid_exists(killed) or psutil.Process(killed).status() == psutil.STATUS_ZOMBIE
    assert cli.returncode == 0, stderr
    retried = [line for line in stdout.splitlines() if line.startswith("retried")]
    assert any("scene1.blend: Block1." in line for line in retried), stdout
    baked = maps_of(out)  # complete and readable, none missing
    assert baked.keys() == serial.keys()
    for name, pixels in serial.items():
        assert np.array_equal(baked[name], pixels), name


@pytest.mark.parametrize(
    "args, message",
    [
        (["--workers", "0"], "1 or more"),
        (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "not allowed with"),
        (["--workers", "1", "--target", "attribute", "--save"], "attribute maps live in the .blend"),
        (["--scheduler", "tcp://127.0.0.1:9"], "cannot reach the Dask scheduler"),
    ],
)
def test_bad_cluster_options_fail_with_a_clear_message(scenes, args, message):
    result = run_cli(scenes[0][0], *args)
    assert result.returncode == 2
    assert message in result.stderr


def test_a_failed_task_fails_the_run_and_the_others_still_bake(scenes, tmp_path):
    paths, _ = scenes
    result = run_cli(*paths[:2], "--objects", "Block0", "--out", tmp_path, "--workers", "1", *FAST)
    assert result.returncode == 1
    assert "scene1.blend: no object named Block0" in result.stderr
    assert os.listdir(tmp_path) == ["Block0.rain.exr"]


def test_outcome_lines_of_the_bake_command_are_parsed():
    stdout = (
        "noise\nwritten   My.Object.rain -> /out/My.Object.rain.exr\nplanned   B.edges -> /o/B.edges.exr\nsaved     x\n"
    )
    assert distributed.parse_outcomes(stdout) == [
        ("written", "My.Object", "rain", "/out/My.Object.rain.exr"),
        ("planned", "B", "edges", "/o/B.edges.exr"),
    ]
