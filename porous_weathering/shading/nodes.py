"""Shader node groups that evaluate the model's maths with node maths (EEVEE and Cycles, CPU and GPU).

The maths is not here: the porous BRDF (``porous.py``) and the weathering modes (``modes/``)
are written once against a backend, and this module evaluates them with ``NODE_OPS``, whose
operations add nodes (``shader_math.Expr``) instead of computing numbers.  What is here is
what only a shader has: the shading cosines, the closures, and the group's sockets.  A group
is built with only the inputs and nodes its light mode and modes need, and is reused when a
group of the same name, build version and sockets is already in the file.
"""

import math

import bpy

from ..contracts import BUILD_VERSION_PROPERTY
from ..core import modes as weathering_modes
from ..core import porous, stones
from ..core.backends import NODE_OPS
from ..core.modes import biological
from ..core.shader_math import Graph, dot, normalize

#: The node builder's build: bumped when it builds the same sockets with other maths, so old
#: files rebuild. A new mode, input or map needs no bump: a group is reused only if its sockets
#: are those the registries give it now (``_reuse``).  (The stone groups and the receptive
#: weathered groups of docs/model.md §8 came new in build 7, which left every other group as it
#: was; build 8 gave them the stone's uptake and deposit mix, §8.6–8.7; build 9 the uptake of
#: the sheltered share, §8.7, every weathered group k_a below 1, §4.0, and the grains' cells
#: drawn in 2D across the face, §8.1; build 10 the run-off in rivulets of a stone's weathered
#: groups that read a run-off map, §8.8, the stone's maths in fewer nodes, §8.1–8.3, and every
#: scalar clip in one Clamp node; build 11 the stone's per-point values in fewer nodes per point,
#: §8.2, §8.9: the receptive groups take them as varying, k_d is clamped in one fewer node everywhere;
#: build 12 the grains' plane, §8.1, in four nodes, its mirror from the rounded normal, and the
#: noise's clamp taken before its gain; build 13 the stones' patches in two octaves as strong, a
#: factor 8 apart, §8.1; build 14 the rivulets' draws from Blender's White Noise, §8.8; build 15
#: the uptake's gain G = 8, §8.7; build 16 every run-off in rivulets a decimetre apart, §8.8;
#: build 17 the rivulets' forms in fewer nodes, §8.8; build 18 the point's own data, and so its
#: place, one node per group; build 19 the lichens orange as far as the sun reaches them, §9.3;
#: build 20 the lichens establishing at the stone's share and the film holding as much as r, §9.3;
#: build 21 the lichens' thalli each of its own size, seen from the two nearest seeds, §9.3; build
#: 22 on a stone a thallus reaching further over its receptive spots, §9.3; build 23 the
#: limestone's beds each of its own thickness and value, and in masonry each block's own, §8.1.)
BUILD_VERSION = 23

#: Light modes (docs/model.md §3): a sun's direction, a point-like light's position, or none.
SUN, POINT, AMBIENT = "SUN", "POINT", "AMBIENT"
LIGHT_MODES = (SUN, POINT, AMBIENT)

#: Group inputs: name -> (socket type, default, min, max, tooltip).
PORE_INPUTS = {
    "Base Color": (
        "NodeSocketColor",
        (0.8, 0.8, 0.8, 1.0),
        None,
        None,
        "Diffuse albedo k_d of the stone without pores",
    ),
    "Specular": ("NodeSocketFloat", 0.1, 0.0, 1.0, "Specular coefficient k_s; k_s + k_d above 1 is clamped"),
    "Roughness": ("NodeSocketFloat", 0.4, 0.0, 1.5, "RMS roughness m: drives pore shadowing and the glossy lobe"),
    "Porosity": ("NodeSocketFloat", 0.2, 0.0, 1.0, "Fraction alpha of the surface covered by pores (brick: up to 0.4)"),
    "Pore Depth Ratio": ("NodeSocketFloat", 2.0, 0.0, 10.0, "s_p: mean pore depth over mean pore diameter"),
}
LIGHT_INPUTS = {
    SUN: (
        "Light Direction",
        "NodeSocketVector",
        (0.0, 0.0, 1.0),
        "World-space unit vector from the surface towards the key sun",
    ),
    POINT: ("Light Position", "NodeSocketVector", (0.0, 0.0, 10.0), "World-space position of the key light"),
}
OUTPUTS = {
    "BSDF": ("NodeSocketShader", "Porous BRDF: Lambert weighted by k_d,poro plus GGX by k_s,poro"),
    "Diffuse Weight": ("NodeSocketColor", "k_d,poro (eq. 3)"),
    "Specular Weight": ("NodeSocketFloat", "k_s,poro (eq. 2)"),
}


