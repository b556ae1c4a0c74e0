"""Life on stone at a site, measured in renders (docs/benchmarks.md, "Life on stone"; docs/model.md
§9): a cube, the untuned corpus and the main job's façade, in RURAL at 50° N after 20 years.

    .venv-5.2/bin/python benchmarks/bench_life.py --out DIR [--objects cube head ... facade]
        [--size 128] [--samples 16] [--no-timing] [--scans FILE ... [--scan-up Y|Z] [--scan-unit mm|cm|m]]

For each object:

1. its scene: the cube (3 m, standing on z = 0, its faces cut into 0.1 m cells so that the
   per-corner maps resolve the damp's front), a corpus shape in metres
   (sample_blends/corpus_generator.py), the main job's façade, united and cut as the main
   job prepares it (``demo.RECIPES[demo.FACADE]``), or a scan file of one's own (``--scans``,
   brought in as bench_corpus.py brings one in, in place of those unless ``--objects`` names some);
2. baked with the bake's defaults (every map, target attribute; the site the sun map's default,
   50° N, +Y north, unless the file sets one);
3. made with the biological mode as the main job makes a material (``demo.Sample.material``:
   the limestone preset, its panel values and the environment's inputs, the façade's ashlar),
   its clocks set from 20 years (``aging.ages_for_years``), in RURAL and in URBAN; the mode off
   is the RURAL material at ``biological_level`` 0 (which renders the material without life bit
   for bit: tests/test_biological.py);
4. rendered with Cycles under a uniform white sky (strength 1, no sun, no denoising, pixel filter
   0.01): an open Lambertian face renders its albedo, so a pixel's colour is the stone's, and
   north and south faces are lit alike. Two orthographic views, from the north and from the
   south, 35° up (the top in both). Probes of the same pixels (one sample each, emissions): the
   shading normal and the baked rain E, run-off R, sun S and damp D as the material reads them;
5. measured in CIELAB (D65, ``colorimetry.linear_to_lab``) of each region's mean linear colour:

   - **north / south faces**: walls (|n_z| < 0.25) whose outward normal's bearing is within 45°
     of north / south (the bearing from the sun map's site: +Y turned by its north angle);
   - **washed tops**: n_z > 0.9 and W = E + R (1 - E) >= 0.8 (corpus_regions.WASHED_FROM);
     **east and west faces**: the other walls;
   - **plinth**: walls with D >= 0.95 (below the damp's front); **above the front**: walls with
     D <= 0.01;

   a region of fewer than MIN_PIXELS pixels (over both views) is not measured on that object.

Criteria: north greener than south (ΔE*ab >= 3.2 between them, a* lower on
the north); washed tops the least colonised (their ΔE*ab from the mode off the smallest of the
regions); the plinth darker than 0.85 × the mode off (luminance Y) below the front and unchanged
above it (ΔE*ab <= 1 against the same material with D = 0, its damp input unlinked); URBAN's
colour change from life at most half RURAL's (the mean over the object's pixels of the
per-pixel ΔE*ab from the mode off). Convergence: the mode off rendered again with another seed;
the largest ΔE*ab between the two of any region's mean colour is the noise of the measures.

Bake cost (``--no-timing`` skips it; ``--objects`` with no name measures it alone): the façade
prepared twice in the same run, baked once with the maps of before the sun and damp (rain,
edges, run-off) and once with every map (the default), each timed: the ratio is the default
bake's cost over before's; the maps before left out are also timed one by one on the first.
"""

import argparse
import json
import os
import pathlib
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

from benchmarks import bench_corpus, corpus_regions, machine, probes  # noqa: E402
from porous_weathering.blender import compat, render  # noqa: E402
from porous_weathering.contracts import GROUP_NODE, SAMPLES_DIR, socket_name  # noqa: E402
from porous_weathering.core import aging, colorimetry, environments, solar  # noqa: E402
from porous_weathering.core import modes as weathering_modes  # noqa: E402
from porous_weathering.maps import bake, linking, sun  # noqa: E402
from porous_weathering.maps import registry as maps  # noqa: E402
from porous_weathering.samples import demo, studio  # noqa: E402
from porous_weathering.shading import presets, weathering  # noqa: E402

