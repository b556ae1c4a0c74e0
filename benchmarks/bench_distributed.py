"""Wall time of ``bake`` on Dask against the serial run (docs/batch.md), every number with the
1-minute load average of the machine when it started; the ratios come from one run of this script.

1. On one machine with workers = cores: the façade and the three samples, serial, with
   ``--workers <cores>`` (the target: no more than 1.3x the serial time), and on a running
   cluster of as many workers whose bake processes have started (``--scheduler``), in
   interleaved rounds.
2. Tasks per second against workers, on FILES tiny files (a cube each, no name clashes, one task
   each): ``--workers 1``, ``--workers 2`` and a simulated many-node cluster (a
   ``LocalCluster(processes=True)`` of NODES worker processes, given as ``--scheduler``), with
   Dask's fixed cost (a run of one file on one worker, less the serial run of it) and its cost
   per task (one worker: what it adds per file over the serial run, the fixed cost taken out).
   For scale: what a fresh Blender per task (a bake command per file) costs per file.

    .venv-5.2/bin/python benchmarks/bench_distributed.py [--rounds 3] [--files 12] [--nodes 8]
"""

import argparse
import logging
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)  # the scheduler and the workers of the simulated cluster import porous_weathering
# The three small samples (not the scan-sized bust: 200k triangles would dominate every run).
SAMPLES = [
    os.path.join(ROOT, "sample_blends", f"{name}.blend")
    for name in ("brick_wall", "limestone_facade", "sculpted_stone")
]
FACADE = SAMPLES[1]
TINY = ["--resolution", "64", "--samples", "4"]


def make_files(folder, count):
    """``count`` .blend files, each a cube ``Block<i>`` (names that do not clash)."""
    import bpy  # here: the spawned workers of the simulated cluster run this module's top level

    paths = []
    for index in range(count):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bpy.ops.mesh.primitive_cube_add(size=1.0, rotation=(0.2 * index, 0.1, 0))
        bpy.context.object.name = f"Block{index}"
        paths.append(os.path.join(folder, f"scene{index}.blend"))
        bpy.ops.wm.save_as_mainfile(filepath=paths[-1], copy=True)
    return paths


class Timer:
    """Runs ``bake`` into a fresh folder each time, so that every map is baked."""

    def __init__(self, folder):
        self.folder, self.runs = folder, 0

    def __call__(self, paths, *options, copies=False):
        """(wall seconds, exit code, load average when it started); on ``copies`` of the files
        (for --save)."""
        self.runs += 1
        run_folder = os.path.join(self.folder, f"run{self.runs}")
        os.makedirs(run_folder)
        if copies:
            paths = [shutil.copy(path, run_folder) for path in paths]
        load = os.getloadavg()[0]
        started = time.perf_counter()
        out = os.path.join(run_folder, "maps")
        command = [sys.executable, "-m", "porous_weathering", "bake", *paths, "--out", out, *options]
        code = subprocess.run(command, cwd=ROOT, capture_output=True).returncode
        return time.perf_counter() - started, code, load


def local_cluster(workers):
    """A cluster of ``workers`` worker processes on loopback, as ``bake --workers`` starts one."""
    from distributed import LocalCluster

    return LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )


def one_machine(timer, workers, rounds):
    """Serial, ``--workers``, and a running cluster, in interleaved rounds (the load of a shared
    machine then hits them alike): median seconds and load, median ratio and its range."""
    print(f"\n### One machine, {workers} workers ({os.cpu_count()} CPUs), median of {rounds} rounds\n")
    print("| bake | serial (s) | `--workers` (s) | ratio | running cluster (s) | ratio | exit codes |")
    print("|---|---:|---:|---:|---:|---:|---|")
    cases = {
        "façade, 256², 32 samples": ([FACADE], ["--resolution", "256", "--samples", "32"]),
        "three samples, 512², 16 samples": (SAMPLES, ["--samples", "16"]),
        "three samples, attribute maps (--save)": (SAMPLES, ["--target", "attribute", "--save"]),
    }
    with local_cluster(workers) as cluster:
        running = ["--scheduler", cluster.scheduler_address]
        timer([FACADE], *TINY, *running)  # starts its bake processes: they stay, as on a cluster in use
        for name, (paths, options) in cases.items():
            copies = "--save" in options
            runs = [
                [
                    timer(paths, *options, copies=copies),
                    timer(paths, *options, "--workers", str(workers), copies=copies),
                    timer(paths, *options, *running, copies=copies),
                ]
                for _ in range(rounds)
            ]
            cells = []
            for column in range(3):
                seconds = statistics.median(r[column][0] for r in runs)
                cells.append(f"{seconds:.1f} (load {statistics.median(r[column][2] for r in runs):.1f})")
                if column:
                    ratios = [r[column][0] / r[0][0] for r in runs]
                    spread = f" ({min(ratios):.2f}-{max(ratios):.2f})" if rounds > 1 else ""
                    cells.append(f"{statistics.median(ratios):.2f}{spread}")
            codes = ", ".join(sorted({str(r[column][1]) for r in runs for column in range(3)}))
            print(f"| {name} | {' | '.join(cells)} | {codes} |")


def tasks_per_second(timer, paths, nodes):
    count = len(paths)
    serial_one, _, load_serial_one = timer(paths[:1], *TINY)
    serial, _, load_serial = timer(paths, *TINY)
    dask_one, _, load_dask_one = timer(paths[:1], *TINY, "--workers", "1")
    runs = {f"--workers {n}": timer(paths, *TINY, "--workers", str(n)) for n in (1, 2)}
    with local_cluster(nodes) as cluster:
        runs[f"{nodes} nodes (simulated, --scheduler)"] = timer(paths, *TINY, "--scheduler", cluster.scheduler_address)

    fixed = dask_one - serial_one
    per_task = (runs["--workers 1"][0] - serial - fixed) / (count - 1)
    print(f"\n### Tasks per second, {count} files of one cube, 2 maps of 64² at 4 samples\n")
    print("| run | wall (s) | tasks/s | load |")
    print("|---|---:|---:|---:|")
    print(f"| serial | {serial:.1f} | {count / serial:.2f} | {load_serial:.1f} |")
    for name, (seconds, _, load) in runs.items():
        print(f"| {name} | {seconds:.1f} | {count / seconds:.2f} | {load:.1f} |")
    print(
        f"\nDask's fixed cost (cluster and bake processes start): {fixed:.1f} s (one file: serial {serial_one:.1f} s, "
        f"load {load_serial_one:.1f}; --workers 1 {dask_one:.1f} s, load {load_dask_one:.1f}).\n"
        f"Dask's cost per task: {per_task:.2f} s. A fresh Blender per task would cost "
        f"{serial_one - serial / count:.2f} s per file (one bake command per file, against one for all)."
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=12, help="tiny files of the tasks-per-second runs")
    parser.add_argument("--nodes", type=int, default=8, help="worker processes of the simulated many-node run")
    parser.add_argument("--workers", type=int, default=os.cpu_count(), help="workers of the one-machine runs")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds of the one-machine runs")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        timer = Timer(folder)
        one_machine(timer, args.workers, args.rounds)
        tasks_per_second(timer, make_files(folder, args.files), args.nodes)


if __name__ == "__main__":
    main()
