"""Sun bake against the rain bake: error against a high-sample reference vs samples per texel and
wall time, on the rain benchmark's scene or the main job's façade.

    python benchmarks/bench_sun.py [--scene terrain|facade] [--resolution 512] [--reference 1024]

terrain (the default): the ~100k-triangle terrain half under a roof of benchmarks/bench_rain.py,
baked to a RESOLUTION² image (the bake's default, 512, unless given): the rain (its default sky,
the sun lamp; vertical rain, cone 15°) and the sun map (50° N, north along +Y). facade: the main
job's façade as benchmarks/bench_life.py prepares it (united, cut into 10 cm cells), baked per
corner with the bake's default settings (the rain's and the sun's), the scene's other objects as
occluders. For each sample count: wall time and the RMSE against each map's own reference baked
at --reference samples with another seed. Writes the table, and the time the sun takes at the
rain's default error, to docs/sun_benchmark.md (terrain) or docs/sun_benchmark_facade.md
(facade).
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

from porous_weathering.maps import neighbours, rain, sun  # noqa: E402
from porous_weathering.maps.bake import DEFAULT_RESOLUTION  # noqa: E402

SAMPLES = (4, 16, 64, 128, 256)
DOCS = pathlib.Path(__file__).resolve().parent.parent / "docs"
OUT = {"terrain": DOCS / "sun_benchmark.md", "facade": DOCS / "sun_benchmark_facade.md"}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", choices=tuple(SCENES), default="terrain")
    parser.add_argument("--resolution", type=int, default=DEFAULT_RESOLUTION)
    parser.add_argument("--reference", type=int, default=1024)
    args = parser.parse_args()
    bake, setting, unit = SCENES[args.scene](args)

    def timed(kind, samples, seed=0):
        started = time.perf_counter()
        values = bake(kind, samples, seed)
        return values, time.perf_counter() - started

    rows = []
    for kind in ("rain", "sun"):
        reference, reference_time = timed(kind, args.reference, seed=1)
        print(f"{kind:5} reference {args.reference} spp {reference_time:7.2f} s", flush=True)
        for samples in SAMPLES:
            values, seconds = timed(kind, samples)
            rmse = float(np.sqrt(np.mean((values - reference) ** 2)))
            rows.append((kind, samples, seconds, rmse))
            print(f"{kind:5} {samples:5d} spp  {seconds:7.2f} s  RMSE {rmse:.4f}", flush=True)
    OUT[args.scene].write_text(report(rows, setting, unit, args))
    print(f"wrote {OUT[args.scene]}")


def terrain_scene():
    """(terrain, roof): bench_rain's terrain half under a roof, in a new empty scene."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj, roof = bench_rain.terrain(bpy.context.scene)
    bpy.context.view_layer.update()
    obj.data.calc_loop_triangles()
    return obj, roof


def terrain(args):
    """(bake(kind, samples, seed) -> image, the setting's sentence, what a sample is per) on bench_rain's terrain."""
    obj, roof = terrain_scene()

    def bake(kind, samples, seed):
        if kind == "rain":
            settings = rain.RainSettings(cone=15.0, samples=samples, seed=seed)
            return rain.bake_rain_image(obj, "UVMap", args.resolution, settings, occluders=[roof])
        settings = sun.SunSettings(latitude=50.0, north_angle=0.0, samples=samples, seed=seed)
        return sun.bake_sun_image(obj, "UVMap", args.resolution, settings, occluders=[roof])

    setting = (
        f"A {len(obj.data.loop_triangles)}-triangle terrain half under a roof (benchmarks/bench_rain.py), "
        f"{args.resolution}² texels; rain: vertical, cone 15°, sun lamp; sun: 50° N"
    )
    return bake, setting, "texel"


def facade(args):
    """(bake(kind, samples, seed) -> corner values, the setting's sentence, what a sample is per) on the main job's
    façade."""
    import bench_life  # noqa: PLC0415  (benchmarks/bench_life.py: the main job's façade, on --scene facade only)

    _, [obj], _ = bench_life.facade()
    bake = corner_bake(obj)
    setting = (
        f"The main job's façade as benchmarks/bench_life.py prepares it ({len(obj.data.polygons)} faces, "
        f"{len(obj.data.loops)} corners), per corner; the rain and the sun with the bake's defaults"
    )
    return bake, setting, "corner"


def corner_bake(obj):
    """bake(kind, samples, seed) -> the rain's or the sun's values at ``obj``'s corners, with the bake's
    defaults and the scene's other objects as occluders."""
    occluders = neighbours.default_occluders(obj)

    def bake(kind, samples, seed):
        if kind == "rain":
            return rain.bake_rain_corners(obj, rain.RainSettings(samples=samples, seed=seed), occluders)
        return sun.bake_sun_corners(obj, sun.SunSettings(samples=samples, seed=seed), occluders)

    return bake


#: The scenes (--scene), each (args) -> (bake, setting, unit).
SCENES = {"terrain": terrain, "facade": facade}


def report(rows, setting, unit, args):
    """The benchmark's page: the setting, the table and the time each map takes at the rain's
    default error (RMSE falls as 1 / √samples: interpolated in log-log between measured counts)."""
    lines = [
        f"# Sun bake against the rain bake: error against samples per {unit} and wall time",
        "",
        f"`python benchmarks/bench_sun.py{'' if args.scene == 'terrain' else ' --scene ' + args.scene}` "
        f"({machine.describe(bpy.app.version_string)}).",
        "",
        f"{setting}. Each against its own reference at {args.reference} samples (another seed).",
        "",
        f"| map | samples per {unit} | wall time (s) | RMSE vs reference | RMSE × 255 |",
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
        f"in {rain_time:.2f} s) the sun bake takes {sun_time:.2f} s (interpolated in log-log), "
        f"{sun_time / rain_time:.2f}× the rain's time; its default, "
        f"`sun.DEFAULT_SAMPLES` = {sun.DEFAULT_SAMPLES}. "
        "Why: [maps.md](maps.md#sun-exposure-s-porous_weatheringmapssunpy).",
    ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
