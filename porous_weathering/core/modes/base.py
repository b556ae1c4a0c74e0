"""The records a weathering mode is made of, and the maths the modes share (docs/model.md §4).

A mode is one ``Mode`` record: its inputs, its asset metadata, and its maths as ``Layer``
functions written once against a backend ``xp`` (``backends.py``) that either evaluates
numpy arrays (the model) or builds shader nodes (the groups).  Layers of every mode a
material uses run in the order of their ``stage`` on one ``Point``: pore-filling layers
first (carbon, salt, the algae, water, then the wet darkening), then layers lying over the
surface (the grey deposit, the algal film and the lichens, then the black crust over
everything: docs/model.md §4.4, §9.3).
"""

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ...contracts import socket_name
from .. import porous

#: Stages: where a layer runs among those of the other modes.  The extensions beyond the paper
#: (docs/model.md §6) are layers of their own: the wet darkening right after the water fill, the crust last.
FILL_CARBON, FILL_SALT, FILL_WATER, DARKEN_WET, COVER_DEPOSIT, COVER_CRUST = 10, 20, 30, 35, 40, 50
#: Life (docs/model.md §9.3): the algae fill the pores beside the salt, and lie over the deposit, the
#: lichens over them; a black crust (soot cemented by gypsum) forms over what lives there.
FILL_ALGAE, COVER_ALGAE, COVER_LICHEN = 25, 42, 45


@dataclass(frozen=True)
class Input:
    """One weathering input: a keyword of make_weathered_material and a group socket."""

    name: str
    default: float | tuple
    low: float
    high: float
    tooltip: str
    #: A per-point mask: a number, an image or a colour attribute (weathering.mask_source).
    mask: bool = False
    #: The map that feeds this mask: a maps-registry name (baked) or one the panel makes.
    map: str | None = None
    #: A scalar the artist's panel shows (and its Make button passes), stone presets may set.
    panel: bool = False
    #: The map read in its place where the object has no ``map`` (docs/model.md §7.2).
    fallback_map: str | None = None
    #: A clock that Years and Keyframe Aging set (docs/model.md §9.4): "age", the soiling's t by
    #: the site's law; "years", the years themselves.
    clock: str | None = None

    @property
    def socket(self) -> str:
        """The group input's name: 'rain_map' -> 'Rain Map'."""
        return socket_name(self.name)

    @property
    def is_colour(self) -> bool:
        return isinstance(self.default, tuple)


@dataclass
class Point:
    """A shading point as the layers weather it: the clean stone's terms, and the weights of
    the diffuse, glossy and water lobes that each layer updates."""

    kd: Any  #: k_d, clamped (a colour)
    ka: Any  #: k_a = 1 - k_s - k_d
    m: Any
    sp: Any
    pore: Any  #: alpha * G_p, per channel
    theta_i: Any
    theta_r: Any
    n_dot_v: Any  #: N.V, clamped to [0, 1]
    kd_w: Any  #: diffuse weight
    ks_w: Any  #: glossy weight (roughness m)
    state: dict  #: {input name: value}, clamped to each input's range
    water_w: Any = None  #: near-mirror water lobe weight; None while no layer made one
    #: The stone's uptake spread v clamp(G z_p, -1, 1) at the point (docs/model.md §8.7); None: no stone.
    spread: Any = None
    #: The stone's variation v (docs/model.md §8.6); None: no stone.
    variation: Any = None
    notes: dict = field(default_factory=dict)  #: what a mode's layers pass on to each other
    #: The stone's receptivity r (docs/model.md §8.3); 1 without a stone.
    receptivity: Any = 1.0
    #: {field name: value}: what the shader reads from the point's place (``Mode.fields``).
    fields: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Layer:
    stage: int
    apply: Callable[[Any, Point], None]  #: apply(xp, point) updates the point's weights


