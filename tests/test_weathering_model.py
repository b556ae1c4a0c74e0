"""The weathering section of model.py (docs/model.md §4): exactness at t = 0, bounds and monotone aging;
the extensions beyond the paper (docs/model.md §6: black crust, wet darkening) and their paper-exact
settings; where water goes (docs/model.md §7: run-off in the soiling and wet modes); and the
efflorescence location maps."""

import os
import warnings

import bpy

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from helpers import paper_modes, rain_only_modes
from porous_weathering.common import imageio
from porous_weathering.core import model
from porous_weathering.core.backends import NumpyOps
from porous_weathering.core.modes import soiling, wet
from porous_weathering.maps import efflorescence_map

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
TIMES = np.linspace(0.0, 1.0, 41)
MODE_SETS = [(model.SOILING,), (model.WET,), (model.EFFLORESCENCE,), model.MODES]

unit = st.floats(0.0, 1.0)
colour = st.tuples(unit, unit, unit)


@st.composite
def stones(draw):
    """Valid porous parameters (k_d + k_s <= 1) and a light/view pair; None is the ambient mode."""
    kd = np.array(draw(colour))
    ks = draw(unit) * (1.0 - kd.max())
    kd = np.minimum(kd, 1.0 - ks)  # k_d + k_s <= 1 as the model computes it, not one ulp over
    n_dot_l = draw(st.one_of(st.none(), unit))
    return dict(
        kd=kd,
        ks=ks,
        m=draw(st.floats(0.0, 1.5)),
        alpha=draw(unit),
        sp=draw(st.floats(0.0, 10.0)),
        n_dot_l=n_dot_l,
        n_dot_v=draw(unit),
    )


@st.composite
def masks(draw):
    return dict(
        rain_map=draw(unit),
        edge_map=draw(unit),
        efflorescence_map=draw(unit),
        front_width=draw(st.floats(0.01, 1.0)),
        rain_threshold=draw(unit),
        crust=draw(unit),
        wet_darkening=draw(unit),
        runoff_map=draw(unit),
        runoff=draw(unit),
        streaks=draw(unit),
        # a stone's structure at the point (docs/model.md §8.3, §8.6, §8.7), or none
        structure=draw(
            st.one_of(
                st.none(),
                st.fixed_dictionaries(
                    dict(receptivity=st.floats(0.0, 3.0), field=st.floats(-1.0, 1.0), variation=unit)
                ),
            )
        ),
    )


def weathered(stone, modes, structure=None, **state):
    used = set(model.inputs_of(modes))
    return model.weathered_coefficients(
        stone["kd"],
        stone["ks"],
        stone["m"],
        stone["alpha"],
        stone["sp"],
        stone["n_dot_l"],
        stone["n_dot_v"],
        modes,
        **(structure or {}),
        **{name: value for name, value in state.items() if name in used},
    )


#: The settings under which the extensions beyond the paper (docs/model.md §6) vanish.
PAPER_EXACT = dict(crust=0.0, wet_darkening=0.0)


def over_time(stone, modes, **state):
    """(k_d, k_s, k_water) at every time in TIMES, time on the first axis."""
    kd_w, ks_w, water_w = weathered(stone, modes, time=TIMES, **state)
    return kd_w, np.broadcast_to(ks_w, TIMES.shape)[:, None], water_w


@SETTINGS
@given(stone=stones(), state=masks(), modes=st.sampled_from(MODE_SETS))
def test_time_zero_is_the_clean_material_exactly(stone, state, modes):
    clean = model.porous_coefficients(
        stone["kd"], stone["ks"], stone["m"], stone["alpha"], stone["sp"], stone["n_dot_l"], stone["n_dot_v"]
    )
    kd_w, ks_w, water_w = weathered(stone, modes, time=0.0, **state)
    assert np.array_equal(kd_w, clean[0]) and np.array_equal(ks_w, clean[1])
    assert not water_w.any()