def porous_group_name(light_mode):
    return f"PW Porous ({light_mode.title()})"


def porous_group(light_mode):
    """The porous BRDF node group for ``light_mode``, built on first use."""
    name = porous_group_name(light_mode)
    return _build(
        name, lambda graph, inputs: porous_bsdf(graph, inputs, light_mode), {**PORE_INPUTS, **_light_input(light_mode)}
    )


def _light_input(light_mode):
    if light_mode not in LIGHT_MODES:
        raise ValueError(f"light mode must be one of {LIGHT_MODES}, not {light_mode!r}")
    if light_mode == AMBIENT:
        return {}
    name, socket_type, default, tooltip = LIGHT_INPUTS[light_mode]
    return {name: (socket_type, default, None, None, tooltip)}


def _close(values, expected):
    values = tuple(values) if hasattr(values, "__len__") else (values,)
    expected = expected if isinstance(expected, tuple) else (expected,)
    return len(values) == len(expected) and all(math.isclose(a, b, abs_tol=1e-6) for a, b in zip(values, expected))


def _has_sockets(group, inputs, outputs):
    """Whether ``group``'s sockets are those ``_build`` gives a group of ``inputs`` and ``outputs``:
    the same names, types and tooltips in the same order, and the same defaults and ranges."""
    items = [item for item in group.interface.items_tree if item.item_type == "SOCKET"]
    items.sort(key=lambda item: item.in_out != "INPUT")  # Blender lists the outputs first
    wanted = [("INPUT", name, spec) for name, spec in inputs.items()]
    wanted += [
        ("OUTPUT", name, (socket_type, None, None, None, tooltip)) for name, (socket_type, tooltip) in outputs.items()
    ]
    if len(items) != len(wanted):
        return False
    for item, (in_out, name, (socket_type, default, low, high, tooltip)) in zip(items, wanted):
        if (item.in_out, item.name, item.socket_type, item.description) != (in_out, name, socket_type, tooltip):
            return False
        if in_out == "INPUT" and not _close(item.default_value, default):
            return False
        if low is not None and not _close((item.min_value, item.max_value), (low, high)):
            return False
    return True


def _reuse(name, inputs, outputs):
    group = bpy.data.node_groups.get(name)
    if (
        group is not None
        and group.get(BUILD_VERSION_PROPERTY) == BUILD_VERSION
        and _has_sockets(group, inputs, outputs)
    ):
        return group
    if group is not None:  # an older build: rename it away so materials using it keep working
        group.name = name + " (old)"
    return None


def _build(name, body, inputs, outputs=OUTPUTS, varying=(), bounded=None):
    """The shader node group ``name`` with ``inputs`` and ``outputs`` whose maths ``body`` writes,
    the one in the file if it is that group (``_reuse``), else a new one; the inputs named in
    ``varying`` change from point to point (masks); those in ``bounded`` (name -> (low, high))
    are taken to lie in that range, and no clamp to it is built."""
    reused = _reuse(name, inputs, outputs)
    if reused is not None:
        return reused
    tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for socket_name, (socket_type, default, low, high, tooltip) in inputs.items():
        item = tree.interface.new_socket(socket_name, in_out="INPUT", socket_type=socket_type)
        item.description = tooltip
        item.default_value = default
        if low is not None:
            item.min_value, item.max_value = low, high
    for socket_name, (socket_type, tooltip) in outputs.items():
        item = tree.interface.new_socket(socket_name, in_out="OUTPUT", socket_type=socket_type)
        item.description = tooltip
    graph = Graph(tree)
    group_in = graph.node("NodeGroupInput", depth=0)
    values = {
        socket.name: graph.wrap_varying(socket) if socket.name in varying else graph.wrap(socket)
        for socket in group_in.outputs
        if socket.name
    }
    for socket_name, bounds in (bounded or {}).items():
        values[socket_name].bounds = bounds
    results = body(graph, values)
    group_out = graph.node("NodeGroupOutput", results)
    group_out.is_active_output = True
    _remove_unused(tree, keep=(group_in, group_out))
    tree[BUILD_VERSION_PROPERTY] = BUILD_VERSION
    return tree


