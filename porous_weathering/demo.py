"""The main job: bake the bundled limestone façade's maps and render how it weathers.

``python -m porous_weathering demo --out out`` writes to the output folder:

- ``porous_vs_base.png``: the paper's Fig. 11, the same stone without and with porosity;
- ``<mode>_t<age>.png``: the façade at ages t = 0, 0.33, 0.66 and 1 for soiling, wetting and
  efflorescence (the rain and edge maps are baked first, as colour attributes);
- ``comparison.png``: all of them side by side, one row per mode.

``python -m porous_weathering demo --docs`` regenerates every picture of docs/images/ instead:
``porous_vs_base.png``, ``facade_aging.png`` (the comparison) and ``<mode>_before_after.png``,
a sample scene new (left) and fully weathered (right) for each mode (DOCS_BEFORE_AFTER).

``Sample`` (a sample scene opened, its maps made, its weathered materials at any age) is what
the tests of the sample scenes use too.
"""

import os
import sys
import tempfile
import time
from dataclasses import dataclass, field

import bpy

from . import bake, efflorescence_map, maps, material, model, presets, rain, render, studio, weathering
from .progress import ProgressBar

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES_DIR = os.path.join(ROOT, "sample_blends")
DOCS_IMAGES = os.path.join(ROOT, "docs", "images")
FACADE = "limestone_facade"
AGES = (0.0, 0.33, 0.66, 1.0)

STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.25, roughness=0.35)
POROUS = dict(porosity=0.4, pore_depth_ratio=3.0)

#: Rain driven 25 degrees from the vertical by a wind from the front (the samples face -Y):
#: it washes the open wall (E = sin 25 = 0.42 there), while cornices, sills and window heads
#: keep what lies below dry. Vertical rain would leave every wall face unwashed (E = 0).
DRIVEN_RAIN = dict(wind_azimuth=-90.0, wind_tilt=25.0)
#: Soiling in a polluted city: a wall open to driven rain counts as washed (E >= 0.3), and the
#: deposit is dark, so the sheltered areas stand out at a glance.
CITY_SOILING = dict(rain_threshold=0.3, deposit_color=(0.06, 0.055, 0.05))
#: A soft, porous limestone (Lecce or Caen stone: the top of the preset's porosity range) with
#: shallow pores. Deep pores are nearly black when clean (A_p near 1), so carbon, water or salt
#: in them would hardly change how the stone looks.
SOFT_LIMESTONE = dict(presets.PRESETS["LIMESTONE"].material_params(), porosity=0.3, pore_depth_ratio=0.5)
#: The brick sample's efflorescence map: salt along the joints of its bond, reaching a few
#: millimetres into each brick. Rows and bricks per row are the sample's courses and bricks per
#: course, whose UV map build_samples.py projects onto the bond.
JOINT_MAP = dict(size=512, rows=16, bricks_per_row=9, mortar=0.01, reach=0.006, noise=0.5)


@dataclass(frozen=True)
class Recipe:
    """How a sample scene weathers: the objects (None: every mesh but the ground), their stone,
    for each mode the map each mask reads: "rain" or "edges" (baked as colour attributes) or
    "joints" (JOINT_MAP, an image on the bricks' UV map), the rain of the bake and the
    weathering inputs (model.WEATHERING_INPUTS) that differ from their defaults."""

    objects: tuple
    stone: dict
    masks: dict
    rain: dict = field(default_factory=lambda: DRIVEN_RAIN)
    inputs: dict = field(default_factory=dict)


RAIN_AND_EDGES = dict(rain_map="rain", edge_map="edges")
RECIPES = {
    # Efflorescence follows the rain map on the façade: salts crystallise where rain soaks in.
    FACADE: Recipe(
        None,
        SOFT_LIMESTONE,
        {
            model.SOILING: RAIN_AND_EDGES,
            model.WET: dict(rain_map="rain"),
            model.EFFLORESCENCE: dict(efflorescence_map="rain"),
        },
        inputs=CITY_SOILING,
    ),
    "brick_wall": Recipe(
        ("Bricks",),
        presets.PRESETS["BRICK"].material_params(),
        {model.WET: dict(rain_map="rain"), model.EFFLORESCENCE: dict(efflorescence_map="joints")},
    ),
    # Vertical rain: the hollows and the undersides of the ridges are the sheltered places.
    "sculpted_stone": Recipe(
        ("Sculpted Stone",), SOFT_LIMESTONE, {model.SOILING: RAIN_AND_EDGES}, rain={}, inputs=CITY_SOILING
    ),
}
#: The sample scene that shows each mode in docs/images/<mode>_before_after.png.
DOCS_BEFORE_AFTER = {model.SOILING: "sculpted_stone", model.WET: "brick_wall", model.EFFLORESCENCE: "brick_wall"}


