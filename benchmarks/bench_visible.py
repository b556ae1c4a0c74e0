"""Visible targets of the weathering modes (docs/weathering.md, "Visible targets").

    python benchmarks/bench_visible.py [--size 160] [--samples 16] [--bake-samples 32]
                                       [--only NAME ...] [--areas DIR]

Each sample scene is weathered as the main job weathers it (``demo.Sample`` and ``demo.RECIPES``:
the stone and environment a user picks in the panel, its maps baked with the bake's defaults, the
site's rain and the view), every weathering input at the panel's value for them, and rendered
with Cycles (the main job's 4 bounces, no denoising, pixel filter 0.01 so that each pixel is
one surface point) at t = 0 and t = 1. Each area is found from the geometry, as
tests/test_weathering_composite.py finds its areas: position and normal probe renders of the
weathered objects, never the baked maps (the maps' mean values in each area
are printed beside it, to explain a miss). An area's change is the mean luminance of its pixels
at t = 1 over the mean luminance of the same pixels at t = 0 (only pixels lit at t = 0 count).
Beside it, "k_d, model" is the same ratio of model.py's diffuse weight alone at those pixels (the
stone's colour, without the light: the water lobe's sheen of the sky, shadows and bounces).

Targets (docs/weathering.md): black area <= 0.35x, grey area 0.5-0.9x, white area 0.98-1.02x; wet area,
away from the mirror direction of the sun (> 25 degrees from it), <= 0.8x on limestone and on
brick; efflorescence >= 1.5x where salted, <= 1.05x on bare stone. ``VARIANTS`` adds rows for the
model's settings a result comes from (the paper's equations): each names what it changes.

``--areas DIR`` writes, per sample and mode, the t = 1 picture with each area tinted, to check
that the areas are where their names say. Prints a Markdown table and the machine line.
"""

import argparse
import dataclasses
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

import machine  # noqa: E402  (benchmarks/machine.py)
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

from benchmarks import probes
from porous_weathering.blender import compat, render  # noqa: E402
from porous_weathering.core import model
from porous_weathering.samples import demo, studio
from porous_weathering.shading import weathering

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])

#: Target of each kind of area: (lowest, highest) t = 1 over t = 0 mean luminance (None: open).
TARGETS = {
    "black": (None, 0.35),
    "grey": (0.5, 0.9),
    "white": (0.98, 1.02),
    "wet": (None, 0.8),
    "salted": (1.5, None),
    "bare": (None, 1.05),
}
#: Degrees from the sun's mirror direction within which a wet pixel counts as in the glint.
GLINT_DEGREES = 25.0


@dataclasses.dataclass
class Geometry:
    """Per pixel of the weathered objects: world position P (scene units), unit shading normal N,
    unit vectors towards the camera V and the sun S, and the covered pixels."""

    P: np.ndarray
    N: np.ndarray
    V: np.ndarray
    S: np.ndarray
    covered: np.ndarray

    def facing(self, direction, cosine=0.95):
        return self.N @ np.asarray(direction, dtype=float) > cosine

    def within(self, axis, low, high):
        return (low <= self.P[..., axis]) & (self.P[..., axis] <= high)

    def glint_angle(self):
        """Degrees between the sun and the mirror direction of the view about the normal."""
        n_dot_v = (self.N * self.V).sum(-1, keepdims=True)
        mirror = 2.0 * n_dot_v * self.N - self.V
        return np.degrees(np.arccos(np.clip(mirror @ self.S, -1.0, 1.0)))


# --- the areas, by geometry ------------------------------------------------------------------

FRONT = (0.0, -1.0, 0.0)
DOWN = (0.0, 0.0, -1.0)


def facade_bays(g):
    """The façade's open wall between windows and pilasters (x, m), away from their edges."""
    x = g.P[..., 0]
    return (
        ((-3.05 <= x) & (x <= -2.55))
        | ((-0.95 <= x) & (x <= -0.45))
        | ((0.45 <= x) & (x <= 0.95))
        | ((2.55 <= x) & (x <= 3.05))
    )


def facade_open_wall(g):
    return g.facing(FRONT) & (np.abs(g.P[..., 1]) < 0.02) & g.within(2, 2.4, 3.8) & facade_bays(g)


def facade_under_cornice(g):
    return g.facing(FRONT) & (np.abs(g.P[..., 1]) < 0.02) & g.within(2, 4.95, 5.35) & facade_bays(g)


