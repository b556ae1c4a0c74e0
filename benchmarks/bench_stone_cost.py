"""EEVEE's shader compile with and without the stone's structure (docs/benchmarks.md, "The stone's
cost"; docs/model.md §8): the weathered material of the three modes, then the same with a
preset's structure, then laid as ashlar.

Each material's first EEVEE render compiles its shader (EEVEE's own engine shaders are compiled
first, on a plain material); the later renders, interleaved in rounds, do not. Compile = first
render − the median of the later ones. On a software-GL machine the fixed cost of a render varies
by as much as a compile, so the table shows both numbers. Cycles' cost per sample is counted in
instructions by shading_instructions.py (the material "all three modes, key light, baked maps,
the limestone's structure").

    python benchmarks/bench_stone_cost.py [--size 64] [--samples 4] [--rounds 3] [--stone LIMESTONE]
"""

import argparse
import os
import pathlib
import statistics
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import porous_weathering as pw  # noqa: E402
from benchmarks import scenes, speed, timing  # noqa: E402
from porous_weathering.blender import render  # noqa: E402
from porous_weathering.core import model, stones  # noqa: E402
from porous_weathering.samples import studio  # noqa: E402


def materials(sun, stone):
    """label -> material: the same weathered material, uniform, with ``stone``'s structure, as ashlar."""
    state = {name: value for name, value in speed.WEATHERING.items() if name in model.inputs_of(model.MODES)}

    def weathered(label, **structure):
        return pw.make_weathered_material(
            label, modes=model.MODES, key_light=sun, **speed.stone(), **state, **structure
        )

    return {
        "all three modes, uniform": weathered("Uniform"),
        f"all three modes, the {stone.lower()}'s structure": weathered("Structured", stone=stone),
        f"all three modes, the {stone.lower()} as ashlar": weathered("Ashlar", stone=stone, masonry=stones.Ashlar()),
    }


def node_count(material):
    """Nodes the material's shader holds, its groups' nodes included (each group counted once)."""
    seen, count, trees = set(), 0, [material.node_tree]
    while trees:
        tree = trees.pop()
        count += len(tree.nodes)
        for node in tree.nodes:
            if node.type == "GROUP" and node.node_tree and node.node_tree.name not in seen:
                seen.add(node.node_tree.name)
                trees.append(node.node_tree)
    return count


def measure(size, samples, rounds, stone):
    """label -> (nodes, first render s, median later render s)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = scenes.build(scene, "SPHERE", (speed.SUN,))
    sun = next(o for o in scene.objects if o.type == "LIGHT")
    made = materials(sun, stone)
    render.use_eevee(scene, size=size, samples=samples)
    studio.assign(obj, pw.make_base_material("Warm-up"))
    timing.timed_render(scene)  # compiles EEVEE's engine shaders
    first = {}
    for label, material in made.items():
        studio.assign(obj, material)
        first[label] = timing.timed_render(scene)[0]
    times, _ = timing.interleaved_rounds(scene, obj, made, lambda *_: None, (samples,), rounds, warm_up=0)
    return {
        label: (node_count(material), first[label], statistics.median(times[label, samples]))
        for label, material in made.items()
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--samples", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--stone", default="LIMESTONE")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    measured = measure(args.size, args.samples, args.rounds, args.stone)
    rows = [
        [label, nodes, f"{first:.2f}", f"{later:.2f}", f"{first - later:.2f}"]
        for label, (nodes, first, later) in measured.items()
    ]
    header = ["material", "nodes (groups included)", "EEVEE first render s", "later renders s (median)", "compile s"]
    print(
        f"### EEVEE shader compile with the stone's structure (Blender {bpy.app.version_string}, {args.size} px "
        f"sphere, {args.samples} samples, {args.rounds} rounds; 1-min load {load:.1f} at the start, "
        f"{os.getloadavg()[0]:.1f} at the end)\n\n" + scenes.markdown_table(header, rows)
    )


if __name__ == "__main__":
    main()