@SETTINGS
@given(stone=stones(), state=masks(), modes=st.sampled_from(MODE_SETS))
def test_no_energy_is_created_and_all_is_finite(stone, state, modes):
    kd_w, ks_w, water_w = over_time(stone, modes, **state)
    total = kd_w + ks_w + water_w
    assert np.isfinite(total).all()
    assert kd_w.min() >= 0.0 and ks_w.min() >= 0.0 and water_w.min() >= 0.0
    assert total.max() <= 1.0 + 1e-12


@SETTINGS
@given(stone=stones(), state=masks(), darkness=unit)
def test_soiling_darkens(stone, state, darkness):
    """With black carbon and a deposit darker than the stone's pore-free part, every step darkens
    (and so with a stone: the deposit filters k_d by at most the deposit over the reference stone's
    darkest channel, docs/model.md §8.6)."""
    deposit = stone["kd"] * (1.0 - stone["alpha"]) * darkness * min(soiling.DEPOSIT_REFERENCE_STONE)
    kd_w, ks_w, _ = over_time(stone, model.SOILING, pollution_color=(0.0, 0.0, 0.0), deposit_color=deposit, **state)
    assert (np.diff(kd_w, axis=0) <= 1e-12).all()
    assert (np.diff(ks_w, axis=0) <= 1e-12).all()


@SETTINGS
@given(stone=stones(), state=masks())
def test_wetting_darkens_the_diffuse_and_raises_the_specular(stone, state):
    kd_w, ks_w, water_w = over_time(stone, model.WET, **state)
    assert (np.diff(kd_w, axis=0) <= 1e-12).all()
    assert (np.diff(ks_w + water_w, axis=0) >= -1e-12).all()
    assert (np.diff(water_w, axis=0) >= -1e-12).all()


@SETTINGS
@given(stone=stones(), state=masks(), salt=unit)
def test_efflorescence_whitens(stone, state, salt):
    """Salt at least as bright as the stone's specular coefficient (white salt: 0.8) whitens."""
    salt = stone["ks"] + salt * (1.0 - stone["ks"])
    kd_w, _, _ = over_time(stone, model.EFFLORESCENCE, salt_color=(salt,) * 3, **state)
    assert (np.diff(kd_w, axis=0) >= -1e-12).all()


def test_each_mode_changes_what_the_paper_says():
    """With the paper-exact settings (crust = 0, wet_darkening = 0): soaked pores: eq. (9)
    diffuse and a water lobe; salt-filled: eq. (11) with s_p = 0; carbon-filled: eq. (7) with
    s_p = 0, under no deposit (smooth stone, m = 0)."""
    kd, ks, alpha = np.array([0.6, 0.5, 0.4]), 0.1, 0.3
    stone = dict(kd=kd, ks=ks, m=0.0, alpha=alpha, sp=3.0, n_dot_l=0.8, n_dot_v=0.9)
    full = dict(time=1.0, front_width=0.1, **PAPER_EXACT)
    gp = 1.0  # m = 0: no shadowing at all
    kd_w, ks_w, water_w = weathered(stone, model.WET, rain_map=1.0, **full)
    assert np.allclose(kd_w, kd * (1 - alpha * gp)) and np.allclose(water_w, alpha * gp)
    assert np.isclose(ks_w, ks * (1 - alpha * gp))
    kd_w, _, _ = weathered(stone, model.EFFLORESCENCE, efflorescence_map=1.0, salt_color=(0.8,) * 3, **full)
    assert np.allclose(kd_w, np.minimum(kd + 0.8 * alpha * gp, 1 - ks * (1 - alpha * gp)))
    pollution = np.array([0.02, 0.03, 0.04])
    kd_w, _, _ = weathered(stone, model.SOILING, edge_map=1.0, pollution_color=pollution, **full)
    assert np.allclose(kd_w, kd * (1 - alpha * gp) + pollution * alpha * gp)


