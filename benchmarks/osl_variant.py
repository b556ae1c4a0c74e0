"""The porous group as one OSL Script node (benchmarks/osl/porous.osl) against the
node-math group: agreement and Cycles CPU speed (docs/accuracy.md).  Not shipped: it does not win by
enough (SHIP_MARGIN; docs/accuracy.md, "OSL variant").

Agreement: renders of the lit sphere under one zero-angle sun (deterministic at one sample)
with the OSL shader and with the node group, key-light and ambient mode, as relative RMSE
and max over the covered pixels.  Speed: the cost of one sample (timing.py: two sample
counts, interleaved rounds, medians) of the OSL shader under the OSL shading system, against
the node group under SVM (Cycles' default) and under OSL.

The Script node is compiled without Blender's ``oslquery`` module (bundled inside the bpy
wheel, and tied to Blender's own OpenImageIO): Cycles' compiler makes the bytecode and its
parameters are read from the .oso text.

    python benchmarks/osl_variant.py [--size 128] [--rounds 7]
"""

import argparse
import hashlib
import os
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402

from benchmarks import reference as ref  # noqa: E402
from benchmarks import scenes, timing  # noqa: E402
from benchmarks.accuracy import MATERIALS, percent, sun_towards  # noqa: E402
from porous_weathering.blender import compat, render
from porous_weathering.samples import studio  # noqa: E402

OSL_SOURCE = ROOT / "benchmarks" / "osl" / "porous.osl"
#: .oso parameter types -> node socket types
SOCKET_TYPES = {
    "color": "NodeSocketColor",
    "float": "NodeSocketFloat",
    "vector": "NodeSocketVector",
    "int": "NodeSocketInt",
    "closure color": "NodeSocketShader",
}
SUN = ref.Sun(sun_towards(45.0), 3.0)
SAMPLES = (16, 64)


def compile_osl(path):
    """The .oso bytecode of the OSL source at ``path`` (Cycles' own compiler)."""
    from cycles import osl

    ok, oso_path = osl.osl_compile(str(path), lambda kind, message: None)
    try:
        if not ok:
            raise RuntimeError(f"OSL compilation of {path} failed (see the console)")
        return pathlib.Path(oso_path).read_text()
    finally:
        if os.path.exists(oso_path):
            os.remove(oso_path)


def parameters(bytecode):
    """[(is_output, type, name)] of a shader's parameters, read from its .oso text."""
    found = []
    for line in bytecode.splitlines():
        fields = line.split("\t")
        if fields[0] in ("param", "oparam"):
            found.append((fields[0] == "oparam", fields[1], fields[2]))
    return found


def script_node(tree, bytecode):
    """A Script node running ``bytecode``, with one socket per shader parameter.  It holds no
    Text: assigning one makes Cycles recompile it through ``oslquery``, which fails here."""
    node = tree.nodes.new("ShaderNodeScript")
    node.mode = "INTERNAL"
    node.bytecode = bytecode
    node.bytecode_hash = hashlib.md5(bytecode.encode(), usedforsecurity=False).hexdigest()
    for is_output, kind, name in parameters(bytecode):
        sockets = node.outputs if is_output else node.inputs
        sockets.new(type=SOCKET_TYPES[kind], name=name, identifier=name)
    return node


def osl_material(name, params, light_direction=None):
    """The porous material as one Script node (light_direction None: ambient mode)."""
    material = compat.new_material(name)
    tree = material.node_tree
    tree.nodes.clear()
    node = script_node(tree, compile_osl(OSL_SOURCE))
    values = {
        "BaseColor": (*params["kd"], 1.0),
        "Specular": params["ks"],
        "Roughness": params["m"],
        "Porosity": params["alpha"],
        "PoreDepthRatio": params["sp"],
        "Ambient": int(light_direction is None),
    }
    if light_direction is not None:
        values["LightDirection"] = light_direction
    for socket_name, value in values.items():
        node.inputs[socket_name].default_value = value
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(node.outputs["BSDF"], output.inputs["Surface"])
    return material


def sun_scene(surface, size, samples):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = scenes.build(scene, surface, (SUN,))
    render.use_cycles(scene, size=size, samples=samples)
    return scene, obj


def set_osl(scene, on):
    scene.cycles.shading_system = on


