"""Shader node groups that evaluate model.py with node maths (EEVEE and Cycles, CPU and GPU).

Each function here mirrors the model function of the same name, line by line, on
``shader_math.Expr`` values instead of numpy arrays.  A group is built with only the
inputs and nodes its light mode needs, and is reused when a group of the same name and
build version is already in the file.
"""

import math

import bpy

from . import model
from .shader_math import Graph, arccos, clip, dot, maximum, minimum, normalize, power

#: Bumped whenever the maths or the interface of a group changes, so old files rebuild.
BUILD_VERSION = 1

#: Light modes (SPEC 3): a sun's direction, a point-like light's position, or none.
SUN, POINT, AMBIENT = "SUN", "POINT", "AMBIENT"
LIGHT_MODES = (SUN, POINT, AMBIENT)

#: Group inputs: name -> (socket type, default, min, max, tooltip).
PORE_INPUTS = {
    "Base Color": ("NodeSocketColor", (0.8, 0.8, 0.8, 1.0), None, None,
                   "Diffuse albedo k_d of the stone without pores"),
    "Specular": ("NodeSocketFloat", 0.1, 0.0, 1.0,
                 "Specular coefficient k_s; k_s + k_d above 1 is clamped"),
    "Roughness": ("NodeSocketFloat", 0.4, 0.0, 1.5,
                  "RMS roughness m: drives pore shadowing and the glossy lobe"),
    "Porosity": ("NodeSocketFloat", 0.2, 0.0, 1.0,
                 "Fraction alpha of the surface covered by pores (brick: up to 0.4)"),
    "Pore Depth Ratio": ("NodeSocketFloat", 2.0, 0.0, 10.0,
                         "s_p: mean pore depth over mean pore diameter"),
}
LIGHT_INPUTS = {
    SUN: ("Light Direction", "NodeSocketVector", (0.0, 0.0, 1.0),
          "World-space unit vector from the surface towards the key sun"),
    POINT: ("Light Position", "NodeSocketVector", (0.0, 0.0, 10.0),
            "World-space position of the key light"),
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
    return _reuse(name) or _build(name, lambda graph, inputs: porous_bsdf(graph, inputs, light_mode),
                                  {**PORE_INPUTS, **_light_input(light_mode)})


def _light_input(light_mode):
    if light_mode not in LIGHT_MODES:
        raise ValueError(f"light mode must be one of {LIGHT_MODES}, not {light_mode!r}")
    if light_mode == AMBIENT:
        return {}
    name, socket_type, default, tooltip = LIGHT_INPUTS[light_mode]
    return {name: (socket_type, default, None, None, tooltip)}


def _reuse(name):
    group = bpy.data.node_groups.get(name)
    if group is not None and group.get("pw_build_version") == BUILD_VERSION:
        return group
    if group is not None:  # an older build: rename it away so materials using it keep working
        group.name = name + " (old)"
    return None


def _build(name, body, inputs, outputs=OUTPUTS):
    """A new shader node group with ``inputs`` and ``outputs`` whose maths ``body`` writes."""
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
    values = {socket.name: graph.wrap(socket) for socket in group_in.outputs if socket.name}
    results = body(graph, values)
    group_out = graph.node("NodeGroupOutput", results)
    group_out.is_active_output = True
    tree["pw_build_version"] = BUILD_VERSION
    return tree


# --- the model, mirrored ---------------------------------------------------------------


def valid_albedo(kd, ks):
    """model.valid_albedo: k_d clamped so that k_a >= 0."""
    ks = clip(ks, 0.0, 1.0)
    kd = minimum(clip(kd, 0.0, 1.0), 1.0 - ks)
    return kd, ks


def shadowing_k(m):
    return 2.0 * m * m / math.pi


def shadowing_g(x, k):
    x = clip(x, 0.0, 1.0)
    return x / maximum(x * (1.0 - k) + k, model.EPSILON)


def ambient_g(k):
    terms = [2.0 * w * mu * shadowing_g(mu, k) for mu, w in zip(model.AMBIENT_NODES, model.AMBIENT_WEIGHTS)]
    return terms[0] + terms[1] + terms[2]


def bounce_count(sp, theta_i, theta_r):
    return maximum(0.0, sp * (3.7 - 2.0 * ((theta_i + theta_r) / 2.0 - 2.0 * math.pi / (sp + 6.0))))


def pore_absorption(ka, nb):
    return 1.0 - power(1.0 - ka, nb)


def porous_weights(kd, ks, alpha, gp, ap):
    pore = alpha * gp
    kd_poro = kd * (1.0 - pore * ap) + ks * pore * (1.0 - ap)
    ks_poro = ks * (1.0 - alpha * gp)
    return kd_poro, ks_poro


def pore_geometry(m, n_dot_l, n_dot_v):
    m = maximum(m, 0.0)
    n_dot_v = clip(n_dot_v, 0.0, 1.0)
    k = shadowing_k(m)
    if n_dot_l is None:
        g_light, theta_i = ambient_g(k), model.AMBIENT_THETA_I
    else:
        n_dot_l = clip(n_dot_l, 0.0, 1.0)
        g_light, theta_i = shadowing_g(n_dot_l, k), arccos(n_dot_l)
    return g_light * shadowing_g(n_dot_v, k), theta_i, arccos(n_dot_v)


def pore_terms(kd, ks, m, sp, n_dot_l, n_dot_v):
    sp = maximum(sp, 0.0)
    gp, theta_i, theta_r = pore_geometry(m, n_dot_l, n_dot_v)
    nb = bounce_count(sp, theta_i, theta_r)
    ap = pore_absorption(1.0 - ks - kd, nb)
    return gp, ap


def porous_coefficients(kd, ks, m, alpha, sp, n_dot_l, n_dot_v):
    kd, ks = valid_albedo(kd, ks)
    alpha = clip(alpha, 0.0, 1.0)
    gp, ap = pore_terms(kd, ks, m, sp, n_dot_l, n_dot_v)
    return porous_weights(kd, ks, alpha, gp, ap)


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
    glossy = graph.node("ShaderNodeBsdfGlossy", {"Color": ks_weight, "Roughness": roughness},
                        distribution="GGX")
    return graph.node("ShaderNodeAddShader", [diffuse.outputs[0], glossy.outputs[0]]).outputs[0]


def porous_bsdf(graph, inputs, light_mode):
    """The porous group's body: weights from the model, then the two lobes."""
    n_dot_l, n_dot_v = shading_cosines(graph, inputs, light_mode)
    roughness = inputs["Roughness"]  # the Glossy BSDF clamps it to [0, 1] itself
    kd_poro, ks_poro = porous_coefficients(inputs["Base Color"], inputs["Specular"], roughness,
                                           inputs["Porosity"], inputs["Pore Depth Ratio"],
                                           n_dot_l, n_dot_v)
    bsdf = diffuse_plus_glossy(graph, kd_poro, ks_poro, roughness)
    return {"BSDF": bsdf, "Diffuse Weight": kd_poro, "Specular Weight": ks_poro}


# --- weathering (SPEC 4): model.py's weathering section, mirrored ------------------------

#: Near-mirror roughness of the water lobe (a GGX of its own, SPEC 4 "wet surfaces").
WATER_ROUGHNESS = 0.05

WEATHERING_TOOLTIPS = {
    "time": "Age t: 0 is the clean material exactly, 1 fully weathered. Keyframe it to animate",
    "front_width": "Width, in mask units, over which a point goes from clean to fully filled",
    "rain_map": "Rain exposure E: 1 where rain falls freely, 0 where sheltered",
    "rain_threshold": "E at and above which rain washes the surface (white area)",
    "edge_map": "Edge/cavity mask C: carbon fills the pores from the highest C down",
    "soiling_level": "How far down the edge mask the black area reaches at t = 1",
    "pollution_color": "k_d,pollution: the carbon in the pores (the paper suggests 0.8; soot is dark)",
    "deposit_color": "Colour of the grey-area deposit on sheltered, rough surfaces",
    "wet_level": "How far down the rain map the wet area reaches at t = 1 (lower it to dry)",
    "water_specular": "k_s,water: the water lobe's weight (about 1)",
    "efflorescence_map": "Efflorescence location: salt fills the pores from the highest value down",
    "efflorescence_level": "How far down the location map the salt reaches at t = 1",
    "salt_color": "k_d,efflo_salt: the salt's diffuse colour (about 0.8)",
}
WATER_OUTPUT = {"Water Weight": ("NodeSocketColor", "Weight of the near-mirror water lobe (eq. 8)")}


def socket_name(name):
    """The group input of a model.WEATHERING_INPUTS name: 'rain_map' -> 'Rain Map'."""
    return name.replace("_", " ").title()


def weathering_inputs(modes):
    """Group inputs (as PORE_INPUTS) of the weathering state that ``modes`` use."""
    inputs = {}
    for name in model.inputs_of(modes):
        default, low, high, _ = model.WEATHERING_INPUTS[name]
        if isinstance(default, tuple):
            inputs[socket_name(name)] = ("NodeSocketColor", (*default, 1.0), None, None, WEATHERING_TOOLTIPS[name])
        else:
            inputs[socket_name(name)] = ("NodeSocketFloat", default, low, high, WEATHERING_TOOLTIPS[name])
    if model.WET in modes:
        inputs["Water Roughness"] = ("NodeSocketFloat", WATER_ROUGHNESS, 0.0, 1.0,
                                     "Roughness of the water lobe: near 0 is a mirror")
    return inputs


def weathered_group_name(modes, light_mode):
    return f"PW Weathered {'+'.join(mode.title() for mode in modes)} ({light_mode.title()})"


def weathered_group(modes, light_mode):
    """The group for ``modes`` (only their nodes) in ``light_mode``; no modes: the porous group."""
    modes = model.weathering_modes(modes)
    if not modes:
        return porous_group(light_mode)
    name = weathered_group_name(modes, light_mode)
    outputs = {**OUTPUTS, **(WATER_OUTPUT if model.WET in modes else {})}
    return _reuse(name) or _build(name, lambda graph, inputs: weathered_bsdf(graph, inputs, light_mode, modes),
                                  {**PORE_INPUTS, **_light_input(light_mode), **weathering_inputs(modes)}, outputs)


def weathering_state(state):
    return {name: clip(value, *model.WEATHERING_INPUTS[name][1:3]) for name, value in state.items()}


def fill_curve(progress):
    x = clip(progress, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def pore_fill(mask, time, level, width):
    return fill_curve((mask - (1.0 - level * time)) / width)


def blend(clean, weathered, fill):
    return clean + fill * (weathered - clean)


def filled_absorption(ka, sp, fill, theta_i, theta_r):
    nb = bounce_count(sp * (1.0 - fill), theta_i, theta_r)
    return pore_absorption(ka, nb)


def polluted_diffuse(kd, pollution_color, pore, ap):
    return kd * (1.0 - pore) + pollution_color * pore * (1.0 - ap)


def wet_weights(kd, water_specular, pore, ap):
    return kd * (1.0 - pore), water_specular * pore * (1.0 - ap)


def efflorescence_diffuse(kd, salt_color, pore, ap, ks_poro):
    return minimum(kd * (1.0 - pore * ap) + salt_color * pore * (1.0 - ap), 1.0 - ks_poro)


def sheltered_fraction(rain_map, rain_threshold, width):
    return clip((rain_threshold - rain_map) / width, 0.0, 1.0)


def deposit_coverage(sheltered, m, time, level):
    return sheltered * m / (m + model.DEPOSIT_HALF_ROUGHNESS) * (level * time)


def weathered_coefficients(kd, ks, m, alpha, sp, n_dot_l, n_dot_v, modes, **state):
    """model.weathered_coefficients; ``modes`` already checked, ``state`` holds every input they use."""
    s = weathering_state(state)
    kd, ks = valid_albedo(kd, ks)
    m = maximum(m, 0.0)
    alpha = clip(alpha, 0.0, 1.0)
    sp = maximum(sp, 0.0)
    gp, theta_i, theta_r = pore_geometry(m, n_dot_l, n_dot_v)
    ka = 1.0 - ks - kd
    kd_w, ks_w = porous_weights(kd, ks, alpha, gp, filled_absorption(ka, sp, 0.0, theta_i, theta_r))
    pore = alpha * gp
    water_w = 0.0
    if model.SOILING in modes:
        sheltered = sheltered_fraction(s["rain_map"], s["rain_threshold"], s["front_width"])
        carbon = sheltered * pore_fill(s["edge_map"], s["time"], s["soiling_level"], s["front_width"])
        ap = filled_absorption(ka, sp, carbon, theta_i, theta_r)
        kd_w = blend(kd_w, polluted_diffuse(kd, s["pollution_color"], pore, ap), carbon)
    if model.EFFLORESCENCE in modes:
        salt = pore_fill(s["efflorescence_map"], s["time"], s["efflorescence_level"], s["front_width"])
        ap = filled_absorption(ka, sp, salt, theta_i, theta_r)
        salty = efflorescence_diffuse(kd, s["salt_color"], pore, ap, ks_w)
        kd_w = blend(kd_w, salty, salt)
    if model.WET in modes:
        water = pore_fill(s["rain_map"], s["time"], s["wet_level"], s["front_width"])
        ap = filled_absorption(ka, sp, water, theta_i, theta_r)
        kd_wet, water_lobe = wet_weights(kd, s["water_specular"], pore, ap)
        kd_w = blend(kd_w, kd_wet, water)
        water_w = water * water_lobe
    if model.SOILING in modes:  # the deposit lies on top of whatever fills the pores
        coverage = deposit_coverage(sheltered, m, s["time"], s["soiling_level"])
        kd_w = blend(kd_w, s["deposit_color"], coverage)
        ks_w = ks_w * (1.0 - coverage)
        if model.WET in modes:
            water_w = water_w * (1.0 - coverage)
    return kd_w, ks_w, water_w


def weathered_bsdf(graph, inputs, light_mode, modes):
    """The weathered group's body: the porous lobes with weathered weights, plus the water lobe."""
    n_dot_l, n_dot_v = shading_cosines(graph, inputs, light_mode)
    roughness = inputs["Roughness"]
    state = {name: inputs[socket_name(name)] for name in model.inputs_of(modes)}
    kd_w, ks_w, water_w = weathered_coefficients(inputs["Base Color"], inputs["Specular"], roughness,
                                                 inputs["Porosity"], inputs["Pore Depth Ratio"],
                                                 n_dot_l, n_dot_v, modes, **state)
    bsdf = diffuse_plus_glossy(graph, kd_w, ks_w, roughness)
    results = {"BSDF": bsdf, "Diffuse Weight": kd_w, "Specular Weight": ks_w}
    if model.WET in modes:
        water = graph.node("ShaderNodeBsdfGlossy", {"Color": water_w, "Roughness": inputs["Water Roughness"]},
                           distribution="GGX")
        results["BSDF"] = graph.node("ShaderNodeAddShader", [bsdf, water.outputs[0]]).outputs[0]
        results["Water Weight"] = water_w
    return results