def _remove_unused(tree, keep):
    """Remove the nodes no group output depends on (intermediate results that a later
    operation replaced, such as a colour scaled twice), so the group holds only its maths."""
    sources = {}
    for link in tree.links:
        sources.setdefault(link.to_node.name, []).append(link.from_node)
    used, frontier = set(), list(keep)
    while frontier:
        node = frontier.pop()
        if node.name not in used:
            used.add(node.name)
            frontier += sources.get(node.name, [])
    for node in [node for node in tree.nodes if node.name not in used]:
        tree.nodes.remove(node)


# --- geometry and closures -------------------------------------------------------------


def shading_cosines(graph, inputs, light_mode):
    """(N.S or None, N.V) at the shading point, for the light mode's light input."""
    geometry = graph.node("ShaderNodeNewGeometry", depth=0)
    normal = graph.wrap(geometry.outputs["Normal"])
    n_dot_v = dot(normal, graph.wrap(geometry.outputs["Incoming"]))
    if light_mode == AMBIENT:
        return None, n_dot_v
    if light_mode == SUN:
        to_light = normalize(inputs["Light Direction"])
    else:
        to_light = normalize(inputs["Light Position"] - graph.wrap(geometry.outputs["Position"]))
    return dot(normal, to_light), n_dot_v


def diffuse_plus_glossy(graph, kd_weight, ks_weight, roughness):
    """F_d (Lambert) weighted by k_d plus F_s (single-scatter GGX of roughness m) by k_s."""
    diffuse = graph.node("ShaderNodeBsdfDiffuse", {"Color": kd_weight, "Roughness": 0.0})
    glossy = graph.node("ShaderNodeBsdfGlossy", {"Color": ks_weight, "Roughness": roughness}, distribution="GGX")
    return graph.node("ShaderNodeAddShader", [diffuse.outputs[0], glossy.outputs[0]]).outputs[0]


def porous_bsdf(graph, inputs, light_mode):
    """The porous group's body: weights from the model, then the two lobes."""
    n_dot_l, n_dot_v = shading_cosines(graph, inputs, light_mode)
    roughness = inputs["Roughness"]  # the Glossy BSDF clamps it to [0, 1] itself
    kd_poro, ks_poro = porous.porous_coefficients(
        NODE_OPS,
        inputs["Base Color"],
        inputs["Specular"],
        roughness,
        inputs["Porosity"],
        inputs["Pore Depth Ratio"],
        n_dot_l,
        n_dot_v,
    )
    bsdf = diffuse_plus_glossy(graph, kd_poro, ks_poro, roughness)
    return {"BSDF": bsdf, "Diffuse Weight": kd_poro, "Specular Weight": ks_poro}


# --- weathering (docs/model.md §4): the modes of the registry ------------------------------------------

#: Near-mirror roughness of the water lobe (a GGX of its own, docs/model.md §4.2).
WATER_ROUGHNESS = weathering_modes.base.WATER_ROUGHNESS.default
WATER_OUTPUT = {"Water Weight": ("NodeSocketColor", "Weight of the near-mirror water lobe (eq. 8)")}


def weathering_inputs(modes):
    """Group inputs (as PORE_INPUTS) of the weathering state that ``modes`` use."""
    inputs = {}
    for item in [*weathering_modes.inputs_of(modes), *weathering_modes.shader_inputs(modes)]:
        if item.is_colour:
            inputs[item.socket] = ("NodeSocketColor", (*item.default, 1.0), None, None, item.tooltip)
        else:
            inputs[item.socket] = ("NodeSocketFloat", item.default, item.low, item.high, item.tooltip)
    return inputs


def weathered_group_name(modes, light_mode, receptive=False, rivulets=False):
    receptive = " Receptive" if receptive else ""
    receptive += " Rivulets" if rivulets else ""
    return f"PW Weathered {'+'.join(mode.title() for mode in modes)}{receptive} ({light_mode.title()})"


#: The scene's unit scale: what a group that reads the point's place in metres needs (fed by a
#: driver that follows the scene's unit, ``material.follow_unit_scale``).
METRES_PER_UNIT = "Metres Per Unit"
METRES_PER_UNIT_INPUT = {
    METRES_PER_UNIT: (
        "NodeSocketFloat",
        1.0,
        1e-9,
        1e9,
        "The scene's unit scale (Scene > Units > Unit Scale): the structure's sizes are in metres",
    ),
}