@dataclass(frozen=True)
class Mode:
    name: str
    label: str
    description: str  #: the panel's tooltip
    inputs: tuple[Input, ...]  #: in the order of the group's sockets
    layers: tuple[Layer, ...]
    catalog: str  #: the asset catalog, under "Porous Weathering/"
    asset_summary: str  #: the asset description's first clause
    #: Inputs set for the asset preview, so that it shows the weathered look.
    preview: dict = field(default_factory=dict)
    #: The mode adds the near-mirror water lobe (its group has Water Roughness / Water Weight).
    water_lobe: bool = False
    #: Where the mode comes in the registry's lists (the panel's switches, the groups' names and
    #: sockets): soiling 10, wet 20, efflorescence 30; a new mode takes the next free ten.
    order: int = 1000
    #: The condition-survey patterns the mode produces (``patterns.Pattern``; docs/model.md §10).
    patterns: tuple = ()
    #: Per-point values a shader computes from the point's place in metres (a texture), which the
    #: numpy model is given (``weathered_coefficients(fields=...)``): not inputs, not sockets.
    fields: tuple[str, ...] = ()


# --- inputs every mode shares -----------------------------------------------------------------

TIME = Input(
    "time",
    0.0,
    0.0,
    1.0,
    "Age t: 0 is the clean material exactly, 1 fully weathered. Keyframe it to animate",
    clock="age",
)
FRONT_WIDTH = Input(
    "front_width", 0.1, 0.01, 1.0, "Width, in mask units, over which a point goes from clean to fully filled"
)
RAIN_MAP = Input(
    "rain_map", 0.0, 0.0, 1.0, "Rain exposure E: 1 where rain falls freely, 0 where sheltered", mask=True, map="rain"
)
RUNOFF_MAP = Input(
    "runoff_map",
    0.0,
    0.0,
    1.0,
    "Run-off R: how much water runs over the point from above (docs/model.md §7)",
    mask=True,
    map="runoff",
)
RUNOFF = Input(
    "runoff",
    1.0,
    0.0,
    1.0,
    "How much of the run-off map counts as water reaching the surface: 0 is the rain map alone",
    panel=True,
)
DAMP_MAP = Input(
    "damp_map",
    0.0,
    0.0,
    1.0,
    "Rising damp D: 1 below the steady front of water drawn up from the ground, 0 above it (docs/model.md §9.2)",
    mask=True,
    map="damp",
)
SUN_MAP = Input(
    "sun_map",
    1.0,
    0.0,
    1.0,
    "Sun exposure S: the year's direct sun on the point over that on a surface always facing the sun (docs/model.md §9.1)",  # noqa: E501
    mask=True,
    map="sun",
)

#: The water lobe's roughness: a group input of the modes with a water lobe, not a model input.
WATER_ROUGHNESS = Input("water_roughness", 0.05, 0.0, 1.0, "Roughness of the water lobe: near 0 is a mirror")


# --- maths the modes share ---------------------------------------------------------------------


def water_reaching(xp, rain_map, runoff_map, runoff):
    """W, the water reaching a point (docs/model.md §7.2): rain falling on it (E) or water running
    over it from above (``runoff`` x R), W = 1 - (1 - E)(1 - runoff R), written as
    E + (runoff R)(1 - E): one multiply-add of E, and E bit for bit at ``runoff`` = 0."""
    return xp.multiply_add(runoff * runoff_map, 1.0 - rain_map, rain_map)


def water_of(xp, state):
    """W (water_reaching) from a point's state: what the modes read where they read the rain."""
    return water_reaching(xp, state["rain_map"], state["runoff_map"], state["runoff"])


# --- run-off in rivulets (docs/model.md §8.8) --------------------------------------------------

#: k: a rivulet's profile across its cell is (1 - tau^2)^k, tau in [-1, 1] across its width (0 and
#: flat at its edges, so the weight is smooth from one cell to the next); half its peak is within
#: |tau| < 0.29. Even: the profile is taken as a power of tau^2 - 1.
RIVULET_SHARPNESS = 8
#: The profile's mean over its width, (1/2) integral (1 - tau^2)^k dtau = 4^k (k!)^2 / (2k + 1)!:
#: the weight divides by it (and the width), so that it has mean 1 over every cell.
RIVULET_MEAN = 4**RIVULET_SHARPNESS * math.factorial(RIVULET_SHARPNESS) ** 2 / math.factorial(2 * RIVULET_SHARPNESS + 1)
#: How far a rivulet moves sideways, in spacings, per unit of the stone's porosity field z_p.
RIVULET_WANDER = 0.25
#: The horizontal part h = |n x z| of the normal (the sine of the face's slope) below which the fall
#: line is undefined and the water not in rivulets (w = 1), and above which the rivulets are whole:
#: the sines of 5 and 15 degrees.
RIVULET_SLOPES = (math.sin(math.radians(5.0)), math.sin(math.radians(15.0)))
#: The least and the most half-width a cell's rivulet draws, in spacings (its width at half its
#: peak is 0.58 of the half-width: 6 mm to 2.3 cm at the stones' 10 cm).
RIVULET_HALF_WIDTHS = (0.1, 0.4)


