"""The sun map's sky as sun lamps, one per cell of the sky, against the world image it is baked
under (docs/maps.md, "Sun exposure", "Measured and not kept").

    python benchmarks/bench_sun_lamps.py [--scene terrain|facade] [--resolution 64] [--reference 1024]

The year's suns at 50° N (``core.solar.year``) binned into sky cells: elevation bands CELL
degrees high, each cut into about-square cells; one sun lamp per non-empty cell along Σ w s
(s its suns' unit directions, w their weights) of strength π |Σ w s|, so that an unshadowed
plane that sees the whole cell gets exactly its share of S (``sky_bake``: irradiance / π), and
of angular diameter 0 or CELL. Each lamp sky with Cycles' light tree on and off.

On bench_rain's terrain under its roof at RESOLUTION²: every variant and the rain's default sky,
interleaved at 16, 32, 64 and 128 samples (1 sample: the fixed cost of a bake), wall time and RMSE
against the image's bake at --reference samples (another seed); then each 10° lamp sky at
--reference samples, whose RMSE is its bias (its discretisation) plus the two noises. With
--scene facade: the main job's façade as bench_life prepares it, baked per corner by the rain,
the image and the 10° lamps at 1, 64 and 128 samples, the RMSE against the image at --reference
samples. Prints the lines; the times compare only within a run.
"""

import argparse
import math
import os
import pathlib
import sys
import time

import bpy

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "sample_blends"))
import bench_rain  # noqa: E402  (benchmarks/bench_rain.py: the terrain)

from porous_weathering.blender.scratch_scene import aim_sun  # noqa: E402
from porous_weathering.core import solar  # noqa: E402
from porous_weathering.maps import rain, sky_bake, sun  # noqa: E402

LATITUDE = 50.0
#: (cell in degrees, lamp's angular diameter the cell's, Cycles' light tree on); cell None: the image.
VARIANTS = [(None, False, True), (3, False, True), (5, False, True), (10, False, True), (5, True, True)]
VARIANTS += [(10, True, True), (10, False, False), (10, True, False), (5, False, False)]
SAMPLES = (1, 16, 32, 64, 128)
#: Left out above 64 samples: 977 lamps take 0.6 s a sample at 64² under the light tree.
SLOW = (3, False, True)


def sky_cells(directions, weights, cell):
    """(unit directions (C, 3), weights (C,)) of the non-empty cells of ``cell`` degrees: each
    along its suns' Σ w s, weighing |Σ w s|."""
    size = math.radians(cell)
    band = np.floor(np.arcsin(np.clip(directions[:, 2], -1.0, 1.0)) / size).astype(np.int64)
    columns = np.maximum(1, np.round(2.0 * np.pi * np.cos((band + 0.5) * size) / size)).astype(np.int64)
    azimuth = np.arctan2(directions[:, 1], directions[:, 0]) % (2.0 * np.pi)
    column = np.minimum((azimuth / (2.0 * np.pi) * columns).astype(np.int64), columns - 1)
    keys, cell_of = np.unique(band * (1 << 20) + column, return_inverse=True)
    summed = np.stack([np.bincount(cell_of, weights * directions[:, k], len(keys)) for k in range(3)], axis=1)
    strength = np.linalg.norm(summed, axis=1)
    return summed / strength[:, None], strength


def lamp_sky(samples, seed, cell, spread, fixed):
    """The sun's year as one sun lamp per cell; ``fixed`` gets (lamps, seconds making them)."""
    directions, weights = solar.year(LATITUDE)
    towards, strengths = sky_cells(directions, weights, cell)

    def add(scene, made):
        started = time.perf_counter()
        for index, (direction, strength) in enumerate(zip(towards, strengths)):
            light = made.add(bpy.data.lights.new(f"PW Sun {index}", "SUN"))
            light.energy = math.pi * strength
            light.angle = math.radians(cell) if spread else 0.0
            lamp = made.add(bpy.data.objects.new(f"PW Sun {index}", light))
            scene.collection.objects.link(lamp)
            aim_sun(lamp, direction)
        fixed.append((len(towards), time.perf_counter() - started))

    return sky_bake.Sky("Sun", samples, seed, add, lambda normals: np.ones(len(normals), dtype=bool))