def facade_window_heads(g):
    """The top 0.4 m of the window recesses (head soffit, reveals, back), 0.3 m deep in the wall."""
    x = np.abs(g.P[..., 0])
    return g.within(1, 0.01, 0.31) & (1.15 <= x) & (x <= 2.35) & g.within(2, 3.8, 4.21)


def facade_capitals_below(g):
    """The undersides of the pilasters' capitals, under the cornice."""
    x = g.P[..., 0]
    near = np.min([np.abs(x - c) for c in (-3.5, 0.0, 3.5)], axis=0) < 0.35
    return g.facing(DOWN) & near & g.within(2, 5.15, 5.2)


def facade_sills_below(g):
    """The undersides of the window sills."""
    x = np.abs(g.P[..., 0])
    return g.facing(DOWN) & (1.0 <= x) & (x <= 2.5) & g.within(2, 2.1, 2.14) & g.within(1, -0.18, 0.0)


def facade_under_sills(g):
    """The wall in the corner under the sills, 0.1 m high: sheltered from the driven rain."""
    x = np.abs(g.P[..., 0])
    return g.facing(FRONT) & (np.abs(g.P[..., 1]) < 0.02) & (1.15 <= x) & (x <= 2.35) & g.within(2, 2.0, 2.1)


def brick_faces(g):
    """The bricks' front faces (y = 0), away from the wall's ends."""
    return g.facing(FRONT, 0.99) & (np.abs(g.P[..., 1]) < 0.002) & g.within(0, 0.3, 1.8) & g.within(2, 0.1, 1.1)


def distance_to_joint(g):
    """Distance (m) from a point of the brick wall's face to the nearest joint centre line."""
    import build_samples

    pitch = build_samples.BRICK.x + build_samples.JOINT
    course = build_samples.BRICK.z + build_samples.JOINT
    x, z = g.P[..., 0], g.P[..., 2]
    bed = np.mod(z - build_samples.JOINT / 2, course)
    odd = np.floor((z - build_samples.JOINT / 2) / course) % 2
    head = np.mod(x + build_samples.JOINT / 2 - odd * pitch / 2, pitch)
    return np.minimum(np.minimum(bed, course - bed), np.minimum(head, pitch - head))


def brick_near_joints(g):
    """The brick faces' first 5 mm from their joints' edges (the joints are 10 mm wide)."""
    d = distance_to_joint(g)
    return g.within(2, 0.1, 1.1) & g.within(0, 0.3, 1.8) & (d > 0.004) & (d < 0.011) & (g.P[..., 1] < 0.004)


def brick_centres(g):
    return brick_faces(g) & (distance_to_joint(g) > 0.025)


def stone_top(g):
    """The sculpted stone's upward faces on its upper half, out of the hollows (vertical rain washes them)."""
    return g.facing((0, 0, 1), 0.8) & g.within(2, 0.9, 1.4) & ~stone_in_hollows(g)


HOLLOWS = (((-0.22, -0.3, 0.95), 0.2), ((0.22, -0.25, 0.62), 0.17), ((-0.05, -0.32, 0.42), 0.13))


def stone_in_hollows(g):
    inside = np.zeros(g.covered.shape, bool)
    for centre, radius in HOLLOWS:
        inside |= np.linalg.norm(g.P - np.array(centre), axis=-1) < radius + 0.01
    return inside


def stone_hollow_roofs(g):
    """The upper half of the three hollows, facing down: sheltered cavities."""
    return stone_in_hollows(g) & (g.N[..., 2] < -0.2)


def stone_flanks(g):
    """Steep flanks facing the camera's side, out of the hollows, 0.6-1.0 m up."""
    return (np.abs(g.N[..., 2]) < 0.25) & ~stone_in_hollows(g) & g.within(2, 0.6, 1.0)


#: The bust's head turns 5 degrees to its left above the neck; its front is -Y (scan_generator).
BUST_TURN = math.radians(5.0)
FACE_RADIUS = 105.0


def bust_face_coordinates(g):
    """(u, z): mm across the face from its centre line (> 0 towards +X) and height, on the head."""
    phi = np.arctan2(g.P[..., 1], g.P[..., 0]) - BUST_TURN
    alpha = (phi + np.pi / 2 + np.pi) % (2 * np.pi) - np.pi
    return alpha * FACE_RADIUS, g.P[..., 2]


def bust_hat_top(g):
    """The brim's and crown's upper faces (driven rain washes them)."""
    return g.within(2, 408.0, 500.0) & (g.N[..., 2] > 0.5)


