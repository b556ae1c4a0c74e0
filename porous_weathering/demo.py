"""The main job: bake the bundled limestone façade's maps and render how it weathers.

``python -m porous_weathering demo --out out`` writes to the output folder:

- ``porous_vs_base.png``: the paper's Fig. 11, the same stone without and with porosity;
- ``<mode>_t<age>.png``: the façade at ages t = 0, 0.33, 0.66 and 1 for soiling, wetting and
  efflorescence (the rain and edge maps are baked first, as colour attributes);
- ``comparison.png``: all of them side by side, one row per mode.
"""

import os
import sys
import time

import bpy

from . import bake, material, model, presets, render, studio, weathering

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FACADE = os.path.join(ROOT, "sample_blends", "limestone_facade.blend")
AGES = (0.0, 0.33, 0.66, 1.0)

STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.25, roughness=0.35)
POROUS = dict(porosity=0.4, pore_depth_ratio=3.0)
#: Where each mode reads its mask. Efflorescence follows the rain map on the façade: salts
#: crystallise where rain water soaks in and evaporates.
MODE_MASKS = {
    model.SOILING: dict(rain_map=bake.ATTRIBUTES["rain"], edge_map=bake.ATTRIBUTES["edges"]),
    model.WET: dict(rain_map=bake.ATTRIBUTES["rain"]),
    model.EFFLORESCENCE: dict(efflorescence_map=bake.ATTRIBUTES["rain"]),
}


def configure_parser(parser):
    parser.add_argument("--out", default="out", help="folder the pictures are written to (default: out)")
    parser.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel (default: 16)")
    parser.add_argument("--size", type=int, default=240, help="picture height in pixels (default: 240)")
    parser.add_argument("--bake-samples", type=int, default=32, help="rain samples per face corner (default: 32)")


def run(args):
    os.makedirs(args.out, exist_ok=True)
    started = time.time()
    written = [render_porous_vs_base(os.path.join(args.out, "porous_vs_base.png"), args.size, args.samples * 4)]
    written += render_aging(args.out, args.size, args.samples, args.bake_samples)
    written.append(side_by_side(written[1:], len(AGES), os.path.join(args.out, "comparison.png")))
    print(f"wrote {len(written)} pictures to {args.out} in {time.time() - started:.0f} s", file=sys.stderr)
    return 0


def render_porous_vs_base(path, size=256, samples=64):
    """Fig. 11: left the Diffuse + Glossy base, right the same with porosity (key-light mode)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    sun = studio.add_sun(scene, (-0.55, 0.35, 0.76), strength=2.5)
    world = bpy.data.worlds.new("Sky")
    world.color = (0.02, 0.025, 0.03)
    scene.world = world
    for x, mat in ((-1.1, material.make_base_material("Base", **STONE)),
                   (1.1, material.make_porous_material("Porous", **STONE, **POROUS, key_light=sun))):
        sphere = studio.add_sphere(scene, name=mat.name)
        sphere.location.x = x
        studio.assign(sphere, mat)
    studio.add_ortho_camera(scene, scale=4.6)
    render.use_cycles(scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
    scene.render.resolution_x = 2 * size
    return render.render_picture(scene, path)


def render_aging(out, size, samples, bake_samples):
    """Bake the façade's maps, then render each weathering mode at each age."""
    bpy.ops.wm.open_mainfile(filepath=FACADE, load_ui=False)
    scene = bpy.context.scene
    stones = [obj for obj in scene.objects if obj.type == "MESH" and obj.data.polygons]
    options = bake.BakeOptions(maps=bake.MAPS, target="attribute",
                               rain_settings=bake.rain.RainSettings(samples=bake_samples))
    progress = bake.ProgressBar("baking the façade's maps")
    bake.bake_maps(stones, options, progress=progress)
    progress.finish()

    render.use_cycles(scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
    scene.render.resolution_x = size * 4 // 3
    sun = next((obj for obj in scene.objects if obj.type == "LIGHT"), None)
    stone = dict(presets.PRESETS["LIMESTONE"].material_params(), key_light=sun)
    pictures = []
    progress = bake.ProgressBar("rendering the aging sequence")
    for row, (mode, masks) in enumerate(MODE_MASKS.items()):
        weathered = weathering.make_weathered_material(f"Limestone {mode}", modes=(mode,), **stone, **masks)
        for obj in stones:
            if obj.name != "Ground":
                studio.assign(obj, weathered)
        for column, age in enumerate(AGES):
            progress((row * len(AGES) + column) / (len(MODE_MASKS) * len(AGES)), f"{mode}, t = {age:.2f}")
            weathering.set_input(weathered.node_tree.nodes["Porous"], "time", age)
            pictures.append(render.render_picture(scene, os.path.join(out, f"{mode}_t{age:.2f}.png")))
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