def test_white_area_stays_clean_and_grey_area_takes_the_deposit():
    stone = dict(kd=np.array([0.7, 0.6, 0.5]), ks=0.1, m=0.8, alpha=0.3, sp=2.0, n_dot_l=0.7, n_dot_v=0.9)
    clean = weathered(stone, model.SOILING, time=0.0)
    washed = weathered(stone, model.SOILING, time=1.0, rain_map=0.9, edge_map=1.0)
    assert np.array_equal(washed[0], clean[0])
    deposit = np.array([0.3, 0.29, 0.27])
    grey = weathered(stone, model.SOILING, time=1.0, rain_map=0.0, edge_map=0.0, deposit_color=deposit)
    coverage = 0.8 / (0.8 + model.DEPOSIT_HALF_ROUGHNESS)
    assert np.allclose(grey[0], clean[0] + coverage * (deposit - clean[0]))
    assert np.isclose(grey[1], clean[1] * (1 - coverage))


# --- beyond the paper (docs/model.md §6): black crust and wet darkening ------------------------------


@SETTINGS
@given(stone=stones(), state=masks(), time=unit, modes=st.sampled_from(MODE_SETS))
def test_paper_exact_settings_are_the_paper_bit_for_bit(stone, state, time, modes):
    """crust = 0 and wet_darkening = 0 give, bit for bit, the modes without the layers beyond
    the paper (their records as the paper writes them)."""
    with paper_modes(modes) as paper:
        extended = weathered(stone, modes, time=time, **{**state, **PAPER_EXACT})
        as_paper = weathered(stone, paper, time=time, **state)
    for got, want in zip(extended, as_paper):
        assert np.array_equal(got, want)


# --- where water goes (docs/model.md §7): run-off in the modes ----------------------------------------

#: The settings under which run-off changes nothing (docs/model.md §7.2).
WITHOUT_RUNOFF = dict(runoff=0.0, streaks=0.0)


@SETTINGS
@given(stone=stones(), state=masks(), time=unit, modes=st.sampled_from(MODE_SETS))
def test_no_runoff_is_the_model_before_runoff_bit_for_bit(stone, state, time, modes):
    """runoff = 0 and streaks = 0 give, bit for bit, the modes as they were before run-off (E
    where they read W, no streaks: helpers.rain_only_modes), whatever the run-off map; and so
    does a run-off map of 0 at any runoff and streaks."""
    with rain_only_modes(modes) as before:
        as_before = weathered(stone, before, time=time, **state)
    without = weathered(stone, modes, time=time, **{**state, **WITHOUT_RUNOFF})
    no_map = weathered(stone, modes, time=time, **{**state, "runoff_map": 0.0})
    for got, map_zero, want in zip(without, no_map, as_before):
        assert np.array_equal(got, want) and np.array_equal(map_zero, want)


STONE = dict(kd=np.array([0.7, 0.6, 0.5]), ks=0.1, m=0.8, alpha=0.3, sp=2.0, n_dot_l=0.7, n_dot_v=0.9)


def clean_stone():
    return model.porous_coefficients(*(STONE[k] for k in ("kd", "ks", "m", "alpha", "sp", "n_dot_l", "n_dot_v")))


def test_water_is_rain_or_runoff():
    """W = 1 - (1 - E)(1 - runoff R) is what the wet front sweeps: E = 0.3, R = 0.5 and
    runoff = 0.6 wet a point as E = 0.51 does without run-off."""
    state = dict(time=0.7, front_width=0.3)
    with_runoff = weathered(STONE, model.WET, rain_map=0.3, runoff_map=0.5, runoff=0.6, **state)
    rain_alone = weathered(STONE, model.WET, rain_map=1 - 0.7 * 0.7, runoff_map=0.0, **state)
    for got, want in zip(with_runoff, rain_alone):
        assert np.allclose(got, want, rtol=1e-14, atol=0) and want.any()