LIFE = "biological"
YEARS = 20.0
LATITUDE = 50.0
CUBE_SIDE = 3.0  # m: its damp front (h_ss of a 2 m body, 2.1 m) stands below its top
CUBE_CELL = 0.1
OBJECTS = ("cube", *corpus_generator.SHAPES, "facade")
#: The views: towards the camera from the object, in the site's frame (x east, y north, z up).
VIEWS = {"north": (0.0, 1.0, 0.7), "south": (0.0, -1.0, 0.7)}
WALL_BELOW = 0.25  # |n_z| of a wall
TOP_FROM = 0.9  # n_z of a top
BELOW_FRONT, ABOVE_FRONT = 0.95, 0.01  # D
LIT = 1e-3
#: The fewest pixels a region is measured on (fewer: not measurable on that object).
MIN_PIXELS = 50
#: The criteria's thresholds (docs/benchmarks.md, "Life on stone").
VISIBLE = 3.2  # ΔE*ab clearly visible (Sanmartín et al. 2012)
PLINTH_DARKER = 0.85
UNCHANGED = 1.0  # ΔE*ab
URBAN_SHARE = 0.5


# --- the scenes -----------------------------------------------------------------------------------


def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.system = "METRIC"
    return scene


def cube():
    """A CUBE_SIDE cube on z = 0, its faces cut into CUBE_CELL cells (per-corner maps)."""
    import bmesh  # loadable once bpy is

    scene = empty_scene()
    mesh = bpy.data.meshes.new("cube")
    made = bmesh.new()
    bmesh.ops.create_cube(made, size=CUBE_SIDE)
    bmesh.ops.translate(made, vec=(0.0, 0.0, CUBE_SIDE / 2), verts=made.verts)
    cuts = round(CUBE_SIDE / CUBE_CELL) - 1
    bmesh.ops.subdivide_edges(made, edges=made.edges[:], cuts=cuts, use_grid_fill=True)
    made.to_mesh(mesh)
    made.free()
    obj = bpy.data.objects.new("cube", mesh)
    scene.collection.objects.link(obj)
    return scene, [obj], None


def corpus_shape(name):
    scene = empty_scene()
    scene.unit_settings.scale_length, scene.unit_settings.length_unit = scan_generator.SCENE_UNITS["m"]
    vertices, triangles = corpus_generator.shape_mesh(name, "m")
    return scene, [scan_generator.add_to_scene(name, vertices, triangles, scene.collection)], None


def facade():
    """The main job's façade as it prepares it (united, cut), the ground hidden from the renders."""
    recipe = demo.RECIPES[demo.FACADE]
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES_DIR, f"{demo.FACADE}.blend"), load_ui=False)
    scene = bpy.context.scene
    parts = [obj for obj in scene.objects if obj.type == "MESH" and obj.name != "Ground"]
    united = demo.unite(parts, recipe.unite)
    demo.refine(united, recipe.cell)
    return scene, [united], recipe.masonry


def build(name, args):
    """(scene, [objects], masonry or None) of one object, its maps not baked: a scan's (``--scans``:
    a path) as ``bench_corpus.import_scan`` brings it in."""
    if isinstance(name, pathlib.Path):
        scan = bench_corpus.import_scan(name, args.scan_up, args.scan_unit)  # a new file
        return bpy.context.scene, [scan], None
    if name == "cube":
        return cube()
    if name == "facade":
        return facade()
    return corpus_shape(name)


def timed_bake(objects, maps):
    started = time.monotonic()
    bake.bake_maps(objects, bake.BakeOptions(maps=maps, target="attribute"))
    return time.monotonic() - started


#: The maps a bake made before the sun and damp maps existed.
BEFORE = ("rain", "edges", "runoff")


def bake_cost():
    """{map or set: seconds, ratio}: the façade's default bake against the bake of BEFORE, in one
    run: a freshly prepared façade baked with BEFORE, and another with every map (the default);
    then, on the first, each map BEFORE leaves out alone (its BEFORE maps are kept: unchanged
    attributes are skipped), so that the default's extra cost is split by map."""
    _, objects, _ = facade()
    before = timed_bake(objects, BEFORE)
    split = {name: round(timed_bake(objects, (name,)), 1) for name in maps.names() if name not in BEFORE}
    _, objects, _ = facade()
    default = timed_bake(objects, ())
    return dict(before_s=round(before, 1), default_s=round(default, 1), ratio=round(default / before, 2), **split)