def variant_sky(variant, samples, seed, fixed):
    cell, spread, tree = variant
    if cell is None:
        made = sun.sky(sun.SunSettings(samples=samples, seed=seed), LATITUDE, 0.0)
    else:
        made = lamp_sky(samples, seed, cell, spread, fixed)

    def add(scene, ledger):
        made.add(scene, ledger)
        scene.cycles.use_light_tree = tree

    return sky_bake.Sky(made.label, samples, seed, add, made.reaches)


def name(variant):
    cell, spread, tree = variant
    if cell is None:
        return "image"
    return f"{cell}° lamps, angle {f'{cell}°' if spread else '0'}, tree {'on' if tree else 'off'}"


def load():
    return f"load {os.getloadavg()[0]:.1f}"


def terrain_runs(resolution, reference_samples):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj, roof = bench_rain.terrain(bpy.context.scene)
    bpy.context.view_layer.update()
    fixed = []

    def bake(variant, samples, seed=0):
        started = time.perf_counter()
        if variant == "rain":
            settings = rain.RainSettings(cone=15.0, samples=samples, seed=seed)
            image = rain.bake_rain_image(obj, "UVMap", resolution, settings, occluders=[roof])
        else:
            sky = variant_sky(variant, samples, seed, fixed)
            image = sky_bake.bake_image(obj, "UVMap", resolution, sky, occluders=[roof])
        return image, time.perf_counter() - started

    reference, seconds = bake(VARIANTS[0], reference_samples, seed=1)
    print(f"terrain {resolution}², image reference at {reference_samples} samples: {seconds:.1f} s, {load()}")
    print("| sky | samples | time (s) | RMSE | lamps | making them (s) | load |\n|---|---:|---:|---:|---:|---:|---:|")
    for samples in SAMPLES:
        for variant in ["rain", *VARIANTS]:
            if variant == SLOW and samples > 64:
                continue
            fixed.clear()
            image, seconds = bake(variant, samples)
            rmse = "" if variant == "rain" else f"{np.sqrt(np.mean((image - reference) ** 2)):.4f}"
            lamps = f"{fixed[0][0]} | {fixed[0][1]:.2f}" if fixed else " | "
            label = "rain" if variant == "rain" else name(variant)
            print(f"| {label} | {samples} | {seconds:.2f} | {rmse} | {lamps} | {load()[5:]} |", flush=True)
    for variant in VARIANTS:
        if variant[0] == 10:
            image, seconds = bake(variant, reference_samples, seed=2)
            rmse = np.sqrt(np.mean((image - reference) ** 2))
            print(f"{name(variant)} at {reference_samples}: {seconds:.1f} s, RMSE {rmse:.4f}, {load()}", flush=True)


def facade_runs(reference_samples):
    import bench_life  # noqa: PLC0415  (benchmarks/bench_life.py: the main job's façade, on --scene facade only)

    _, [obj], _ = bench_life.facade()
    occluders = sky_bake.default_occluders(obj)
    fixed = []

    def bake(variant, samples, seed=0):
        started = time.perf_counter()
        if variant == "rain":
            values = rain.bake_rain_corners(obj, rain.RainSettings(samples=samples, seed=seed), occluders)
        else:
            values = sky_bake.bake_corners(obj, variant_sky(variant, samples, seed, fixed), occluders)
        return values, time.perf_counter() - started

    reference, seconds = bake(VARIANTS[0], reference_samples, seed=1)
    print(f"façade, {len(reference)} corners, image reference at {reference_samples}: {seconds:.1f} s, {load()}")
    for samples in (1, 64, 128):
        for variant in ["rain", VARIANTS[0], (10, False, True), (10, False, False), (10, True, False)]:
            if samples > 64 and variant in ("rain", (10, False, True)):
                continue
            values, seconds = bake(variant, samples)
            label = "rain" if variant == "rain" else name(variant)
            rmse = "" if variant == "rain" else f", RMSE {np.sqrt(np.mean((values - reference) ** 2)):.4f}"
            print(f"façade {label}, {samples} samples: {seconds:.2f} s{rmse}, {load()}", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", choices=("terrain", "facade"), default="terrain")
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--reference", type=int, default=1024)
    args = parser.parse_args()
    if args.scene == "terrain":
        terrain_runs(args.resolution, args.reference)
    else:
        facade_runs(args.reference)


if __name__ == "__main__":
    main()