def test_runoff_washes_and_wets_where_no_rain_falls():
    """E = 0, R = 1, runoff = 1: W = 1, in the white area (the clean porous material at every t,
    crust and streaks included), and soaked at t = 1 as a point in the rain is."""
    clean = clean_stone()
    runoff = dict(rain_map=0.0, runoff_map=1.0, runoff=1.0, edge_map=1.0, crust=1.0, streaks=1.0)
    kd_w, ks_w, water_w = weathered(STONE, model.SOILING, time=TIMES, **runoff)
    assert np.array_equal(kd_w, np.broadcast_to(clean[0], kd_w.shape)) and np.array_equal(
        np.broadcast_to(ks_w, TIMES.shape), np.full(TIMES.shape, clean[1])
    )
    sheltered = weathered(STONE, model.SOILING, time=1.0, **{**runoff, "runoff": 0.0})
    assert np.abs(sheltered[0] - clean[0]).min() > 0.05  # without the run-off, the same point is black
    wet_runoff = weathered(STONE, model.WET, time=1.0, rain_map=0.0, runoff_map=1.0, runoff=1.0)
    in_rain = weathered(STONE, model.WET, time=1.0, rain_map=1.0, runoff_map=0.0)
    dry = weathered(STONE, model.WET, time=1.0, rain_map=0.0, runoff_map=1.0, runoff=0.0)
    for got, want in zip(wet_runoff, in_rain):
        assert np.array_equal(got, want)
    assert in_rain[2].min() > 0.0 and not dry[2].any()


def test_dirty_streaks_darken_where_runoff_is_half_the_washing_water():
    """u = runoff R / rain_threshold = 0.5 (R = 0.25, threshold 0.5): tail 4 u (1 - u) = 1, so at
    t = 1, streaks = 1, a sheltered point (E = 0) is all deposit: darker than with R = 0, where
    there is no tail; the streaks alone make the difference (streaks = 0 gives R = 0's weights)."""
    deposit = np.array([0.1, 0.09, 0.08])
    state = dict(time=1.0, rain_map=0.0, streaks=1.0, rain_threshold=0.5, front_width=0.25, deposit_color=deposit)
    streaked = weathered(STONE, model.SOILING, runoff_map=0.25, **state)
    plain = weathered(STONE, model.SOILING, runoff_map=0.0, **state)
    assert (streaked[0] < plain[0]).all() and streaked[1] < plain[1]
    assert np.allclose(streaked[0], deposit, rtol=1e-14) and streaked[1] == 0.0
    no_streaks = weathered(STONE, model.SOILING, runoff_map=0.25, **{**state, "streaks": 0.0})
    assert np.array_equal(no_streaks[0], plain[0]) and no_streaks[1] == plain[1]
    tail = soiling.streak_tail(NumpyOps(colour=False), np.array([0.0, 0.125, 0.25, 0.375, 0.5, 0.9]), 1.0, 0.5)
    assert np.allclose(tail, [0.0, 0.75, 1.0, 0.75, 0.0, 0.0], rtol=0, atol=1e-15)


def test_streaks_compose_with_the_deposit_as_two_covers():
    """One cover of c + d (1 - c) is the deposit's cover c followed by the streaks' cover d:
    k_d -> (k_d (1 - c) + col c)(1 - d) + col d, k_s -> k_s (1 - c)(1 - d) (docs/model.md §7.2),
    over the clean stone here (the edge mask 0 is not reached by t = 0.7: no carbon, no crust)."""
    deposit = np.array([0.3, 0.29, 0.27])
    state = dict(time=0.7, rain_map=0.1, rain_threshold=0.6, front_width=0.8, deposit_color=deposit)
    streaked = weathered(STONE, model.SOILING, runoff_map=0.2, runoff=0.9, streaks=0.6, **state)
    plain = weathered(STONE, model.SOILING, runoff_map=0.2, runoff=0.9, streaks=0.0, **state)
    rain_alone = weathered(STONE, model.SOILING, runoff_map=0.0, **state)
    water = 1 - (1 - 0.1) * (1 - 0.9 * 0.2)
    sheltered = (0.6 - water) / 0.8
    c = STONE["m"] / (STONE["m"] + model.DEPOSIT_HALF_ROUGHNESS) * 0.7 * sheltered
    u = 0.9 * 0.2 / 0.6
    d = 0.6 * 4 * u * (1 - u) * 0.7 * sheltered
    clean = clean_stone()
    assert np.allclose(plain[0], clean[0] * (1 - c) + deposit * c, rtol=1e-13)
    assert np.allclose(streaked[0], (clean[0] * (1 - c) + deposit * c) * (1 - d) + deposit * d, rtol=1e-13)
    assert streaked[1] == pytest.approx(clean[1] * (1 - c) * (1 - d), rel=1e-13) and 0.05 < d < c
    assert np.abs(plain[0] - rain_alone[0]).min() > 1e-3  # the run-off moved the sheltered fraction