#: The inputs of a receptive weathered group: the stone's receptivity r (docs/model.md §8.3), its
#: porosity field z_p and its variation v (docs/model.md §8.6, §8.7).
RECEPTIVITY, FIELD, VARIATION = "Receptivity", "Porosity Field", "Variation"
RECEPTIVITY_INPUT = {
    RECEPTIVITY: (
        "NodeSocketFloat",
        1.0,
        0.0,
        10.0,
        "Receptivity r from the stone's structure: this point's pores fill r times as fast (1: the stone's mean)",
    ),
    FIELD: (
        "NodeSocketFloat",
        0.0,
        -1.0,
        1.0,
        "The stone's porosity field z_p: where in the stone's spread this point takes up soot, water and salt "
        "(and so where lichens take hold and rivulets wander)",
    ),
    VARIATION: (
        "NodeSocketFloat",
        0.0,
        0.0,
        1.0,
        "The stone's variation v: how far its fills, covers, rivulets and lichens follow its field, and the "
        "deposit its colour",
    ),
}
#: The input of a receptive group whose run-off gathers into rivulets (docs/model.md §8.8).
RIVULET_SPACING = "Rivulet Spacing"
RIVULET_INPUT = {
    RIVULET_SPACING: (
        "NodeSocketFloat",
        stones.RIVULET_SPACING,
        1e-6,
        1e6,
        "The stone's spacing of the run-off's rivulets across the fall line, metres",
    ),
}
#: The stone node's outputs that feed a receptive weathered group, and the porous group.
STONE_FEEDS = ("Base Color", "Porosity", "Pore Depth Ratio", "Roughness", RECEPTIVITY, FIELD, VARIATION)
#: The stone's values at the point, which a receptive weathered group reads from the stone group and
#: takes as varying, so that the §4 maths reading them takes its per-point forms (docs/model.md §8.9).
STONE_POINT_VALUES = ("Base Color", "Porosity", "Pore Depth Ratio", "Roughness")
#: The ranges the stone group keeps its outputs in (``stones.point_parameters``, a square root):
#: a receptive weathered group, fed by it, takes them as they are (docs/model.md §8.3).
STONE_RANGES = {
    "Base Color": (0.0, math.inf),
    "Porosity": stones.POROSITY_RANGE,
    "Pore Depth Ratio": stones.PORE_DEPTH_RANGE,
    "Roughness": stones.ROUGHNESS_RANGE,
    RECEPTIVITY: (0.0, math.inf),
}


def weathered_group(modes, light_mode, receptive=False, rivulets=False):
    """The group for ``modes`` (only their nodes) in ``light_mode``; no modes: the porous group.
    ``receptive``: with the Receptivity input of a stone's structure (docs/model.md §8.3), which
    only materials with a stone have; ``rivulets`` (receptive groups whose modes read the run-off
    map): with the run-off gathered into the stone's rivulets (docs/model.md §8.8)."""
    modes = weathering_modes.checked(modes)
    if not modes:
        return porous_group(light_mode)
    rivulets = rivulets and receptive and uses_runoff(modes)
    name = weathered_group_name(modes, light_mode, receptive, rivulets)
    outputs = {**OUTPUTS, **(WATER_OUTPUT if weathering_modes.has_water_lobe(modes) else {})}
    return _build(
        name,
        lambda graph, inputs: weathered_bsdf(graph, inputs, light_mode, modes),
        {
            **PORE_INPUTS,
            **_light_input(light_mode),
            **weathering_inputs(modes),
            **(RECEPTIVITY_INPUT if receptive else {}),
            **(RIVULET_INPUT if rivulets else {}),
            **(METRES_PER_UNIT_INPUT if weathering_modes.fields_of(modes) or rivulets else {}),
        },
        outputs,
        varying={item.socket for item in weathering_modes.inputs_of(modes) if item.mask}
        | ({RECEPTIVITY, FIELD, *STONE_POINT_VALUES} if receptive else set()),
        bounded=STONE_RANGES if receptive else None,
    )