def bust_cheeks_and_brow(g):
    """Forehead and cheeks under the brim: sheltered, smooth."""
    u, z = bust_face_coordinates(g)
    forehead = (np.abs(u) < 40) & (z > 385) & (z < 398)
    cheeks = (np.abs(np.abs(u) - 45.0) < 8.0) & (z > 322) & (z < 340)
    return (forehead | cheeks) & g.facing(FRONT, 0.5)


def bust_eye_sockets(g):
    u, z = bust_face_coordinates(g)
    socket = np.hypot((np.abs(u) - 31.0) / 16.0, (z - 361.0) / 11.0) < 1.0
    eyeball = np.hypot((np.abs(u) - 31.0) / 7.0, (z - 358.5) / 5.0) < 1.0
    return socket & ~eyeball & (z > 300)


def bust_under_the_brim(g):
    """The head just under the brim, where the forehead meets the brim's underside: a sheltered
    inner corner all round the head."""
    return g.within(2, 398.0, 412.0) & (np.hypot(g.P[..., 0], g.P[..., 1]) < 105.0) & (g.N[..., 2] < 0.3)


def bust_ears(g):
    """The ears' hollows and rims, at the sides of the head."""
    u, z = bust_face_coordinates(g)
    behind = (np.abs(u) / FACE_RADIUS - np.pi / 2) * 80.0  # mm from the ear's centre, > 0 towards the back
    return (np.abs(behind) < 14.0) & (np.abs(z - 350.0) < 22.0) & (np.hypot(g.P[..., 0], g.P[..., 1]) < 120.0)


def bust_chest(g):
    """The front of the chest, open to the driven rain."""
    return g.within(2, 110.0, 200.0) & (g.N[..., 1] < -0.6) & (g.N[..., 2] > -0.1)


#: sample -> mode -> [(kind of area, what it is, geometry -> mask)]
AREAS = {
    "limestone_facade": {
        model.SOILING: [
            ("white", "open wall, 2.4-3.8 m", facade_open_wall),
            ("grey", "wall under the cornice, 4.95-5.35 m", facade_under_cornice),
            ("black", "window heads (top 0.4 m of the recesses)", facade_window_heads),
            ("black", "undersides of the capitals", facade_capitals_below),
            ("black", "undersides of the sills", facade_sills_below),
            ("black", "wall in the corner under the sills, 0.1 m", facade_under_sills),
        ],
        model.WET: [("wet", "open wall, 2.4-3.8 m", facade_open_wall)],
        model.EFFLORESCENCE: [
            ("salted", "open wall (its map: the run-off map)", facade_open_wall),
            ("bare", "wall under the cornice", facade_under_cornice),
        ],
    },
    "sculpted_stone": {
        model.SOILING: [
            ("white", "upward faces", stone_top),
            ("grey", "steep flanks out of the hollows", stone_flanks),
            ("black", "roofs of the three hollows", stone_hollow_roofs),
        ],
    },
    "brick_wall": {
        model.SOILING: [
            ("grey", "brick faces (W = 0.81, E = 0.42)", brick_faces),
        ],
        model.WET: [("wet", "brick faces", brick_faces)],
        model.EFFLORESCENCE: [
            ("salted", "brick faces within 5 mm of a joint", brick_near_joints),
            ("bare", "brick faces over 25 mm from a joint", brick_centres),
        ],
    },
    "bust": {
        model.SOILING: [
            ("white", "top of the hat", bust_hat_top),
            ("grey", "forehead and cheeks, under the brim", bust_cheeks_and_brow),
            ("black", "eye sockets", bust_eye_sockets),
            ("black", "ears", bust_ears),
            ("black", "under the brim, against the head", bust_under_the_brim),
        ],
        model.WET: [("wet", "front of the chest", bust_chest)],
    },
}

#: Extra rows: (sample, mode, what changes, {weathering input: value}) on top of the sample's
#: panel choices, for the model's settings a result comes from (nothing here changes a default).
VARIANTS = (("brick_wall", model.WET, "wet_darkening 0, the paper's equations", {"wet_darkening": 0.0}),)


# --- measuring -------------------------------------------------------------------------------


def luminance(image):
    return image[..., :3] @ LUMINANCE