def fresnel(cos_i, n):
    """Unpolarised Fresnel reflectance from air into a medium of index ``n``."""
    cos_t = np.sqrt(1.0 - (1.0 - cos_i**2) / n**2)
    rs = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    rp = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    return (rs**2 + rp**2) / 2.0


def test_water_mean_reflectance_is_the_hemispherical_fresnel_integral():
    """r̄ = 2 ∫ F(θ) cos θ sin θ dθ = 2 ∫_0^1 F(μ) μ dμ (64-point Gauss-Legendre in μ = cos θ)."""
    nodes, weights = np.polynomial.legendre.leggauss(64)
    mu = (nodes + 1.0) / 2.0
    r_mean = np.sum(weights / 2.0 * 2.0 * fresnel(mu, wet.WATER_INDEX) * mu)
    assert wet.WATER_MEAN_REFLECTANCE == pytest.approx(r_mean, abs=1e-13)
    assert fresnel(1.0, wet.WATER_INDEX) < r_mean < 0.07  # more than at normal incidence
    assert wet.WATER_INTERNAL_REFLECTANCE == pytest.approx(0.4746, abs=5e-5)  # docs/model.md


def test_wet_darkening_is_lekner_and_dorf():
    """Over the water-covered fraction w = wet_darkening x water fill, eq. (9)'s diffuse is
    multiplied by (1 - w) + w (1 - p) / (1 - p k_d) per channel, and the water lobe by
    (1 - d) + d F(N.V) for d = wet_darkening (water's Fresnel reflectance, Schlick's form,
    F_0 = (0.333 / 2.333)^2); the stone's glossy lobe does not change."""
    p = wet.WATER_INTERNAL_REFLECTANCE
    kd, alpha = np.array([0.6, 0.3, 0.1]), 0.3
    stone = dict(kd=kd, ks=0.1, m=0.0, alpha=alpha, sp=3.0, n_dot_l=0.8, n_dot_v=0.9)
    for rain_map, fill in ((1.0, 1.0), (0.05, 0.5)):  # soaked, and half full (time 1, width 0.1)
        state = dict(time=1.0, front_width=0.1, rain_map=rain_map)
        assert model.pore_fill(rain_map, 1.0, 1.0, 0.1) == fill
        paper = weathered(stone, model.WET, wet_darkening=0.0, **state)
        for strength in (1.0, 0.4):
            covered = strength * fill
            kd_w, ks_w, water_w = weathered(stone, model.WET, wet_darkening=strength, **state)
            assert np.allclose(kd_w, paper[0] * ((1 - covered) + covered * (1 - p) / (1 - p * kd)), rtol=1e-14)
            schlick = 0.0203732 + (1 - 0.0203732) * (1 - 0.9) ** 5  # at N.V = 0.9
            assert ks_w == paper[1] and np.allclose(water_w, paper[2] * ((1 - strength) + strength * schlick))
    soaked = weathered(stone, model.WET, wet_darkening=1.0, time=1.0, front_width=0.1, rain_map=1.0)
    assert np.allclose(soaked[0], kd * (1 - alpha) * (1 - p) / (1 - p * kd))
    darkening = soaked[0] / (kd * (1 - alpha))
    assert darkening[0] > darkening[1] > darkening[2]  # dark channels darken more: colours deepen


