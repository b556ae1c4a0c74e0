"""The porous BRDF post-process of docs/model.md §2-3, eqs. (2)-(6), written once.

Each function takes a backend ``xp`` (``backends.py``) first: ``model.py`` evaluates these
lines on numpy arrays, ``nodes.py`` builds shader nodes from them.  Inputs are clamped here
the way the node groups clamp theirs; ``model.py`` sanitises (and warns) before calling.
"""

import math

#: Guards denominators that may reach 0 (the crust's second front).
EPSILON = 1e-6
#: The least k in g(): its denominator x (1 - k) + k is then never 0, so no shader node guards
#: it at every point (k folds into a constant), and g = 0 at grazing x = 0 even for m = 0
#: (docs/model.md §2), while any x a float holds still gives g = 1 there (1e-30 is under half an ulp of it).
K_FLOOR = 1e-30

#: Three-point Gauss-Legendre rule on [0, 1], used for the ambient mean of g
#: (docs/model.md: its largest error against the exact mean is 1.6e-3).
AMBIENT_NODES = (0.1127016653792583, 0.5, 0.8872983346207417)
AMBIENT_WEIGHTS = (0.2777777777777778, 0.4444444444444444, 0.2777777777777778)

#: Cosine-weighted hemisphere mean of the incidence angle theta_i: pi / 4.
AMBIENT_THETA_I = math.pi / 4


def valid_albedo(xp, kd, ks):
    """(k_d, k_s) clamped to [0, 1], k_d also to 1 - k_s so that k_a >= 0 (docs/model.md §1): k_d
    to [0, 1 - k_s], which lies in [0, 1]."""
    ks = xp.clip(ks, 0.0, 1.0)
    kd = xp.minimum(xp.maximum(kd, 0.0), 1.0 - xp.channel(ks))
    return kd, ks


def shadowing_k(m):
    """k = 2 m^2 / pi, eq. (4)."""
    return 2.0 * m * m / math.pi


def shadowing_g(xp, x, k):
    """One factor of G_p, eq. (4): x / (x(1-k) + k), 0 at x = 0 even when k = 0 (K_FLOOR)."""
    x = xp.clip(x, 0.0, 1.0)
    k = xp.maximum(k, K_FLOOR)
    return x / xp.multiply_add(x, 1.0 - k, k)


def ambient_g(xp, k):
    """Cosine-weighted hemisphere mean of g(N.S): 2 * integral_0^1 g(mu, k) mu dmu (docs/model.md §3)."""
    terms = [2.0 * w * mu * shadowing_g(xp, mu, k) for mu, w in zip(AMBIENT_NODES, AMBIENT_WEIGHTS)]
    return terms[0] + terms[1] + terms[2]


def bounce_count(xp, sp, theta_i, theta_r, plus=0.0, fill=0.0):
    """n_b + ``plus``, eq. (6), of pores a fraction ``fill`` full, whose depth ratio is then
    s = s_p (1 - fill) (docs/model.md §4.0): s (3.7 - theta_i - theta_r) + 4 pi s / (s + 6).  For angles in
    [0, pi/2] it is never negative (3.7 + 4 pi / (s + 6) > pi >= theta_i + theta_r), so no node
    clamps it.  Written as a multiply-add of s by 3.7 - theta_i - theta_r (one node that every
    fill shares) and 4 pi s / (s + 6) = s / (s / 4 pi + 6 / 4 pi): where s is a constant (an
    empty pore, a fill the material sets) a shader folds all but one multiply-add, and a fill
    that a map drives costs four operations per point."""
    depth = xp.multiply_add(fill, -sp, sp)
    angles = xp.multiply_add(theta_i + theta_r, -1.0, 3.7)
    return xp.multiply_add(depth, angles, depth / xp.multiply_add(depth, 0.25 / math.pi, 1.5 / math.pi)) + plus


def pore_absorption(xp, ka, nb):
    """A_p, eq. (5) in its stable form 1 - (1 - k_a)^n_b (no 0/0 at k_a = 0)."""
    return 1.0 - xp.power(1.0 - ka, nb)


def pore_return(xp, kd, ks, sp, theta_i, theta_r):
    """(1 - A_p)(k_d + k_s): the share of the light entering a pore that leaves it, which is
    (k_d + k_s)^(n_b + 1) since 1 - k_a = k_d + k_s; one power per point."""
    return xp.power(kd + xp.channel(ks), xp.channel(bounce_count(xp, sp, theta_i, theta_r, plus=1.0)))


def porous_weights(xp, kd, ks, alpha, gp, returned):
    """(k_d,poro, k_s,poro), eqs. (2) and (3), from ``returned`` = (1 - A_p)(k_d + k_s)
    (pore_return): eq. (3) is k_d (1 - alpha G_p) + alpha G_p (1 - A_p)(k_d + k_s), one Mix per
    point, and eq. (2) alpha G_p (-k_s) + k_s, one multiply-add."""
    pore = alpha * gp
    return xp.mix(xp.channel(pore), kd, returned), xp.multiply_add(pore, -ks, ks)


def pore_geometry(xp, m, n_dot_l, n_dot_v):
    """(G_p, theta_i, theta_r): eq. (4) and the angles of eq. (6); ``n_dot_l=None`` is ambient,
    where g(N.S) and theta_i are replaced by their cosine-weighted hemisphere means (docs/model.md §3)."""
    m = xp.maximum(m, 0.0)
    n_dot_v = xp.clip(n_dot_v, 0.0, 1.0)
    k = shadowing_k(m)
    if n_dot_l is None:
        g_light, theta_i = ambient_g(xp, k), AMBIENT_THETA_I
    else:
        n_dot_l = xp.clip(n_dot_l, 0.0, 1.0)
        g_light, theta_i = shadowing_g(xp, n_dot_l, k), xp.arccos(n_dot_l)
    return g_light * shadowing_g(xp, n_dot_v, k), theta_i, xp.arccos(n_dot_v)


def pore_terms(xp, kd, ks, m, sp, n_dot_l, n_dot_v):
    """(G_p, A_p), eqs. (4)-(6), for valid k_d and k_s; A_p is a colour when k_d is one."""
    sp = xp.maximum(sp, 0.0)
    gp, theta_i, theta_r = pore_geometry(xp, m, n_dot_l, n_dot_v)
    nb = bounce_count(xp, sp, theta_i, theta_r)
    ap = pore_absorption(xp, 1.0 - xp.channel(ks) - kd, xp.channel(nb))
    return gp, ap


def porous_coefficients(xp, kd, ks, m, alpha, sp, n_dot_l, n_dot_v):
    """k_d,poro and k_s,poro for a light at N.S = n_dot_l seen at N.V = n_dot_v."""
    kd, ks = valid_albedo(xp, kd, ks)
    alpha = xp.clip(alpha, 0.0, 1.0)
    gp, theta_i, theta_r = pore_geometry(xp, m, n_dot_l, n_dot_v)
    return porous_weights(xp, kd, ks, alpha, gp, pore_return(xp, kd, ks, xp.maximum(sp, 0.0), theta_i, theta_r))