# --- rendering ------------------------------------------------------------------------------------


def light_and_frame(scene, objects, north_angle):
    """A uniform white sky, nothing else lit or seen but ``objects``; {view: camera}."""
    for obj in scene.objects:
        if obj.type == "LIGHT" or (obj.type == "MESH" and obj not in objects):
            obj.hide_render = True
    world = bpy.data.worlds.new("White sky")
    compat.use_world_nodes(world)
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = 1.0
    scene.world = world
    corners = np.array([obj.matrix_world @ Vector(c) for obj in objects for c in obj.bound_box])
    to_scene = solar.site_to_scene(north_angle)
    return {
        view: bench_corpus.frame(scene, corners, to_scene @ np.asarray(towards, float), margin=1.05)
        for view, towards in VIEWS.items()
    }


def assign(objects, material):
    for obj in objects:
        studio.assign(obj, material)


def probe_render(scene, objects, material):
    assign(objects, material)
    samples, scene.cycles.samples = scene.cycles.samples, 1
    try:
        return render.render_array(scene)
    finally:
        scene.cycles.samples = samples


def probe_fields(scene, objects):
    """{quantity: (H, W) array}: n_x, n_y, n_z (scene), E, R, S, D and the coverage alpha."""
    normal = probe_render(scene, objects, probes.normal_probe())
    found = linking.discover_maps(objects[0])
    out = {"alpha": normal[..., 3], "normal": normal[..., :3] * 2.0 - 1.0}
    for name in ("rain", "runoff", "sun", "damp"):
        material = probes.emission_probe(
            f"Probe {name}", lambda graph, geometry, source=found[name]: weathering.mask_socket(graph, source)
        )
        out[name] = probe_render(scene, objects, material)[..., 0]
    return out


def life_material(obj, environment, masonry):
    """The biological material the main job's ``Sample.material`` makes for ``environment``,
    its clocks set to YEARS."""
    stone = demo.RECIPES[demo.FACADE].stone
    panel = presets.weathering_values(stone, environment)
    site = environments.weathering_inputs(environment, (LIFE,))
    used = {item.name for item in weathering_modes.inputs_of((LIFE,))}
    made = weathering.make_weathered_material(
        f"{obj.name} life {environment}",
        modes=(LIFE,),
        environment=environment,
        stone=stone,
        masonry=masonry,
        **presets.PRESETS[stone].material_params(),
        **linking.map_inputs(obj, (LIFE,)),
        **{**site, **{name: value for name, value in panel.items() if name in used}},
    )
    group = made.node_tree.nodes[GROUP_NODE]
    carbon = environments.get(environment).elemental_carbon
    for clock, value in aging.ages_for_years(YEARS, carbon).items():
        if socket_name(clock) in group.inputs:
            weathering.set_input(group, clock, value)
    return made


def without(material, input_name, value):
    """A copy of ``material`` with ``input_name`` unlinked and set to ``value``."""
    copy = material.copy()
    group = copy.node_tree.nodes[GROUP_NODE]
    socket = group.inputs[socket_name(input_name)]
    for link in list(socket.links):
        copy.node_tree.links.remove(link)
    weathering.set_input(group, input_name, value)
    return copy


def renders(scene, objects, masonry, args):
    """{view: {condition: linear RGBA}} and {view: probes}."""
    rural = life_material(objects[0], "RURAL", masonry)
    materials = {
        "off": without(rural, "biological_level", 0.0),
        "rural": rural,
        "rural, D = 0": without(rural, "damp_map", 0.0),
        "urban": life_material(objects[0], "URBAN", masonry),
    }
    pictures, probed = {}, {}
    for view, cam in args.cameras.items():
        scene.camera = cam
        probed[view] = probe_fields(scene, objects)
        pictures[view] = {}
        for condition, material in materials.items():
            assign(objects, material)
            pictures[view][condition] = render.render_array(scene)
        if view == "north":  # the noise: the mode off again, another seed
            assign(objects, materials["off"])
            scene.cycles.seed = 1
            pictures[view]["off, seed 0"] = pictures[view]["off"]
            pictures[view]["off, seed 1"] = render.render_array(scene)
            scene.cycles.seed = 0
    return pictures, probed


