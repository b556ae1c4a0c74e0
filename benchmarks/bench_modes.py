"""Shader cost per weathering mode against the porous-only material (the paper's table 2:
83 / 138 / 120 / 101 pixel-shader instructions for porosity / soiling / wet / efflorescence).

Cost proxies: the nodes of each material's group (all of them, and the maths nodes alone);
EEVEE's first render of each material, which compiles its shader (EEVEE's own engine shaders
are compiled first, on a plain material), against the median of its later renders; and that
median render time, from interleaved rounds, with the per-round ratio to porous-only.  On a
software-GL machine the fixed cost of an EEVEE render (seconds, varying by as much) can hide
the compile: the table shows both numbers rather than a difference that may be negative.

    python benchmarks/bench_modes.py [--size 64] [--samples 4] [--rounds 3]
"""

import argparse
import pathlib
import statistics
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import porous_weathering as pw  # noqa: E402
from benchmarks import scenes, speed, timing  # noqa: E402
from porous_weathering.blender import render
from porous_weathering.core import model
from porous_weathering.core import modes as modes_registry  # noqa: E402
from porous_weathering.samples import studio  # noqa: E402
from porous_weathering.shading import nodes

#: label -> modes, and the paper's instruction count
MODE_SETS = {
    "porosity": ((), 83),
    "soiling": ((model.SOILING,), 138),
    "wet": ((model.WET,), 120),
    "efflorescence": ((model.EFFLORESCENCE,), 101),
    "all three": (model.MODES, None),
}
#: Node types that compute (Mix: the blends since build 5; Map Range: the smoothstep fronts).
MATHS = {"MATH", "VECT_MATH", "GAMMA", "MIX", "MAP_RANGE"}


def node_counts(modes, light_mode):
    """(all nodes, maths nodes, live maths nodes with constant masks, live with baked maps) of
    a group: live nodes are those Cycles evaluates at every shaded point (live_nodes)."""
    group = nodes.weathered_group(modes, light_mode)
    maths = [node for node in group.nodes if node.type in MATHS]
    live = [sum(node in live_nodes(group, maps) for node in maths) for maps in (False, True)]
    return len(group.nodes), len(maths), *live


def live_nodes(group, maps):
    """The nodes of ``group`` downstream of the Geometry node and, with ``maps``, of a mask
    input (a baked map changes from point to point): Cycles folds every other node, whose
    inputs are the material's constants, before rendering (Blender 5.2 folds Map Range nodes
    too: benchmarks.md)."""
    masks = {item.socket for item in modes_registry.inputs().values() if item.mask} if maps else set()
    live = set()
    frontier = [node for node in group.nodes if node.bl_idname == "ShaderNodeNewGeometry"]
    frontier += [link.to_node for link in group.links if link.from_socket.name in masks]  # only group inputs
    while frontier:
        node = frontier.pop()
        if node not in live:
            live.add(node)
            frontier += [link.to_node for link in group.links if link.from_node == node]
    return live


def measure(size, samples, rounds):
    """label -> (first render seconds, median later render seconds, per-round ratios to porosity)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = scenes.build(scene, "SPHERE", (speed.SUN,))
    sun = next(o for o in scene.objects if o.type == "LIGHT")
    materials = {
        label: speed.weathered(modes, sun) if modes else pw.make_porous_material(label, **speed.stone(), key_light=sun)
        for label, (modes, _) in MODE_SETS.items()
    }
    render.use_eevee(scene, size=size, samples=samples)
    studio.assign(obj, pw.make_base_material("Warm-up"))
    timing.timed_render(scene)  # compiles EEVEE's engine shaders
    first = {}
    for label, material in materials.items():
        studio.assign(obj, material)
        first[label] = timing.timed_render(scene)[0]
    times, _ = timing.interleaved_rounds(scene, obj, materials, lambda *_: None, (samples,), rounds, warm_up=0)
    steady = {label: statistics.median(times[label, samples]) for label in materials}
    ratios = {
        label: [t / base for t, base in zip(times[label, samples], times["porosity", samples])] for label in materials
    }
    return {label: (first[label], steady[label], ratios[label]) for label in materials}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--samples", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    measured = measure(args.size, args.samples, args.rounds)
    rows = []
    for label, (modes, paper) in MODE_SETS.items():
        total, maths, live, live_maps = node_counts(modes, nodes.SUN)
        ambient_total, _, ambient_live, ambient_live_maps = node_counts(modes, nodes.AMBIENT)
        first_seconds, render_seconds, ratios = measured[label]
        rows.append(
            [
                label,
                paper or "—",
                f"{paper / 83:.2f}" if paper else "—",
                total,
                ambient_total,
                maths,
                f"{live} / {ambient_live}",
                f"{live_maps} / {ambient_live_maps}",
                f"{live_maps / node_counts((), nodes.SUN)[3]:.2f}",
                f"{first_seconds:.2f}",
                f"{render_seconds:.2f}",
                f"{statistics.median(ratios):.2f} ({min(ratios):.2f}–{max(ratios):.2f})",
            ]
        )
    header = [
        "material",
        "paper instr.",
        "paper × porosity",
        "nodes (sun)",
        "nodes (ambient)",
        "maths nodes (sun)",
        "live maths nodes, constant masks (sun / ambient)",
        "live maths nodes, baked maps (sun / ambient)",
        "live × porosity (baked maps)",
        "EEVEE first render s",
        "EEVEE later renders s",
        "render × porosity (range)",
    ]
    print(
        f"### Shader cost per weathering mode (EEVEE, Blender {bpy.app.version_string}, {args.size} px sphere, "
        f"{args.samples} samples)\n\nFirst render = shader compile + render; later renders = median of "
        f"{args.rounds} interleaved rounds; ratios per round, median and range.\n\n"
        + scenes.markdown_table(header, rows)
    )


if __name__ == "__main__":
    main()