def weathered_bsdf(graph, inputs, light_mode, modes):
    """The weathered group's body: the porous lobes with weathered weights, plus the water lobe."""
    n_dot_l, n_dot_v = shading_cosines(graph, inputs, light_mode)
    roughness = inputs["Roughness"]
    state = {item.name: inputs[item.socket] for item in weathering_modes.inputs_of(modes)}
    kd_w, ks_w, water_w = weathering_modes.weathered_weights(
        NODE_OPS,
        inputs["Base Color"],
        inputs["Specular"],
        roughness,
        inputs["Porosity"],
        inputs["Pore Depth Ratio"],
        n_dot_l,
        n_dot_v,
        modes,
        state,
        inputs.get(RECEPTIVITY),
        inputs.get(FIELD),
        inputs.get(VARIATION),
        {name: FIELDS[name](graph, inputs) for name in weathering_modes.fields_of(modes)},
        fall_line(graph, inputs) if RIVULET_SPACING in inputs else None,
    )
    bsdf = diffuse_plus_glossy(graph, kd_w, ks_w, roughness)
    results = {"BSDF": bsdf, "Diffuse Weight": kd_w, "Specular Weight": ks_w}
    if water_w is not None:
        water = graph.node(
            "ShaderNodeBsdfGlossy", {"Color": water_w, "Roughness": inputs["Water Roughness"]}, distribution="GGX"
        )
        results["BSDF"] = graph.node("ShaderNodeAddShader", [bsdf, water.outputs[0]]).outputs[0]
        results["Water Weight"] = water_w
    return results


def uses_runoff(modes):
    """Whether ``modes`` read the run-off map (docs/model.md §7.2)."""
    return weathering_modes.base.RUNOFF_MAP in weathering_modes.inputs_of(modes)


def fall_line(graph, inputs):
    """(u, h, spacing) of docs/model.md §8.8 at the shading point: its place across the fall line in
    metres (``point_in_metres``), the horizontal part of its normal and the rivulet spacing."""
    normal = graph.wrap(graph.node("ShaderNodeNewGeometry", depth=0).outputs["Normal"])
    return (*weathering_modes.base.fall_line(NODE_OPS, point_in_metres(graph, inputs), normal), inputs[RIVULET_SPACING])


def lichen_seeds(graph, inputs):
    """The lichens' seeds (biological.LICHEN_SEEDS: the nearest seed's distance in cells, value and
    size draw, then the second nearest's; docs/model.md §9.3): a 2D Voronoi texture's F1 and F2 (its
    Distance, its Color's red and blue) of one seed per cell of side 1/sqrt(lambda) metres, on the
    world plane the surface faces most (x-y for tops, x-z for faces along x, y-z for faces along y:
    a thallus on any face is a disc), each plane its own seeds."""
    normal = graph.node("ShaderNodeNewGeometry", depth=0).outputs["Normal"]
    n = graph.node("ShaderNodeSeparateXYZ", {"Vector": normal})
    ax, ay, az = (graph.math("ABSOLUTE", graph.wrap(n.outputs[axis])) for axis in "XYZ")
    faces_z = graph.math("GREATER_THAN", az, NODE_OPS.maximum(ax, ay) - 1e-6)  # 1 on tops and bottoms
    faces_x = (1.0 - faces_z) * graph.math("GREATER_THAN", ax, ay)  # 1 on faces along y (normal along x)
    metres = graph.node("ShaderNodeSeparateXYZ", {"Vector": point_in_metres(graph, inputs)})
    x, y, z = (graph.wrap(metres.outputs[axis]) for axis in "XYZ")
    u = NODE_OPS.mix(faces_x, x, y) + faces_x * biological.PLANE_OFFSET
    v = NODE_OPS.mix(faces_z, z, y) + faces_z * biological.PLANE_OFFSET
    density = NODE_OPS.maximum(inputs[biological.LICHEN_DENSITY.socket], biological.LEAST_DENSITY)
    place = graph.node("ShaderNodeCombineXYZ", {"X": u, "Y": v, "Z": 0.0})
    scale = NODE_OPS.power(density, 0.5)
    seeds = []
    for feature in ("F1", "F2"):
        voronoi = graph.node(
            "ShaderNodeTexVoronoi",
            {"Vector": place.outputs[0], "Scale": scale},
            voronoi_dimensions="2D",
            feature=feature,
            distance="EUCLIDEAN",
        )
        draws = graph.node("ShaderNodeSeparateColor", {"Color": voronoi.outputs["Color"]})
        seeds += [
            graph.wrap(voronoi.outputs["Distance"]),
            graph.wrap(draws.outputs["Red"]),
            graph.wrap(draws.outputs["Blue"]),
        ]
    return tuple(seeds)