# --- measuring ------------------------------------------------------------------------------------


def regions(probed, north_angle):
    """{region: boolean (H, W)} of one view."""
    n = probed["normal"]
    covered = probed["alpha"] > 0.999
    bearing = (np.degrees(np.arctan2(n[..., 0], n[..., 1])) - north_angle + 180.0) % 360.0 - 180.0
    wall = covered & (np.abs(n[..., 2]) < WALL_BELOW)
    water = corpus_regions.water_reaching(probed["rain"], probed["runoff"])
    north, south = wall & (np.abs(bearing) <= 45.0), wall & (np.abs(bearing) >= 135.0)
    return {
        "north faces": north,
        "south faces": south,
        "east and west faces": wall & ~north & ~south,
        "washed tops": covered & (n[..., 2] > TOP_FROM) & (water >= corpus_regions.WASHED_FROM),
        "plinth": wall & (probed["damp"] >= BELOW_FRONT),
        "above the front": wall & (probed["damp"] <= ABOVE_FRONT),
        "object": covered,
    }


def luminance_y(rgb):
    return rgb @ colorimetry.RGB_TO_XYZ[1]


def measure(name, args):
    scene, objects, masonry = build(name, args)
    name = name.stem if isinstance(name, pathlib.Path) else name
    started = time.monotonic()
    bake.bake_maps(objects, bake.BakeOptions(target="attribute"))
    baked = time.monotonic() - started
    latitude, north_angle = sun.site(sun.SunSettings(), scene)
    render.use_cycles(scene, size=args.size, samples=args.samples, bounces=4, pixel_filter=0.01)
    args.cameras = light_and_frame(scene, objects, north_angle)
    pictures, probed = renders(scene, objects, masonry, args)
    # Each region's pixels over both views (a face seen in both counts twice: the same stone).
    sums, seen, counts, sun_sums = {}, {}, {}, {}
    per_pixel = {"rural": [], "urban": []}
    for view in VIEWS:
        lit = luminance_y(pictures[view]["off"][..., :3]) > LIT
        for region, mask in regions(probed[view], north_angle).items():
            mask = mask & lit
            counts[region] = counts.get(region, 0) + int(mask.sum())
            sun_sums[region] = sun_sums.get(region, 0.0) + float(probed[view]["sun"][mask].sum())
            for condition, picture in pictures[view].items():
                key = (region, condition)
                sums[key] = sums.get(key, 0.0) + picture[mask, :3].sum(axis=0)
                seen[key] = seen.get(key, 0) + int(mask.sum())
        dry = colorimetry.linear_to_lab(pictures[view]["off"][lit, :3])
        for environment in per_pixel:
            aged = colorimetry.linear_to_lab(pictures[view][environment][lit, :3])
            per_pixel[environment].append(np.linalg.norm(aged - dry, axis=-1))
    lab = {key: colorimetry.linear_to_lab(total / seen[key]) for key, total in sums.items() if seen[key] >= MIN_PIXELS}
    row = dict(object=name, triangles=sum(len(o.data.polygons) for o in objects), bake_s=round(baked, 1))
    row["site"] = dict(latitude=latitude, north_angle=north_angle)
    row["pixels"] = counts
    row["sun"] = {r: sun_sums[r] / counts[r] for r in counts if counts[r]}
    row["lab"] = {f"{r} | {c}": [round(float(v), 2) for v in value] for (r, c), value in lab.items()}

    def difference(a, b):
        """ΔE*ab between two (region, condition) means; nan where either is not measured."""
        return float(np.linalg.norm(lab[a] - lab[b])) if a in lab and b in lab else float("nan")

    north, south = ("north faces", "rural"), ("south faces", "rural")
    row["north_south_de"] = difference(north, south)
    row["north_south_da"] = float(lab[north][1] - lab[south][1]) if north in lab and south in lab else float("nan")
    walls = ("north faces", "south faces", "east and west faces")
    row["colonised"] = {r: difference((r, "rural"), (r, "off")) for r in (*walls, "washed tops")}
    plinth_y = [luminance_y(sums["plinth", c]) for c in ("rural", "off")] if ("plinth", "off") in lab else None
    row["plinth_ratio"] = float(plinth_y[0] / plinth_y[1]) if plinth_y else float("nan")
    row["above_front_de"] = difference(("above the front", "rural"), ("above the front", "rural, D = 0"))
    row["below_front_damp_de"] = difference(("plinth", "rural"), ("plinth", "rural, D = 0"))
    row["rural_de"] = float(np.mean(np.concatenate(per_pixel["rural"])))
    row["urban_de"] = float(np.mean(np.concatenate(per_pixel["urban"])))
    row["noise_de"] = max(
        (difference((r, "off, seed 1"), (r, "off, seed 0")) for r in counts if (r, "off, seed 1") in lab),
        default=0.0,
    )
    row["verdicts"] = verdicts(row)
    return row