def test_the_water_lobe_reflects_as_water_does():
    """With wet_darkening = 1 the water lobe's weight is eq. (8)'s times water's reflectance:
    Schlick's form, within 0.01 of the exact Fresnel for N.V >= 0.5 and 0.06 at grazing angles,
    2% face on, the paper's weight at N.V = 0 (docs/model.md)."""
    cosines = np.linspace(0.0, 1.0, 2001)
    schlick = wet.fresnel_weight(NumpyOps(colour=False), cosines, 1.0)  # the weight at d = 1: F
    exact = fresnel(cosines, wet.WATER_INDEX)
    assert np.abs(schlick - exact)[cosines >= 0.5].max() < 0.01
    assert np.abs(schlick - exact).max() < 0.06
    assert schlick[-1] == pytest.approx(exact[-1], abs=1e-12) and schlick[0] == 1.0
    stone = dict(kd=np.array([0.6, 0.3, 0.1]), ks=0.1, m=0.3, alpha=0.3, sp=3.0, n_dot_l=0.8)
    soaked = dict(modes=model.WET, time=1.0, rain_map=1.0)
    for index in (2000, 1000, 10):  # N.V = 1, 0.5, 0.005
        paper = model.weathered_coefficients(**stone, n_dot_v=cosines[index], wet_darkening=0.0, **soaked)
        water = model.weathered_coefficients(**stone, n_dot_v=cosines[index], **soaked)[2]
        assert paper[2].min() > 0.0 and np.allclose(water, paper[2] * schlick[index], rtol=1e-12)


def test_crust_covers_a_fully_black_point_with_its_coverage():
    """At t = 1, level 1, a fully black point (sheltered, edge mask 1): c = crust exactly, laid
    over all beneath: k_d -> k_d,pollution by c, k_s and the water lobe lose c."""
    stone = dict(kd=np.array([0.6, 0.5, 0.4]), ks=0.1, m=0.6, alpha=0.3, sp=2.0, n_dot_l=0.7, n_dot_v=0.9)
    pollution = np.array([0.02, 0.03, 0.04])
    # E = 0.2: sheltered (threshold 0.5 - width 0.25) yet wet (the water front has reached E = 0)
    black = dict(time=1.0, rain_map=0.2, edge_map=1.0, rain_threshold=0.5, front_width=0.25, pollution_color=pollution)
    modes = (model.SOILING, model.WET, model.EFFLORESCENCE)
    beneath = weathered(stone, modes, crust=0.0, efflorescence_map=0.9, **black)
    assert beneath[2].min() > 0.0, "the water lobe lies beneath the crust too"
    for crust in (1.0, 0.35):
        kd_w, ks_w, water_w = weathered(stone, modes, crust=crust, efflorescence_map=0.9, **black)
        assert np.allclose(kd_w, (1 - crust) * beneath[0] + crust * pollution, rtol=1e-14)
        assert ks_w == pytest.approx((1 - crust) * beneath[1], rel=1e-14)
        assert np.allclose(water_w, (1 - crust) * beneath[2], rtol=1e-14)


def test_crust_grows_behind_the_carbon_front():
    """c = crust x sheltered x smoothstep((C - (1 - level t) - w) / (1 - w)): none until a point's
    pores are full (there the result is the crust-free one bit for bit), then a second front."""
    stone = dict(kd=np.array([0.6, 0.5, 0.4]), ks=0.1, m=0.6, alpha=0.3, sp=2.0, n_dot_l=0.7, n_dot_v=0.9)
    edge, width, time, level, crust = np.array([0.4, 0.6, 0.8, 1.0]), 0.25, 0.9, 0.8, 0.7
    state = dict(time=time, soiling_level=level, rain_map=0.35, rain_threshold=0.5, edge_map=edge, front_width=width)
    sheltered = (0.5 - 0.35) / width  # E = 0.35 below the threshold 0.5
    _, bare, _ = weathered(stone, model.SOILING, crust=0.0, **state)
    kd_w, ks_w, _ = weathered(stone, model.SOILING, crust=crust, **state)
    progress = np.clip((edge - (1 - level * time) - width) / (1 - width), 0.0, 1.0)
    expected = crust * sheltered * progress**2 * (3 - 2 * progress)
    assert np.allclose(1.0 - ks_w / bare, expected, rtol=1e-12, atol=1e-15)
    assert 0.0 < model.pore_fill(edge[0], time, level, width) < 1.0 and ks_w[0] == bare[0] and expected[1:].all()
    assert np.array_equal(kd_w[0], weathered(stone, model.SOILING, crust=0.0, **state)[0][0])


