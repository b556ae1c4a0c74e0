"""EEVEE's shader compile with and without the stone's structure (docs/benchmarks.md, "The stone's
cost"; docs/model.md §8): the weathered material of the three modes, then the same with a
preset's structure, then laid as ashlar.

Each material is measured in a child process of its own, so that each first render finds EEVEE
in the same state: its engine shaders compiled on a plain material, no other material of the
table compiled yet (rendered one after another in one process, the first material's first render
also paid for what the others then shared). The first render of the material compiles its
shader; the later ones do not. Compile = first render − the median of the later ones. On a
software-GL machine the fixed cost of a render varies by as much as a compile, so the table shows
both numbers. Cycles' cost per sample is counted in instructions by shading_instructions.py (the
material "all three modes, key light, baked maps, the limestone's structure").

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
from benchmarks import apart, scenes, speed, timing  # noqa: E402
from porous_weathering.blender import render  # noqa: E402
from porous_weathering.core import model, stones  # noqa: E402
from porous_weathering.samples import studio  # noqa: E402


def structures(stone):
    """label -> the structure keywords of each material: uniform, with ``stone``'s structure, as ashlar."""
    return {
        "all three modes, uniform": {},
        f"all three modes, the {stone.lower()}'s structure": dict(stone=stone),
        f"all three modes, the {stone.lower()} as ashlar": dict(stone=stone, masonry=stones.Ashlar()),
    }


def material(label, sun, stone):
    """The weathered material of the three modes under the key light ``sun``, with ``label``'s structure."""
    state = {name: value for name, value in speed.WEATHERING.items() if name in model.inputs_of(model.MODES)}
    return pw.make_weathered_material(
        label, modes=model.MODES, key_light=sun, **speed.stone(), **state, **structures(stone)[label]
    )


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


def measure(label, size, samples, rounds, stone):
    """(nodes, first render s, median later render s) of the material ``label``, alone in this process."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = scenes.build(scene, "SPHERE", (speed.SUN,))
    sun = next(o for o in scene.objects if o.type == "LIGHT")
    made = material(label, sun, stone)
    render.use_eevee(scene, size=size, samples=samples)
    studio.assign(obj, pw.make_base_material("Warm-up"))
    timing.timed_render(scene)  # compiles EEVEE's engine shaders
    studio.assign(obj, made)
    first = timing.timed_render(scene)[0]
    later = [timing.timed_render(scene)[0] for _ in range(rounds)]
    return node_count(made), first, statistics.median(later)


def measure_apart(label):
    """``measure`` of ``label`` in a child process (this script, its options and --child)."""
    done = apart.run(__file__, [*sys.argv[1:], "--child", label])
    if done.result is None:
        raise RuntimeError(f"measuring {label!r} failed: {done.errors}")
    return done.result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--samples", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--stone", default="LIMESTONE")
    parser.add_argument("--child", help=argparse.SUPPRESS)  # measure this material alone, print its JSON
    args = parser.parse_args()
    if args.child:
        apart.report(measure(args.child, args.size, args.samples, args.rounds, args.stone))
        return
    load = os.getloadavg()[0]
    measured = {label: measure_apart(label) for label in structures(args.stone)}
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