class Sample:
    """A sample scene, opened, with the maps its recipe needs made (baked into colour
    attributes, or generated into image files in ``map_dir``), ready to show any of its modes
    at any age."""

    def __init__(self, name, *, map_dir, bake_samples=32, progress=False):
        bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES_DIR, f"{name}.blend"), load_ui=False)
        self.name, self.recipe = name, RECIPES[name]
        self.scene = bpy.context.scene
        self.sun = next(obj for obj in self.scene.objects if obj.type == "LIGHT")
        self.objects = [
            obj
            for obj in self.scene.objects
            if obj.type == "MESH" and (obj.name in self.recipe.objects if self.recipe.objects else obj.name != "Ground")
        ]
        self.sources = self._make_maps(bake_samples, map_dir, progress)
        self._materials = {}

    def _make_maps(self, bake_samples, map_dir, progress):
        used = {source for masks in self.recipe.masks.values() for source in masks.values()}
        baked = tuple(map_name for map_name in maps.names() if map_name in used)
        sources = {map_name: maps.get(map_name).attribute for map_name in baked}
        if baked:
            options = bake.BakeOptions(
                maps=baked,
                target="attribute",
                rain_settings=rain.RainSettings(samples=bake_samples, **self.recipe.rain),
            )
            bar = ProgressBar(f"baking the maps of {self.name}") if progress else None
            bake.bake_maps(self.objects, options, progress=bar)
            if bar:
                bar.finish()
        if "joints" in used:  # a file, as a user's own location map would be
            path = os.path.join(map_dir, f"{self.name}.efflorescence.exr")
            sources["joints"] = efflorescence_map.save_map(efflorescence_map.brick_joint_map(**JOINT_MAP), path)
        return sources

    def material(self, mode):
        """The weathered material of ``mode`` (made once), on the sample's stone and maps."""
        if mode not in self._materials:
            masks = {mask: self.sources[map_name] for mask, map_name in self.recipe.masks[mode].items()}
            inputs = {name: value for name, value in self.recipe.inputs.items() if name in model.inputs_of(mode)}
            self._materials[mode] = weathering.make_weathered_material(
                f"{self.name} {mode}", modes=(mode,), key_light=self.sun, **self.recipe.stone, **masks, **inputs
            )
        return self._materials[mode]

    def show(self, mode, age):
        """Give the weathered objects ``mode``'s material at age ``age``."""
        weathered = self.material(mode)
        weathering.set_input(weathered.node_tree.nodes["Porous"], "time", age)
        for obj in self.objects:
            studio.assign(obj, weathered)

    def render(self, mode, age, path):
        """A picture of ``mode`` at ``age``. The Standard view keeps the contrast that AgX, made
        for bright highlights, squeezes out of the weathered areas: a deposit that halves the
        light looks only a little darker through AgX."""
        self.show(mode, age)
        return render.render_picture(self.scene, path, view_transform="Standard")

    def use_cycles(self, size, samples):
        """Cycles for pictures ``size`` pixels high, in the scene's own aspect ratio, denoised
        (OpenImageDenoise: a few samples per pixel give a clean picture)."""
        aspect = self.scene.render.resolution_x / self.scene.render.resolution_y
        render.use_cycles(self.scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
        self.scene.render.resolution_x = round(size * aspect)
        self.scene.cycles.use_denoising = True


def configure_parser(parser):
    parser.add_argument("--out", default="out", help="folder the pictures are written to (default: out)")
    parser.add_argument(
        "--docs",
        action="store_true",
        help=f"regenerate the documentation's pictures in {os.path.relpath(DOCS_IMAGES, ROOT)}/ "
        "instead (--out is ignored)",
    )
    parser.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel (default: 16)")
    parser.add_argument("--size", type=int, default=240, help="picture height in pixels (default: 240)")
    parser.add_argument("--bake-samples", type=int, default=32, help="rain samples per face corner (default: 32)")


def run(args):
    started = time.time()
    if args.docs:
        written = docs_pictures(args)
    else:
        os.makedirs(args.out, exist_ok=True)
        written = [render_porous_vs_base(os.path.join(args.out, "porous_vs_base.png"), args.size, args.samples * 4)]
        aging = render_aging(args.out, args.size, args.samples, args.bake_samples)
        written += aging + [side_by_side(aging, len(AGES), os.path.join(args.out, "comparison.png"))]
    print(f"wrote {len(written)} pictures in {time.time() - started:.0f} s", file=sys.stderr)
    return 0


def docs_pictures(args):
    """Every picture of docs/images/; the façade's single ages go to a temporary folder."""
    os.makedirs(DOCS_IMAGES, exist_ok=True)
    written = [render_porous_vs_base(os.path.join(DOCS_IMAGES, "porous_vs_base.png"), args.size, args.samples * 4)]
    with tempfile.TemporaryDirectory(prefix="pw_docs_") as work:
        aging = render_aging(work, args.size, args.samples, args.bake_samples)
        written.append(side_by_side(aging, len(AGES), os.path.join(DOCS_IMAGES, "facade_aging.png")))
        modes_of = {}  # sample -> the modes it shows: each sample is opened and baked once
        for mode, name in DOCS_BEFORE_AFTER.items():
            modes_of.setdefault(name, []).append(mode)
        for name, modes in modes_of.items():
            sample = Sample(name, bake_samples=args.bake_samples, map_dir=work, progress=True)
            sample.use_cycles(args.size, args.samples)
            for mode in modes:
                pictures = [
                    sample.render(mode, age, os.path.join(work, f"{name}_{mode}_{age}.png")) for age in (0.0, 1.0)
                ]
                written.append(side_by_side(pictures, 2, os.path.join(DOCS_IMAGES, f"{mode}_before_after.png")))
    return written


def render_porous_vs_base(path, size=256, samples=64):
    """Fig. 11: left the Diffuse + Glossy base, right the same with porosity (key-light mode)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    sun = studio.add_sun(scene, (-0.55, 0.35, 0.76), strength=2.5)
    world = bpy.data.worlds.new("Sky")
    world.color = (0.02, 0.025, 0.03)
    scene.world = world
    for x, mat in (
        (-1.1, material.make_base_material("Base", **STONE)),
        (1.1, material.make_porous_material("Porous", **STONE, **POROUS, key_light=sun)),
    ):
        sphere = studio.add_sphere(scene, name=mat.name)
        sphere.location.x = x
        studio.assign(sphere, mat)
    studio.add_ortho_camera(scene, scale=4.6)
    render.use_cycles(scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
    scene.render.resolution_x = 2 * size
    return render.render_picture(scene, path)


def render_aging(out, size, samples, bake_samples):
    """Bake the façade's maps, then render each weathering mode at each age."""
    facade = Sample(FACADE, bake_samples=bake_samples, map_dir=out, progress=True)
    facade.use_cycles(size, samples)
    modes = list(facade.recipe.masks)
    pictures = []
    progress = ProgressBar("rendering the aging sequence")
    for row, mode in enumerate(modes):
        for column, age in enumerate(AGES):
            progress((row * len(AGES) + column) / (len(modes) * len(AGES)), f"{mode}, t = {age:.2f}")
            pictures.append(facade.render(mode, age, os.path.join(out, f"{mode}_t{age:.2f}.png")))
    progress(1.0, "done")
    progress.finish()
    return pictures


def side_by_side(paths, columns, out_path):
    """One picture of ``paths`` laid out in rows of ``columns`` (OpenImageIO)."""
    import OpenImageIO as oiio

    tiles = [oiio.ImageBuf(path) for path in paths]
    width, height = tiles[0].spec().width, tiles[0].spec().height
    rows = -(-len(tiles) // columns)
    sheet = oiio.ImageBuf(oiio.ImageSpec(width * columns, height * rows, tiles[0].spec().nchannels, oiio.UINT8))
    for index, tile in enumerate(tiles):
        oiio.ImageBufAlgo.paste(sheet, (index % columns) * width, (index // columns) * height, 0, 0, tile)
    if not sheet.write(out_path):
        raise OSError(f"cannot write {out_path}: {sheet.geterror()}")
    return out_path
