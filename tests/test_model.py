"""model.py on its own: known values, hard cases and properties over the whole parameter range."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from porous_weathering.core import model
from porous_weathering.core.model import PorousInputWarning, porous_coefficients


def test_hand_computed_value():
    """One point worked by hand from eqs. (2)-(6)."""
    kd, ks, m, alpha, sp, nl, nv = 0.5, 0.2, 0.5, 0.4, 2.0, 0.8, 0.6
    k = 2 * m * m / math.pi
    g = lambda x: x / (x * (1 - k) + k)  # noqa: E731
    gp = g(nl) * g(nv)
    nb = sp * (3.7 - 2 * ((math.acos(nl) + math.acos(nv)) / 2 - 2 * math.pi / (sp + 6)))
    ka = 1 - kd - ks
    ap = ka * (1 - (1 - ka) ** nb) / (1 - (1 - ka))  # the paper's form of eq. (5)
    kd_poro, ks_poro = porous_coefficients(kd, ks, m, alpha, sp, nl, nv)
    assert kd_poro == pytest.approx(kd * (1 - alpha * gp * ap) + ks * alpha * gp * (1 - ap), rel=1e-12)
    assert ks_poro == pytest.approx(ks * (1 - alpha * gp), rel=1e-12)


def test_alpha_zero_is_the_base_brdf_exactly():
    kd = np.array([0.3, 0.5, 0.7])
    kd_poro, ks_poro = porous_coefficients(kd, 0.2, 0.4, 0.0, 3.0, 0.7, 0.5)
    assert np.array_equal(kd_poro, kd) and ks_poro == 0.2


@pytest.mark.parametrize("nl, nv", [(0.0, 0.7), (0.7, 0.0), (0.0, 0.0), (1e-9, 1e-9)])
@pytest.mark.parametrize("m", [0.0, 1e-8, 0.5, 1.5])
def test_grazing_and_smooth_are_finite(nl, nv, m):
    """docs/model.md §2: at m = 0, g = 1 for x > 0 and g = 0 at x = 0; no NaN or Inf at grazing angles."""
    kd_poro, ks_poro = porous_coefficients((0.6, 0.5, 0.4), 0.1, m, 0.3, 2.0, nl, nv)
    assert np.isfinite(kd_poro).all() and np.isfinite(ks_poro)
    if nl == 0.0 or nv == 0.0:  # G_p = 0: no pore effect at all
        assert np.allclose(kd_poro, (0.6, 0.5, 0.4)) and ks_poro == pytest.approx(0.1)


def test_smooth_surface_g_is_a_step():
    assert model.shadowing_g(np.array([0.0, 1e-6, 0.5, 1.0]), 0.0).tolist() == [0.0, 1.0, 1.0, 1.0]


def test_no_absorption_conserves_energy_exactly():
    """k_a = 0: A_p = 0, and pores only move specular energy into the diffuse term."""
    kd_poro, ks_poro = porous_coefficients(0.7, 0.3, 0.5, 0.4, 2.0, 0.8, 0.9)
    assert kd_poro + ks_poro == pytest.approx(1.0, abs=1e-12)
    assert model.pore_absorption(0.0, 5.0) == 0.0


def test_shallow_pores_do_not_absorb():
    """s_p = 0: no bounces, A_p = 0."""
    _, ap = model.pore_terms(np.array([0.5, 0.4, 0.3]), 0.1, 0.5, 0.0, 0.7, 0.7)
    assert np.array_equal(ap, np.zeros(3))


def test_full_porosity():
    kd_poro, ks_poro = porous_coefficients((0.5, 0.4, 0.3), 0.2, 0.3, 1.0, 4.0, 1.0, 1.0)
    gp = model.shadowing_g(1.0, model.shadowing_k(0.3)) ** 2
    assert gp == pytest.approx(1.0) and ks_poro == pytest.approx(0.0)
    assert np.all(kd_poro < (0.5, 0.4, 0.3))


def test_too_bright_albedo_is_clamped_with_a_warning():
    with pytest.warns(PorousInputWarning, match="k_s \\+ k_d > 1"):
        kd_poro, ks_poro = porous_coefficients((0.9, 0.5, 0.4), 0.3, 0.4, 0.3, 2.0, 0.8, 0.8)
    clamped, _ = porous_coefficients((0.7, 0.5, 0.4), 0.3, 0.4, 0.3, 2.0, 0.8, 0.8)
    assert np.array_equal(kd_poro, clamped)


@pytest.mark.parametrize("bad", [math.nan, -1.0, math.inf, -math.inf])
@pytest.mark.parametrize("which", ["kd", "ks", "m", "alpha", "sp", "nl", "nv"])
def test_invalid_inputs_warn_and_stay_finite(which, bad):
    args = dict(kd=(0.5, 0.4, 0.3), ks=0.1, m=0.4, alpha=0.3, sp=2.0, n_dot_l=0.7, n_dot_v=0.6)
    key = {"nl": "n_dot_l", "nv": "n_dot_v"}.get(which, which)
    args[key] = bad if key != "kd" else (bad, 0.4, 0.3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        kd_poro, ks_poro = porous_coefficients(**args)
    assert np.isfinite(kd_poro).all() and np.isfinite(ks_poro)
    is_clamped_cosine = key in ("n_dot_l", "n_dot_v") and not math.isnan(bad)
    assert is_clamped_cosine or any(issubclass(w.category, PorousInputWarning) for w in caught)


def test_ambient_mean_of_g_matches_the_integral():
    """The 3-point rule stands for 2 * integral g(mu) mu dmu within 1.6e-3 over m in [0, 1.5]."""
    mu = (np.arange(400000) + 0.5) / 400000  # midpoint rule
    for m in np.linspace(0.0, 1.5, 61):
        k = model.shadowing_k(m)
        exact = 2.0 * np.mean(model.shadowing_g(mu, k) * mu)
        assert abs(model.ambient_g(k) - exact) < 1.6e-3, m


def test_ambient_theta_is_the_cosine_weighted_mean():
    theta = np.linspace(0.0, np.pi / 2, 200001)
    weight = np.cos(theta) * np.sin(theta)
    assert np.sum(theta * weight) / np.sum(weight) == pytest.approx(model.AMBIENT_THETA_I, rel=1e-6)


unit = st.floats(0.0, 1.0)
params = dict(
    kd=st.tuples(unit, unit, unit),
    ks=unit,
    m=st.floats(0.0, 1.5),
    alpha=unit,
    sp=st.floats(0.0, 10.0),
    nl=unit,
    nv=unit,
)


@settings(max_examples=400, deadline=None)
@given(**params)
def test_properties_over_the_parameter_range(kd, ks, m, alpha, sp, nl, nv):
    kd = np.minimum(np.array(kd), 1.0 - ks)  # valid input: k_a >= 0
    kd_poro, ks_poro = porous_coefficients(kd, ks, m, alpha, sp, nl, nv)
    _, ap = model.pore_terms(kd, ks, m, sp, nl, nv)
    assert np.isfinite(kd_poro).all() and np.isfinite(ks_poro)
    assert np.all((ap >= 0.0) & (ap <= 1.0))
    assert np.all(kd_poro >= 0.0) and ks_poro >= 0.0
    assert np.all(kd_poro + ks_poro <= kd + ks + 1e-12), "porosity never creates energy"


@settings(max_examples=200, deadline=None)
@given(**params)
def test_ambient_properties(kd, ks, m, alpha, sp, nl, nv):
    kd = np.minimum(np.array(kd), 1.0 - ks)
    kd_poro, ks_poro = porous_coefficients(kd, ks, m, alpha, sp, None, nv)
    assert np.isfinite(kd_poro).all() and np.all(kd_poro + ks_poro <= kd + ks + 1e-12)


def test_vectorised_over_pixels():
    nl = np.linspace(0, 1, 12).reshape(3, 4)
    kd_poro, ks_poro = porous_coefficients((0.5, 0.4, 0.3), 0.1, 0.4, 0.3, 2.0, nl, 0.8)
    assert kd_poro.shape == (3, 4, 3) and ks_poro.shape == (3, 4)
    one, _ = porous_coefficients((0.5, 0.4, 0.3), 0.1, 0.4, 0.3, 2.0, nl[1, 2], 0.8)
    assert np.array_equal(kd_poro[1, 2], one)