#: The shader's builder of each per-point field a mode's record names (``Mode.fields``).
FIELDS = {biological.LICHEN_SEEDS: lichen_seeds}


# --- the stone's own structure (docs/model.md §8) -----------------------------------------------

#: The stone group's inputs: the material's own values (the means) and the structure's settings.
STONE_INPUTS = {
    "Base Color": PORE_INPUTS["Base Color"][:4] + ("Mean diffuse albedo k_d of the stone",),
    "Porosity": PORE_INPUTS["Porosity"][:4] + ("Mean porosity alpha",),
    "Pore Depth Ratio": PORE_INPUTS["Pore Depth Ratio"][:4] + ("Mean pore depth ratio s_p",),
    "Roughness": PORE_INPUTS["Roughness"][:4] + ("Mean roughness m",),
    "Variation": (
        "NodeSocketFloat",
        stones.DEFAULT_VARIATION,
        0.0,
        1.0,
        "How much of the stone's structure shows: 0 is the uniform material, 1 the stone as it shows it",
    ),
    **METRES_PER_UNIT_INPUT,
}
STONE_OUTPUTS = {
    "Base Color": ("NodeSocketColor", "k_d at this point"),
    "Porosity": ("NodeSocketFloat", "alpha at this point"),
    "Pore Depth Ratio": ("NodeSocketFloat", "s_p at this point"),
    "Roughness": ("NodeSocketFloat", "m at this point"),
    RECEPTIVITY: ("NodeSocketFloat", "r: how much faster than the mean this point's pores fill"),
    FIELD: ("NodeSocketFloat", "z_p in [-1, 1], the porosity field"),
    "Colour Field": ("NodeSocketFloat", "z_c in [-1, 1], the colour field"),
    VARIATION: (
        "NodeSocketFloat",
        "v, the variation in [0, 1]: what the weathering's uptake, deposit, rivulets and lichens read",
    ),
}


def point_in_metres(graph, inputs):
    """Where the shading point lies from its object's origin, in metres, along the world's axes
    (docs/model.md §8.2): physical whatever the object's scale, and the beds and courses level
    (along Z) whatever way the object was modelled or turned."""
    return point_from_origin(graph) * inputs[METRES_PER_UNIT]


def point_from_origin(graph):
    """Where the shading point lies from its object's origin along the world's axes, in the
    scene's unit (``point_in_metres`` times the unit's metres)."""
    position = graph.node("ShaderNodeNewGeometry", depth=0).outputs["Position"]
    origin = graph.node("ShaderNodeObjectInfo", depth=0).outputs["Location"]
    return graph.wrap(position) - graph.wrap(origin)


def stone_group_name(key):
    return f"PW Stone {key.title()}"


def stone_group(key, stone):
    """The node group of the stone ``key`` (a preset key) whose structure is ``stone``
    (``stones.Stone``), built on first use: its textures at their physical sizes, at the point's
    place from its object's origin in metres (``point_in_metres``), and the maths of
    ``core/stones.py``."""
    name = stone_group_name(key)
    body = lambda graph, inputs: stone_body(graph, inputs, stone)  # noqa: E731
    return _build(name, body, STONE_INPUTS, STONE_OUTPUTS)


def stone_body(graph, inputs, stone, block_draw_at=None):
    """The stone's per-point values (STONE_OUTPUTS); with ``block_draw_at(graph, metres)``, each
    block's own draw b (docs/model.md §8.5) mixed into its fields, and the "Block Field" output."""
    # the textures take the place in the scene's unit and their scales per unit: the unit's metres
    # fold into each scale, where scaling the place would cost a node per point
    place, metres_per_unit = point_from_origin(graph), inputs[METRES_PER_UNIT]
    draw = block_draw_at(graph, place * metres_per_unit) if block_draw_at else None
    values = [texture_value(graph, place, texture, metres_per_unit, draw) for texture in stone.textures]
    z_p, z_c = stones.fields(NODE_OPS, stone, values)
    if draw is not None:
        z_p, z_c = stones.block_fields(NODE_OPS, stone, z_p, z_c, draw)
    variation = inputs["Variation"]
    kd, alpha, sp, m = stones.point_parameters(
        NODE_OPS,
        stone,
        inputs["Base Color"],
        inputs["Porosity"],
        inputs["Pore Depth Ratio"],
        inputs["Roughness"],
        z_p,
        z_c,
        variation,
    )
    outputs = {
        "Base Color": kd,
        "Porosity": alpha,
        "Pore Depth Ratio": sp,
        "Roughness": m,
        RECEPTIVITY: stones.receptivity(NODE_OPS, stone, z_p, variation),
        FIELD: z_p,
        "Colour Field": z_c,
        VARIATION: NODE_OPS.clip(variation, 0.0, 1.0),
    }
    return outputs if draw is None else {**outputs, "Block Field": draw}


