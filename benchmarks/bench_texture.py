"""Texture of the weathered surfaces: β and the fine share (benchmarks/texture_spectrum.py) of
256 x 256 crops of each sample and corpus shape, new and fully weathered (docs/benchmarks.md,
"Texture: β and fine share").

    python benchmarks/bench_texture.py [--size 540] [--samples 48] [--bake-samples 32]
        [--only NAME ...] [--quick] [--work DIR] [--crops DIR] [--inputs NAME=VALUE ...]
        [--scans FILE ... [--scan-up Y|Z] [--scan-unit mm|cm|m]]

Each bundled sample is weathered as the main job weathers it (``demo.Sample``: its recipe's
stone, environment, site rain, view and maps baked with the bake's defaults, its parts each as
its own stone: the brick wall's mortar; the ground held out, the parts the recipe does not
weather kept: the stone's plinth)
and each corpus shape as benchmarks/bench_corpus.py makes it (in millimetres: its scene, the
command line's bake with its defaults, the panel's Make), in soiling mode. Cycles as the main job
renders it (4 bounces, the default pixel filter 1.5 pixels wide, as a camera's pixel integrates
its area) but **without denoising**, which would remove the very texture measured.

The crop: a coverage render (``PROBE_HEIGHT`` pixels high, 1 sample, alpha; the transparent film
shows what the object covers) finds the largest square the weathered objects cover fully; the picture
height is ``--size`` (the main job's 540) or, if the square would be smaller than the crop there,
the height at which it holds the crop with a coverage-render pixel (``MARGIN``) to spare round
it. Only the crop is rendered (a render border), centred on that square, at t = 0 and t = 1
with seed 0 and at t = 1 with seed 1. Per shape: β and the fine share at t = 0 and t = 1, β of
the ratio image (luminance at t = 1 over t = 0, per pixel: same seed, so most noise cancels),
how much of the crop the object covers (alpha > 0.999; 100% is the rule), and the convergence:
the fine-band variance of the difference of the two seeds' t = 1 crops over that of the seed-0
crop (< 10%: the render noise is a small part of the fine band measured). A shape whose seeds
differ by more is rendered again at twice the samples, up to ``MOST_SAMPLES_FACTOR`` times
``--samples``; its row says the samples its figures come from.

Targets (the photographs of real decay): at t = 1, 1.8 <= β <= 3.0 and fine share >= 0.10 on
every shape; the façade's ratio image β <= 3.2. Prints a Markdown table with a verdict per cell
and the machine line. ``--crops DIR`` writes each shape's crops (t = 0, t = 1, and the ratio at
half grey = 1) and a picture of where the crop lies. ``--quick``: 8 samples, 8 rain samples,
the façade and the head only (unless ``--only``). ``--scans``: scan files of your own (OBJ, PLY,
STL, glTF) measured in place of the bundled shapes (with them: ``--only``), each brought in as
docs/scans.md says (its importer, ``--scan-up``, smooth shaded, ``--scan-unit`` as the scene's
unit) and then baked, made and lit as a corpus shape. ``--inputs``: weathering inputs (and the stone's
``variation``) given other values on every shape, to see what holds its figures (``runoff=0
streaks=0``: the rain alone; ``variation=0``: no stone).
"""

import argparse
import math
import os
import pathlib
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "sample_blends"))

import bpy  # noqa: E402

import bench_corpus  # noqa: E402  (benchmarks/: the corpus's scenes, bake and Make)
import bench_visible  # noqa: E402  (benchmarks/: render options, PNG writing)
import corpus_generator  # noqa: E402  (sample_blends/)
import machine  # noqa: E402
import numpy as np  # noqa: E402
import texture_spectrum  # noqa: E402

from benchmarks import probes  # noqa: E402
from porous_weathering.blender import compat, render  # noqa: E402
from porous_weathering.contracts import GROUP_NODE  # noqa: E402
from porous_weathering.core import model  # noqa: E402
from porous_weathering.samples import demo, studio  # noqa: E402
from porous_weathering.shading import weathering  # noqa: E402

