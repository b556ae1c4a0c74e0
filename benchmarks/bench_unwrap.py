"""Lightmaps at scan size: time, texel utilisation and seam length against triangle count.

    python benchmarks/bench_unwrap.py [--sizes 100000 400000 2000000] [--resolution 4096]
        [--methods shipped xatlas smart check] [--xatlas-up-to 400000] [--json FILE]

Every (method, size) runs in a child process of its own (its peak memory is the child's
``ru_maxrss``), on the scan generator's bust (sample_blends/scan_generator.py: millimetres, no
UVs). The methods:

- ``shipped``: ``uv.make_lightmap`` as the bake runs it: above ``uv.XATLAS_CHARTS`` triangles,
  charts by projection on the axes, the fold search, xatlas' packing and the check;
- ``xatlas``: the same with xatlas' own charts (as below ``uv.XATLAS_CHARTS``); slow, so only
  up to ``--xatlas-up-to`` triangles;
- ``smart``: Blender's Smart UV Project (``bpy.ops.uv.smart_project``, the padding as island
  margin) on the mesh in Edit Mode, then the same check;
- ``check``: ``uv.check_uvs`` alone, on the shipped lightmap: what reusing a lightmap costs
  (the second bake of a scan).

Columns: wall and CPU seconds of the method (not the mesh's building), CPU µs per triangle,
texel utilisation (the texels whose centre lies on a triangle, over all), UV islands, seam
length (the 3D length of the edges along which the UV map is cut, over the square root of the
surface area: unit-free), whether the check passes, the child's peak resident memory, and the
load average while it ran (the machine may be shared: CPU time is the fairer measure then).
Last, for each method, the least-squares line of CPU seconds against triangles: its slope (µs per
triangle) and the time per triangle at the largest size over that at the smallest.
"""

import argparse
import json
import os
import pathlib
import sys
import time

import apart  # benchmarks/apart.py (the script's folder is on the path)

ROOT = pathlib.Path(__file__).resolve().parents[1]
GIB = 1024**3
METHODS = ("shipped", "xatlas", "smart", "check")


