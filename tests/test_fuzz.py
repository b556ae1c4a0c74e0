"""Property-based tests (hypothesis, derandomised so every run tries the same cases): random
valid parameter sets give finite, physically bounded model results, and the node groups'
'Diffuse Weight' and 'Specular Weight' outputs, read out by emission-probe renders, agree
with model.py at every covered pixel."""

import warnings

import bpy

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks import probes
from porous_weathering.blender import render
from porous_weathering.core import model
from porous_weathering.core.model import PorousInputWarning
from porous_weathering.samples import studio
from porous_weathering.shading import nodes

unit = st.floats(0.0, 1.0)
cosine = st.floats(-1.0, 1.0)


@st.composite
def porous_parameters(draw):
    """(kd RGB, ks, m, alpha, sp), valid: k_s + k_d <= 1 per channel (docs/model.md §1)."""
    ks = draw(unit)
    kd = tuple(draw(st.floats(0.0, 1.0 - ks)) for _ in range(3))
    return kd, ks, draw(st.floats(0.0, 1.5)), draw(unit), draw(st.floats(0.0, 10.0))


@settings(max_examples=300, derandomize=True, deadline=None)
@given(params=porous_parameters(), n_dot_l=st.one_of(st.none(), cosine), n_dot_v=cosine)
def test_valid_parameters_give_finite_weights_within_energy(params, n_dot_l, n_dot_v):
    with warnings.catch_warnings():
        warnings.simplefilter("error", PorousInputWarning)  # valid input is never "corrected"
        kd_poro, ks_poro = model.porous_coefficients(*params, n_dot_l, n_dot_v)
    kd, ks = np.asarray(params[0]), params[1]
    assert np.isfinite(kd_poro).all() and np.isfinite(ks_poro)
    assert kd_poro.min() >= 0.0 and 0.0 <= ks_poro <= ks + 1e-12
    assert np.all(kd_poro + ks_poro <= kd + ks + 1e-9)  # pores never add light (eqs. 2, 3)


weathering_state = st.fixed_dictionaries(
    {
        name: (st.tuples(unit, unit, unit) if np.ndim(default) else st.floats(low, high))
        for name, (default, low, high, _) in model.WEATHERING_INPUTS.items()
    }
)


@settings(max_examples=200, derandomize=True, deadline=None)
@given(
    params=porous_parameters(),
    n_dot_l=st.one_of(st.none(), cosine),
    n_dot_v=cosine,
    modes=st.sets(st.sampled_from(model.MODES), min_size=1),
    state=weathering_state,
)
def test_weathering_of_valid_states_is_finite_and_bounded(params, n_dot_l, n_dot_v, modes, state):
    used = {name: value for name, value in state.items() if name in model.inputs_of(modes)}
    with warnings.catch_warnings():
        warnings.simplefilter("error", PorousInputWarning)
        kd_w, ks_w, water = model.weathered_coefficients(*params, n_dot_l, n_dot_v, modes, **used)
    for weight in (kd_w, ks_w, water):
        assert np.isfinite(weight).all() and np.min(weight) >= -1e-12
    assert np.max(kd_w) <= 1.0 + 1e-9 and np.max(water) <= 1.0 + 1e-9


class WeightProbe:
    """A small sphere seen from +Z under no light: renders emission probes of a porous group's
    weight outputs and knows each pixel's shading normal."""

    SIZE = 16

    def __init__(self, scene):
        self.scene = scene
        self.sphere = studio.add_sphere(scene, segments=32, rings=16)
        studio.add_ortho_camera(scene)
        render.use_cycles(scene, size=self.SIZE, samples=1)
        probe = self.shot(probes.normal_probe())
        self.covered = probe[..., 3] > 0.999
        normals = probe[..., :3] * 2.0 - 1.0
        self.normals = normals / np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-9)

    def shot(self, material):
        studio.assign(self.sphere, material)
        try:
            return render.render_array(self.scene)
        finally:
            bpy.data.materials.remove(material)

    def weights(self, light_mode, inputs):
        """(Diffuse Weight (H, W, 3), Specular Weight (H, W)) rendered for group ``inputs``."""
        group = nodes.porous_group(light_mode)

        def output_of(name):
            def build(graph, geometry):
                node = graph.node("ShaderNodeGroup", node_tree=group)
                for socket, value in inputs.items():
                    node.inputs[socket].default_value = value
                return node.outputs[name]

            return self.shot(probes.emission_probe(f"Probe {name}", build))

        return output_of("Diffuse Weight")[..., :3], output_of("Specular Weight")[..., 0]


def test_node_group_weights_agree_with_the_model(fresh_scene):
    probe = WeightProbe(fresh_scene)  # one scene for every example: its normals are rendered once
    view = probe.normals @ np.array(probes.VIEW_DIRECTION)

    @settings(max_examples=12, derandomize=True, deadline=None)
    @given(params=porous_parameters(), light=st.one_of(st.none(), st.tuples(cosine, cosine, st.floats(0.2, 1.0))))
    def agrees(params, light):
        kd, ks, m, alpha, sp = params
        inputs = {"Base Color": (*kd, 1.0), "Specular": ks, "Roughness": m, "Porosity": alpha, "Pore Depth Ratio": sp}
        if light is None:
            mode, n_dot_l = nodes.AMBIENT, None
        else:
            towards = np.asarray(light) / np.linalg.norm(light)
            mode, n_dot_l = nodes.SUN, probe.normals @ towards
            inputs["Light Direction"] = tuple(towards)
        diffuse, specular = probe.weights(mode, inputs)
        expected_kd, expected_ks = model.porous_coefficients(kd, ks, m, alpha, sp, n_dot_l, view)
        covered = probe.covered
        assert np.abs(diffuse - expected_kd)[covered].max() <= 2e-4
        assert np.abs(specular - np.broadcast_to(expected_ks, covered.shape))[covered].max() <= 2e-4

    assert probe.covered.sum() > 100
    agrees()