SAMPLES = ("limestone_facade", "brick_wall", "sculpted_stone", "bust")
SHAPES = SAMPLES + tuple(corpus_generator.SHAPES)
QUICK_SHAPES = (demo.FACADE, "head")
CROP = 256
#: The coverage render's height (pixels): enough to place the crop, cheap at 1 sample.
PROBE_HEIGHT = 160
#: Coverage-render pixels of the covered square kept round the crop: a pixel there is as wide
#: as height / PROBE_HEIGHT pixels of the picture, so its edge is known to one of them.
MARGIN = 1
COVERED = 0.999
#: Targets of the photographs of real decay: (low, high), None open.
TARGETS = {"beta": (1.8, 3.0), "fine": (0.10, None), "ratio_beta": (None, 3.2), "seeds": (None, 0.10)}
#: A shape whose two seeds differ by 10% or more of the fine band is rendered again at twice the
#: samples, up to this many times --samples (the seeds' difference falls as 1 / samples).
MOST_SAMPLES_FACTOR = 4
#: The shape whose ratio image has a target: the main job's façade.
RATIO_TARGET_SHAPE = demo.FACADE


# --- the shapes, weathered -------------------------------------------------------------------


def open_sample(name, args, work):
    """(scene, show(age), the other parts) of a bundled sample weathered as the main job
    weathers it (its parts too: the brick wall's mortar), its ground held out. The other parts,
    which the recipe does not weather (the sculpted stone's plinth), are rendered."""
    sample = demo.Sample(name, map_dir=work, bake_samples=args.bake_samples, progress=True)
    ground = sample.scene.objects["Ground"]
    studio.assign(ground, probes.holdout_material())
    others = [
        obj
        for obj in sample.scene.objects
        if obj.type == "MESH" and obj not in (*sample.objects, *sample.parts, ground)
    ]
    return sample.scene, lambda age: sample.show(model.SOILING, age, **args.inputs), others


def open_corpus_shape(shape, args, work):
    """(scene, show(age), no other parts) of a corpus shape in millimetres, baked and made as bench_corpus.py does
    (a saved scene in ``work`` is reused, and the bake skips maps whose inputs did not change)."""
    path = pathlib.Path(work) / f"{shape}_mm.blend"
    if not path.exists():
        bench_corpus.build_scene(shape, "mm")
        bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
    return open_made(path, shape, args)


def open_scan(scan, args, work):
    """(scene, show(age), no other parts) of a scan file (``--scans``) in the corpus's light,
    baked and made as a corpus shape is."""
    path = pathlib.Path(work) / f"{scan.stem}_scan.blend"
    if not path.exists():
        bench_corpus.scan_scene(scan, args.scan_up, args.scan_unit)
        bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
    return open_made(path, scan.stem, args)


def open_made(path, name, args):
    """(scene, show(age), no other parts) of the object ``name`` of the saved scene at ``path``,
    baked by the command line and made by the panel's Make, as bench_corpus.py does."""
    bench_corpus.bake(path)
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    scene, obj = bpy.context.scene, bpy.data.objects[name]
    scene.render.resolution_x = scene.render.resolution_y  # bench_corpus.py's pictures are square
    material = bench_corpus.made_material(obj, (model.SOILING,), changes=args.inputs)

    def show(age):
        weathering.set_input(material.node_tree.nodes[GROUP_NODE], "time", age)
        studio.assign(obj, material)

    return scene, show, []


# --- rendering the crop ----------------------------------------------------------------------


def use_cycles(scene, height, samples, aspect):
    """The main job's Cycles set-up (4 bounces, pixel filter 1.5) without denoising, ``height``
    pixels high in ``aspect``."""
    render.use_cycles(scene, size=height, samples=samples, bounces=4, pixel_filter=1.5)
    scene.render.resolution_x = round(height * aspect)