def agreement(size=64):
    """Rows: material, light mode, RMSE and max of the OSL render against the node group's."""
    rows = []
    scene, obj = sun_scene("SPHERE", size, 1)
    sun = next(o for o in scene.objects if o.type == "LIGHT")
    for name, params in MATERIALS.items():
        for mode, key, direction in (("key", sun, SUN.towards), ("ambient", None, None)):
            set_osl(scene, False)
            studio.assign(obj, scenes.porous_material(params, key, name="Nodes"))
            nodes_image = render.render_array(scene)
            set_osl(scene, True)
            studio.assign(obj, osl_material("OSL", params, direction))
            osl_image = render.render_array(scene)
            mask = (nodes_image[..., 3] > 0.999) & (osl_image[..., 3] > 0.999)
            rmse, worst = ref.errors(osl_image, nodes_image[..., :3], mask)
            rows.append([name, mode, percent(rmse), percent(worst)])
    return rows


def speed(size, rounds):
    """variant -> timing.costs() entry: fixed seconds, ms per sample, per-sample ratio to nodes (SVM).

    The surface is a plane that fills most of the frame: one ray and one shadow ray per
    sample and no BVH to speak of, so shading is as large a share of a sample as it gets.
    """
    scene, obj = sun_scene("PLANE", size, SAMPLES[0])
    sun = next(o for o in scene.objects if o.type == "LIGHT")
    params = MATERIALS["diffuse"]
    variants = {
        "node group, SVM": (scenes.porous_material(params, sun, name="Nodes"), False),
        "node group, OSL": (scenes.porous_material(params, sun, name="Nodes OSL"), True),
        "OSL script": (osl_material("OSL", params, SUN.towards), True),
    }
    materials = {name: material for name, (material, _) in variants.items()}
    osl_of = {id(material): osl for material, osl in variants.values()}

    def configure(scene_, samples):  # the shading system is a scene setting: follow the material
        scene_.cycles.samples = samples
        set_osl(scene_, osl_of[id(obj.active_material)])

    times, _ = timing.interleaved_rounds(scene, obj, materials, configure, SAMPLES, rounds)
    return timing.costs(times, materials, SAMPLES, "node group, SVM")


#: Shipping the OSL variant would tie a material to the OSL shading system (CPU only, and the
#: rest of the scene's node shaders then run as OSL too): worth it only for a clear win, at
#: least this much less per sample in every round.  (Set after the first runs of the day
#: measured the script at 0.94x and 0.98x, with the node group itself drifting by 5-8%.)
SHIP_MARGIN = 0.10


def verdict(costs):
    """Whether the OSL script wins clearly enough to ship, with the numbers that decide it."""
    script, nodes_osl = costs["OSL script"], costs["node group, OSL"]
    low, high = script["ratio range"]
    numbers = (
        f"the OSL script costs {script['ratio']:.2f}× the node group (SVM) per sample (median; rounds "
        f"{low:.2f}–{high:.2f}), and switching the scene to OSL makes the node group itself "
        f"{nodes_osl['ratio']:.2f}×"
    )
    if high <= 1.0 - SHIP_MARGIN:
        return f"The OSL script wins by more than {SHIP_MARGIN:.0%} in every round: {numbers}."
    return (
        f"Not shipped: {numbers}; a win must be over {SHIP_MARGIN:.0%} in every round to be worth tying a "
        f"material to the OSL shading system (CPU only). The shader stays in benchmarks/osl/porous.osl."
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    agree = scenes.markdown_table(["material", "light mode", "RMSE", "max"], agreement())
    costs = speed(args.size, args.rounds)
    fast = scenes.markdown_table(
        ["variant", "fixed s / render", "ms / sample", "× node group (SVM), range"],
        [
            [name, f"{cost['fixed s']:.2f}", f"{cost['ms/sample']:.1f}", timing.ratio_cell(cost)]
            for name, cost in costs.items()
        ],
    )
    print(
        f"### OSL variant of the porous group (Cycles CPU)\n\nAgreement: OSL script against the node group, "
        f"lit sphere, one sun at 45°, 64 px, one sample (relative to the node render's RMS):\n\n{agree}\n\n"
        f"Speed: {args.size} px plane under the sun, diffuse stone; cost of one sample from {SAMPLES[0]} and "
        f"{SAMPLES[1]} samples, median of {args.rounds} interleaved rounds (range of the per-round ratios):\n\n"
        f"{fast}\n\n{verdict(costs)}"
    )


if __name__ == "__main__":
    main()
