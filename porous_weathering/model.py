"""The porous BRDF post-process of SPEC.md, sections 1-3, in plain vectorised numpy.

This module is the project's one ground truth: the node-group builder (``nodes.py``)
mirrors it line by line and the tests check rendered pixels against it.  It never
imports bpy.

Every function broadcasts its arguments.  A colour quantity (k_d, k_a, A_p, k_d,poro)
carries its RGB channels on the last axis; scalar quantities broadcast against it.
"""

import warnings

import numpy as np

#: Guards the denominator of g() at m = 0 and grazing x = 0 (SPEC 2: g = 0 there).
EPSILON = 1e-6

#: Stands in for +inf in inputs that have no upper bound (m, s_p), so results stay finite.
LARGE = 1e6

#: Three-point Gauss-Legendre rule on [0, 1], used for the ambient mean of g
#: (docs/model.md: its largest error against the exact mean is 1.6e-3).
AMBIENT_NODES = (0.1127016653792583, 0.5, 0.8872983346207417)
AMBIENT_WEIGHTS = (0.2777777777777778, 0.4444444444444444, 0.2777777777777778)

#: Cosine-weighted hemisphere mean of the incidence angle theta_i: pi / 4.
AMBIENT_THETA_I = np.pi / 4


class PorousInputWarning(UserWarning):
    """An input was out of range or NaN and was replaced by the nearest valid value."""


def _warn(message):
    warnings.warn(message, PorousInputWarning, stacklevel=3)


def sanitize(name, value, low=0.0, high=None):
    """``value`` as a float64 array with NaN replaced by ``low`` and clamped to [low, high].

    Warns (PorousInputWarning) naming the input when anything had to change.
    """
    value = np.asarray(value, dtype=np.float64)
    clean = np.nan_to_num(value, nan=low, posinf=LARGE if high is None else high, neginf=low)
    clean = np.clip(clean, low, high)
    if not np.array_equal(clean, value):
        bounds = f"[{low}, {high}]" if high is not None else f">= {low}"
        _warn(f"porous input '{name}' had NaN or values outside {bounds}; clamped")
    return clean


def clamp_cosine(name, x):
    """A cosine clamped to [0, 1] as SPEC 2 defines x: back-facing is 0, not an error; NaN warns."""
    x = np.asarray(x, dtype=np.float64)
    if np.isnan(x).any():
        _warn(f"porous input '{name}' had NaN; taken as 0")
    return np.clip(np.nan_to_num(x, nan=0.0), 0.0, 1.0)


def valid_albedo(kd, ks):
    """(k_d, k_s) with k_d clamped so that k_a = 1 - k_s - k_d >= 0 (SPEC 1)."""
    kd = sanitize("k_d", kd, 0.0, 1.0)
    ks = sanitize("k_s", ks, 0.0, 1.0)
    limit = 1.0 - per_channel(ks, kd)
    if np.any(kd > limit):
        _warn("k_s + k_d > 1: k_d clamped to 1 - k_s so that the absorbed fraction k_a is 0")
    return np.minimum(kd, limit), ks


def shadowing_k(m):
    """k = 2 m^2 / pi, eq. (4)."""
    return 2.0 * m * m / np.pi


def shadowing_g(x, k):
    """One factor of G_p, eq. (4): x / (x(1-k) + k), 0 at x = 0 even when k = 0."""
    x = np.clip(x, 0.0, 1.0)
    return x / np.maximum(x * (1.0 - k) + k, EPSILON)


def ambient_g(k):
    """Cosine-weighted hemisphere mean of g(N.S): 2 * integral_0^1 g(mu, k) mu dmu (SPEC 3)."""
    return sum(2.0 * w * mu * shadowing_g(mu, k) for mu, w in zip(AMBIENT_NODES, AMBIENT_WEIGHTS))


def bounce_count(sp, theta_i, theta_r):
    """n_b, eq. (6): mean number of bounces inside a pore, never negative."""
    return np.maximum(0.0, sp * (3.7 - 2.0 * ((theta_i + theta_r) / 2.0 - 2.0 * np.pi / (sp + 6.0))))