def verdicts(row):
    """{criterion: True, False or None (not measurable on this object)}."""
    finite = np.isfinite
    colonised = row["colonised"]
    walls = [v for k, v in colonised.items() if k != "washed tops" and finite(v)]
    return {
        "north": (row["north_south_de"] >= VISIBLE and row["north_south_da"] < 0.0)
        if finite(row["north_south_de"])
        else None,
        "tops": (colonised["washed tops"] < min(walls)) if finite(colonised["washed tops"]) and walls else None,
        "plinth": (row["plinth_ratio"] <= PLINTH_DARKER) if finite(row["plinth_ratio"]) else None,
        "above": (row["above_front_de"] <= UNCHANGED) if finite(row["above_front_de"]) else None,
        "urban": row["urban_de"] <= URBAN_SHARE * row["rural_de"],
    }


# --- reporting ------------------------------------------------------------------------------------


def mark(value):
    return {True: "✓", False: "✗", None: "–"}[value]


def number(value, digits=2):
    return f"{value:.{digits}f}" if np.isfinite(value) else "–"


def table(rows):
    lines = [
        "| object | north − south ΔE\\*ab (≥ 3.2), Δa\\* (< 0) | ΔE\\*ab from the mode off: north / south / "
        "east-west / washed tops (tops least) | plinth Y / off (≤ 0.85) | above the front ΔE\\*ab "
        "vs D = 0 (≤ 1) | mean ΔE\\*ab RURAL / URBAN (URBAN ≤ ½) | noise ΔE\\*ab | bake s |",
        "|---|---|---|---|---|---|---:|---:|",
    ]
    for row in rows:
        v, c = row["verdicts"], row["colonised"]
        cells = [
            row["object"],
            f"{number(row['north_south_de'])}, {number(row['north_south_da'])} {mark(v['north'])}",
            " / ".join(number(c[k]) for k in ("north faces", "south faces", "east and west faces", "washed tops"))
            + f" {mark(v['tops'])}",
            f"{number(row['plinth_ratio'])} {mark(v['plinth'])}",
            f"{number(row['above_front_de'])} {mark(v['above'])}",
            f"{number(row['rural_de'])} / {number(row['urban_de'])} {mark(v['urban'])}",
            number(row["noise_de"]),
            number(row["bake_s"], 1),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="folder for results.json")
    parser.add_argument(
        "--objects", nargs="*", choices=OBJECTS, help="default: all (none with --scans); none: the bake cost alone"
    )
    bench_corpus.add_scan_options(parser)
    parser.add_argument("--size", type=int, default=128, help="picture size in pixels (default: 128)")
    parser.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel (default: 16)")
    parser.add_argument("--no-timing", action="store_true", help="skip the façade's bake cost")
    args = parser.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(machine.describe(bpy.app.version_string), flush=True)
    started = time.time()
    result = {}
    if not args.no_timing:
        result["bake_cost"] = bake_cost()
        print(f"bake cost: {json.dumps(result['bake_cost'])}; {machine.describe(bpy.app.version_string)}", flush=True)
    rows = []
    objects = args.objects if args.objects is not None else [] if args.scans else OBJECTS
    for name in [*objects, *args.scans]:
        rows.append(measure(name, args))
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    result["rows"] = rows
    print()
    print(table(rows))
    print(
        f"\n{YEARS:g} years, {args.size} px, {args.samples} samples, 4 bounces, uniform white sky; "
        f"{machine.describe(bpy.app.version_string)}; {time.time() - started:.0f} s"
    )
    (out / "results.json").write_text(json.dumps(result, indent=1, default=float))
    compat.end_process(0)  # bpy 4.5 can hang at interpreter exit


if __name__ == "__main__":
    main()
