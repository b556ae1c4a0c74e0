"""Sun bake against the rain bake: error against a high-sample reference vs samples per texel and
wall time, on the rain benchmark's scene.

    python benchmarks/bench_sun.py [--resolution 128] [--reference 1024]

The ~100k-triangle terrain half under a roof of benchmarks/bench_rain.py, baked to a RESOLUTION²
image: the rain (its default sky, the sun lamp; vertical rain, cone 15°) and the sun map (50° N,
north along +Y). For each sample count: wall time and the RMSE against each map's own reference
baked at --reference samples with another seed. Writes the table, and the sun samples that match
the rain's default error, to docs/sun_benchmark.md.
"""

import argparse
import pathlib
import sys
import time

import bpy

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
import bench_rain  # noqa: E402  (benchmarks/bench_rain.py: the scene)
import machine  # noqa: E402  (benchmarks/machine.py)

from porous_weathering.maps import rain, sun  # noqa: E402

SAMPLES = (4, 16, 64, 256)
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
        started = time.perf_counter()
        if kind == "rain":
            settings = rain.RainSettings(cone=15.0, samples=samples, seed=seed)
            image = rain.bake_rain_image(obj, "UVMap", args.resolution, settings, occluders=[roof])
        else:
            settings = sun.SunSettings(latitude=50.0, north_angle=0.0, samples=samples, seed=seed)
            image = sun.bake_sun_image(obj, "UVMap", args.resolution, settings, occluders=[roof])
        return image, time.perf_counter() - started

    rows = []
    for kind in ("rain", "sun"):
        reference, reference_time = bake(kind, args.reference, seed=1)
        print(f"{kind:5} reference {args.reference} spp {reference_time:7.2f} s", flush=True)
        for samples in SAMPLES:
            image, seconds = bake(kind, samples)
            rmse = float(np.sqrt(np.mean((image - reference) ** 2)))
            rows.append((kind, samples, seconds, rmse))
            print(f"{kind:5} {samples:5d} spp  {seconds:7.2f} s  RMSE {rmse:.4f}", flush=True)
    OUT.write_text(report(rows, triangles, args))
    print(f"wrote {OUT}")


def report(rows, triangles, args):
    """docs/sun_benchmark.md: the setting, the table and the time each map takes at the rain's
    default error (RMSE falls as 1 / √samples: interpolated in log-log between measured counts)."""
    lines = [
        "# Sun bake against the rain bake: error against samples per texel and wall time",
        "",
        f"`python benchmarks/bench_sun.py` ({machine.describe(bpy.app.version_string)}).",
        "",
        f"A {triangles}-triangle terrain half under a roof (benchmarks/bench_rain.py), {args.resolution}² texels; "
        "rain: vertical, cone 15°, sun lamp; sun: 50° N. Each against its own reference at "
        f"{args.reference} samples (another seed).",
        "",
        "| map | samples per texel | wall time (s) | RMSE vs reference | RMSE × 255 |",
        "|---|---:|---:|---:|---:|",
    ]
    lines += [f"| {kind} | {n} | {seconds:.2f} | {rmse:.4f} | {rmse * 255:.1f} |" for kind, n, seconds, rmse in rows]
    target = next(rmse for kind, n, _, rmse in rows if kind == "rain" and n == rain.DEFAULT_SAMPLES)
    rain_time = next(seconds for kind, n, seconds, _ in rows if kind == "rain" and n == rain.DEFAULT_SAMPLES)
    sun_rows = sorted((rmse, seconds) for kind, _, seconds, rmse in rows if kind == "sun")
    errors, times = np.log([r for r, _ in sun_rows]), np.log([s for _, s in sun_rows])
    sun_time = float(np.exp(np.interp(np.log(target), errors, times)))
    lines += [
        "",
        f"At the rain's default error (`rain.DEFAULT_SAMPLES` = {rain.DEFAULT_SAMPLES}: RMSE {target * 255:.1f}/255 "
        f"in {rain_time:.2f} s) the sun bake takes {sun_time:.2f} s (interpolated in log-log); its default, "
        f"`sun.DEFAULT_SAMPLES` = {sun.DEFAULT_SAMPLES}. "
        "Why: [maps.md](maps.md#sun-exposure-s-porous_weatheringmapssunpy).",
    ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
