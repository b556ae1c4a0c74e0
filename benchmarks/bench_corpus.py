"""Aging on models nobody tuned: the untuned corpus (sample_blends/corpus_generator.py) baked
and made from the defaults, measured region by region (docs/benchmarks.md, "The untuned corpus").

    .venv-5.2/bin/python benchmarks/bench_corpus.py --out DIR [--shapes NAME ...] [--units mm m]
        [--size 256] [--samples 16] [--fresh] [--scans FILE ... [--scan-up Y|Z] [--scan-unit mm|cm|m]]

For each shape and unit:

1. the shape (in millimetres, or the same mesh scaled to metres with the scene's units) in a
   scene with a fixed sun and a uniform sky, saved as DIR/<shape>_<unit>.blend (kept: a re-run
   reuses it, and the bake then skips maps whose inputs did not change; ``--fresh`` makes it
   again);
2. baked by the command line with its defaults: ``python -m porous_weathering bake FILE
   --target attribute --save`` (rain, edges, run-off), in a child process;
3. made as the panel's Make makes it: ``linking.weathered_material_for`` with the default stone
   (limestone), the panel's weathering values for it (``ui.settings.source_weathering``), the
   scene's sun as key light, and the API's default environment (``--environment`` passes one);
4. rendered with Cycles (4 bounces, no denoising, pixel filter 0.01 so that a pixel is one
   surface point) at t = 0 and t = 1 in soiling mode and at t = 1 in wet mode, and probed: the
   baked pw_rain, pw_runoff and pw_edges as the material reads them, and the sign of the mean
   curvature at the bake's edge radius (``edges.curvature``), each as an emission render of the
   same pixels;
5. classified per pixel by ``corpus_regions.classify`` (geometry and maps only), and measured:
   the ratio of linear luminance t = 1 / t = 0 at each pixel, its median over each region and
   over the object, its 5th percentile (the darkest 5%), and the fraction of the pixels that
   rain or run-off reaches (W >= 0.1) whose wet / dry luminance (wet t = 1 over the t = 0
   render; the wet material at t = 0 renders the same pixels, checked on the head) is <= 0.8.

Ratios are per pixel on the noisy renders (same seed at both ages, so most of the noise is
shared); only pixels lit at t = 0 (luminance > 1e-3) count. Prints a Markdown table against the
targets of docs/weathering.md and writes DIR/corpus.png, a contact sheet (a row per shape, in
the first unit: t = 0, t = 1 soiling, t = 1 wet, and the regions: sheltered hollows red, washed blue, the
rest grey), and DIR/results.json.
"""

import argparse
import json
import pathlib
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "sample_blends"))

import bpy  # noqa: E402

import corpus_generator  # noqa: E402  (sample_blends/)
import numpy as np  # noqa: E402
import scan_generator  # noqa: E402
from mathutils import Vector  # noqa: E402

