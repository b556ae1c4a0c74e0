"""Scale: bake the maps of a 2M-triangle scan-like mesh and measure peak memory and time.

Each stage runs in a child process of its own; its peak resident memory is the child's
``ru_maxrss`` (from ``os.wait4``), so stages do not hide each other's peaks. The stages go
through the real pipeline, ``bake.bake_maps``:

- ``build``: only make the mesh (the baseline: Python, bpy and the mesh itself);
- ``rain-attribute``: rain exposure to the per-corner colour attribute ``pw_rain``;
- ``rain-image``: rain exposure to a float EXR on the mesh's own (non-overlapping) UV map;
- ``edges-attribute``: the curvature edge mask to the colour attribute ``pw_edges``;
- ``scan-image``: both maps of the scan generator's bust (sample_blends/scan_generator.py: no UVs,
  millimetres) to images, as ``bake`` makes them: its lightmap first (target, docs/scans.md
  "Baking at full size": 2M triangles at 4096² in 4 minutes and 8 GiB);
- ``scan-attribute``: both maps of the bust to colour attributes (target: 90 s at 2M);

the scan stages give the time of each step (the unwrap, each map) too. Then the curvature alone
(``edges.curvature``) at growing sizes, to show it is linear.

    .venv-5.2/bin/python benchmarks/bench_scale.py [--triangles 2000000] [--samples 16]
        [--resolution 4096] [--stages STAGE ...] [--sizes 125000 250000 500000 1000000 2000000]
        [--rounds 3] [--json out.json]

``--stages`` with no stage runs only the curvature series.

The other stages' mesh is a heightfield (a weathered wall: waves, ridges and pits) of triangles
with planar UVs in [0, 1], which the image bake reuses. Rain time grows linearly with
``--samples`` (docs/reliability.md gives the numbers); ``benchmarks/bench_unwrap.py`` times the
lightmaps alone.
"""

import argparse
import json
import os
import sys
import tempfile
import time

import apart  # benchmarks/apart.py (the script's folder is on the path)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
GIB = 1024**3
LIMIT_BYTES = 8 * GIB
DEFAULT_EDGE_RADIUS = 0.05  # scene units, for the curvature stage (the bake's own default follows the object's size)
STAGES = ("build", "rain-attribute", "rain-image", "edges-attribute", "scan-image", "scan-attribute")


def heightfield(name, triangles):
    """A linked mesh object of about ``triangles`` triangles: an n x n grid of quads, each cut
    in two, its height a sum of waves, ridges and pits; UVs planar in [0, 1]."""
    import bpy

    import numpy as np

    n = max(1, int(round((triangles / 2) ** 0.5)))
    u = np.linspace(0.0, 1.0, n + 1)
    x, y = np.meshgrid(u, u, indexing="xy")
    z = (
        0.05 * np.sin(12 * x) * np.cos(9 * y)
        + 0.02 * np.abs(np.sin(40 * x + 3 * y))
        - 0.03 * np.exp(-((x - 0.4) ** 2 + (y - 0.6) ** 2) / 0.002)
    )
    positions = np.stack([x * 4.0, y * 4.0, z], axis=-1).reshape(-1, 3).astype(np.float32)

    a = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()  # lower-left vertex of each quad
    b, c, d = a + 1, a + n + 2, a + n + 1
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int32)

    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.ravel())
    mesh.loops.add(tris.size)
    mesh.loops.foreach_set("vertex_index", tris.ravel())
    mesh.polygons.add(len(tris))
    mesh.polygons.foreach_set("loop_start", np.arange(0, tris.size, 3, dtype=np.int32))
    mesh.update(calc_edges=True)
    layer = mesh.uv_layers.new(name="UVMap")
    uvs = positions[tris.ravel(), :2] / 4.0
    layer.data.foreach_set("uv", np.clip(uvs, 0.0, 1.0).ravel())
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    return obj


def child(args):
    """Run one stage in this process and print its timings as JSON."""
    sys.path.insert(0, ROOT)
    import bpy

    from benchmarks import timing

    bpy.ops.wm.read_factory_settings(use_empty=True)
    start = time.perf_counter()
    if args.child.startswith("scan-"):
        sys.path.insert(0, os.path.join(ROOT, "sample_blends"))
        import scan_generator

        obj = scan_generator.add_to_scene("Bust", *scan_generator.bust_mesh(args.triangles, seed=0))
    else:
        obj = heightfield("Scan", args.triangles)
    result = {
        "stage": args.child,
        "triangles": len(obj.data.polygons),
        "vertices": len(obj.data.vertices),
        "build_s": time.perf_counter() - start,
    }
    # The curvature is timed best of --rounds; a bake runs once (a second run would find its map
    # unchanged and skip it).
    rounds = args.rounds if args.child == "curvature" else 1
    steps = {}  # the scan stages' seconds per step
    timings = [timing.wall_and_cpu_seconds(lambda: run_stage(args.child, obj, args, steps)) for _ in range(rounds)]
    result["stage_s"], result["stage_cpu_s"] = (min(seconds) for seconds in zip(*timings))
    result["steps"] = steps
    apart.report(result)