def test_fill_curve_has_three_phases():
    x = np.linspace(0.0, 1.0, 1001)
    f = model.fill_curve(x)
    assert f[0] == 0.0 and f[-1] == 1.0 and (np.diff(f) >= 0).all()
    slope = np.gradient(f, x)
    slow_end, fast_end = (3 - np.sqrt(3)) / 6, (3 + np.sqrt(3)) / 6  # where the rate is the mean rate
    assert (slope[x < slow_end - 1e-3] < 1).all() and (slope[(x > slow_end + 1e-3) & (x < fast_end - 1e-3)] > 1).all()
    assert model.fill_curve(1.7) == 1.0 and model.fill_curve(-0.2) == 0.0  # saturated, and not started


def test_the_front_reaches_the_highest_mask_first():
    fills = model.pore_fill(np.array([1.0, 0.8, 0.5]), 0.3, 1.0, 0.25)
    assert fills[0] > fills[1] > fills[2] == 0.0


@pytest.mark.parametrize(
    "name, value, clamped",
    [
        ("time", 1.7, 1.0),
        ("time", -0.3, 0.0),
        ("rain_map", 2.0, 1.0),
        ("edge_map", np.nan, 0.0),
        ("front_width", 0.0, 0.01),
    ],
)
def test_out_of_range_inputs_are_clamped_with_a_warning(name, value, clamped):
    stone = dict(kd=np.array([0.6, 0.5, 0.4]), ks=0.1, m=0.5, alpha=0.3, sp=2.0, n_dot_l=0.7, n_dot_v=0.9)
    base = dict(time=0.6, rain_map=0.2, edge_map=0.8, front_width=0.2)
    with pytest.warns(model.PorousInputWarning, match=name):
        result = weathered(stone, model.MODES, **{**base, name: value})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        expected = weathered(stone, model.MODES, **{**base, name: clamped})
    for got, want in zip(result, expected):
        assert np.array_equal(got, want) and np.isfinite(got).all()


def test_modes_and_inputs_are_checked():
    with pytest.raises(ValueError, match="rust"):
        model.weathering_modes(("soiling", "rust"))
    with pytest.raises(TypeError, match="wetness"):
        model.weathering_state(model.WET, {"wetness": 1.0})
    with pytest.warns(model.PorousInputWarning, match="salt_color"):
        model.weathering_state(model.WET, {"salt_color": (1, 1, 1)})
    assert model.weathering_modes(["wet", "soiling"]) == ("soiling", "wet")
    assert "edge_map" not in model.inputs_of(model.WET) and "salt_color" not in model.inputs_of(model.SOILING)


# --- efflorescence location maps --------------------------------------------------------


def test_brick_map_is_highest_along_the_joints():
    height = efflorescence_map.brick_joint_map(128, rows=8, bricks_per_row=4, noise=0.0)
    assert height.shape == (128, 128) and height.dtype == np.float32
    assert height.min() == 0.0 and height.max() == 1.0
    bed_joint, brick_middle = height[64], height[72]  # v = 0.5 is a joint; v = 0.4375 mid-course
    assert bed_joint.min() > 0.99 and np.median(brick_middle) < 0.1  # head joints cross it too
    noisy = efflorescence_map.brick_joint_map(128, seed=1)
    assert np.array_equal(noisy, efflorescence_map.brick_joint_map(128, seed=1))
    assert not np.array_equal(noisy, efflorescence_map.brick_joint_map(128, seed=2))