from benchmarks import corpus_regions, machine, probes  # noqa: E402
from porous_weathering.blender import compat, mesh_arrays, render  # noqa: E402
from porous_weathering.contracts import GROUP_NODE  # noqa: E402
from porous_weathering.core import model, stones  # noqa: E402
from porous_weathering.core import modes as weathering_modes  # noqa: E402
from porous_weathering.maps import edges, linking  # noqa: E402
from porous_weathering.samples import studio  # noqa: E402
from porous_weathering.shading import presets, weathering  # noqa: E402
from porous_weathering.ui import settings as panel_settings  # noqa: E402

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
UNITS = ("mm", "m")
#: Towards the sun: from the front left, 30 degrees up.
SUN_TOWARDS = (-0.45, -0.78, 0.43)
SUN_STRENGTH = 4.0
SKY = ((0.42, 0.5, 0.62), 0.6)  # a uniform sky: colour, strength
#: The camera looks at the object from the front (-Y), a little from its left and above; at the
#: gargoyle, which juts out of its wall towards -Y, from its side.
VIEW_FROM = (-0.35, -1.0, 0.3)
VIEW_FROM_SHAPE = {"gargoyle": (-1.0, -0.45, 0.3)}
#: ``--scans``: Blender's importer of each file kind and the up axes offered (docs/scans.md), and
#: the units offered, metres per unit.
SCAN_IMPORTERS = {
    ".obj": bpy.ops.wm.obj_import,
    ".ply": bpy.ops.wm.ply_import,
    ".stl": bpy.ops.wm.stl_import,
    ".glb": bpy.ops.import_scene.gltf,
    ".gltf": bpy.ops.import_scene.gltf,
}
SCAN_AXES = {None: {}, "Y": dict(up_axis="Y", forward_axis="NEGATIVE_Z"), "Z": dict(up_axis="Z", forward_axis="Y")}
SCAN_UNITS = {"mm": 0.001, "cm": 0.01, "m": 1.0}
#: The concave-curvature attribute the probes read (the bench's own, never the product's).
CONCAVE_ATTRIBUTE = "bench_concave"
LIT = 1e-3
WET_DARKER = 0.8
#: Targets (docs/weathering.md): (low, high) of each measure; None: open.
TARGETS = {
    "hollows": (None, 0.4),
    "washed": (0.95, 1.05),
    "median": (0.55, 0.9),
    "wet": (0.7, None),
}


# --- the scene --------------------------------------------------------------------------------


def build_scene(shape, unit):
    """A new file with the shape's object (named after it), the sun, the sky and an
    orthographic camera framing it."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.system = "METRIC"
    scene.unit_settings.scale_length, scene.unit_settings.length_unit = scan_generator.SCENE_UNITS[unit]
    vertices, triangles = corpus_generator.shape_mesh(shape, unit)
    obj = scan_generator.add_to_scene(shape, vertices, triangles, scene.collection)
    light(scene, vertices, VIEW_FROM_SHAPE.get(shape, VIEW_FROM))
    return obj


def import_scan(scan, up, unit):
    """A new file holding the scan at ``scan`` as docs/scans.md brings one in: its importer by
    the file's suffix, read with ``up`` as its up axis (None: the importer's own), smooth shaded,
    the scene's unit ``unit`` (a SCAN_UNITS key). The object, named after the file."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.system = "METRIC"
    scene.unit_settings.scale_length = SCAN_UNITS[unit]
    importer = SCAN_IMPORTERS[scan.suffix.lower()]
    axes = {} if importer is bpy.ops.import_scene.gltf else SCAN_AXES[up]  # glTF is Y-up by its spec
    importer(filepath=str(scan), **axes)
    meshes = [obj for obj in bpy.context.selected_objects if obj.type == "MESH"]
    if len(meshes) != 1:
        raise RuntimeError(f"{scan} holds {len(meshes)} meshes, not one")
    obj = meshes[0]
    obj.name = scan.stem
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.shade_smooth()
    return obj


def scan_scene(scan, up, unit):
    """The scan's new file (``import_scan``), lit and framed as a corpus shape."""
    obj = import_scan(scan, up, unit)
    matrix = np.array(obj.matrix_world)
    corners = mesh_arrays.attribute(obj.data, "position", np.float64, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    light(bpy.context.scene, corners, VIEW_FROM)
    return obj


def scan_path(text):
    """The path of a ``--scans`` file: one that exists, of a kind SCAN_IMPORTERS reads."""
    path = pathlib.Path(text).resolve()
    if path.suffix.lower() not in SCAN_IMPORTERS:
        raise argparse.ArgumentTypeError(f"{text!r}: give a scan file ({', '.join(SCAN_IMPORTERS)})")
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"{text!r}: no such file")
    return path


def add_scan_options(parser):
    """``--scans``, ``--scan-up`` and ``--scan-unit``, as both benchmarks that take scans read them."""
    parser.add_argument(
        "--scans",
        nargs="+",
        default=[],
        type=scan_path,
        metavar="FILE",
        help=f"scan files ({', '.join(SCAN_IMPORTERS)}) measured in place of the bundled shapes (and them if named)",
    )
    parser.add_argument("--scan-up", choices=("Y", "Z"), help="the scans' up axis (default: their importer's)")
    parser.add_argument("--scan-unit", choices=SCAN_UNITS, default="m", help="the scans' unit (default: m)")