# --- masonry (docs/model.md §8.5) -----------------------------------------------------------

#: The masonry group's inputs beyond the stone group's: the ashlar's lengths and the mortar's values.
MASONRY_INPUTS = {
    **{
        length.label: (
            "NodeSocketFloat",
            getattr(stones.Ashlar, name),
            length.least,
            1e6,
            f"{length.description}, metres",
        )
        for name, length in stones.ASHLAR_LENGTHS.items()
    },
    "Mortar Color": PORE_INPUTS["Base Color"][:4] + ("Diffuse albedo k_d of the mortar",),
    "Mortar Porosity": PORE_INPUTS["Porosity"][:4] + ("Porosity alpha of the mortar",),
    "Mortar Pore Depth Ratio": PORE_INPUTS["Pore Depth Ratio"][:4] + ("Pore depth ratio s_p of the mortar",),
    "Mortar Roughness": PORE_INPUTS["Roughness"][:4] + ("Roughness m of the mortar",),
}
MASONRY_OUTPUTS = {
    "Block Field": ("NodeSocketFloat", "b in [-1, 1]: this block's own draw (its bed)"),
    "Joint": ("NodeSocketFloat", "j in [0, 1]: 1 in the mortar joints, 0 in the stone"),
}
#: What the mortar's values and the ashlar's lengths are called in the masonry group.
MORTAR_SOCKETS = ("Mortar Color", "Mortar Porosity", "Mortar Pore Depth Ratio", "Mortar Roughness")


#: The stone's outputs the mortar takes over in the joints, in ``stones.jointed``'s order.
JOINTED = ("Base Color", "Porosity", "Pore Depth Ratio", "Roughness", RECEPTIVITY)


def masonry_group_name(key):
    return f"{stone_group_name(key)} Ashlar"


def masonry_group(key, stone):
    """The node group of the stone ``key`` laid as coursed ashlar (docs/model.md §8.5): the
    stone group's textures and maths, each block's own draw, and the mortar in the joints."""
    name = masonry_group_name(key)
    body = lambda graph, inputs: masonry_body(graph, inputs, stone)  # noqa: E731
    return _build(name, body, {**STONE_INPUTS, **MASONRY_INPUTS}, {**STONE_OUTPUTS, **MASONRY_OUTPUTS})


def masonry_body(graph, inputs, stone):
    layout = {}

    def ashlar_draw(graph, metres):
        axes = graph.node("ShaderNodeSeparateXYZ", {"Vector": metres})
        x, y, z = (graph.wrap(axes.outputs[axis]) for axis in "XYZ")
        lengths = {name: inputs[length.label] for name, length in stones.ASHLAR_LENGTHS.items()}
        course, block, layout["joint"] = stones.ashlar(NODE_OPS, x, y, z, **lengths)
        return block_draw(graph, course, block)

    outputs = stone_body(graph, inputs, stone, ashlar_draw)
    mortar = [inputs[socket] for socket in MORTAR_SOCKETS]
    mortar_r = stones.mortar_receptivity(NODE_OPS, mortar[1], mortar[3], inputs["Porosity"], inputs["Roughness"])
    jointed = stones.jointed(NODE_OPS, layout["joint"], [outputs[name] for name in JOINTED], (*mortar, mortar_r))
    return {**outputs, **dict(zip(JOINTED, jointed)), "Joint": layout["joint"]}


def mesh_blocks_group_name(key, attribute):
    suffix = "" if attribute == stones.BLOCK_ATTRIBUTE else f" ({attribute})"
    return f"{stone_group_name(key)} Blocks{suffix}"


