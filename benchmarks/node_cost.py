"""Where the porous material's Cycles overhead goes: the cost of one sample of Diffuse + Glossy
with N extra maths nodes evaluated at run time, against the porous groups
(docs/accuracy.md, "What a maths node costs in Cycles").

The extra nodes are a chain that starts from the shading normal (so Cycles cannot fold it to
a constant) and ends in the diffuse colour, changing it by less than 1e-6.  Same scene and
timing method as the OSL benchmark: a plane under a sun, where shading is as large a share
of a sample as it gets.

    python benchmarks/node_cost.py [--size 128] [--rounds 5]
"""

import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import porous_weathering as pw  # noqa: E402
from benchmarks import osl_variant, scenes, speed, timing  # noqa: E402
from porous_weathering.core.shader_math import Graph, dot  # noqa: E402

CHAINS = (15, 30, 60)
SAMPLES = (16, 64)
BASELINE = "Diffuse+Glossy"


def with_maths_nodes(count):
    """Diffuse + Glossy whose diffuse colour goes through ``count`` live maths nodes."""
    material = pw.make_base_material(f"Diffuse+Glossy+{count}", **speed.stone(False))
    tree = material.node_tree
    graph = Graph(tree)
    normal = graph.wrap(graph.node("ShaderNodeNewGeometry", depth=0).outputs["Normal"])
    value = dot(normal, (1e-9, 1e-9, 1e-9))  # one node
    for step in range(count - 2):  # one node each
        value = value * 0.999 if step % 2 else value + 1e-9
    red, green, blue = speed.PARAMS["kd"]
    colour = graph.node("ShaderNodeCombineXYZ", {"X": value + red, "Y": green, "Z": blue})  # the last maths node
    diffuse = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeBsdfDiffuse")
    tree.links.new(colour.outputs[0], diffuse.inputs["Color"])
    return material


def measure(size, rounds):
    scene, obj = osl_variant.sun_scene("PLANE", size, SAMPLES[0])
    sun = next(o for o in scene.objects if o.type == "LIGHT")
    materials = {
        BASELINE: pw.make_base_material("Base", **speed.stone(False)),
        **{f"Diffuse+Glossy + {count} maths nodes": with_maths_nodes(count) for count in CHAINS},
        "porous key light": pw.make_porous_material("Key", **speed.stone(), key_light=sun),
        "porous ambient": pw.make_porous_material("Ambient", **speed.stone()),
    }

    def configure(scene_, samples):
        scene_.cycles.samples = samples

    times, _ = timing.interleaved_rounds(scene, obj, materials, configure, SAMPLES, rounds)
    return [
        [name, f"{cost['ms/sample']:.1f}", timing.ratio_cell(cost)]
        for name, cost in timing.costs(times, materials, SAMPLES, BASELINE).items()
    ]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    table = scenes.markdown_table(
        ["material", "ms / sample", "× Diffuse+Glossy per sample (range)"], measure(args.size, args.rounds)
    )
    print(
        f"### What a maths node costs in Cycles ({args.size} px plane under a sun, {SAMPLES} samples, median of "
        f"{args.rounds} interleaved rounds)\n\nThe porous group evaluates its maths nodes for every sample that "
        f"shades a point; nodes whose inputs are all constants are folded away by Cycles before rendering.\n\n" + table
    )


if __name__ == "__main__":
    main()
