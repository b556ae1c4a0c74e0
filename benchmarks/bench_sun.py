"""Sun bake against the rain bake: error against a high-sample reference vs samples per texel and
wall time, on the rain benchmark's scene.

    python benchmarks/bench_sun.py [--resolution 128] [--reference 1024]

The ~100k-triangle terrain half under a roof of benchmarks/bench_rain.py, baked to a RESOLUTION²
image: the rain (its default sky, the sun lamp; vertical rain, cone 15°) and the sun map (50° N,
north along +Y), as baked (the unshadowed exposure as control variate, docs/model.md §9.1) and
plain (one bake, as before it: "sun plain"). For each sample count: wall time and the RMSE
against each map's own reference baked at --reference samples with another seed (the sun's, as
baked, for both sun rows: they estimate the same map). Writes the table, and the time each sun
bake takes at the rain's default error over the rain's, to docs/sun_benchmark.md.
"""

import argparse
import dataclasses
import os
import pathlib
import sys
import time

import bpy

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
import bench_rain  # noqa: E402  (benchmarks/bench_rain.py: the scene)
import machine  # noqa: E402  (benchmarks/machine.py)

from porous_weathering.core import solar  # noqa: E402
from porous_weathering.maps import rain, sky_bake, sun  # noqa: E402

SAMPLES = {"rain": (4, 16, 64, 256), "sun": (4, 16, 64, 256), "sun plain": (64, 256)}
OUT = pathlib.Path(__file__).resolve().parent.parent / "docs" / "sun_benchmark.md"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--reference", type=int, default=1024)
    args = parser.parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj, roof = bench_rain.terrain(bpy.context.scene)
    bpy.context.view_layer.update()
    obj.data.calc_loop_triangles()
    triangles = len(obj.data.loop_triangles)

    def bake(kind, samples, seed=0):
        solar._exposure_table.cache_clear()  # each bake pays for its table, as a first bake at a site does
        started = time.perf_counter()
        if kind == "rain":
            settings = rain.RainSettings(cone=15.0, samples=samples, seed=seed)
            image = rain.bake_rain_image(obj, "UVMap", args.resolution, settings, occluders=[roof])
        elif kind == "sun":
            settings = sun.SunSettings(latitude=50.0, north_angle=0.0, samples=samples, seed=seed)
            image = sun.bake_sun_image(obj, "UVMap", args.resolution, settings, occluders=[roof])
        else:
            settings = sun.SunSettings(latitude=50.0, north_angle=0.0, samples=samples, seed=seed)
            plain = dataclasses.replace(sun.sky(settings, 50.0, 0.0), unshadowed=None)
            image = sky_bake.bake_image(obj, "UVMap", args.resolution, plain, occluders=[roof])
        return image, time.perf_counter() - started

    load = os.getloadavg()[0]
    rows = []
    for kind in SAMPLES:
        if kind != "sun plain":
            reference, reference_time = bake(kind, args.reference, seed=1)
            print(f"{kind:9} reference {args.reference} spp {reference_time:7.2f} s", flush=True)
        for samples in SAMPLES[kind]:
            image, seconds = bake(kind, samples)
            rmse = float(np.sqrt(np.mean((image - reference) ** 2)))
            rows.append((kind, samples, seconds, rmse))
            print(f"{kind:9} {samples:5d} spp  {seconds:7.2f} s  RMSE {rmse:.4f}", flush=True)
    OUT.write_text(report(rows, triangles, args, load))
    print(f"wrote {OUT}")


def report(rows, triangles, args, load):
    """docs/sun_benchmark.md: the setting, the table and the time each map takes at the rain's
    default error (interpolated in log-log between measured counts), over the rain's."""
    lines = [
        "# Sun bake against the rain bake: error against samples per texel and wall time",
        "",
        f"`python benchmarks/bench_sun.py` ({machine.describe(bpy.app.version_string)}; "
        f"load average {load:.1f} at the start). Times are inflated by the load; their ratios are the figure.",
        "",
        f"A {triangles}-triangle terrain half under a roof (benchmarks/bench_rain.py), {args.resolution}² texels; "
        "rain: vertical, cone 15°, sun lamp; sun: 50° N, as baked (the unshadowed exposure as control "
        "variate) and plain (one bake, as before it). Each against its own reference at "
        f"{args.reference} samples (another seed; the sun's as baked for both sun rows).",
        "",
        "| map | samples per texel | wall time (s) | RMSE vs reference | RMSE × 255 |",
        "|---|---:|---:|---:|---:|",
    ]
    lines += [f"| {kind} | {n} | {seconds:.2f} | {rmse:.4f} | {rmse * 255:.1f} |" for kind, n, seconds, rmse in rows]
    target = next(rmse for kind, n, _, rmse in rows if kind == "rain" and n == rain.DEFAULT_SAMPLES)
    rain_time = next(seconds for kind, n, seconds, _ in rows if kind == "rain" and n == rain.DEFAULT_SAMPLES)
    lines += [
        "",
        f"At the rain's default error (`rain.DEFAULT_SAMPLES` = {rain.DEFAULT_SAMPLES}: RMSE {target * 255:.1f}/255 "
        f"in {rain_time:.2f} s), interpolated in log-log (extended past the ends):",
        "",
    ]
    for name in ("sun", "sun plain"):
        measured = sorted((rmse, seconds, n) for kind, n, seconds, rmse in rows if kind == name)
        errors = np.log([r for r, _, _ in measured])
        seconds = float(np.exp(_interpolate(np.log(target), errors, np.log([s for _, s, _ in measured]))))
        samples = float(np.exp(_interpolate(np.log(target), errors, np.log([n for _, _, n in measured]))))
        ratio = seconds / rain_time
        lines.append(f"- {name}: {samples:.0f} samples, {seconds:.2f} s, **{ratio:.2f}× the rain's time**")
    lines += [
        "",
        f"The sun's default, `sun.DEFAULT_SAMPLES` = {sun.DEFAULT_SAMPLES}. "
        "Why: [maps.md](maps.md#sun-exposure-s-porous_weatheringmapssunpy).",
    ]
    return "\n".join(lines) + "\n"


def _interpolate(x, xs, ys):
    """ys at x along the line through (xs, ys) sorted by xs, extended past its ends by the
    nearest segment."""
    i = int(np.clip(np.searchsorted(xs, x), 1, len(xs) - 1))
    return ys[i - 1] + (ys[i] - ys[i - 1]) * (x - xs[i - 1]) / (xs[i] - xs[i - 1])


if __name__ == "__main__":
    main()