def light(scene, vertices, view_from):
    """The corpus's fixed sun and uniform sky in ``scene``, and its camera looking at ``vertices``
    (world) from ``view_from``."""
    studio.add_sun(scene, towards=SUN_TOWARDS, strength=SUN_STRENGTH)
    world = bpy.data.worlds.new("Sky")
    compat.use_world_nodes(world)
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*SKY[0], 1.0)
    background.inputs["Strength"].default_value = SKY[1]
    scene.world = world
    frame(scene, vertices, view_from)


def frame(scene, vertices, view_from, margin=1.08):
    """An orthographic camera looking at the object from ``view_from``, fitting it with ``margin``
    to spare; the scene's camera, returned."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    centre, diagonal = (low + high) / 2, float(np.linalg.norm(high - low))
    view = Vector(view_from).normalized()
    data = bpy.data.cameras.new("Camera")
    data.type = "ORTHO"
    data.clip_start, data.clip_end = 0.01 * diagonal, 10.0 * diagonal
    camera = bpy.data.objects.new("Camera", data)
    scene.collection.objects.link(camera)
    camera.location = Vector(centre) + view * 2.0 * diagonal
    camera.rotation_euler = (-view).to_track_quat("-Z", "Y").to_euler()
    rotation = np.array(camera.rotation_euler.to_matrix())
    across = (vertices - centre) @ rotation[:, :2]  # along the camera's right and up
    data.ortho_scale = margin * 2.0 * float(np.abs(across).max())
    scene.camera = camera
    return camera


def bake(path):
    """The command line's bake of ``path``, its defaults; raises with its output if it fails."""
    command = [sys.executable, "-m", "porous_weathering", "bake", str(path), "--target", "attribute", "--save"]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"bake of {path} failed ({done.returncode}): {done.stderr.strip()[-400:]}")


def made_material(obj, modes, environment=None, changes=None):
    """The material the panel's Make gives ``obj`` for ``modes`` with the scene's default panel
    settings: the default stone and ``environment`` (None: the default one), their panel values,
    the scene's sun (``ui/operators.py``); ``changes``: weathering inputs, and ``variation``, given
    other values (None: none)."""
    stone = panel_settings.DEFAULT_SOURCE
    environment = environment or presets.DEFAULT_ENVIRONMENT
    defaults = presets.weathering_values(stone, environment)
    values = {item.name: defaults[item.name] for item in weathering_modes.inputs_of(modes) if item.panel}
    changes = dict(changes or {})
    variation = changes.pop("variation", stones.DEFAULT_VARIATION)
    return linking.weathered_material_for(
        obj,
        modes,
        preset=stone,
        key_light=panel_settings.scene_sun(bpy.context.scene),
        values={**values, **changes},
        environment=environment,
        variation=variation,
    )


def write_concavity(obj):
    """1 where the mean curvature at the edge mask's default radius is negative (concave)."""
    radius = edges.effective_radius(obj, edges.EdgeSettings())
    concave = (edges.curvature(obj, radius) < 0.0).astype(np.float32)
    mesh = obj.data
    mesh_arrays.write_corner_attribute(
        mesh, CONCAVE_ATTRIBUTE, concave[mesh_arrays.attribute(mesh, ".corner_vert", np.int32)]
    )


# --- measuring --------------------------------------------------------------------------------


def probe(scene, obj, source):
    """The attribute ``source`` as the material reads it, per pixel (one sample: an emission)."""
    material = probes.emission_probe("Probe", lambda graph, geometry: weathering.mask_socket(graph, source))
    studio.assign(obj, material)
    samples, scene.cycles.samples = scene.cycles.samples, 1
    try:
        return render.render_array(scene)
    finally:
        scene.cycles.samples = samples


def luminance(image):
    return image[..., :3] @ LUMINANCE