def mesh_blocks_group(key, stone, attribute):
    """The node group of the stone ``key`` laid in the blocks the mesh knows (docs/model.md §8.5):
    the stone group's textures and maths, each block (a whole number of the face attribute
    ``attribute``) its own draw; the joints are the mesh's."""
    name = mesh_blocks_group_name(key, attribute)
    body = lambda graph, inputs: mesh_blocks_body(graph, inputs, stone, attribute)  # noqa: E731
    outputs = {**STONE_OUTPUTS, "Block Field": MASONRY_OUTPUTS["Block Field"]}
    return _build(name, body, STONE_INPUTS, outputs)


def mesh_blocks_body(graph, inputs, stone, attribute):
    def face_block_draw(graph, metres):
        block = graph.node("ShaderNodeAttribute", depth=0, attribute_type="GEOMETRY", attribute_name=attribute)
        return block_draw(graph, 0.0, graph.wrap(block.outputs["Fac"]))

    return stone_body(graph, inputs, stone, face_block_draw)


def block_draw(graph, course, block):
    """b in [-1, 1], uniform and of mean 0: each block's own random value (a White Noise of its
    whole-number (block, course) index: the same at every point of the block)."""
    cell = graph.node("ShaderNodeCombineXYZ", {"X": block, "Y": course, "Z": 0.0})
    noise = graph.node("ShaderNodeTexWhiteNoise", {"Vector": cell.outputs[0]}, noise_dimensions="3D")
    return graph.wrap(noise.outputs["Value"]) * 2.0 - 1.0


def texture_value(graph, place, texture, metres_per_unit, block_draw=None):
    """The value (mean 1/2, in [0, 1]) of one layer's Blender texture at ``place``, in a unit of
    ``metres_per_unit`` metres; beds in masonry are moved along Z by the block's own draw."""
    scale = texture.scale * metres_per_unit
    if texture.kind == stones.BEDS:
        # each bed between the midpoints of seeds jittered one per bed along the height
        height = graph.wrap(graph.node("ShaderNodeSeparateXYZ", {"Vector": place}).outputs["Z"])
        beds = height * scale
        if block_draw is not None:
            beds = NODE_OPS.multiply_add(block_draw, stones.BED_SHIFT, beds)
        return cell_value(graph, {"W": beds, "Scale": 1.0}, "1D")
    if texture.kind == stones.CELLS:
        return cell_value(graph, {"Vector": place_across_the_face(graph, place), "Scale": scale}, "2D")
    common = {"Vector": place, "Scale": scale}
    if texture.kind == stones.NOISE:
        node = graph.node(
            "ShaderNodeTexNoise",
            {
                **common,
                "Detail": texture.detail,
                "Roughness": texture.roughness,
                "Lacunarity": texture.lacunarity,
                "Distortion": texture.distortion,
            },
            noise_dimensions="3D",
        )
        return graph.wrap(node.outputs[0])  # "Fac" (4.5) / "Factor" (5.x)
    node = graph.node(
        "ShaderNodeTexWave",
        # the phase puts the object's origin mid-way between a light and a dark band (value 1/2)
        {**common, "Distortion": texture.distortion, "Detail": texture.detail, "Phase Offset": math.pi / 2},
        wave_type="BANDS",
        bands_direction=texture.direction,
        wave_profile="SIN",
    )
    return graph.wrap(node.outputs[1])  # "Fac" (4.5) / "Factor" (5.x)


def cell_value(graph, inputs, dimensions):
    """The random value of the Voronoi cell (a grain, a bed) a point lies in: its F1 cell's own
    Color, red, uniform in [0, 1]."""
    node = graph.node("ShaderNodeTexVoronoi", inputs, voronoi_dimensions=dimensions, feature="F1", distance="EUCLIDEAN")
    red = graph.node("ShaderNodeSeparateColor", {"Color": node.outputs["Color"]})
    return graph.wrap(red.outputs["Red"])


def place_across_the_face(graph, place):
    """The point's place mirrored onto the world's plane most nearly along its face, as the (x, y)
    of a vector (docs/model.md §8.1): (x, y) itself on a face facing along Z, (±z, y) along X,
    (x, ±z) along Y, a face between the axes by its own mirror (``stones.grains_mirror``). The
    grains' cells are drawn in 2D there: a third of a 3D Voronoi's neighbour cells, the same cell
    size, stretched at most 1.57 times on a tilted face."""
    normal = graph.wrap(graph.node("ShaderNodeNewGeometry", depth=0).outputs["True Normal"])
    return graph.math("REFLECT", place, stones.grains_mirror(NODE_OPS, normal))