def largest_square(covered):
    """(row, column, side) of the largest square of True pixels in ``covered`` (a summed-area
    table, and a bisection on the side)."""
    table = np.pad(covered.astype(np.int64), ((1, 0), (1, 0))).cumsum(0).cumsum(1)

    def fitting(side):
        sums = table[side:, side:] - table[:-side, side:] - table[side:, :-side] + table[:-side, :-side]
        return np.argwhere(sums == side * side)

    low, high, found = 0, min(covered.shape), None
    while low < high:  # the largest side with a fitting square
        side = (low + high + 1) // 2
        places = fitting(side)
        if len(places):
            low, found = side, places[len(places) // 2]
        else:
            high = side - 1
    return (0, 0, 0) if found is None else (int(found[0]), int(found[1]), low)


def place_crop(scene, show, others, args, aspect):
    """(picture height, (top, left) of the crop in it, the coverage render, the square) for the
    weathered objects: the pixels they cover, the other parts hidden (the plinth does not count)."""
    use_cycles(scene, PROBE_HEIGHT, 1, aspect)
    show(0.0)
    coverage = render.render_array(scene)
    covered = coverage[..., 3] > COVERED
    if others:
        for obj in others:
            obj.hide_render = True
        try:
            covered &= render.render_array(scene)[..., 3] > COVERED
        finally:
            for obj in others:
                obj.hide_render = False
    row, column, side = largest_square(covered)
    if side <= 2 * MARGIN + 1:
        raise RuntimeError("the object covers no square of the coverage render")
    height = max(args.size, math.ceil(PROBE_HEIGHT * CROP / (side - 2 * MARGIN)))
    scale = height / PROBE_HEIGHT
    width = round(height * aspect)
    top = min(max(round((row + side / 2) * scale - CROP / 2), 0), height - CROP)
    left = min(max(round((column + side / 2) * scale - CROP / 2), 0), width - CROP)
    return height, (top, left), coverage, (row, column, side)


def render_crop(scene, top, left, seed=0):
    """The CROP x CROP pixels at (top, left) of the scene's picture, linear RGBA, top row first:
    only they are rendered (a render border)."""
    width, height = scene.render.resolution_x, scene.render.resolution_y
    bottom = height - top - CROP  # the border counts pixels from the bottom
    # A quarter pixel past each edge: the border's fractions are float32, and whether Blender
    # truncates or rounds them to pixels, the edge lands on the intended one.
    scene.render.use_border = scene.render.use_crop_to_border = True
    scene.render.border_min_x, scene.render.border_max_x = (left + 0.25) / width, (left + CROP + 0.25) / width
    scene.render.border_min_y, scene.render.border_max_y = (bottom + 0.25) / height, (bottom + CROP + 0.25) / height
    scene.cycles.seed = seed
    try:
        image = render.render_array(scene)
    finally:
        scene.render.use_border = scene.render.use_crop_to_border = False
        scene.cycles.seed = 0
    if image.shape[:2] != (CROP, CROP):
        raise RuntimeError(f"the render border gave {image.shape[:2]} pixels, not {CROP} x {CROP}")
    return image


# --- measuring -------------------------------------------------------------------------------


def measure(name, args, work):
    """The row of one shape (a sample's or a corpus shape's name, or a scan's path), and its
    pictures (crops and where the crop lies)."""
    if isinstance(name, pathlib.Path):
        scene, show, others = open_scan(name, args, work)
        name = name.stem
    else:
        scene, show, others = (open_sample if name in SAMPLES else open_corpus_shape)(name, args, work)
    aspect = scene.render.resolution_x / scene.render.resolution_y
    height, (top, left), coverage, square = place_crop(scene, show, others, args, aspect)
    samples = args.samples
    while True:
        use_cycles(scene, height, samples, aspect)
        crops = {}
        for age, seed in ((0.0, 0), (1.0, 0), (1.0, 1)):
            show(age)
            crops[age, seed] = render_crop(scene, top, left, seed)
        new, old, other_seed = crops[0.0, 0], crops[1.0, 0], crops[1.0, 1]
        seeds = texture_spectrum.fine_band_variance(old - other_seed) / texture_spectrum.fine_band_variance(old)
        if meets("seeds", seeds) or 2 * samples > MOST_SAMPLES_FACTOR * args.samples:
            break
        samples *= 2
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = texture_spectrum.luminance(old) / texture_spectrum.luminance(new)
    covered = float((new[..., 3] > COVERED).mean())
    # Outside the object (a miss of the rule) the ratio is undefined: 1 there, said by `covered`.
    ratio = np.where(np.isfinite(ratio), ratio, 1.0)
    row = dict(
        shape=name,
        height=height,
        crop=(top, left),
        covered=covered,
        new=texture_spectrum.spectrum_slope(new),
        old=texture_spectrum.spectrum_slope(old),
        ratio_beta=texture_spectrum.spectrum_slope(ratio)[0],
        seeds=seeds,
        samples=samples,
    )
    pictures = dict(crops=(new, old, ratio), where=where_picture(coverage, square))
    return row, pictures


# --- reporting -------------------------------------------------------------------------------


def meets(measure_name, value):
    """Whether ``value`` lies within the target of ``measure_name`` (TARGETS)."""
    low, high = TARGETS[measure_name]
    return (low is None or value >= low) and (high is None or value <= high)


def verdict(measure_name, value):
    return "✓" if meets(measure_name, value) else "✗"


def target_text(measure_name):
    low, high = TARGETS[measure_name]
    return f"<= {high:g}" if low is None else f">= {low:g}" if high is None else f"{low:g}-{high:g}"


def table(rows):
    lines = [
        "| shape | picture height, px | crop top, left | covered, % | β, t = 0 | fine share, t = 0 | "
        f"β, t = 1 ({target_text('beta')}) | fine share, t = 1 ({target_text('fine')}) | "
        f"β of t1/t0 (façade {target_text('ratio_beta')}) | seeds differ, % of fine band (< 10) | samples |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        ratio = f"{row['ratio_beta']:.2f}"
        if row["shape"] == RATIO_TARGET_SHAPE:
            ratio += " " + verdict("ratio_beta", row["ratio_beta"])
        cells = (
            row["shape"],
            row["height"],
            "{}, {}".format(*row["crop"]),
            f"{100 * row['covered']:.0f}",
            f"{row['new'][0]:.2f}",
            f"{row['new'][1]:.3f}",
            f"{row['old'][0]:.2f} {verdict('beta', row['old'][0])}",
            f"{row['old'][1]:.3f} {verdict('fine', row['old'][1])}",
            ratio,
            f"{100 * row['seeds']:.1f} {verdict('seeds', row['seeds'])}",
            row["samples"],
        )
        lines.append("| " + " | ".join(str(cell) for cell in cells) + " |")
    return "\n".join(lines)


def where_picture(coverage, square):
    """The coverage render with the largest covered square outlined in red (the crop is at its
    centre)."""
    picture = coverage.copy()
    picture[..., :3] += 1.0 - picture[..., 3:4]  # over white
    row, column, side = square
    red = np.array([1.0, 0.0, 0.0])
    picture[row, column : column + side, :3] = picture[row + side - 1, column : column + side, :3] = red
    picture[row : row + side, column, :3] = picture[row : row + side, column + side - 1, :3] = red
    return picture


def write_pictures(folder, name, pictures):
    new, old, ratio = pictures["crops"]
    grey_ratio = np.repeat(0.5 * ratio[..., None], 3, axis=2) ** 2.2  # 1 -> half grey on the PNG
    strip = np.concatenate([new[..., :3], old[..., :3], grey_ratio], axis=1)
    bench_visible.write_areas(strip, [], os.path.join(folder, f"{name}_crops.png"))
    bench_visible.write_areas(pictures["where"], [], os.path.join(folder, f"{name}_where.png"))


def input_value(text):
    """(name, value) of a NAME=VALUE argument."""
    name, _, value = text.partition("=")
    try:
        return name, float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give NAME=VALUE, VALUE a number") from None


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    bench_visible.add_render_options(parser, size=540, samples=48)
    parser.add_argument("--only", nargs="+", choices=SHAPES, metavar="NAME", help=f"only these ({', '.join(SHAPES)})")
    parser.add_argument("--quick", action="store_true", help="a small check: 8 samples, 8 rain samples, 2 shapes")
    bench_corpus.add_scan_options(parser)
    parser.add_argument("--work", help="keep the corpus scenes here, reused (default: a temporary folder)")
    parser.add_argument("--crops", metavar="DIR", help="write each shape's crops and where they lie here (PNG)")
    parser.add_argument(
        "--inputs",
        nargs="+",
        default=[],
        type=input_value,
        metavar="NAME=VALUE",
        help="weathering inputs, or variation, given other values on every shape (default: none)",
    )
    args = parser.parse_args(argv)
    args.inputs = dict(args.inputs)
    if args.quick:
        args.samples, args.bake_samples = 8, 8
    names = [*(args.only or ([] if args.scans else QUICK_SHAPES if args.quick else SHAPES)), *args.scans]
    started = time.time()
    rows = []
    with tempfile.TemporaryDirectory(prefix="pw_texture_") as scratch:
        work = args.work or scratch
        os.makedirs(work, exist_ok=True)
        for name in names:
            row, pictures = measure(name, args, work)
            rows.append(row)
            if args.crops:
                os.makedirs(args.crops, exist_ok=True)
                write_pictures(args.crops, row["shape"], pictures)
            print(table([row]).splitlines()[-1], flush=True)  # progress
    print()
    print(table(rows))
    print(
        f"\nCrops {CROP} x {CROP}, {args.samples} samples (more where the seeds differed: the last column), "
        "4 bounces, pixel filter 1.5, no denoising, "
        f"{args.bake_samples} rain samples; soiling"
        + "".join(f", {name} {value:g}" for name, value in args.inputs.items())
        + f"; {machine.describe(bpy.app.version_string)}; "
        f"{time.time() - started:.0f} s"
    )
    compat.end_process(0)  # bpy 4.5 can hang at interpreter exit


if __name__ == "__main__":
    main()
