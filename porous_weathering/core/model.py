"""The porous BRDF post-process of docs/model.md and its weathering, in plain vectorised numpy.

This module is the project's one ground truth.  The maths itself is written once, in
``porous.py`` (eqs. 2-6) and ``modes/`` (the weathering modes), and evaluated here on numpy
arrays; ``nodes.py`` builds the shader-node groups from the same lines.  What this module
adds is the checking of inputs: NaN and out-of-range values are clamped with a
PorousInputWarning naming the input.  It never imports bpy.

Every function broadcasts its arguments.  A colour quantity (k_d, k_a, A_p, k_d,poro)
carries its RGB channels on the last axis; scalar quantities broadcast against it.
"""

import warnings
from collections.abc import Iterable, Mapping

import numpy as np
from numpy.typing import ArrayLike

from . import modes as _modes
from . import porous
from .backends import NumpyOps, numpy_ops
from .modes.soiling import DEPOSIT_HALF_ROUGHNESS  # noqa: F401  (public: docs/weathering.md)
from .porous import AMBIENT_NODES, AMBIENT_THETA_I, AMBIENT_WEIGHTS, EPSILON  # noqa: F401  (public)

#: Stands in for +inf in inputs that have no upper bound (m, s_p), so results stay finite.
LARGE = 1e6

#: Scalar maths: no colour channel to broadcast against.
_SCALAR = NumpyOps(colour=False)


class PorousInputWarning(UserWarning):
    """An input was out of range or NaN and was replaced by the nearest valid value."""


def _warn(message):
    warnings.warn(message, PorousInputWarning, stacklevel=3)


def sanitize(name: str, value: ArrayLike, low: float = 0.0, high: float | None = None) -> np.ndarray:
    """``value`` as a float64 array with NaN replaced by ``low`` and clamped to [low, high].

    Warns (PorousInputWarning) naming the input when anything had to change; ValueError naming
    it for what is no number or array of numbers (a string: "0.5" is not taken for 0.5).
    """
    if np.asarray(value).dtype.kind not in "biuf":
        raise ValueError(f"porous input '{name}' must be a number or an array of numbers, not {value!r}")
    value = np.asarray(value, dtype=np.float64)
    clean = np.nan_to_num(value, nan=low, posinf=LARGE if high is None else high, neginf=low)
    clean = np.clip(clean, low, high)
    if not np.array_equal(clean, value):
        bounds = f"[{low}, {high}]" if high is not None else f">= {low}"
        _warn(f"porous input '{name}' had NaN or values outside {bounds}; clamped")
    return clean


def clamp_cosine(name: str, x: ArrayLike) -> np.ndarray:
    """A cosine clamped to [0, 1] as docs/model.md §2 defines x: back-facing is 0, not an error; NaN warns."""
    x = np.asarray(x, dtype=np.float64)
    if np.isnan(x).any():
        _warn(f"porous input '{name}' had NaN; taken as 0")
    return np.clip(np.nan_to_num(x, nan=0.0), 0.0, 1.0)