def pore_absorption(ka, nb):
    """A_p, eq. (5) in its stable form 1 - (1 - k_a)^n_b (no 0/0 at k_a = 0)."""
    return 1.0 - np.power(1.0 - ka, nb)


def per_channel(x, kd):
    """Scalar x made to broadcast against the colour k_d (whose last axis is RGB, if any)."""
    return np.asarray(x)[..., None] if np.ndim(kd) else x


def porous_weights(kd, ks, alpha, gp, ap):
    """(k_d,poro, k_s,poro), eqs. (2) and (3)."""
    pore = per_channel(alpha * gp, kd)
    kd_poro = kd * (1.0 - pore * ap) + per_channel(ks, kd) * pore * (1.0 - ap)
    ks_poro = ks * (1.0 - alpha * gp)
    return kd_poro, ks_poro


def pore_geometry(m, n_dot_l, n_dot_v):
    """(G_p, theta_i, theta_r): eq. (4) and the angles of eq. (6); ``n_dot_l=None`` is ambient.

    In the ambient mode (SPEC 3) g(N.S) and theta_i are replaced by their cosine-weighted
    hemisphere means.
    """
    m = sanitize("m", m)
    n_dot_v = clamp_cosine("n_dot_v", n_dot_v)
    k = shadowing_k(m)
    if n_dot_l is None:
        g_light, theta_i = ambient_g(k), AMBIENT_THETA_I
    else:
        n_dot_l = clamp_cosine("n_dot_l", n_dot_l)
        g_light, theta_i = shadowing_g(n_dot_l, k), np.arccos(n_dot_l)
    return g_light * shadowing_g(n_dot_v, k), theta_i, np.arccos(n_dot_v)


def pore_terms(kd, ks, m, sp, n_dot_l, n_dot_v):
    """(G_p, A_p), eqs. (4)-(6), for valid k_d and k_s; ``n_dot_l=None`` is the ambient mode.

    A_p is a colour when k_d is one.
    """
    sp = sanitize("s_p", sp)
    gp, theta_i, theta_r = pore_geometry(m, n_dot_l, n_dot_v)
    nb = bounce_count(sp, theta_i, theta_r)
    ap = pore_absorption(1.0 - per_channel(ks, kd) - kd, per_channel(nb, kd))
    return gp, ap


def porous_coefficients(kd, ks, m, alpha, sp, n_dot_l, n_dot_v):
    """k_d,poro and k_s,poro for a light at N.S = n_dot_l seen at N.V = n_dot_v.

    ``kd`` is an RGB colour (last axis 3) or a scalar grey; the other arguments are
    scalars or arrays that broadcast against it.  ``n_dot_l=None`` gives the ambient
    light mode.  Invalid input is handled as SPEC 1 says (clamped, with a
    PorousInputWarning); the result is always finite.
    """
    kd, ks = valid_albedo(kd, ks)
    alpha = sanitize("alpha", alpha, 0.0, 1.0)
    gp, ap = pore_terms(kd, ks, m, sp, n_dot_l, n_dot_v)
    return porous_weights(kd, ks, alpha, gp, ap)


def porous_coefficients_ambient(kd, ks, m, alpha, sp, n_dot_v):
    """The ambient light mode of SPEC 3 (no light direction)."""
    return porous_coefficients(kd, ks, m, alpha, sp, None, n_dot_v)


# === Weathering (SPEC 4) ================================================================
# The paper's three applications on top of the porous post-process above.  Every state is
# the clean porous weights blended towards a weathered one by a per-point fill fraction, so
# time = 0 is the clean material exactly.  docs/weathering.md explains each decision.

SOILING, WET, EFFLORESCENCE = "soiling", "wet", "efflorescence"
MODES = (SOILING, WET, EFFLORESCENCE)