def measure(shape, unit, args):
    """(row of measures, {key: picture}: the three renders and the regions) of one shape in one
    unit: a corpus shape's name, or a scan's path (``--scans``, in ``--scan-unit``)."""
    scan = isinstance(shape, pathlib.Path)
    path = pathlib.Path(args.out) / f"{shape.stem if scan else shape}_{unit}.blend"
    if args.fresh or not path.exists():
        if scan:
            scan_scene(shape, args.scan_up, unit)
        else:
            build_scene(shape, unit)
        bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
    shape = shape.stem if scan else shape
    started = time.monotonic()
    bake(path)
    baked = time.monotonic() - started
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    scene, obj = bpy.context.scene, bpy.data.objects[shape]
    render.use_cycles(scene, size=args.size, samples=args.samples, bounces=4, pixel_filter=0.01)
    write_concavity(obj)
    sources = linking.discover_maps(obj)
    rain, runoff, edge, concave = (
        probe(scene, obj, s) for s in (*(sources[m] for m in ("rain", "runoff", "edges")), CONCAVE_ATTRIBUTE)
    )
    covered = rain[..., 3] > 0.999
    regions = corpus_regions.classify(rain[..., 0], runoff[..., 0], edge[..., 0], 0.5 - concave[..., 0])
    water = corpus_regions.water_reaching(rain[..., 0], runoff[..., 0])

    renders = {}
    for mode, age in ((model.SOILING, 0.0), (model.SOILING, 1.0), (model.WET, 1.0)):
        material = made_material(obj, (mode,), args.environment)
        weathering.set_input(material.node_tree.nodes[GROUP_NODE], "time", age)
        studio.assign(obj, material)
        renders[mode, age] = render.render_array(scene)
    clean = luminance(renders[model.SOILING, 0.0])
    lit = covered & (clean > LIT)
    with np.errstate(divide="ignore", invalid="ignore"):
        aged = luminance(renders[model.SOILING, 1.0]) / clean
        wet = luminance(renders[model.WET, 1.0]) / clean

    def median(mask):
        return float(np.median(aged[mask])) if mask.sum() >= 8 else float("nan")

    reached = lit & (water >= corpus_regions.REACHED_FROM)
    row = dict(
        shape=shape,
        unit=unit,
        triangles=len(obj.data.polygons),
        bake_s=round(baked, 1),
        pixels=int(lit.sum()),
        share={
            name: float((lit & (regions == key)).sum() / max(lit.sum(), 1))
            for key, name in corpus_regions.NAMES.items()
        },
        hollows=median(lit & (regions == corpus_regions.SHELTERED_HOLLOW)),
        washed=median(lit & (regions == corpus_regions.WASHED)),
        rest=median(lit & (regions == corpus_regions.REST)),
        median=median(lit),
        darkest=float(np.percentile(aged[lit], 5)) if lit.any() else float("nan"),
        reached=float(reached.sum() / max(lit.sum(), 1)),
        wet=float((wet[reached] <= WET_DARKER).mean()) if reached.any() else float("nan"),
    )
    renders["regions"] = region_picture(regions, lit, renders[model.SOILING, 0.0])
    return row, renders


# --- reporting --------------------------------------------------------------------------------


def verdict(measure_name, value):
    low, high = TARGETS[measure_name]
    if not np.isfinite(value):
        return "–"
    return "✓" if (low is None or value >= low) and (high is None or value <= high) else "✗"


