"""Shading-dominated Cycles speed: the cost of one sample of the porous and weathered materials
against Diffuse + Glossy, on a sphere that fills the frame (docs/benchmarks.md, "Where shading dominates").

The sphere of speed.py (same stone, same sun at 45° and overcast sky) seen by an orthographic
camera whose frame is the sphere's diameter, so its silhouette touches the four edges and
covers π/4 of the pixels; Cycles CPU, 2 bounces (every bounce off the sphere shades it again),
fixed seed, no denoising, no adaptive sampling.  The cost of one sample is the slope of the
wall time of ``bpy.ops.render.render`` between two sample counts (the fixed per-render cost
drops out), and the same slope of this process's CPU time, which counts Cycles' render
threads.  Rounds are interleaved as in timing.py, materials in a rotating order (round r
starts at the r-th), after one warm-up round that is not kept.

    python benchmarks/shading.py [--rounds 5] [--size 160] [--threads N] [--quick] [--out FILE]
"""

import argparse
import os
import pathlib
import statistics
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import numpy as np  # noqa: E402

import porous_weathering as pw  # noqa: E402
from benchmarks import machine, scenes, speed, timing  # noqa: E402
from porous_weathering.blender import mesh_arrays, render
from porous_weathering.core import backends, model, porous
from porous_weathering.core import modes as weathering_modes
from porous_weathering.samples import studio  # noqa: E402

SAMPLES = (8, 40)
BOUNCES = 2
#: Orthographic frame width in sphere radii: the unit sphere's diameter.
FRAME = 2.0
#: Blender's default pixel filter (render.use_cycles' default samples pixel centres only).
PIXEL_FILTER = 1.5
BASELINE = "Diffuse+Glossy"
#: The sphere's colour attribute that stands for baked maps: a mask that changes from point to
#: point, as every map a user bakes does (a constant mask lets Cycles fold part of the maths).
MAP_ATTRIBUTE = "pw_bench_map"
#: Its range: the mask runs across the sphere from MAP_RANGE[0] at the bottom to [1] at the top.
MAP_RANGE = (0.2, 0.8)


def weathered(modes, key_light, maps=(), stone=None):
    """The material of ``modes``; ``maps``: the mask inputs read from MAP_ATTRIBUTE (BAKED_MAPS,
    EVERY_MAP); ``stone``: a preset key whose structure the material takes (docs/model.md §8)."""
    masks = {name: MAP_ATTRIBUTE for name in maps}
    state = {name: value for name, value in {**speed.WEATHERING, **masks}.items() if name in model.inputs_of(modes)}
    name = "+".join(modes) + (f" {stone}" if stone else "")
    return pw.make_weathered_material(name, modes=modes, key_light=key_light, stone=stone, **speed.stone(), **state)


def add_map_attribute(obj):
    """MAP_ATTRIBUTE on ``obj``'s mesh: a point colour rising linearly with height over MAP_RANGE."""
    mesh = obj.data
    heights = np.array([vertex.co.z for vertex in mesh.vertices])
    span = heights.max() - heights.min()
    values = MAP_RANGE[0] + (MAP_RANGE[1] - MAP_RANGE[0]) * (heights - heights.min()) / span
    attribute = mesh.color_attributes.new(MAP_ATTRIBUTE, "FLOAT_COLOR", "POINT")
    attribute.data.foreach_set("color", mesh_arrays.grey_rgba(values))


#: The lookup texture measured against the node maths (docs/benchmarks.md): its side in texels
#: (linear filter, extended edges).
LOOKUP_SIZE = 64
#: Math nodes chained behind a Map Range of constants in folded_chain_material().
FOLDED_CHAIN = 20
FOLDED = f"Diffuse+Glossy, {FOLDED_CHAIN} Math nodes behind a Map Range of constants"
#: The weathered material with a stone's structure (docs/model.md §8), against the same without it.
STRUCTURED_STONE = "LIMESTONE"
UNSTRUCTURED = "all three modes, key light, baked maps"
STRUCTURED = f"{UNSTRUCTURED}, the {STRUCTURED_STONE.lower()}'s structure"
#: The masks "baked maps" reads from MAP_ATTRIBUTE (the rest keep their defaults: no run-off, damp
#: or shade, which Cycles folds), and every mask the modes have (the run-off map brings the
#: rivulets, docs/model.md §8.8).
BAKED_MAPS = ("rain_map", "edge_map", "efflorescence_map")
EVERY_MAP = tuple(item.name for item in weathering_modes.inputs_of(model.MODES) if item.mask)
ON_EVERY_MAP = "all modes, key light, every map"
STRUCTURED_ON_EVERY_MAP = f"{ON_EVERY_MAP}, the {STRUCTURED_STONE.lower()}'s structure"
#: Materials shading_instructions.py can count but the timings leave out: designs measured, not
#: shipped, a check of what Cycles folds, and the weathered material on every map.
EXPERIMENTS = ("porous key light, lookup texture", FOLDED, ON_EVERY_MAP, STRUCTURED_ON_EVERY_MAP)
#: (without, with) the stone's structure: what it adds per sample (docs/benchmarks.md, "The
#: structure's cost per sample, timed").
STRUCTURE_PAIRS = ((UNSTRUCTURED, STRUCTURED), (ON_EVERY_MAP, STRUCTURED_ON_EVERY_MAP))