def probe_geometry(sample):
    """Position and normal probes of the weathered objects (others held out)."""
    scene = sample.scene
    holdout = probes.holdout_material()
    originals = {obj.name: list(obj.data.materials) for obj in scene.objects if obj.type == "MESH"}
    for obj in scene.objects:
        if obj.type == "MESH" and obj not in sample.objects:
            studio.assign(obj, holdout)
    corners = np.array([obj.matrix_world @ Vector(corner) for obj in sample.objects for corner in obj.bound_box])
    centre = (corners.min(axis=0) + corners.max(axis=0)) / 2
    extent = float(np.abs(corners - centre).max()) * 1.01
    scale = 0.5 / extent

    def probe(material):
        for obj in sample.objects:
            studio.assign(obj, material)
        return render.render_array(scene)

    position_material = probes.emission_probe(
        "Position Probe",
        lambda graph, geometry: (graph.wrap(geometry.outputs["Position"]) - tuple(centre)) * scale + 0.5,
    )
    positions = probe(position_material)
    normals = probe(probes.normal_probe())
    for obj in scene.objects:  # the materials as they were
        if obj.type == "MESH":
            obj.data.materials.clear()
            for material in originals[obj.name]:
                obj.data.materials.append(material)
    P = (positions[..., :3] - 0.5) / scale + centre
    N = normals[..., :3] * 2.0 - 1.0
    N /= np.maximum(np.linalg.norm(N, axis=-1, keepdims=True), 1e-9)
    V = np.array(scene.camera.matrix_world.translation) - P
    V /= np.maximum(np.linalg.norm(V, axis=-1, keepdims=True), 1e-12)
    S = np.array(sample.sun.matrix_world.to_3x3().col[2])
    return Geometry(P, N, V, S, (positions[..., 3] > 0.999) & (normals[..., 3] > 0.999))


def probe_maps(sample, mode):
    """Mean-value probes of every mask ``mode`` reads, as the material reads them."""
    values = {}
    for mask, map_name in sample.recipe.masks[mode].items():
        source = weathering.mask_source(mask, sample.sources[map_name])
        material = probes.emission_probe(
            "Mask Probe", lambda graph, geometry, s=source: weathering.mask_socket(graph, s)
        )
        for obj in sample.objects:
            studio.assign(obj, material)
        values[mask] = render.render_array(sample.scene)[..., 0]
    return values


def model_diffuse(sample, mode, geometry, maps, age, inputs):
    """model.py's diffuse weight k_d (luminance) at each pixel at ``age``: what the stone's own
    colour does, without the light (the sheen of the water lobe, shadows, bounces)."""
    stone = sample.stone
    weights = model.weathered_coefficients(
        stone["base_color"][:3],
        stone["ks"],
        stone["roughness"],
        stone["porosity"],
        stone["pore_depth_ratio"],
        geometry.N @ geometry.S,
        (geometry.N * geometry.V).sum(-1),
        (mode,),
        **{**sample.inputs(mode, **inputs), "time": age, **maps},
    )
    return luminance(np.asarray(weights[0]))


def verdict(kind, ratio):
    low, high = TARGETS[kind]
    if low is not None and ratio < low:
        return f"missed: {low - ratio:.2f} below {low:g}"
    if high is not None and ratio > high:
        return f"missed: {ratio - high:.2f} above {high:g}"
    return "met"


def target_text(kind):
    low, high = TARGETS[kind]
    if low is None:
        return f"<= {high:g}"
    if high is None:
        return f">= {low:g}"
    return f"{low:g}-{high:g}"


def use_cycles(sample, args):
    """Cycles for measuring: ``args.size`` pixels high in the sample's aspect, ``args.samples``,
    the main job's 4 bounces, no denoising, pixel filter 0.01 (a pixel is one surface point)."""
    scene = sample.scene
    aspect = scene.render.resolution_x / scene.render.resolution_y
    render.use_cycles(scene, size=args.size, samples=args.samples, bounces=4, pixel_filter=0.01)
    scene.render.resolution_x = round(args.size * aspect)


def add_render_options(parser, size=160, samples=16):
    """--size, --samples and --bake-samples, which ``use_cycles``, ``demo.Sample`` and
    ``closing_line`` read (``size`` and ``samples``: their defaults)."""
    parser.add_argument("--size", type=int, default=size, help=f"picture height in pixels (default: {size})")
    parser.add_argument("--samples", type=int, default=samples, help=f"Cycles samples per pixel (default: {samples})")
    parser.add_argument("--bake-samples", type=int, default=32, help="rain samples per corner (default: 32)")


def closing_line(args, started):
    """The settings, the machine and the time taken, under the table."""
    return (
        f"\n{args.size} px high, {args.samples} samples, 4 bounces, {args.bake_samples} rain samples; "
        f"{machine.describe(bpy.app.version_string)}; {time.time() - started:.0f} s"
    )


