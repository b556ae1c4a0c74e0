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


def pore_terms(kd, ks, m, sp, n_dot_l, n_dot_v):
    """(G_p, A_p), eqs. (4)-(6), for valid k_d and k_s; ``n_dot_l=None`` is the ambient mode.

    In the ambient mode (SPEC 3) g(N.S) and theta_i are replaced by their cosine-weighted
    hemisphere means.  A_p is a colour when k_d is one.
    """
    m = sanitize("m", m)
    sp = sanitize("s_p", sp)
    n_dot_v = clamp_cosine("n_dot_v", n_dot_v)
    k = shadowing_k(m)
    if n_dot_l is None:
        g_light, theta_i = ambient_g(k), AMBIENT_THETA_I
    else:
        n_dot_l = clamp_cosine("n_dot_l", n_dot_l)
        g_light, theta_i = shadowing_g(n_dot_l, k), np.arccos(n_dot_l)
    gp = g_light * shadowing_g(n_dot_v, k)
    nb = bounce_count(sp, theta_i, np.arccos(n_dot_v))
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
