"""Numerical stability of the porous and weathered node groups on the hard cases
(docs/accuracy.md, "Numerical stability").

Every input of a group takes values from its list of hard cases (grazing angles, m -> 0 and
large, k_a -> 0 and 1, s_p -> 0 and large, alpha -> 0 and 1, masks and t at and beyond their
bounds); a fixed-seed draw of combinations is evaluated by the numpy model (float64) and by
the shipped node group in one Cycles render (float32 in the shader).  Each case is one pixel:
one flat face of a tilted grid (the tilt sets N.V, the face's own light direction sets N.S),
its inputs read from face attributes.  Prints markdown: non-finite outputs on each side and
the largest model-vs-nodes disagreement, with the case where it occurs.

Cycles replaces a non-finite pixel by 0 (and its MIN/MAX nodes replace NaN by a bound), so a
NaN cannot be seen as a pixel value: each case also renders a flag, 1 + zero * (sum of all its
outputs) with zero read from an attribute at render time, which is 0 exactly when an output
is NaN or infinite.

    python benchmarks/stability.py [--size 48]
"""

import argparse
import pathlib
import sys
import warnings

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import numpy as np  # noqa: E402

from porous_weathering.blender import compat, render
from porous_weathering.contracts import socket_name
from porous_weathering.core import model
from porous_weathering.core import modes as weathering_modes
from porous_weathering.core.shader_math import Graph, dot  # noqa: E402
from porous_weathering.samples import studio  # noqa: E402
from porous_weathering.shading import nodes
from porous_weathering.survey.tally import FIELDS as FIELDS_IN_NUMPY

#: (k_d, k_s) pairs: k_a -> 0, k_a = 1, k_a -> 0 in one channel and -> 1 in another,
#: k_s + k_d > 1 (invalid: clamped), a typical stone.
ALBEDOS = (
    ((0.9, 0.9, 0.9), 0.1),
    ((0.0, 0.0, 0.0), 0.0),
    ((1e-4, 0.5, 0.9999), 0.0),
    ((0.9, 0.9, 0.9), 0.5),
    ((0.62, 0.55, 0.45), 0.05),
)
POROUS_VALUES = {
    "m": (0.0, 1e-4, 0.4, 1.5, 10.0),
    "alpha": (0.0, 1e-4, 0.5, 1.0),
    "sp": (0.0, 1e-4, 2.0, 10.0, 1000.0),
    "n_dot_l": (1.0, 0.5, 1e-3, 0.0, -0.5),
    "n_dot_v": (1.0, 0.5, 1e-2, 1e-3),
}


def hard_values(item):
    """The hard values of a weathering input, from its record: its bounds, beyond them (clamped),
    the middle and its default (a colour: black, white and its default)."""
    if item.is_colour:
        values = ((item.low,) * 3, (item.high,) * 3, item.default)
    else:
        span = item.high - item.low
        values = (item.low, item.high, item.low - 0.5 * span, item.high + span, item.low + 0.5 * span, item.default)
    return tuple(dict.fromkeys(values))


#: Hard values of every weathering input of every mode (the mode registry).
STATE_VALUES = {item.name: hard_values(item) for item in weathering_modes.inputs().values()}
#: Groups under test: label -> (weathering modes, light mode).
GROUPS = {
    "porous (key sun)": ((), nodes.SUN),
    "porous (ambient)": ((), nodes.AMBIENT),
    **{mode: ((mode,), nodes.SUN) for mode in model.MODES},
    "every mode": (model.MODES, nodes.SUN),
}
PORE_SOCKETS = {"kd": "Base Color", "ks": "Specular", "m": "Roughness", "alpha": "Porosity", "sp": "Pore Depth Ratio"}


def draw_cases(modes, count, seed=0):
    """``count`` combinations of hard values: {name: float32-exact float64 array}; row 0 is
    every input at its first value, then a fixed-seed draw."""
    rng = np.random.default_rng(seed)
    choices = (
        {**POROUS_VALUES, **{name: STATE_VALUES[name] for name in model.inputs_of(modes)}}
        if modes
        else dict(POROUS_VALUES)
    )
    picks = {name: rng.integers(len(values), size=count) for name, values in choices.items()}
    albedo = rng.integers(len(ALBEDOS), size=count)
    cases = {name: np.asarray(values, dtype=np.float64)[picks[name]] for name, values in choices.items()}
    cases["kd"] = np.array([ALBEDOS[i][0] for i in albedo])
    cases["ks"] = np.array([ALBEDOS[i][1] for i in albedo])
    return {name: value.astype(np.float32).astype(np.float64) for name, value in cases.items()}