#: Every weathering input: name -> (default, low, high, the modes that use it).
#: Colours are RGB; the three maps are per-point mask values.
WEATHERING_INPUTS = {
    "time": (0.0, 0.0, 1.0, MODES),
    "front_width": (0.25, 0.01, 1.0, MODES),
    "rain_map": (0.0, 0.0, 1.0, (SOILING, WET)),
    "rain_threshold": (0.5, 0.0, 1.0, (SOILING,)),
    "edge_map": (0.0, 0.0, 1.0, (SOILING,)),
    "soiling_level": (1.0, 0.0, 1.0, (SOILING,)),
    "pollution_color": ((0.03, 0.03, 0.03), 0.0, 1.0, (SOILING,)),
    "deposit_color": ((0.30, 0.29, 0.27), 0.0, 1.0, (SOILING,)),
    "wet_level": (1.0, 0.0, 1.0, (WET,)),
    "water_specular": (1.0, 0.0, 1.0, (WET,)),
    "efflorescence_map": (0.0, 0.0, 1.0, (EFFLORESCENCE,)),
    "efflorescence_level": (1.0, 0.0, 1.0, (EFFLORESCENCE,)),
    "salt_color": ((0.8, 0.8, 0.8), 0.0, 1.0, (EFFLORESCENCE,)),
}

#: Roughness m at which the grey deposit covers half of what it can (grooves trap particles).
DEPOSIT_HALF_ROUGHNESS = 0.5


def weathering_modes(modes):
    """``modes`` (one name or several) as a tuple in MODES order; ValueError for unknown names."""
    modes = (modes,) if isinstance(modes, str) else tuple(modes)
    unknown = set(modes) - set(MODES)
    if unknown:
        raise ValueError(f"unknown weathering modes {sorted(unknown)}; known: {MODES}")
    return tuple(mode for mode in MODES if mode in modes)


def inputs_of(modes):
    """The names of the weathering inputs that ``modes`` use, in WEATHERING_INPUTS order."""
    modes = weathering_modes(modes)
    return [name for name, (*_, users) in WEATHERING_INPUTS.items() if set(users) & set(modes)]


def weathering_state(modes, state):
    """{input: value} for ``modes``: defaults filled in, values clamped (PorousInputWarning).

    An unknown name is a TypeError; a known one that ``modes`` do not use warns and is ignored.
    """
    unknown = set(state) - set(WEATHERING_INPUTS)
    if unknown:
        raise TypeError(f"unknown weathering inputs {sorted(unknown)}; known: {list(WEATHERING_INPUTS)}")
    used = inputs_of(modes)
    unused = sorted(set(state) - set(used))
    if unused:
        _warn(f"weathering inputs {unused} are not used by modes {weathering_modes(modes)}; ignored")
    return {name: sanitize(name, state.get(name, WEATHERING_INPUTS[name][0]), *WEATHERING_INPUTS[name][1:3])
            for name in used}