#: The world's up, z: the horizontal tangent of a face is n x z.
UP = (0.0, 0.0, 1.0)


def fall_line(xp, place, normal):
    """(u, h) at a point (docs/model.md §8.8): u its place across the fall line, the vector ``place``
    (world axes, in its unit) along the horizontal tangent n x z / |n x z| of its unit ``normal``,
    and h = |n x z|, the horizontal part of the normal (0 on a level face, 1 on a vertical one)."""
    tangent = xp.cross(normal, UP)  # (n_y, -n_x, 0): u = (x n_y - y n_x) / h in one dot product
    horizontal = xp.length(tangent)
    return xp.dot(place, tangent) / xp.maximum(horizontal, porous.EPSILON), horizontal


def cell_draws(xp, cell):
    """Three draws in [0, 1] of a whole-numbered cell (docs/model.md §8.8): its rivulet's place,
    width and strength, Blender's White Noise of the cell (``xp.white_noise``); the same cell, the
    same draws, in both backends."""
    return xp.white_noise(cell)


def rivulet_excess(xp, across, horizontal, spacing, field, strength):
    """(w - 1, w_peak - 1): the rivulets' excess of run-off at a point over the map's, and that at
    its cell's rivulet's peak (docs/model.md §8.8).  Across the fall line (``across``, ``spacing`` in
    one unit), moved sideways by the stone's porosity ``field``, each cell of one spacing holds one
    rivulet of its own place, width and share of the water (``cell_draws``; the share the square
    root of a uniform draw: most rivulets strong, some faint), a peak of mean 1 over the cell;
    ``strength`` (the stone's variation) and the face's slope
    (``horizontal`` between RIVULET_SLOPES) mix it towards 1.  Of mean 0 over every cell where
    ``strength`` and ``field`` hold across it; w in [0, 17]; 0 exactly at strength 0."""
    x = xp.multiply_add(field, RIVULET_WANDER, across / xp.maximum(spacing, porous.EPSILON))
    cell = xp.floor(x)
    place, width, share = cell_draws(xp, cell)
    half = xp.multiply_add(width, RIVULET_HALF_WIDTHS[1] - RIVULET_HALF_WIDTHS[0], RIVULET_HALF_WIDTHS[0])
    inverse = 1.0 / half
    # tau = (x - cell - c) / half about the centre c = half + (1 - 2 half) place, in [half, 1 - half]
    offset = xp.multiply_add(x - cell - place, inverse, xp.multiply_add(place, 2.0, -1.0))
    # (1 - tau^2)^k within |tau| < 1 and 0 beyond, as (min(tau^2 - 1, 0))^k: k is even
    peak = xp.power(xp.minimum(xp.multiply_add(offset, offset, -1.0), 0.0), float(RIVULET_SHARPNESS))
    height = inverse * (0.5 / RIVULET_MEAN)  # the profile's peak, for mean 1 over the cell
    gathered = strength * xp.smoothstep(RIVULET_SLOPES[0], RIVULET_SLOPES[1], horizontal) * xp.sqrt(share)
    return gathered * xp.multiply_add(peak, height, -1.0), gathered * (height - 1.0)


def in_rivulets(xp, runoff_map, excess, peak_excess):
    """The run-off map R gathered into rivulets (docs/model.md §8.8): R + (w - 1) min(R, (1 - R) /
    (w_peak - 1)), w R where R is at most 1 / w_peak (all the cell's water in its rivulet), in
    [0, 1] with the peak at 1 where the flow is heavier; linear in w at each R over a cell, so of
    R's mean over every cell.  R itself, bit for bit, at w = 1."""
    room = xp.minimum(runoff_map, (1.0 - runoff_map) / xp.maximum(peak_excess, porous.EPSILON))
    return xp.multiply_add(excess, room, runoff_map)


