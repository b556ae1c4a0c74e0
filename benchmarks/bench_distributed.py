"""Wall time of ``bake`` on N files: serial, and on a local Dask cluster of 1 and 2 workers,
as a ratio against the serial run (docs/batch.md). Each run bakes into a fresh folder, so
every map is baked; the times include starting the cluster and one bpy process per task.

    .venv-5.2/bin/python benchmarks/bench_distributed.py [--files 4] [--resolution 64] [--samples 16]
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

import bpy  # noqa: E402


def make_files(folder, count):
    """``count`` .blend files, each a subdivided cube ``Block<i>`` under a roof slab ``Roof<i>``."""
    paths = []
    for index in range(count):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bpy.ops.mesh.primitive_cube_add(size=1.0, rotation=(0.2 * index, 0.1, 0))
        bpy.context.object.name = f"Block{index}"
        bpy.ops.object.modifier_add(type="SUBSURF")
        bpy.ops.object.modifier_apply(modifier="Subdivision")
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.4, 0, 1.2), scale=(1, 1, 0.05))
        bpy.context.object.name = f"Roof{index}"
        paths.append(os.path.join(folder, f"scene{index}.blend"))
        bpy.ops.wm.save_as_mainfile(filepath=paths[-1], copy=True)
    return paths


def timed_bake(paths, out, options):
    started = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "porous_weathering", "bake", *paths, "--out", out, *options],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    return time.perf_counter() - started


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=4)
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--maps", default="rain,edges")
    args = parser.parse_args()
    options = ["--maps", args.maps, "--resolution", str(args.resolution), "--samples", str(args.samples)]

    with tempfile.TemporaryDirectory() as folder:
        paths = make_files(folder, args.files)
        maps = 2 * args.files * len(args.maps.split(","))
        runs = {"serial": []} | {f"--workers {n}": ["--workers", str(n)] for n in (1, 2)}
        times = {
            name: timed_bake(paths, os.path.join(folder, name.replace(" ", "")), options + extra)
            for name, extra in runs.items()
        }

    print(
        f"{args.files} files, {maps} maps of {args.resolution}^2 texels, {args.samples} samples, {os.cpu_count()} CPUs"
    )
    print("| run | wall time (s) | ratio to serial |")
    print("|---|---:|---:|")
    for name, seconds in times.items():
        print(f"| {name} | {seconds:.1f} | {seconds / times['serial']:.2f} |")


if __name__ == "__main__":
    main()
