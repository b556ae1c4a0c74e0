"""Wet surfaces (docs/model.md §4, section 4.2 of the paper): water fills the pores where water
reaches first (rain, run-off or rising damp), and a near-mirror water lobe of its own reflects the
sky.  Beyond the paper (docs/model.md §6; ``wet_darkening = 0`` is the paper): the stone under the
water darkens as Ångström and Lekner & Dorf explain, by light the water's surface sends back down to
be absorbed again, and the water's surface reflects as water does, by Fresnel (this project's
decision: docs/model.md).
The front sweeps the water reaching a point, rain or run-off (docs/model.md §7; ``runoff = 0`` is the
rain map alone) or rising damp drawn up from the ground (docs/model.md §9.2; D = 0 is the water from above
alone)."""

from ..patterns import NSD, Pattern, shown
from .base import (
    DAMP_MAP,
    DARKEN_WET,
    FILL_WATER,
    FRONT_WIDTH,
    RAIN_MAP,
    RUNOFF,
    RUNOFF_MAP,
    TIME,
    Input,
    Layer,
    Mode,
    blend,
    filled_absorption,
    local_share,
    pore_fill,
    water_of,
)

#: Refractive index of water in the visible (docs/model.md §6.2).
WATER_INDEX = 1.333

#: r̄: the cosine-weighted hemispherical Fresnel reflectance of water seen from air,
#: 2 ∫_0^{π/2} F(θ) cos θ sin θ dθ for unpolarised light from air (n = 1) into water (n = WATER_INDEX),
#: integrated numerically once (tests/test_weathering_model.py computes it again).
WATER_MEAN_REFLECTANCE = 0.0664057647830794

#: p = 1 - (1 - r̄) / n²: the share of the light the stone scatters up into the water that the
#: water-air surface reflects back down (total internal reflection outside the critical cone).
WATER_INTERNAL_REFLECTANCE = 1.0 - (1.0 - WATER_MEAN_REFLECTANCE) / WATER_INDEX**2

#: F_0 = ((n - 1) / (n + 1))^2: water's reflectance at normal incidence, 0.0204.
WATER_NORMAL_REFLECTANCE = ((WATER_INDEX - 1.0) / (WATER_INDEX + 1.0)) ** 2

WET_LEVEL = Input(
    "wet_level",
    1.0,
    0.0,
    1.0,
    "How far down its water mask (rain, run-off, rising damp) the wet area reaches at t = 1 (lower it to dry)",
)
WATER_SPECULAR = Input("water_specular", 1.0, 0.0, 1.0, "k_s,water: the water lobe's weight (about 1)")
WET_DARKENING = Input(
    "wet_darkening",
    1.0,
    0.0,
    1.0,
    "Wet darkening (beyond the paper; 0 is the paper): how much of the wet area's diffuse light the water "
    "traps (Lekner & Dorf 1988), and how far the water lobe follows water's Fresnel reflectance (2% face on, "
    "a mirror at grazing angles). Dark stones darken more and colours deepen",
    panel=True,
)


def wet_weights(xp, kd, water_specular, pore, ap):
    """(k_d,wet, water-lobe weight): eq. (9), k_d (1 - alpha G_p), and eq. (8) less its
    k_s (1 - alpha G_p) part, which is k_s,poro and stays on the stone's own glossy lobe."""
    return xp.mix(pore, kd, 0.0), water_specular * pore * (1.0 - ap)


def wet_darkening_factor(xp, kd, strength, water):
    """What the diffuse weight is multiplied by, per channel (docs/model.md §6.2): 1 on dry stone, and
    (1 - p) / (1 - p k_d) under water, where light bounces between stone and water surface,
    for the share w = ``strength`` x ``water`` the water covers.  A Mix by w of 1 and that is a
    Mix by ``water`` of 1 and the Mix by ``strength`` (both 1 + w ((1 - p) / (1 - p k_d) - 1)),
    which a shader folds when the darkening and k_d are constants: one node per point."""
    p = WATER_INTERNAL_REFLECTANCE
    return xp.mix(water, 1.0, xp.mix(strength, 1.0, (1.0 - p) / (1.0 - p * kd)))