def table(rows):
    lines = [
        "| shape | unit | triangles | hollows / washed / rest, % of pixels | sheltered hollows (<= 0.4) | "
        "washed (0.95-1.05) | the rest | object median (0.55-0.9) | darkest 5% | reached by water, % | "
        "wet <= 0.8x dry, % of reached (>= 70) |",
        "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        share = " / ".join(f"{100 * row['share'][name]:.0f}" for name in corpus_regions.NAMES.values())
        cells = [
            row["shape"],
            row["unit"],
            row["triangles"],
            share,
            f"{row['hollows']:.2f} {verdict('hollows', row['hollows'])}",
            f"{row['washed']:.2f} {verdict('washed', row['washed'])}",
            f"{row['rest']:.2f}",
            f"{row['median']:.2f} {verdict('median', row['median'])}",
            f"{row['darkest']:.2f}",
            f"{100 * row['reached']:.0f}",
            f"{100 * row['wet']:.0f} {verdict('wet', row['wet'])}",
        ]
        lines.append("| " + " | ".join(str(cell) for cell in cells) + " |")
    return "\n".join(lines)


#: The contact sheet's columns: the renders of each row.
SHEET_COLUMNS = ((model.SOILING, 0.0), (model.SOILING, 1.0), (model.WET, 1.0), "regions")
#: The regions' tints in the contact sheet's fourth column.
TINTS = {
    corpus_regions.SHELTERED_HOLLOW: (1.0, 0.1, 0.1),
    corpus_regions.WASHED: (0.1, 0.8, 1.0),
    corpus_regions.REST: (0.6, 0.6, 0.6),
}


def region_picture(regions, lit, clean):
    """The t = 0 picture with each lit pixel tinted by its region (linear RGBA)."""
    picture = clean.copy()
    for key, tint in TINTS.items():
        chosen = lit & (regions == key)
        picture[chosen, :3] = 0.4 * picture[chosen, :3] + 0.6 * np.array(tint)
    return picture


def display(image):
    """Linear RGBA over a white card, to 8-bit sRGB."""
    rgb = image[..., :3] + (1.0 - image[..., 3:4])
    rgb = np.clip(rgb, 0.0, 1.0)
    return np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055)


def contact_sheet(tiles, path):
    """Rows of (t = 0, t = 1 soiling, t = 1 wet, regions) pictures, written to ``path`` (PNG)."""
    import OpenImageIO as oiio

    sheet = np.concatenate([np.concatenate([display(t) for t in row], axis=1) for row in tiles], axis=0)
    buf = oiio.ImageBuf(oiio.ImageSpec(sheet.shape[1], sheet.shape[0], 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), np.ascontiguousarray(sheet, dtype=np.float32))
    if not buf.write(str(path)):
        raise OSError(f"cannot write {path}: {buf.geterror()}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="folder for the .blend files, results.json and corpus.png")
    parser.add_argument(
        "--shapes", nargs="+", choices=corpus_generator.SHAPES, help="default: every one, or none with --scans"
    )
    parser.add_argument("--units", nargs="+", choices=UNITS, default=list(UNITS))
    parser.add_argument("--size", type=int, default=256, help="picture size in pixels (default: 256)")
    parser.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel (default: 16)")
    parser.add_argument("--environment", help="pass this environment to Make (default: the API's)")
    parser.add_argument("--fresh", action="store_true", help="make the .blend files again (default: reuse them)")
    add_scan_options(parser)
    args = parser.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.time()
    rows, tiles = [], []
    shapes = args.shapes or ([] if args.scans else corpus_generator.SHAPES)
    units = {shape: args.units for shape in shapes} | {scan: [args.scan_unit] for scan in args.scans}
    for shape, its_units in units.items():
        for unit in its_units:
            row, renders = measure(shape, unit, args)
            rows.append(row)
            if unit == its_units[0]:  # one row per shape: the other unit renders the same picture
                tiles.append([renders[key] for key in SHEET_COLUMNS])
            print(table([row]).splitlines()[-1], flush=True)  # progress
    print()
    print(table(rows))
    print(
        f"\n{args.size} px, {args.samples} samples, 4 bounces; {machine.describe(bpy.app.version_string)}; "
        f"{time.time() - started:.0f} s"
    )
    (out / "results.json").write_text(json.dumps(rows, indent=1))
    contact_sheet(tiles, out / "corpus.png")
    print(f"wrote {out / 'corpus.png'} and {out / 'results.json'}")
    compat.end_process(0)  # bpy 4.5 can hang at interpreter exit


if __name__ == "__main__":
    main()
