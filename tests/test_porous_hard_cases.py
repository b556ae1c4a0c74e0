"""Hard cases rendered: the node group stays finite and agrees with model.py (docs/model.md §2)."""

import math
import warnings

import numpy as np
import pytest

import porous_weathering as pw
from benchmarks import probes
from benchmarks.scenes import porous_material
from helpers import TOLERANCE, LitSphere, assert_matches
from porous_weathering.blender import render
from porous_weathering.core import model
from porous_weathering.core.model import PorousInputWarning
from porous_weathering.samples import studio

BASE = dict(kd=(0.5, 0.45, 0.4), ks=0.15, m=0.4, alpha=0.3, sp=2.0)

HARD_CASES = {
    "m=0": dict(m=0.0),
    "k_a=0": dict(kd=(0.85, 0.8, 0.85), ks=0.15),
    "s_p=0": dict(sp=0.0),
    "alpha=1": dict(alpha=1.0),
    "large m and s_p": dict(m=1.5, sp=10.0),
    "black": dict(kd=(0.0, 0.0, 0.0), ks=0.0),
}


@pytest.mark.parametrize("case", HARD_CASES, ids=list(HARD_CASES))
def test_hard_case_matches_model(fresh_scene, case):
    params = {**BASE, **HARD_CASES[case]}
    sphere = LitSphere(fresh_scene, towards=(0.7, 0.0, 0.714))  # the rim reaches grazing N.L and N.V
    image = sphere.render(porous_material(params, sphere.sun))
    expected, mask = sphere.expected(**params)
    assert np.isfinite(image).all()
    if case == "black":
        assert np.abs(image[..., :3]).max() == 0.0
    else:
        assert_matches(image, expected, mask)


def test_alpha_zero_renders_the_base_material_exactly(fresh_scene):
    sphere = LitSphere(fresh_scene, samples=2)
    params = {**BASE, "alpha": 0.0}
    image = sphere.render(porous_material(params, sphere.sun))
    base = sphere.render(pw.make_base_material("Base", base_color=params["kd"], ks=params["ks"], roughness=params["m"]))
    assert np.array_equal(image, base)


def test_too_bright_albedo_is_clamped_in_the_render(fresh_scene):
    sphere = LitSphere(fresh_scene)
    params = {**BASE, "kd": (0.95, 0.9, 0.5), "ks": 0.3}
    with pytest.warns(PorousInputWarning, match="k_s \\+ k_d > 1"):
        material = porous_material(params, sphere.sun)
    image = sphere.render(material)
    with pytest.warns(PorousInputWarning):
        expected, mask = sphere.expected(**params)
    assert_matches(image, expected, mask)
    assert tuple(material.node_tree.nodes["Porous"].inputs["Base Color"].default_value)[:3] == pytest.approx(
        (0.7, 0.7, 0.5)
    )


@pytest.mark.parametrize(
    "field, bad", [("alpha", math.nan), ("m", -0.5), ("sp", math.inf), ("ks", -1.0), ("alpha", 7.0)]
)
def test_invalid_parameters_are_reported_and_render_finite(fresh_scene, field, bad):
    sphere = LitSphere(fresh_scene)
    params = {**BASE, field: bad}
    with pytest.warns(PorousInputWarning, match="clamped|NaN"):
        material = porous_material(params, sphere.sun)
    image = sphere.render(material)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PorousInputWarning)
        expected, mask = sphere.expected(**{**params, "sp": min(params["sp"], 10.0)})
    assert_matches(image, expected, mask)


def test_group_sockets_outside_their_range_stay_finite(fresh_scene):
    """A user (or a texture) can drive the group's sockets anywhere: the group clamps."""
    sphere = LitSphere(fresh_scene)
    material = porous_material(BASE, sphere.sun)
    group = material.node_tree.nodes["Porous"]
    for name, value in {"Specular": 3.0, "Roughness": -2.0, "Porosity": -1.0, "Pore Depth Ratio": -4.0}.items():
        group.inputs[name].default_value = value
    group.inputs["Base Color"].default_value = (-1.0, 2.0, 0.5, 1.0)
    image = sphere.render(material)
    assert np.isfinite(image).all() and image[..., :3].min() >= 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PorousInputWarning)
        expected, mask = sphere.expected(kd=(-1.0, 2.0, 0.5), ks=3.0, m=-2.0, alpha=-1.0, sp=-4.0)
    assert_matches(image, expected, mask)


def test_point_light_position_drives_the_shading(fresh_scene):
    """Point-like key lights: S runs from the shading point to the light (docs/model.md §3)."""
    plane = studio.add_plane(fresh_scene, size=2.0)
    lamp = probes.add_point_light(fresh_scene, (0.6, -0.3, 0.8))
    studio.add_ortho_camera(fresh_scene, scale=2.0)
    render.use_cycles(fresh_scene, size=32, samples=1)

    def shot(material):
        studio.assign(plane, material)
        return render.render_array(fresh_scene)

    positions = (shot(probes.position_probe(scale=0.1))[..., :3] - 0.5) / 0.1
    to_light = np.array(lamp.location) - positions
    n_dot_l = to_light[..., 2] / np.linalg.norm(to_light, axis=-1)
    p = BASE
    diffuse = shot(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0, roughness=p["m"]))[..., :3]
    glossy = shot(pw.make_base_material("G", base_color=(0, 0, 0), ks=1.0, roughness=p["m"]))[..., :3]
    image = shot(porous_material(p, lamp))
    kd_poro, ks_poro = model.porous_coefficients(p["kd"], p["ks"], p["m"], p["alpha"], p["sp"], n_dot_l, 1.0)
    expected = kd_poro * diffuse + ks_poro[..., None] * glossy
    assert_matches(image, expected, np.ones(n_dot_l.shape, bool), tolerance=TOLERANCE)
    lamp.location = (-0.6, 0.3, 0.5)
    assert not np.allclose(shot(porous_material(p, lamp)), image, atol=1e-3)