def fresnel_weight(xp, n_dot_v, strength):
    """(1 - d) + d F: the water lobe's weight for wet darkening d = ``strength``, F water's
    Fresnel reflectance at N.V (0.02 face on, rising to 1 at grazing angles).  Schlick's form
    of F, as glTF's BRDF, F = F_0 + (1 - F_0)(1 - N.V)^5: within 0.01 of the exact unpolarised
    Fresnel for N.V >= 0.5, 0.06 at most (near N.V = 0.1); cosine-weighted mean 0.0670 against
    r̄ = 0.0664 (docs/model.md).  Gathered as (1 - N.V)^5 d (1 - F_0) + 1 - d (1 - F_0): three
    nodes per point, every other term folds to a constant."""
    f0 = WATER_NORMAL_REFLECTANCE
    scale = strength * (1.0 - f0)
    return xp.multiply_add(xp.power(1.0 - n_dot_v, 5.0), scale, 1.0 - scale)


def water_with_damp(xp, state):
    """The water the wet front sweeps: W from above (``water_of``) or rising damp D from below
    (docs/model.md §9.2), 1 - (1 - W)(1 - D), written as W + D (1 - W): one multiply-add of W,
    and W bit for bit at D = 0."""
    water = water_of(xp, state)
    return xp.multiply_add(state["damp_map"], 1.0 - water, water)


def fill_with_water(xp, point):
    s = point.state
    water = local_share(
        xp, pore_fill(xp, water_with_damp(xp, s), s["time"], s["wet_level"], s["front_width"]), point.spread
    )
    ap = filled_absorption(xp, point.ka, point.sp, water, point.theta_i, point.theta_r)
    kd_wet, water_lobe = wet_weights(xp, point.kd, xp.channel(s["water_specular"]), point.pore, ap)
    point.kd_w = blend(xp, point.kd_w, kd_wet, xp.channel(water))
    point.water_w = xp.channel(water) * water_lobe
    point.notes["water"] = water


def darken_under_water(xp, point):
    """Eq. (9)'s wet diffuse, darkened where water covers the stone (w = wet_darkening x fill);
    and eq. (8)'s water lobe, whose k_s,water ~ 1 holds only at grazing angles, weighted by
    water's Fresnel reflectance F: by (1 - d) + d F for d = wet_darkening (docs/model.md)."""
    strength = point.state["wet_darkening"]
    water = xp.channel(point.notes["water"])
    point.kd_w = point.kd_w * wet_darkening_factor(xp, point.kd, xp.channel(strength), water)
    point.water_w = point.water_w * xp.channel(fresnel_weight(xp, point.n_dot_v, strength))


MOIST_AREA = Pattern(
    "moist area",
    NSD + "MoistArea",
    (0.30, 0.50, 0.90),
    "lines",
    shown("water"),
    30,
    "water fills half the pores or more (fill >= 0.5)",
)


MODE = Mode(
    name="wet",
    label="Wet",
    description="Water fills the pores where rain, run-off or rising damp reaches first",
    inputs=(TIME, FRONT_WIDTH, RAIN_MAP, RUNOFF_MAP, RUNOFF, DAMP_MAP, WET_LEVEL, WATER_SPECULAR, WET_DARKENING),
    layers=(Layer(FILL_WATER, fill_with_water), Layer(DARKEN_WET, darken_under_water)),
    catalog="Wet Surfaces",
    asset_summary="Wet surface: water fills the pores where rain, run-off or rising damp reaches first",
    preview=dict(time=1.0, rain_map=1.0),
    water_lobe=True,
    order=20,
    patterns=(MOIST_AREA,),
)