def measure(name, mode, args, work, inputs=None, label="", areas_dir=None, sample=None):
    """Rows of the table for one sample and mode (``inputs``: changes to the recipe's weathering
    inputs, for a variant), and the sample (opened and baked once for all its rows)."""
    inputs = inputs or {}
    if sample is None or sample.name != name:
        sample = demo.Sample(name, map_dir=work, bake_samples=args.bake_samples, progress=True)
    scene = sample.scene
    use_cycles(sample, args)
    geometry = probe_geometry(sample)
    maps = probe_maps(sample, mode)
    sample.show(mode, 0.0, **inputs)
    clean = luminance(render.render_array(scene))
    sample.show(mode, 1.0, **inputs)
    late_image = render.render_array(scene)
    late = luminance(late_image)
    diffuse_clean, diffuse_late = (model_diffuse(sample, mode, geometry, maps, age, inputs) for age in (0.0, 1.0))
    rows = []
    lit = geometry.covered & (clean > 0.01)
    glint = geometry.glint_angle() < GLINT_DEGREES
    tints = []
    for kind, what, select in AREAS[name][mode]:
        area = select(geometry) & lit
        if kind == "wet":
            area &= ~glint
        count = int(area.sum())
        if count < 8:
            rows.append((name, mode, label, kind, what, count, {}, float("nan"), float("nan"), "not in view"))
            continue
        ratio = float(late[area].mean() / clean[area].mean())
        means = {mask: float(values[area].mean()) for mask, values in maps.items()}
        diffuse = float(diffuse_late[area].mean() / diffuse_clean[area].mean())
        rows.append((name, mode, label, kind, what, count, means, diffuse, ratio, verdict(kind, ratio)))
        tints.append((kind, area))
    if areas_dir:
        write_areas(late_image, tints, os.path.join(areas_dir, f"{name}_{mode}{'_' + label if label else ''}.png"))
    return rows, sample


TINT = {
    "white": (0.2, 0.9, 1.0),
    "grey": (1.0, 0.8, 0.1),
    "black": (1.0, 0.1, 0.1),
    "wet": (0.2, 0.4, 1.0),
    "salted": (0.1, 1.0, 0.2),
    "bare": (1.0, 0.3, 0.9),
}


def write_areas(image, tints, path):
    import OpenImageIO as oiio

    rgb = np.clip(image[..., :3], 0.0, 1.0) ** (1 / 2.2)
    for kind, area in tints:
        rgb[area] = 0.5 * rgb[area] + 0.5 * np.array(TINT[kind])
    buf = oiio.ImageBuf(oiio.ImageSpec(rgb.shape[1], rgb.shape[0], 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), rgb.astype(np.float32))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    buf.write(path)


def table(rows):
    lines = [
        "| sample | mode | area | kind | pixels | masks (mean) | k_d, model | t = 1 / t = 0 | target | result |",
        "|---|---|---|---|---:|---|---:|---:|---|---|",
    ]
    for name, mode, label, kind, what, count, means, diffuse, ratio, result in rows:
        masks = ", ".join(f"{mask.replace('_map', '')} {value:.2f}" for mask, value in means.items())
        mode_text = f"{mode} ({label})" if label else mode
        cells = (name, mode_text, what, kind, count, masks, f"{diffuse:.2f}", f"{ratio:.2f}", target_text(kind), result)
        lines.append("| " + " | ".join(str(cell) for cell in cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_render_options(parser)
    parser.add_argument("--only", nargs="*", default=None, metavar="NAME", help="only these samples")
    parser.add_argument("--areas", metavar="DIR", help="write pictures of the areas to this folder")
    args = parser.parse_args(argv)
    started = time.time()
    rows = []
    with tempfile.TemporaryDirectory(prefix="pw_visible_") as work:
        for name, modes in AREAS.items():
            if args.only and name not in args.only:
                continue
            sample = None
            for mode in modes:
                if mode not in demo.RECIPES[name].masks:
                    continue
                runs = [({}, "")] + [
                    (inputs, label)
                    for sample_name, variant_mode, label, inputs in VARIANTS
                    if (sample_name, variant_mode) == (name, mode)
                ]
                for inputs, label in runs:
                    found, sample = measure(name, mode, args, work, inputs, label, args.areas, sample)
                    rows += found
                    print("\n".join(table(found).splitlines()[2:]), flush=True)  # progress
    print()
    print(table(rows))
    print(closing_line(args, started))
    compat.end_process(0)  # bpy 4.5 can hang at interpreter exit


if __name__ == "__main__":
    main()
