"""What the run-off does to the look of the façade and the bust (docs/weathering.md, "Run-off";
docs/model.md §7.2), with the API's defaults against the model without run-off.

    python benchmarks/bench_runoff_look.py [--size 160] [--samples 16] [--bake-samples 32]
        [--only NAME ...] [--pictures DIR]

Each sample is weathered as the main job weathers it (``demo.Sample``: the stone and environment
a user picks, the site's rain, the maps baked with the bake's defaults) and rendered with Cycles
(4 bounces, no denoising, pixel filter 0.01: a pixel is one surface point) at t = 0 and t = 1,
soiling and wet, twice: with the defaults (``runoff`` = 1, ``streaks`` as the environment sets
it) and without run-off (``runoff = 0, streaks = 0``: docs/model.md §4-§6 exactly). Per pixel of
the object (lit at t = 0), of linear luminance, t = 1 over t = 0 at the same pixel:

- soiling: the object's median and its 5th percentile (the darkest 5%);
- wet: the share of the object's pixels at or below 0.85x dry (the t = 0 render), and the share
  that water reaches (W >= 0.1, W = 1 - (1 - E)(1 - R) from probes of the baked maps as the
  material reads them: the surface the wet front sweeps at t = 1);
- the **streak contrast**: among the pixels that direct rain alone would leave unwashed (E below
  the rain threshold e_rain), the median soiling ratio of the *clean streaks* (the run-off makes
  them washed: W >= e_rain) over that of the *dirty tails* (run-off reaches them, R >= 0.1, too
  weakly to wash: W < e_rain). The regions come from the maps alone; 1 is no streak at all.

Prints a Markdown table and the machine line; ``--pictures DIR`` writes each sample's t = 1
soiling without and with run-off side by side.
"""

import argparse
import os
import pathlib
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


import bench_visible  # noqa: E402  (benchmarks/: the maps' probes, luminance)
import corpus_regions  # noqa: E402  (benchmarks/: the streaks' regions)
import numpy as np  # noqa: E402

from benchmarks import probes  # noqa: E402
from porous_weathering.blender import compat, render  # noqa: E402
from porous_weathering.core import model  # noqa: E402
from porous_weathering.core import modes as weathering_modes  # noqa: E402
from porous_weathering.samples import demo, studio  # noqa: E402

SAMPLES = ("limestone_facade", "bust")
#: The model without run-off (docs/model.md §7.2), against the defaults ({}).
CASES = (("without run-off", dict(runoff=0.0, streaks=0.0)), ("defaults", {}))
LIT = 0.01
WET_DARKER = 0.85


def measure(sample, changes):
    """The measures of one case (``changes`` to the weathering inputs) on an opened sample."""
    scene = sample.scene
    maps = bench_visible.probe_maps(sample, model.SOILING)
    rain, runoff = maps["rain_map"], maps["runoff_map"]
    renders = {}
    for mode, age in ((model.SOILING, 0.0), (model.SOILING, 1.0), (model.WET, 1.0)):
        sample.show(mode, age, **changes)
        renders[mode, age] = render.render_array(scene)
    clean = bench_visible.luminance(renders[model.SOILING, 0.0])
    lit = (renders[model.SOILING, 0.0][..., 3] > 0.999) & (clean > LIT)  # the ground is held out
    with np.errstate(divide="ignore", invalid="ignore"):
        aged = bench_visible.luminance(renders[model.SOILING, 1.0]) / clean
        wet = bench_visible.luminance(renders[model.WET, 1.0]) / clean
    threshold = sample.inputs(model.SOILING, **changes).get(
        "rain_threshold", weathering_modes.inputs()["rain_threshold"].default
    )
    washed, tails = (region & lit for region in corpus_regions.streak_regions(rain, runoff, threshold))
    water = corpus_regions.water_reaching(rain, runoff)

    def median(mask):
        return float(np.median(aged[mask])) if mask.sum() >= 8 else float("nan")

    return dict(
        pixels=int(lit.sum()),
        median=median(lit),
        darkest=float(np.percentile(aged[lit], 5)),
        wet=float((wet[lit] <= WET_DARKER).mean()),
        reached=float((water[lit] >= corpus_regions.REACHED_FROM).mean()),
        streaks=(int(washed.sum()), int(tails.sum())),
        contrast=median(washed) / median(tails),
        picture=renders[model.SOILING, 1.0],
    )


def object_only(sample):
    """Hold every other mesh (the ground) out of the renders: only the object's pixels are lit."""
    holdout = probes.holdout_material()
    for obj in sample.scene.objects:
        if obj.type == "MESH" and obj not in sample.objects:
            studio.assign(obj, holdout)


def table(rows):
    lines = [
        "| sample | case | pixels | soiling median | darkest 5% | wet <= 0.85x dry, % | reached by water, % | "
        "clean streaks / dirty tails, pixels | streak contrast |",
        "|---|---|---:|---:|---:|---:|---:|---|---:|",
    ]
    for name, case, row in rows:
        cells = (
            name,
            case,
            row["pixels"],
            f"{row['median']:.2f}",
            f"{row['darkest']:.2f}",
            f"{100 * row['wet']:.0f}",
            f"{100 * row['reached']:.0f}",
            " / ".join(str(count) for count in row["streaks"]),
            f"{row['contrast']:.2f}",
        )
        lines.append("| " + " | ".join(str(cell) for cell in cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    bench_visible.add_render_options(parser)
    parser.add_argument("--only", nargs="*", default=None, metavar="NAME", choices=SAMPLES, help="only these samples")
    parser.add_argument("--pictures", metavar="DIR", help="write t = 1 soiling without and with run-off here")
    args = parser.parse_args(argv)
    started = time.time()
    rows = []
    with tempfile.TemporaryDirectory(prefix="pw_runoff_look_") as work:
        for name in args.only or SAMPLES:
            sample = demo.Sample(name, map_dir=work, bake_samples=args.bake_samples, progress=True)
            bench_visible.use_cycles(sample, args)
            object_only(sample)
            pictures = []
            for case, changes in CASES:
                row = measure(sample, changes)
                pictures.append(row["picture"])
                rows.append((name, case, row))
                print(table(rows[-1:]).splitlines()[-1], flush=True)  # progress
            if args.pictures:
                os.makedirs(args.pictures, exist_ok=True)
                side_by_side = np.concatenate(pictures, axis=1)
                bench_visible.write_areas(side_by_side, [], os.path.join(args.pictures, f"{name}.png"))
    print()
    print(table(rows))
    print(bench_visible.closing_line(args, started))
    compat.end_process(0)  # bpy 4.5 can hang at interpreter exit


if __name__ == "__main__":
    main()