def valid_albedo(kd: ArrayLike, ks: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(k_d, k_s) with k_d clamped so that k_a = 1 - k_s - k_d >= 0 (docs/model.md §1)."""
    kd = sanitize("k_d", kd, 0.0, 1.0)
    ks = sanitize("k_s", ks, 0.0, 1.0)
    if np.any(kd > 1.0 - per_channel(ks, kd)):
        _warn("k_s + k_d > 1: k_d clamped to 1 - k_s so that the absorbed fraction k_a is 0")
    return porous.valid_albedo(numpy_ops(kd), kd, ks)


def per_channel(x: ArrayLike, kd: ArrayLike) -> np.ndarray:
    """Scalar x made to broadcast against the colour k_d (whose last axis is RGB, if any)."""
    return numpy_ops(kd).channel(x)


def shadowing_k(m: ArrayLike) -> np.ndarray:
    """k = 2 m^2 / pi, eq. (4)."""
    return porous.shadowing_k(m)


def shadowing_g(x: ArrayLike, k: ArrayLike) -> np.ndarray:
    """One factor of G_p, eq. (4): x / (x(1-k) + k), 0 at x = 0 even when k = 0."""
    return porous.shadowing_g(_SCALAR, x, k)


def ambient_g(k: ArrayLike) -> np.ndarray:
    """Cosine-weighted hemisphere mean of g(N.S): 2 * integral_0^1 g(mu, k) mu dmu (docs/model.md §3)."""
    return porous.ambient_g(_SCALAR, k)


def bounce_count(sp: ArrayLike, theta_i: ArrayLike, theta_r: ArrayLike) -> np.ndarray:
    """n_b, eq. (6): mean number of bounces inside a pore, never negative (angles outside
    [0, pi/2], which the BRDF never passes, could make eq. (6) so)."""
    return np.maximum(porous.bounce_count(_SCALAR, sp, theta_i, theta_r), 0.0)


def pore_absorption(ka: ArrayLike, nb: ArrayLike) -> np.ndarray:
    """A_p, eq. (5) in its stable form 1 - (1 - k_a)^n_b (no 0/0 at k_a = 0)."""
    return porous.pore_absorption(_SCALAR, ka, nb)


def porous_weights(
    kd: ArrayLike, ks: ArrayLike, alpha: ArrayLike, gp: ArrayLike, ap: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """(k_d,poro, k_s,poro), eqs. (2) and (3)."""
    xp = numpy_ops(kd)
    return porous.porous_weights(xp, kd, ks, alpha, gp, (1.0 - np.asarray(ap)) * (kd + xp.channel(ks)))


def pore_geometry(
    m: ArrayLike, n_dot_l: ArrayLike | None, n_dot_v: ArrayLike
) -> tuple[np.ndarray, np.ndarray | float, np.ndarray]:
    """(G_p, theta_i, theta_r): eq. (4) and the angles of eq. (6); ``n_dot_l=None`` is ambient.

    In the ambient mode (docs/model.md §3) g(N.S) and theta_i are replaced by their cosine-weighted
    hemisphere means.
    """
    n_dot_l = None if n_dot_l is None else clamp_cosine("n_dot_l", n_dot_l)
    return porous.pore_geometry(_SCALAR, sanitize("m", m), n_dot_l, clamp_cosine("n_dot_v", n_dot_v))


def pore_terms(
    kd: ArrayLike, ks: ArrayLike, m: ArrayLike, sp: ArrayLike, n_dot_l: ArrayLike | None, n_dot_v: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """(G_p, A_p), eqs. (4)-(6), for valid k_d and k_s; ``n_dot_l=None`` is the ambient mode.

    A_p is a colour when k_d is one.
    """
    n_dot_l = None if n_dot_l is None else clamp_cosine("n_dot_l", n_dot_l)
    return porous.pore_terms(
        numpy_ops(kd), kd, ks, sanitize("m", m), sanitize("s_p", sp), n_dot_l, clamp_cosine("n_dot_v", n_dot_v)
    )


def porous_coefficients(
    kd: ArrayLike,
    ks: ArrayLike,
    m: ArrayLike,
    alpha: ArrayLike,
    sp: ArrayLike,
    n_dot_l: ArrayLike | None,
    n_dot_v: ArrayLike,
) -> tuple[np.ndarray, np.ndarray]:
    """k_d,poro and k_s,poro for a light at N.S = n_dot_l seen at N.V = n_dot_v.

    ``kd`` is an RGB colour (last axis 3) or a scalar grey; the other arguments are
    scalars or arrays that broadcast against it.  ``n_dot_l=None`` gives the ambient
    light mode.  Invalid input is handled as docs/model.md §1 says (clamped, with a
    PorousInputWarning); the result is always finite.
    """
    kd, ks = valid_albedo(kd, ks)
    alpha = sanitize("alpha", alpha, 0.0, 1.0)
    n_dot_l = None if n_dot_l is None else clamp_cosine("n_dot_l", n_dot_l)
    return porous.porous_coefficients(
        numpy_ops(kd), kd, ks, sanitize("m", m), alpha, sanitize("s_p", sp), n_dot_l, clamp_cosine("n_dot_v", n_dot_v)
    )


def porous_coefficients_ambient(
    kd: ArrayLike, ks: ArrayLike, m: ArrayLike, alpha: ArrayLike, sp: ArrayLike, n_dot_v: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """The ambient light mode of docs/model.md §3 (no light direction)."""
    return porous_coefficients(kd, ks, m, alpha, sp, None, n_dot_v)


# === Weathering (docs/model.md §4) ================================================================
# The paper's three applications on top of the porous post-process, one module each in
# modes/ (the registry).  docs/weathering.md explains each decision.

SOILING, WET, EFFLORESCENCE = "soiling", "wet", "efflorescence"


def __getattr__(name):
    """MODES and WEATHERING_INPUTS, read from the mode registry when asked (so a mode
    registered later is listed too)."""
    if name == "MODES":
        return _modes.names()
    if name == "WEATHERING_INPUTS":  # name -> (default, low, high, the modes that use it)
        return {
            item.name: (
                item.default,
                item.low,
                item.high,
                tuple(mode for mode in _modes.names() if item in _modes.get(mode).inputs),
            )
            for item in _modes.inputs().values()
        }
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def weathering_modes(modes: str | Iterable[str]) -> tuple[str, ...]:
    """``modes`` (one name or several) as a tuple in registry order; ValueError for unknown names."""
    return _modes.checked(modes)


def inputs_of(modes: str | Iterable[str]) -> list[str]:
    """The names of the weathering inputs that ``modes`` use, in socket order."""
    return [item.name for item in _modes.inputs_of(modes)]


def weathering_state(modes: str | Iterable[str], state: Mapping[str, ArrayLike]) -> dict[str, np.ndarray]:
    """{input: value} for ``modes``: defaults filled in, values clamped (PorousInputWarning).

    An unknown name is a TypeError; a known one that ``modes`` do not use warns and is ignored.
    """
    known = _modes.inputs()
    unknown = set(state) - set(known)
    if unknown:
        raise TypeError(f"unknown weathering inputs {sorted(unknown)}; known: {list(known)}")
    used = _modes.inputs_of(modes)
    unused = sorted(set(state) - {item.name for item in used})
    if unused:
        _warn(f"weathering inputs {unused} are not used by modes {weathering_modes(modes)}; ignored")
    return {item.name: sanitize(item.name, state.get(item.name, item.default), item.low, item.high) for item in used}


def fill_curve(progress: ArrayLike) -> np.ndarray:
    """The three-phase pore fill of Fig. 3 (smoothstep): slow, fast, then saturated at 1."""
    return _modes.base.fill_curve(_SCALAR, progress)


def pore_fill(mask: ArrayLike, time: ArrayLike, level: ArrayLike, width: ArrayLike) -> np.ndarray:
    """Fill fraction of the pores: a front sweeps the mask down from 1 as time grows
    (threshold 1 - level * time); behind it a point fills over ``width`` of mask."""
    return _modes.base.pore_fill(_SCALAR, mask, time, level, width)


def weathered_coefficients(
    kd: ArrayLike,
    ks: ArrayLike,
    m: ArrayLike,
    alpha: ArrayLike,
    sp: ArrayLike,
    n_dot_l: ArrayLike | None,
    n_dot_v: ArrayLike,
    modes: Iterable[str] | None = None,
    *,
    receptivity: ArrayLike | None = None,
    field: ArrayLike | None = None,
    variation: ArrayLike | None = None,
    fields: Mapping[str, tuple[ArrayLike, ...]] | None = None,
    rivulets: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    **state: ArrayLike,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(k_d, k_s, k_water): the weights of the diffuse lobe, the glossy lobe (roughness m)
    and the near-mirror water lobe of a weathered point.

    ``kd`` is an RGB colour (a scalar is taken as grey); ``modes`` picks among the registered
    modes (None: all of them); ``state`` holds their inputs (WEATHERING_INPUTS; defaults for
    those left out).  At time 0 the result is porous_coefficients() exactly, with k_water = 0.
    Pore-filling modes apply first (carbon, salt, the algae, water), then the wet darkening, the
    grey deposit, the algal film and the lichens over them and the black crust over everything;
    ``crust=0, wet_darkening=0`` give the paper's equations exactly (docs/model.md §6).
    ``receptivity`` (docs/model.md §8.3; None: without the stone's structure, as r = 1) makes
    each point's pores fill r times as fast;
    ``field`` (the stone's porosity field z_p, in [-1, 1]) and ``variation`` (v) take every fill and
    cover at the point's place in the stone (docs/model.md §8.7), and ``variation`` mixes the deposit
    with the stone's own colour (docs/model.md §8.6); None: without them.
    ``fields`` holds what a shader reads from the point's place and the modes' records name
    (``Mode.fields``): the biological mode's ``lichen_seeds``, (distance in cells, value, size draw)
    of the nearest seed and then of the second nearest, read back from a render (docs/model.md §9.3);
    without it, no lichen.
    ``rivulets`` = (u, h, spacing): the point's place across the fall line and the rivulet spacing in
    metres, and the horizontal part h of its normal (``modes.base.fall_line``); with ``variation`` it
    gathers the run-off map into rivulets (docs/model.md §8.8).  None: the run-off map as it is.
    """
    point = weathered_point(
        kd,
        ks,
        m,
        alpha,
        sp,
        n_dot_l,
        n_dot_v,
        modes,
        receptivity=receptivity,
        field=field,
        variation=variation,
        fields=fields,
        rivulets=rivulets,
        **state,
    )
    water_w = point.water_w
    return point.kd_w, point.ks_w, np.zeros_like(point.kd_w) + (0.0 if water_w is None else water_w)


def weathered_point(
    kd: ArrayLike,
    ks: ArrayLike,
    m: ArrayLike,
    alpha: ArrayLike,
    sp: ArrayLike,
    n_dot_l: ArrayLike | None,
    n_dot_v: ArrayLike,
    modes: Iterable[str] | None = None,
    *,
    receptivity: ArrayLike | None = None,
    field: ArrayLike | None = None,
    variation: ArrayLike | None = None,
    fields: Mapping[str, tuple[ArrayLike, ...]] | None = None,
    rivulets: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
    **state: ArrayLike,
) -> _modes.Point:
    """The weathered point of ``weathered_coefficients`` (same arguments, checked alike): its
    lobes' weights (``kd_w``, ``ks_w``, ``water_w``: None without a water lobe) and the notes
    its modes' layers leave (``notes``: the condition survey's rules read them, docs/model.md §10)."""
    modes = weathering_modes(_modes.names() if modes is None else modes)
    state = weathering_state(modes, state)
    kd = np.asarray(kd, dtype=np.float64)
    kd, ks = valid_albedo(kd * np.ones(3) if kd.ndim == 0 else kd, ks)
    alpha = sanitize("alpha", alpha, 0.0, 1.0)
    n_dot_l = None if n_dot_l is None else clamp_cosine("n_dot_l", n_dot_l)
    return _modes.weathered_point(
        numpy_ops(kd),
        kd,
        ks,
        sanitize("m", m),
        alpha,
        sanitize("s_p", sp),
        n_dot_l,
        clamp_cosine("n_dot_v", n_dot_v),
        modes,
        state,
        None if receptivity is None else sanitize("receptivity", receptivity),
        None if field is None else sanitize("field", field, -1.0, 1.0),
        None if variation is None else sanitize("variation", variation, 0.0, 1.0),
        {name: tuple(np.asarray(x, dtype=np.float64) for x in value) for name, value in (fields or {}).items()},
        None if rivulets is None else tuple(np.asarray(x, dtype=np.float64) for x in rivulets),
    )