def test_photo_map_is_denoised_normalised_luminance(tmp_path):
    """A bright salt patch on dark brick, with salt-and-pepper grain: the map keeps the patch."""
    rng = np.random.default_rng(0)
    photo = np.full((64, 64, 3), (0.35, 0.12, 0.08), dtype=np.float32)
    photo[20:44, 10:54] = 0.9
    grain = rng.random((64, 64)) < 0.03
    photo[grain] = rng.choice([0.0, 1.0], size=(grain.sum(), 1))
    path = tmp_path / "salt.png"
    imageio.write_image(path, photo)
    height = efflorescence_map.photo_map(path, denoise_width=3)
    assert height.min() == 0.0 and height.max() == 1.0
    assert height[24:40, 14:50].min() > 0.95 and height[:14].max() < 0.05  # grain gone, patch kept
    with pytest.raises(OSError, match="gone.png"):
        efflorescence_map.photo_map(tmp_path / "gone.png")


def test_photo_map_is_upright_as_a_viewer_shows_the_photograph(tmp_path):
    """A camera held upright stores its sensor's rows turned and says so in the Exif
    orientation (6: turn 90° clockwise to view): the map is the photograph as seen."""
    import OpenImageIO as oiio

    stored = np.zeros((40, 60, 3), dtype=np.float32)
    stored[:, :10] = 1.0  # the stored image's left edge: the viewed image's top
    spec = oiio.ImageSpec(60, 40, 3, oiio.UINT8)
    spec.attribute("Orientation", 6)
    path = str(tmp_path / "upright.jpg")
    output = oiio.ImageOutput.create(path)
    assert output.open(path, spec) and output.write_image(stored) and output.close()
    height = efflorescence_map.photo_map(path, denoise_width=1)
    assert height.shape == (60, 40)
    assert height[:8].min() > 0.9 and height[12:].max() < 0.1


def test_map_is_saved_beside_the_blend(tmp_path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with pytest.raises(ValueError, match="save the .blend"):
        efflorescence_map.default_path("Wall")
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "wall.blend"))
    path = efflorescence_map.save_map(efflorescence_map.brick_joint_map(32), efflorescence_map.default_path("Wall"))
    assert path == str(tmp_path / "Wall.efflorescence.exr")
    # names a file name cannot hold as they are stay apart, as bake names its maps
    apart = {efflorescence_map.default_path(name) for name in ("Wall/1", "Wall_1", "Wall:1", "Wall.001", "Wall_001")}
    assert len(apart) == 5 and all(os.path.dirname(p) == str(tmp_path) for p in apart)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temporary left
    pixels, _ = imageio.read_image(path)
    assert np.array_equal(pixels[..., 0], efflorescence_map.brick_joint_map(32))


def test_every_input_may_vary_per_point():
    """Arrays of points (as the benchmarks and the reference renderer pass them) give each
    point what it gets alone, every weathering input included."""
    rng = np.random.default_rng(7)
    count = 5
    state = {
        name: rng.uniform(low, high, count) if np.ndim(default) == 0 else rng.uniform(0.0, 1.0, (count, 3))
        for name, (default, low, high, _) in model.WEATHERING_INPUTS.items()
    }
    stone = dict(
        kd=rng.uniform(0.0, 0.5, (count, 3)),
        ks=rng.uniform(0.0, 0.4, count),
        m=rng.uniform(0.0, 1.5, count),
        alpha=rng.uniform(0.0, 1.0, count),
        sp=rng.uniform(0.0, 10.0, count),
        n_dot_l=rng.uniform(0.0, 1.0, count),
        n_dot_v=rng.uniform(0.0, 1.0, count),
    )
    together = weathered(stone, model.MODES, **state)
    for point in range(count):
        alone = weathered(
            {k: v[point] for k, v in stone.items()}, model.MODES, **{k: v[point] for k, v in state.items()}
        )
        for all_points, one_point in zip(together, alone):  # k_d, k_s (one value a point), k_water
            assert np.allclose(all_points[point], one_point, rtol=1e-12, atol=1e-15)