def fill_curve(progress):
    """The three-phase pore fill of Fig. 3 (smoothstep): slow, fast, then saturated at 1."""
    x = np.clip(progress, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def pore_fill(mask, time, level, width):
    """Fill fraction of the pores: a front sweeps the mask down from 1 as time grows
    (threshold 1 - level * time); behind it a point fills over ``width`` of mask."""
    return fill_curve((mask - (1.0 - level * time)) / width)


def blend(clean, weathered, fill):
    """``clean`` at fill 0 (exactly), ``weathered`` at fill 1."""
    return clean + fill * (weathered - clean)


def filled_absorption(kd, ka, sp, fill, theta_i, theta_r):
    """A_p of pores a fraction ``fill`` full: s_p,eff = s_p (1 - fill) (SPEC 4)."""
    nb = bounce_count(sp * (1.0 - fill), theta_i, theta_r)
    return pore_absorption(ka, per_channel(nb, kd))


def polluted_diffuse(kd, pollution_color, pore, ap):
    """k_d,polluted, eq. (7): carbon in the pores replaces the light they return."""
    return kd * (1.0 - pore) + pollution_color * pore * (1.0 - ap)


def wet_weights(kd, water_specular, pore, ap):
    """(k_d,wet, water-lobe weight): eq. (9), and eq. (8) less its k_s (1 - alpha G_p) part,
    which is k_s,poro and stays on the stone's own glossy lobe."""
    return kd * (1.0 - pore), water_specular * pore * (1.0 - ap)


def efflorescence_diffuse(kd, salt_color, pore, ap, ks_poro):
    """k_d,efflo, eq. (11), capped at 1 - k_s,poro: eq. (11) alone reflects more light than
    arrives on bright stone (k_d + k_s near 1), which must not happen."""
    return np.minimum(kd * (1.0 - pore * ap) + salt_color * pore * (1.0 - ap), 1.0 - ks_poro)


def sheltered_fraction(rain_map, rain_threshold, width):
    """0 in the white (rain-washed) area E >= threshold, rising to 1 over ``width`` below it."""
    return np.clip((rain_threshold - rain_map) / width, 0.0, 1.0)


def deposit_coverage(sheltered, m, time, level):
    """Grey-area deposit (this project's model): grows with time, more on rougher stone."""
    return sheltered * m / (m + DEPOSIT_HALF_ROUGHNESS) * (level * time)


def weathered_coefficients(kd, ks, m, alpha, sp, n_dot_l, n_dot_v, modes=MODES, **state):
    """(k_d, k_s, k_water): the weights of the diffuse lobe, the glossy lobe (roughness m)
    and the near-mirror water lobe of a weathered point.

    ``kd`` is an RGB colour (a scalar is taken as grey); ``modes`` picks among SOILING, WET
    and EFFLORESCENCE; ``state`` holds WEATHERING_INPUTS (defaults for those left out).  At
    time 0 the result is porous_coefficients() exactly, with k_water = 0.  Pore-filling modes
    apply first (carbon, salt, water), then the grey deposit over them.
    """
    modes = weathering_modes(modes)
    s = weathering_state(modes, state)
    kd = np.asarray(kd, dtype=np.float64)
    kd, ks = valid_albedo(kd * np.ones(3) if kd.ndim == 0 else kd, ks)
    m = sanitize("m", m)
    alpha = sanitize("alpha", alpha, 0.0, 1.0)
    sp = sanitize("s_p", sp)
    gp, theta_i, theta_r = pore_geometry(m, n_dot_l, n_dot_v)
    ka = 1.0 - per_channel(ks, kd) - kd
    kd_w, ks_w = porous_weights(kd, ks, alpha, gp, filled_absorption(kd, ka, sp, 0.0, theta_i, theta_r))
    pore = per_channel(alpha * gp, kd)
    water_w = np.zeros_like(kd_w)
    if SOILING in modes:
        sheltered = sheltered_fraction(s["rain_map"], s["rain_threshold"], s["front_width"])
        carbon = sheltered * pore_fill(s["edge_map"], s["time"], s["soiling_level"], s["front_width"])
        ap = filled_absorption(kd, ka, sp, carbon, theta_i, theta_r)
        kd_w = blend(kd_w, polluted_diffuse(kd, s["pollution_color"], pore, ap), per_channel(carbon, kd))
    if EFFLORESCENCE in modes:
        salt = pore_fill(s["efflorescence_map"], s["time"], s["efflorescence_level"], s["front_width"])
        ap = filled_absorption(kd, ka, sp, salt, theta_i, theta_r)
        salty = efflorescence_diffuse(kd, s["salt_color"], pore, ap, per_channel(ks_w, kd))
        kd_w = blend(kd_w, salty, per_channel(salt, kd))
    if WET in modes:
        water = pore_fill(s["rain_map"], s["time"], s["wet_level"], s["front_width"])
        ap = filled_absorption(kd, ka, sp, water, theta_i, theta_r)
        kd_wet, water_lobe = wet_weights(kd, per_channel(s["water_specular"], kd), pore, ap)
        kd_w = blend(kd_w, kd_wet, per_channel(water, kd))
        water_w = per_channel(water, kd) * water_lobe
    if SOILING in modes:  # the deposit lies on top of whatever fills the pores
        coverage = deposit_coverage(sheltered, m, s["time"], s["soiling_level"])
        kd_w = blend(kd_w, s["deposit_color"], per_channel(coverage, kd))
        ks_w = ks_w * (1.0 - coverage)
        if WET in modes:
            water_w = water_w * per_channel(1.0 - coverage, kd)
    return kd_w, ks_w, water_w