def model_outputs(cases, modes, light_mode, fields=None):
    """(k_d (N, 3), k_s (N,), k_water (N, 3)) of the numpy model for ``cases``, given the
    ``fields`` of the point's place its modes read ({name: tuple of (N,) arrays})."""
    n_dot_l = None if light_mode == nodes.AMBIENT else cases["n_dot_l"]
    args = (cases["kd"], cases["ks"], cases["m"], cases["alpha"], cases["sp"], n_dot_l, cases["n_dot_v"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", model.PorousInputWarning)
        if not modes:
            kd, ks = model.porous_coefficients(*args)
            return kd, ks, np.zeros_like(kd)
        state = {name: cases[name] for name in model.inputs_of(modes)}
        return model.weathered_coefficients(*args, modes=modes, fields=fields, **state)


# --- the node side: one face per case --------------------------------------------------------


def tilted_grid(scene, n_dot_v, size):
    """A size x size grid of faces, one per pixel of an orthographic camera looking down -Z,
    face i tilted about X so that its normal is (0, -sin, cos) with cos = n_dot_v[i]."""
    count = size * size
    rows, columns = np.divmod(np.arange(count), size)
    x0, y0 = columns - size / 2.0, size / 2.0 - rows - 1.0
    rise = np.tan(np.arccos(np.clip(n_dot_v, 1e-6, 1.0)))  # z gained per unit of y
    corners = np.stack(
        [
            np.stack([x0, y0, -rise / 2], 1),
            np.stack([x0 + 1, y0, -rise / 2], 1),
            np.stack([x0 + 1, y0 + 1, rise / 2], 1),
            np.stack([x0, y0 + 1, rise / 2], 1),
        ],
        1,
    )
    mesh = bpy.data.meshes.new("Cases")
    mesh.from_pydata(corners.reshape(-1, 3).tolist(), [], np.arange(4 * count).reshape(-1, 4).tolist())
    obj = studio.link(scene, bpy.data.objects.new("Cases", mesh))
    camera = studio.add_ortho_camera(scene, scale=float(size), height=10.0 * rise.max() + 10.0)
    camera.data.clip_end = 30.0 * rise.max() + 100.0
    return obj


def light_directions(n_dot_l, n_dot_v):
    """World unit vectors S with N.S = n_dot_l for the tilted faces' normals N."""
    sine = np.sqrt(1.0 - n_dot_v**2)
    normal = np.stack([np.zeros_like(n_dot_v), -sine, n_dot_v], 1)
    across = np.array([1.0, 0.0, 0.0])  # perpendicular to every normal of the grid
    return n_dot_l[:, None] * normal + np.sqrt(1.0 - n_dot_l**2)[:, None] * across


def set_face_attribute(mesh, name, values):
    values = np.asarray(values, dtype=np.float32)
    kind = "FLOAT" if values.ndim == 1 else "FLOAT_VECTOR"
    attribute = mesh.attributes.new(name, kind, "FACE")
    attribute.data.foreach_set("value" if kind == "FLOAT" else "vector", values.ravel())


def probe_material(group, inputs, readout):
    """A material whose group node reads each of ``inputs`` (socket names) from the face
    attribute of that name and emits ``readout(graph, group_node, zero)``."""
    material = compat.new_material("Probe " + group.name)
    tree = material.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    group_node = graph.node("ShaderNodeGroup", depth=1, node_tree=group)
    for input_socket in inputs:
        attribute = graph.node("ShaderNodeAttribute", depth=0, attribute_name=input_socket)
        output = "Fac" if group_node.inputs[input_socket].type == "VALUE" else "Vector"
        graph.connect(attribute.outputs[output], group_node.inputs[input_socket])
    zero = graph.wrap(graph.node("ShaderNodeAttribute", depth=0, attribute_name="zero").outputs["Fac"])
    emission = graph.node("ShaderNodeEmission", {"Color": readout(graph, group_node, zero), "Strength": 1.0})
    graph.node("ShaderNodeOutputMaterial", {"Surface": emission.outputs[0]})
    return material


def diffuse_readout(graph, group_node, zero):
    return group_node.outputs["Diffuse Weight"]


def specular_readout(graph, group_node, zero):
    """(k_s, k_water red, finite flag) as a colour."""
    outputs = {socket.name: graph.wrap(socket) for socket in group_node.outputs if socket.name != "BSDF"}
    water = outputs.get("Water Weight")
    total = outputs["Specular Weight"] + dot(outputs["Diffuse Weight"], (1.0, 1.0, 1.0))
    if water is not None:
        total = total + dot(water, (1.0, 1.0, 1.0))
    water_red = graph.node("ShaderNodeSeparateXYZ", {"Vector": water}).outputs["X"] if water is not None else 0.0
    flag = 1.0 + zero * total
    return graph.node("ShaderNodeCombineXYZ", {"X": outputs["Specular Weight"], "Y": water_red, "Z": flag}).outputs[0]


def field_readout(name, first, components):
    """A readout of the field ``name`` (its shader builder, ``nodes.FIELDS``), from what feeds
    the group node's inputs: its components ``first`` to ``first + 2`` as a colour; the number of
    its components is appended to ``components``."""

    def readout(graph, group_node, zero):
        inputs = {
            socket.name: graph.wrap(socket.links[0].from_socket) if socket.is_linked else socket.default_value
            for socket in group_node.inputs
            if hasattr(socket, "default_value")
        }
        values = nodes.FIELDS[name](graph, inputs)
        components.append(len(values))
        return graph.node("ShaderNodeCombineXYZ", dict(zip("XYZ", values[first : first + 3]))).outputs[0]

    return readout


def rendered_outputs(cases, modes, light_mode, size):
    """(k_d (N, 3), k_s (N,), k_water red (N,), finite flag (N,)) of the node group, one Cycles
    render pair, and {field: its components (N,) each} read back at the same points (the
    lichens' seeds, a texture of the point's place: docs/model.md §9.3)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = tilted_grid(scene, cases["n_dot_v"], size)
    group = nodes.weathered_group(modes, light_mode)
    sockets = {PORE_SOCKETS[name]: cases[name] for name in PORE_SOCKETS}
    sockets.update({socket_name(name): cases[name] for name in model.inputs_of(modes)} if modes else {})
    if light_mode == nodes.SUN:
        sockets["Light Direction"] = light_directions(cases["n_dot_l"], cases["n_dot_v"])
    for name, values in {**sockets, "zero": np.zeros(len(cases["m"]))}.items():
        set_face_attribute(obj.data, name, values)
    render.use_cycles(scene, size=size, samples=1)
    images = []
    for readout in (diffuse_readout, specular_readout):
        studio.assign(obj, probe_material(group, sockets, readout))
        images.append(render.render_array(scene)[..., :3].reshape(-1, 3))
    diffuse, special = images
    fields = {}
    for name in weathering_modes.fields_of(modes):
        components, read = [], []
        while not components or len(read) < components[0]:  # three components a render
            studio.assign(obj, probe_material(group, sockets, field_readout(name, len(read), components)))
            read += list(render.render_array(scene)[..., :3].reshape(-1, 3).astype(np.float64).T)
        fields[name] = tuple(read[: components[0]])
    return diffuse, special[:, 0], special[:, 1], special[:, 2], fields


def compare(label, size, seed=0):
    """One table row's numbers for the group ``label``: a dict."""
    modes, light_mode = GROUPS[label]
    cases = draw_cases(modes, size * size, seed)
    node_kd, node_ks, node_water, flag, fields = rendered_outputs(cases, modes, light_mode, size)
    kd, ks, water = model_outputs(cases, modes, light_mode, fields)
    errors = np.stack([np.abs(node_kd - kd).max(1), np.abs(node_ks - ks), np.abs(node_water - water[:, 0])], 1)
    worst = int(np.argmax(errors.max(1)))
    return {
        "cases": len(ks),
        "model non-finite": int((~np.isfinite(np.column_stack([kd, ks, water]))).any(1).sum()),
        "model out of [0, 1]": int(((kd < 0) | (kd > 1)).any(1).sum() + ((ks < 0) | (ks > 1)).sum()),
        "nodes non-finite": int((flag < 0.5).sum()),
        "max |Δ| k_d": errors[:, 0].max(),
        "max |Δ| k_s": errors[:, 1].max(),
        "max |Δ| k_water": errors[:, 2].max(),
        "worst case": describe(cases, worst, modes),
        "errors": errors,
        "cases_": cases,
    }


def describe(cases, index, modes):
    names = ["kd", "ks", "m", "alpha", "sp", "n_dot_l", "n_dot_v"] + list(model.inputs_of(modes) if modes else [])
    return ", ".join(f"{name}={format_value(cases[name][index])}" for name in names)


def format_value(value):
    value = np.asarray(value)
    return "(" + ",".join(f"{v:.4g}" for v in value) + ")" if value.ndim else f"{float(value):.4g}"


def model_sweep(count=200_000, seed=1):
    """The numpy model alone on many more hard combinations, including NaN and ±inf inputs:
    the number of non-finite or out-of-range results per group (all must be 0)."""
    rows = []
    for label, (modes, light_mode) in GROUPS.items():
        cases = draw_cases(modes, count, seed)
        rng = np.random.default_rng(seed)
        for name in ("m", "sp", "alpha"):  # sprinkle NaN and infinities, which the model must clamp
            poison = rng.random(count) < 0.02
            cases[name] = np.where(poison, rng.choice([np.nan, np.inf, -np.inf], count), cases[name])
        # the fields of the point's place as the survey draws them, at places up to 100 m out facing anywhere
        places, facing = rng.uniform(-100.0, 100.0, (count, 3)), rng.normal(size=(count, 3))
        facing /= np.linalg.norm(facing, axis=1, keepdims=True)
        fields = {name: FIELDS_IN_NUMPY[name](places, facing, cases) for name in weathering_modes.fields_of(modes)}
        kd, ks, water = model_outputs(cases, modes, light_mode, fields)
        outputs = np.column_stack([kd, ks, water])
        rows.append(
            [
                label,
                count,
                int((~np.isfinite(outputs)).any(1).sum()),
                int(((outputs < 0) | (outputs > 1 + 1e-12)).any(1).sum()),
            ]
        )
    return rows


def tables(size):
    from benchmarks.scenes import markdown_table

    rows = []
    for label in GROUPS:
        result = compare(label, size)
        rows.append(
            [
                label,
                result["cases"],
                result["model non-finite"],
                result["nodes non-finite"],
                f"{result['max |Δ| k_d']:.2g}",
                f"{result['max |Δ| k_s']:.2g}",
                f"{result['max |Δ| k_water']:.2g}",
                result["worst case"],
            ]
        )
    rendered = markdown_table(
        [
            "group",
            "cases",
            "model non-finite",
            "nodes non-finite",
            "max |Δ| k_d",
            "max |Δ| k_s",
            "max |Δ| k_water",
            "worst case",
        ],
        rows,
    )
    swept = markdown_table(["group", "cases (2% NaN/±inf in m, s_p, α)", "non-finite", "outside [0, 1]"], model_sweep())
    return (
        f"### Numerical stability: hard cases, numpy model (float64) against the node groups "
        f"(Cycles, float32)\n\n{size * size} fixed-seed combinations of hard values per group, one pixel "
        "each: a flat face whose tilt sets N.V, its inputs read from face attributes. Values: "
        + "; ".join(f"{name} ∈ {values}" for name, values in POROUS_VALUES.items())
        + f"; (k_d, k_s) ∈ {ALBEDOS}; masks and t at 0, 1, −0.5, 1.5 or 2 and 0.5.\n\n"
        + rendered
        + "\n\nThe numpy model alone, on many more combinations:\n\n"
        + swept
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=48, help="cases per group: size x size")
    args = parser.parse_args()
    print(tables(args.size))


if __name__ == "__main__":
    main()