def folded_chain_material():
    """Diffuse + Glossy whose glossy roughness comes out of a Map Range of constants and
    FOLDED_CHAIN Math nodes: it costs what Diffuse + Glossy costs where Cycles folds a Map Range
    (docs/weathering.md: Blender 5.2 does, so a mask left at a constant costs nothing per point)."""
    material = pw.make_base_material("Folded", **speed.stone(False))
    tree = material.node_tree
    glossy = next(node for node in tree.nodes if node.type == "BSDF_GLOSSY")
    ramp = tree.nodes.new("ShaderNodeMapRange")  # 0.5 in [0, 1] -> the roughness
    ramp.inputs["Value"].default_value = 0.5
    ramp.inputs["To Max"].default_value = 2.0 * glossy.inputs["Roughness"].default_value
    value = ramp.outputs[0]
    for step in range(FOLDED_CHAIN):
        add = tree.nodes.new("ShaderNodeMath")  # +/- 0.001 in turn: no step is an identity to skip
        tree.links.new(value, add.inputs[0])
        add.inputs[1].default_value = 0.001 if step % 2 == 0 else -0.001
        value = add.outputs[0]
    tree.links.new(value, glossy.inputs["Roughness"])
    return material


def lookup_texture_material(sun):
    """The porous key-light material with alpha G_p and n_b + 1 read from a LOOKUP_SIZE² float
    image at (N.S, N.V) instead of computed per point (docs/benchmarks.md: 1.128x Diffuse+Glossy
    down to 1.105x in instructions, not to 1.05x, and only for the m, alpha and s_p it was made for)."""
    stone = speed.stone()
    material = pw.make_porous_material("Lookup", **stone, key_light=sun)
    group_node = material.node_tree.nodes["Porous"]
    group = group_node.node_tree = group_node.node_tree.copy()
    cosine = (np.arange(LOOKUP_SIZE) + 0.5) / LOOKUP_SIZE
    n_dot_l, n_dot_v = np.meshgrid(cosine, cosine)  # columns: N.S, rows: N.V
    xp = backends.numpy_ops(0.0)
    gp, theta_i, theta_r = porous.pore_geometry(xp, stone["roughness"], n_dot_l, n_dot_v)
    texels = np.ones((LOOKUP_SIZE, LOOKUP_SIZE, 4), np.float32)
    texels[..., 0] = stone["porosity"] * gp
    texels[..., 1] = porous.bounce_count(xp, stone["pore_depth_ratio"], theta_i, theta_r, plus=1.0)
    image = bpy.data.images.new("Lookup", LOOKUP_SIZE, LOOKUP_SIZE, alpha=True, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set(texels.ravel())
    image.pack()
    by_type = {}
    for node in group.nodes:
        by_type.setdefault(getattr(node, "operation", node.type), []).append(node)

    def sources(node):
        return [link.from_node for socket in node.inputs for link in socket.links]

    def reads_incoming(node):
        return any(link.from_socket.name == "Incoming" for socket in node.inputs for link in socket.links)

    # the clamped cosines max(N.S, 0) and max(N.V, 0): the maxima of a dot product; N.V's reads Incoming
    clamps = {
        reads_incoming(dot): node
        for node in by_type["MAXIMUM"]
        for dot in sources(node)
        if getattr(dot, "operation", "") == "DOT_PRODUCT"
    }
    cosines = group.nodes.new("ShaderNodeCombineXYZ")
    group.links.new(clamps[False].outputs[0], cosines.inputs[0])
    group.links.new(clamps[True].outputs[0], cosines.inputs[1])
    lookup = group.nodes.new("ShaderNodeTexImage")
    lookup.image, lookup.interpolation, lookup.extension = image, "Linear", "EXTEND"
    group.links.new(cosines.outputs[0], lookup.inputs["Vector"])
    channels = group.nodes.new("ShaderNodeSeparateColor")
    group.links.new(lookup.outputs["Color"], channels.inputs[0])
    mix, gamma = by_type["MIX"][0], by_type["GAMMA"][0]
    # red replaces alpha G_p (the Mix's factor), green n_b + 1 (the colour power's exponent)
    computed = (mix.inputs[0].links[0].from_socket, gamma.inputs["Gamma"].links[0].from_socket)
    for socket, channel in zip(computed, channels.outputs[:2]):
        for link in list(socket.links):
            group.links.new(channel, link.to_socket)
    return material


def material_makers(sun):
    """name -> a function that makes the material (shading_instructions.py makes one only)."""
    return {
        BASELINE: lambda: pw.make_base_material("Base", **speed.stone(False)),
        "porous key light": lambda: pw.make_porous_material("Key", **speed.stone(), key_light=sun),
        "porous ambient": lambda: pw.make_porous_material("Ambient", **speed.stone()),
        "porous key light, lookup texture": lambda: lookup_texture_material(sun),
        FOLDED: folded_chain_material,
        "all three modes, key light": lambda: weathered(model.MODES, sun),
        "all three modes, ambient": lambda: weathered(model.MODES, None),
        UNSTRUCTURED: lambda: weathered(model.MODES, sun, BAKED_MAPS),
        STRUCTURED: lambda: weathered(model.MODES, sun, BAKED_MAPS, stone=STRUCTURED_STONE),
        ON_EVERY_MAP: lambda: weathered(model.MODES, sun, EVERY_MAP),
        STRUCTURED_ON_EVERY_MAP: lambda: weathered(model.MODES, sun, EVERY_MAP, stone=STRUCTURED_STONE),
        **{f"{mode}, key light": (lambda mode=mode: weathered((mode,), sun)) for mode in model.MODES},
    }


def materials(sun, names=None):
    """name -> material: ``names`` (the baseline always with them), else every one but EXPERIMENTS."""
    makers = material_makers(sun)
    if names:
        chosen = [BASELINE, *(name for name in names if name != BASELINE)]
    else:
        chosen = [name for name in makers if name not in EXPERIMENTS]
    return {name: makers[name]() for name in chosen}


def scene_filling_the_frame(size, threads=0):
    """(scene, sphere, sun, fraction of the pixels the sphere covers); ``threads`` render
    threads (0: one per core)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = scenes.build(scene, "SPHERE", (speed.SUN,), speed.SKY)
    add_map_attribute(obj)
    scene.camera.data.ortho_scale = FRAME
    render.use_cycles(scene, size=size, samples=1, bounces=BOUNCES, pixel_filter=PIXEL_FILTER)
    if threads:
        scene.render.threads_mode, scene.render.threads = "FIXED", threads
    coverage = float((render.render_array(scene)[..., 3] > 0.5).mean())
    return scene, obj, next(o for o in scene.objects if o.type == "LIGHT"), coverage


def rotating_rounds(scene, obj, candidates, rounds):
    """({(name, samples): [wall s]}, the same for CPU s, [1-min load average after each round])."""
    names = list(candidates)
    wall = {(name, samples): [] for name in names for samples in SAMPLES}
    cpu = {key: [] for key in wall}
    loads = []
    for round_ in range(1 + rounds):  # round 0 warms up (kernels, caches) and is not kept
        start = round_ % len(names)
        for name in names[start:] + names[:start]:
            studio.assign(obj, candidates[name])
            for samples in SAMPLES:
                scene.cycles.samples = samples
                seconds = timing.wall_and_cpu_seconds(lambda: bpy.ops.render.render(scene=scene.name))
                if round_:
                    wall[name, samples].append(seconds[0])
                    cpu[name, samples].append(seconds[1])
        if round_:
            loads.append(os.getloadavg()[0])
    return wall, cpu, loads


def slope_cell(times, name):
    """Median ms per sample and the spread of the per-round slopes (min..max relative to it)."""
    low, high = SAMPLES
    slopes = [(t_high - t_low) / (high - low) for t_low, t_high in zip(times[name, low], times[name, high])]
    median = statistics.median(slopes)
    if median <= 0:  # the fixed cost's noise swamped the samples: no spread to speak of
        return f"{1000 * median:.1f} (—)"
    return f"{1000 * median:.1f} ({min(slopes) / median - 1:+.0%}..{max(slopes) / median - 1:+.0%})"


def best_slope(times, name):
    """The slope between the fastest render at each sample count: a shared machine only ever
    slows a render down, so the best of the rounds is the estimate the other jobs disturb least
    (as timeit reports its minimum)."""
    low, high = SAMPLES
    return (min(times[name, high]) - min(times[name, low])) / (high - low)


def best_ratio(times, name):
    """``best_slope`` against the baseline's."""
    return f"{best_slope(times, name) / best_slope(times, BASELINE):.3f}"


def busy_threads(wall, cpu):
    """Median CPU seconds per wall second over the high-sample renders: about the core count
    when the render threads are counted and have the machine to themselves."""
    return statistics.median(c / w for key in wall if key[1] == SAMPLES[-1] for w, c in zip(wall[key], cpu[key]))


def structure_lines(wall, cpu):
    """What the stone's structure adds per sample, for each pair of STRUCTURE_PAIRS timed: the
    per-round ratio of the two materials' slopes (median, range), wall and CPU, and the CPU's best
    of rounds."""
    lines = []
    for without, structured in STRUCTURE_PAIRS:
        if (structured, SAMPLES[0]) not in wall or (without, SAMPLES[0]) not in wall:
            continue
        by_wall, by_cpu = (timing.costs(times, [structured], SAMPLES, without)[structured] for times in (wall, cpu))
        best = best_slope(cpu, structured) / best_slope(cpu, without)
        lines.append(
            f'- **The {STRUCTURED_STONE.lower()}\'s structure** on "{without}": × {timing.ratio_cell(by_wall)} '
            f"wall, × {timing.ratio_cell(by_cpu)} CPU, × {best:.3f} CPU best of rounds (per-round ratios of the "
            f"two materials' costs of one sample)."
        )
    return "\n\n" + "\n".join(lines) if lines else ""


def report(size, rounds, threads=0, names=None):
    load_start = os.getloadavg()
    where = machine.describe(bpy.app.version_string)
    scene, obj, sun, coverage = scene_filling_the_frame(size, threads)
    candidates = materials(sun, names)
    wall, cpu, loads = rotating_rounds(scene, obj, candidates, rounds)
    load_end = os.getloadavg()
    by_wall, by_cpu = (timing.costs(times, candidates, SAMPLES, BASELINE) for times in (wall, cpu))
    rows = [
        [
            name,
            f"{by_wall[name]['fixed s']:.2f}",
            slope_cell(wall, name),
            timing.ratio_cell(by_wall[name]),
            slope_cell(cpu, name),
            timing.ratio_cell(by_cpu[name]),
            best_ratio(cpu, name),
        ]
        for name in candidates
    ]
    header = [
        "material",
        "fixed s / render",
        "wall ms / sample (spread)",
        "× Diffuse+Glossy, wall (range)",
        "CPU ms / sample (spread)",
        "× Diffuse+Glossy, CPU (range)",
        "× Diffuse+Glossy, CPU, best of rounds",
    ]
    state = ", ".join(f"{name} {value:.2f}" for name, value in speed.fills().items())

    def loadavg(values):
        return " / ".join(f"{value:.2f}" for value in values)

    return (
        f"### Shading cost per sample (Cycles CPU, {size} px sphere filling the frame, sun 45° + overcast sky, "
        f"{BOUNCES} bounces)\n\n{where}.\n\n"
        f"The sphere covers {coverage:.0%} of the pixels. Cost of one sample = slope of the render time between "
        f"{SAMPLES[0]} and {SAMPLES[1]} samples; fixed = the rest of a render (wall). Median of {rounds} "
        f"interleaved rounds, materials in rotating order; the spread is that of the per-round slopes "
        f"(min..max relative to the median), the range that of the per-round ratios; best of rounds = the slope "
        f"between the fastest render at each sample count (the estimate other jobs disturb least). "
        f"CPU = this process's CPU time, render threads included (median {busy_threads(wall, cpu):.2f} CPU s "
        f"per wall s while rendering {SAMPLES[1]} samples with {threads or os.cpu_count()} render threads on "
        f"{os.cpu_count()} cores). "
        f"Weathered materials: masks as constants, "
        f"{', '.join(f'{k} {v}' for k, v in speed.WEATHERING.items())} (by the model: {state}); "
        f"with baked maps, every mask from a colour attribute rising with height from {MAP_RANGE[0]} to "
        f"{MAP_RANGE[1]}.\n\n"
        + scenes.markdown_table(header, rows)
        + structure_lines(wall, cpu)
        + f"\n\nLoad average (1 / 5 / 15 min): {loadavg(load_start)} at the start, {loadavg(load_end)} at the end; "
        f"1-min after each round: {loadavg(loads)} (this benchmark's own render threads add up to "
        f"{threads or os.cpu_count()}: above that, other jobs shared the cores)."
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--size", type=int, default=160)
    parser.add_argument(
        "--threads",
        type=int,
        default=0,
        help="render threads (default: one per core); 1 leaves a core to the rest of a shared machine",
    )
    parser.add_argument("--quick", action="store_true", help="2 rounds: a smoke check, not a measurement")
    parser.add_argument(
        "--materials",
        nargs="+",
        choices=list(material_makers(None)),
        metavar="NAME",
        help="time these (and the baseline) only; EXPERIMENTS may be named too",
    )
    parser.add_argument("--out", type=pathlib.Path, help="write the markdown here instead of printing it")
    args = parser.parse_args()
    speed.check_fills(parser)
    scenes.print_or_write(report(args.size, 2 if args.quick else args.rounds, args.threads, args.materials), args.out)


if __name__ == "__main__":
    main()