def fill_curve(xp, progress):
    """The three-phase pore fill of Fig. 3 (smoothstep): slow, fast, then saturated at 1."""
    return xp.smoothstep(0.0, 1.0, progress)


def plain_stone(receptivity) -> bool:
    """Whether ``receptivity`` is the constant 1 a material without the stone's structure has
    (docs/model.md §8.3): its layers then build what they built before the stone, node for node."""
    return isinstance(receptivity, float) and receptivity == 1.0


def local_age(xp, time, receptivity):
    """The age at a point of the stone's structure (docs/model.md §8.3): its pores fill
    ``receptivity`` times as fast as the stone's mean, min(r t, 1), so that every front (carbon,
    salt, water), the grey deposit, the streaks and the crust follow the stone's texture; t
    itself, bit for bit, at r = 1."""
    return xp.minimum(time * receptivity, 1.0)


#: G: the gain that turns the stone's porosity field z_p into its uptake field clamp(G z_p, -1, 1)
#: (docs/model.md §8.7): beyond |z_p| = 1/G a point takes up wholly faster or slower than the mean
#: (half the limestone at G = 8; a decision measured there against the photographs' texture).
UPTAKE_GAIN = 8.0


def uptake_spread(xp, field, variation):
    """s = v clamp(G z_p, -1, 1) (docs/model.md §8.7): the stone's uptake field at variation v, odd
    in z_p, so of mean 0 over a field symmetric about 0."""
    return xp.clip(field * (UPTAKE_GAIN * variation), -variation, variation)  # v >= 0: one clamp


def local_share(xp, share, spread):
    """The share (a fill or a cover, in [0, 1]) at a point of the stone (docs/model.md §8.7):
    share + s min(share, 1 - share), so that the receptive part of the stone (s > 0) fills up to
    twice as fast and the resistant part as much slower; in [0, 1], 0 at 0 and 1 at 1 at every
    point, and of mean ``share`` over the stone (s of mean 0).  ``share`` itself without a stone
    (``spread`` None) and at s = 0."""
    if spread is None:
        return share
    return xp.multiply_add(spread, xp.to_nearer_end(share), share)


def pore_fill(xp, mask, time, level, width):
    """Fill fraction of the pores: a front sweeps the mask down from 1 as time grows
    (threshold 1 - level * time); behind it a point fills over ``width`` of mask, along the
    three-phase curve of Fig. 3 (fill_curve)."""
    return xp.front(mask, level * time, 0.0, width)


def past_saturation(xp, mask, time, level, width):
    """How far the pore-fill front has progressed past saturation, in [0, 1]: a second front
    one ``width`` behind it (where the pores are full), whose own width 1 - ``width`` is all the
    mask it can cross by t = 1 at level 1, so that it reaches 1 exactly at mask 1, t = 1, level 1
    (docs/weathering.md).  Three-phase like the fill, so it starts smoothly where pores fill up."""
    return xp.front(mask, level * time, width, xp.maximum(1.0 - width, porous.EPSILON))


def blend(xp, clean, weathered, fill):
    """``clean`` at fill 0 (exactly), ``weathered`` at fill 1: one Mix node."""
    return xp.mix(fill, clean, weathered)


def filled_absorption(xp, ka, sp, fill, theta_i, theta_r):
    """A_p of pores a fraction ``fill`` full: s_p,eff = s_p (1 - fill) (docs/model.md §4.0)."""
    nb = porous.bounce_count(xp, sp, theta_i, theta_r, fill=fill)
    return porous.pore_absorption(xp, ka, xp.channel(nb))


def cover(xp, point, color, coverage):
    """Lay a matte layer of ``color`` over a fraction ``coverage`` of the surface: it hides
    the stone's diffuse, glossy and water lobes alike."""
    point.kd_w = blend(xp, point.kd_w, color, xp.channel(coverage))
    point.ks_w = blend(xp, point.ks_w, 0.0, coverage)
    if point.water_w is not None:
        point.water_w = blend(xp, point.water_w, 0.0, xp.channel(coverage))