def seam_length(positions, vertices, triangle_uvs):
    """The 3D length of the mesh edges whose two triangles give their ends different UVs, over the
    square root of the surface area."""
    import numpy as np

    first, second = vertices, np.roll(vertices, -1, axis=1)
    uv_first, uv_second = triangle_uvs, np.roll(triangle_uvs, -1, axis=1)
    swap = first > second  # each edge with its lower vertex first, and its UVs likewise
    low, high = np.where(swap, second, first).ravel(), np.where(swap, first, second).ravel()
    uv_low = np.where(swap[..., None], uv_second, uv_first).reshape(-1, 2)
    uv_high = np.where(swap[..., None], uv_first, uv_second).reshape(-1, 2)
    order = np.lexsort((high, low))
    low, high, uv_low, uv_high = low[order], high[order], uv_low[order], uv_high[order]
    pair = (low[1:] == low[:-1]) & (high[1:] == high[:-1])  # an edge between two triangles
    cut = pair & np.any((uv_low[1:] != uv_low[:-1]) | (uv_high[1:] != uv_high[:-1]), axis=1)
    lengths = np.linalg.norm(positions[high[1:][cut]] - positions[low[1:][cut]], axis=1)
    a, b, c = (positions[vertices[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()
    return float(lengths.sum() / np.sqrt(area))


def child(args):
    """Run one method at one size in this process; print its result as JSON."""
    sys.path[:0] = [str(ROOT), str(ROOT / "sample_blends"), str(ROOT / "benchmarks")]
    import numpy as np
    import scan_generator
    import timing

    from porous_weathering.maps import lightmap, lightmap_child

    vertices, faces = scan_generator.bust_mesh(args.triangles, seed=0)
    positions, triangles = vertices.astype(np.float32), faces.astype(np.int64)
    polygons = np.arange(len(triangles))
    areas = lightmap.triangle_areas(positions.astype(np.float64)[triangles])
    padding = lightmap.padding_for(args.resolution)
    made = {}

    def shipped():
        made["uvs"], made["report"] = lightmap.make_lightmap(positions, triangles, polygons, args.resolution, padding)

    def xatlas():
        lightmap_child.XATLAS_CHARTS = len(triangles)
        shipped()

    def smart():
        made["uvs"] = smart_project(scan_generator, positions, faces, args.resolution, padding)
        made["report"] = lightmap.check_uvs(made["uvs"], areas, args.resolution, padding)

    def check():
        made["report"] = lightmap.check_uvs(made["uvs"], areas, args.resolution, padding)

    if args.child == "check":
        shipped()
    load = os.getloadavg()[0]
    wall, cpu = timing.wall_and_cpu_seconds(
        {"shipped": shipped, "xatlas": xatlas, "smart": smart, "check": check}[args.child]
    )
    report = made["report"]
    result = {
        "method": args.child,
        "triangles": len(triangles),
        "resolution": args.resolution,
        "wall_s": wall,
        "cpu_s": cpu,
        "utilisation": report.utilisation,
        "islands": report.islands,
        "seam_length": seam_length(positions.astype(np.float64), triangles, made["uvs"]),
        "passes": report.ok,
        "problems": report.problems(),
        "load": (load + os.getloadavg()[0]) / 2,
    }
    apart.report(result)


def smart_project(scan_generator, positions, faces, resolution, padding):
    """Per-triangle UVs of Blender's Smart UV Project of the mesh."""
    import bpy

    import numpy as np

    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = scan_generator.add_to_scene("Bust", positions, faces)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(island_margin=padding / resolution, margin_method="FRACTION")
    bpy.ops.object.mode_set(mode="OBJECT")
    uvs = np.empty(len(obj.data.loops) * 2, dtype=np.float32)
    obj.data.uv_layers.active.data.foreach_get("uv", uvs)
    return uvs.reshape(-1, 3, 2)  # the bust's faces are triangles, one per polygon, in order


def run_child(method, triangles, resolution):
    """(result dict or None if it failed, peak resident bytes) of one method at one size, in a
    fresh child process."""
    done = apart.run(__file__, ["--child", method, "--triangles", triangles, "--resolution", resolution])
    return done.result, done.peak_bytes


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 400_000, 2_000_000])
    parser.add_argument("--resolution", type=int, default=4096)
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--xatlas-up-to", type=int, default=400_000, help="xatlas' charts only up to this size")
    parser.add_argument("--json", help="also write the results here")
    parser.add_argument("--child", choices=METHODS, help=argparse.SUPPRESS)
    parser.add_argument("--triangles", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return child(args)

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bpy

    import machine
    import numpy as np

    print(f"{machine.describe(bpy.app.version_string)}; lightmaps at {args.resolution}²\n")
    columns = ("method", "triangles", "wall s", "CPU s", "CPU µs / triangle", "utilisation", "islands", "seams")
    print(f"| {' | '.join(columns + ('passes', 'peak GiB', 'load'))} |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    results = []
    for method in args.methods:
        for size in args.sizes:
            if method == "xatlas" and size > args.xatlas_up_to:
                continue
            started = time.perf_counter()
            result, peak = run_child(method, size, args.resolution)
            if result is None:
                print(f"| {method} | {size} | failed after {time.perf_counter() - started:.0f} s | | | | | | | | |")
                continue
            result["peak_bytes"] = peak
            results.append(result)
            passes = "yes" if result["passes"] else "no: " + "; ".join(result["problems"])
            print(
                f"| {method} | {result['triangles']:,} | {result['wall_s']:.1f} | {result['cpu_s']:.1f} | "
                f"{1e6 * result['cpu_s'] / result['triangles']:.1f} | {result['utilisation']:.3f} | "
                f"{result['islands']} | {result['seam_length']:.1f} | {passes} | {peak / GIB:.2f} | "
                f"{result['load']:.1f} |",
                flush=True,
            )
    print()
    for method in args.methods:
        rows = [r for r in results if r["method"] == method]
        if len(rows) >= 2:
            sizes = np.array([r["triangles"] for r in rows], dtype=float)
            cpu = np.array([r["cpu_s"] for r in rows])
            slope, intercept = np.polyfit(sizes, cpu, 1)
            growth = (cpu[-1] / sizes[-1]) / (cpu[0] / sizes[0])
            print(
                f"{method}: CPU s = {intercept:.2f} + {1e6 * slope:.2f} µs × triangles; "
                f"per triangle, largest / smallest size: {growth:.2f} (1.0 is linear)"
            )
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
