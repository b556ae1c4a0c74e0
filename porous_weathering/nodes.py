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


def pore_terms(kd, ks, m, sp, n_dot_l, n_dot_v):
    m = maximum(m, 0.0)
    sp = maximum(sp, 0.0)
    n_dot_v = clip(n_dot_v, 0.0, 1.0)
    k = shadowing_k(m)
    if n_dot_l is None:
        g_light, theta_i = ambient_g(k), model.AMBIENT_THETA_I
    else:
        n_dot_l = clip(n_dot_l, 0.0, 1.0)
        g_light, theta_i = shadowing_g(n_dot_l, k), arccos(n_dot_l)
    gp = g_light * shadowing_g(n_dot_v, k)
    nb = bounce_count(sp, theta_i, arccos(n_dot_v))
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