def run_stage(stage, obj, args, steps):
    from porous_weathering.maps import bake, edges, rain

    settings = rain.RainSettings(samples=args.samples)
    if stage.startswith("scan-"):
        with tempfile.TemporaryDirectory() as out:
            target = stage.removeprefix("scan-")
            options = bake.BakeOptions(target=target, resolution=args.resolution, out_dir=out, rain_settings=settings)
            last = time.perf_counter()
            for step in bake.iter_bake([obj], options):  # the time up to a step is its map's
                steps[step.map] = steps.get(step.map, 0.0) + time.perf_counter() - last
                last = time.perf_counter()
                assert step.outcome is None or step.outcome.status == "written"
    elif stage == "rain-attribute":
        bake.bake_maps([obj], bake.BakeOptions(maps=("rain",), target="attribute", rain_settings=settings))
        assert rain.RAIN_ATTRIBUTE in obj.data.color_attributes
    elif stage == "rain-image":
        with tempfile.TemporaryDirectory() as out:
            [outcome] = bake.bake_maps(
                [obj], bake.BakeOptions(maps=("rain",), resolution=args.resolution, out_dir=out, rain_settings=settings)
            )
            assert outcome.status == "written" and os.path.getsize(outcome.where) > 0
    elif stage == "edges-attribute":
        bake.bake_maps([obj], bake.BakeOptions(maps=("edges",), target="attribute"))
        assert edges.EDGE_ATTRIBUTE in obj.data.color_attributes
    elif stage == "curvature":
        edges.curvature(obj, DEFAULT_EDGE_RADIUS)


def run_child(stage, triangles, args):
    """(timings dict, peak resident bytes) of one stage run in a fresh child process."""
    arguments = ["--child", stage, "--triangles", triangles, "--samples", args.samples]
    done = apart.run(__file__, [*arguments, "--resolution", args.resolution, "--rounds", args.rounds])
    if done.result is None:
        raise RuntimeError(f"stage {stage} at {triangles} triangles failed: {done.errors}")
    return done.result, done.peak_bytes


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=2_000_000)
    parser.add_argument("--samples", type=int, default=64, help="rain samples per corner / texel (the bake's default)")
    parser.add_argument("--resolution", type=int, default=4096, help="image size")
    parser.add_argument(
        "--sizes",
        type=int,
        nargs="+",
        default=[125_000, 250_000, 500_000, 1_000_000, 2_000_000],
        help="triangle counts for the curvature linearity series",
    )
    parser.add_argument("--stages", nargs="*", default=list(STAGES), choices=STAGES)
    parser.add_argument("--rounds", type=int, default=3, help="curvature timings: best of this many")
    parser.add_argument("--json", help="also write the results here")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return child(args)

    import bpy  # noqa: F401  (only to report the version)

    report = {
        "blender": bpy.app.version_string,
        "cpus": os.cpu_count(),
        "samples": args.samples,
        "resolution": args.resolution,
        "stages": [],
        "curvature": [],
    }
    print(
        f"Blender {bpy.app.version_string}, {os.cpu_count()} CPUs, rain samples {args.samples}, "
        f"image {args.resolution}^2, limit {LIMIT_BYTES / GIB:.0f} GiB"
    )
    print(f"{'stage':16} {'triangles':>10} {'build s':>8} {'stage s':>8} {'peak GiB':>9}")
    for stage in args.stages:
        timings, peak = run_child(stage, args.triangles, args)
        timings["peak_bytes"] = peak
        report["stages"].append(timings)
        steps = ", ".join(f"{name} {seconds:.1f} s" for name, seconds in timings["steps"].items())
        print(
            f"{stage:16} {timings['triangles']:>10} {timings['build_s']:8.1f} {timings['stage_s']:8.1f} "
            f"{peak / GIB:9.2f}{'  OVER THE LIMIT' if peak > LIMIT_BYTES else ''}{'  (' + steps + ')' if steps else ''}"
            f"  load {os.getloadavg()[0]:.1f}",
            flush=True,
        )

    print(f"\ncurvature (edges.curvature, radius {DEFAULT_EDGE_RADIUS} scene units)")
    print(f"{'triangles':>10} {'wall s':>8} {'CPU s':>8} {'CPU us / triangle':>18} {'peak GiB':>9}")
    for size in args.sizes:
        timings, peak = run_child("curvature", size, args)
        timings["peak_bytes"] = peak
        report["curvature"].append(timings)
        print(
            f"{timings['triangles']:>10} {timings['stage_s']:8.2f} {timings['stage_cpu_s']:8.2f} "
            f"{1e6 * timings['stage_cpu_s'] / timings['triangles']:18.2f} {peak / GIB:9.2f}",
            flush=True,
        )
    series = report["curvature"]
    if len(series) >= 2:
        per_triangle = [t["stage_cpu_s"] / t["triangles"] for t in series]
        report["curvature_cpu_ratio_largest_to_smallest_per_triangle"] = per_triangle[-1] / per_triangle[0]
        print(
            f"CPU time per triangle, largest / smallest size: {per_triangle[-1] / per_triangle[0]:.2f} "
            "(1.0 is exactly linear)"
        )
    worst = max((t["peak_bytes"] for t in report["stages"] + series), default=0)
    print(f"largest peak: {worst / GIB:.2f} GiB of {LIMIT_BYTES / GIB:.0f} GiB")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(report, handle, indent=2)
    return 0 if worst <= LIMIT_BYTES else 1


if __name__ == "__main__":
    sys.exit(main())
