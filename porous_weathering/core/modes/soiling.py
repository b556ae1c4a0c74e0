"""Soiling by atmospheric pollution (docs/model.md §4, section 4.1 of the paper): rain-washed white
areas, sheltered grey areas under a deposit, and black areas whose pores fill with carbon and,
once full, are covered by a black crust (docs/model.md §6, beyond the paper; ``crust = 0`` is the paper).
Where water goes (docs/model.md §7): the rain map's E is replaced by the water reaching a point, W, rain
or run-off, and run-off too weak to wash leaves dirty streaks (``runoff = 0``, ``streaks = 0`` is the
model without run-off)."""

from .. import porous
from ..patterns import NSD, Pattern, darkened, shown
from .base import (
    COVER_CRUST,
    COVER_DEPOSIT,
    FILL_CARBON,
    FRONT_WIDTH,
    RAIN_MAP,
    RUNOFF,
    RUNOFF_MAP,
    TIME,
    Input,
    Layer,
    Mode,
    blend,
    cover,
    filled_absorption,
    local_share,
    past_saturation,
    pore_fill,
    water_of,
)

#: Roughness m at which the grey deposit covers half of what it can (grooves trap particles).
DEPOSIT_HALF_ROUGHNESS = 0.5

#: Black crust reflects about this share of the clean limestone's visible reflectance (the
#: measurement: docs/weathering.md).  CRUST_DEFAULT is the coverage that makes a fully developed
#: black point of the limestone preset reflect it (ambient light, seen face on; tests/test_presets.py).
CRUST_REFLECTANCE_RATIO = 0.2
CRUST_DEFAULT = 0.8

#: The stone the deposit colours are given on (docs/model.md §8.6): the limestone preset's k_d, linear
#: RGB (#D6CDB8), on which every environment's deposit makes the sheltered grey area lose 30% of its
#: reflectance at t = 1 (core/environments.py).  On another stone the same deposit filters that
#: stone's own colour as it filters this one's.
DEPOSIT_REFERENCE_STONE = (0.6724431569576875, 0.6104955708078648, 0.4793201831008268)

#: The streaks' default: chosen so that the façade's dirty tails read (checked on
#: docs/images/runoff_before_after.png, docs/model.md §7.2).
STREAKS_DEFAULT = 0.5

RAIN_THRESHOLD = Input(
    "rain_threshold", 0.8, 0.0, 1.0, "Water W (rain or run-off) at and above which it washes the surface (white area)"
)
EDGE_MAP = Input(
    "edge_map",
    0.0,
    0.0,
    1.0,
    "Edge/cavity mask C: carbon fills the pores from the highest C down",
    mask=True,
    map="edges",
)
SOILING_LEVEL = Input("soiling_level", 1.0, 0.0, 1.0, "How far down the edge mask the black area reaches at t = 1")
POLLUTION_COLOR = Input(
    "pollution_color",
    (0.03, 0.03, 0.03),
    0.0,
    1.0,
    "k_d,pollution: the carbon in the pores (the paper suggests 0.8; soot is dark)",
)
DEPOSIT_COLOR = Input(
    "deposit_color", (0.30, 0.29, 0.27), 0.0, 1.0, "Colour of the grey-area deposit on sheltered, rough surfaces"
)
CRUST = Input(
    "crust",
    CRUST_DEFAULT,
    0.0,
    1.0,
    "Black crust (beyond the paper; 0 is the paper): how much of a fully black area a matte crust of the "
    "pollution colour covers at t = 1. Grows once the pores are full",
    panel=True,
)
STREAKS = Input(
    "streaks",
    STREAKS_DEFAULT,
    0.0,
    1.0,
    "Dirty streaks: how much of the deposit run-off too weak to wash leaves where it soaks in, "
    "most at half the washing water (0: no streaks)",
    panel=True,
)


def sheltered_fraction(xp, water, rain_threshold, width):
    """0 in the white (washed) area W >= threshold, rising to 1 over ``width`` below it:
    (threshold - W) / width as one multiply-add of W (its constants fold in a shader)."""
    return xp.clip(xp.multiply_add(water, -1.0 / width, rain_threshold / width), 0.0, 1.0)


def polluted_diffuse(xp, kd, pollution_color, pore, ap):
    """k_d,polluted, eq. (7), k_d (1 - alpha G_p) + k_d,pollution alpha G_p (1 - A_p): carbon in
    the pores replaces the light they return (a Mix by alpha G_p)."""
    return xp.mix(pore, kd, pollution_color * (1.0 - ap))


def deposit_coverage(sheltered, m, time, level):
    """Grey-area deposit (this project's model): grows with time, more on rougher stone.
    The sheltered fraction with the time (level t x sheltered, which the streaks share), so that
    a shader multiplies it by one factor per point, and the stone's local age and roughness by
    the fewest."""
    return m / (m + DEPOSIT_HALF_ROUGHNESS) * (level * time * sheltered)


def streak_tail(xp, runoff_map, runoff, rain_threshold):
    """4 u (1 - u) for u = clamp(runoff R / threshold, 0, 1) (docs/model.md §7.2): 0 without run-off,
    1 at half the washing water, 0 again where run-off alone washes."""
    u = xp.clip(runoff * runoff_map * (1.0 / xp.maximum(rain_threshold, porous.EPSILON)), 0.0, 1.0)
    return 4.0 * u * (1.0 - u)


def streak_coverage(xp, tail, sheltered, time, level, streaks):
    """d = streaks x tail x (level t) x sheltered: the dirt run-off leaves, growing with time as
    the deposit does (level t x sheltered as the deposit takes it, one factor per point in a shader)."""
    return streaks * tail * (level * time * sheltered)


def fill_with_carbon(xp, point):
    """The black area: carbon fills the sheltered pores from the highest edge mask down."""
    s = point.state
    sheltered = sheltered_fraction(xp, water_of(xp, s), s["rain_threshold"], s["front_width"])
    fill = pore_fill(xp, s["edge_map"], s["time"], s["soiling_level"], s["front_width"])
    carbon = local_share(xp, sheltered * fill, point.spread)  # sheltering included (docs/model.md §8.7)
    ap = filled_absorption(xp, point.ka, point.sp, carbon, point.theta_i, point.theta_r)
    point.kd_w = blend(
        xp, point.kd_w, polluted_diffuse(xp, point.kd, s["pollution_color"], point.pore, ap), xp.channel(carbon)
    )
    point.notes["sheltered"] = sheltered


def crust_coverage(xp, sheltered, edge_map, time, level, width, crust, spread=None):
    """c (docs/model.md §6.1): ``crust`` times how far the black area's carbon fill has progressed past
    saturation where it is sheltered (at the point of the stone, sheltering included: docs/model.md
    §8.7); ``crust`` itself at a fully black point (sheltered, mask 1) at t = 1, level 1."""
    past = past_saturation(xp, edge_map, time, level, width)
    if spread is None:  # without a stone: the product in the order the model's renders were made with
        return crust * sheltered * past
    return crust * local_share(xp, sheltered * past, spread)


def deposit_seen(xp, kd, deposit_color, variation):
    """What a full cover of the deposit shows (docs/model.md §8.6): its colour as the reference
    limestone shows it, or, by the stone's ``variation`` v, the stone's own k_d seen through it as
    through a filter of transmittance min(D / K_ref, 1) (a subtractive mix; a film transmits at
    most all): mix(v, D, k_d min(D / K_ref, 1)).  D itself without a stone (``variation`` None)."""
    if variation is None:
        return deposit_color
    transmittance = xp.minimum(deposit_color * tuple(1.0 / k for k in DEPOSIT_REFERENCE_STONE), 1.0)
    return xp.mix(xp.channel(variation), deposit_color, kd * transmittance)


def lay_deposit(xp, point):
    """The grey area: a deposit over whatever fills the pores, where water does not wash; then
    the dirty streaks, a second cover of the deposit colour (docs/model.md §7.2).  The two covers
    of one colour are laid as one, of coverage 1 - (1 - c)(1 - d) = c + d (1 - c) (one
    multiply-add; c itself, bit for bit, at d = 0)."""
    s = point.state
    sheltered = point.notes["sheltered"]
    coverage = deposit_coverage(sheltered, point.m, s["time"], s["soiling_level"])
    tail = streak_tail(xp, s["runoff_map"], s["runoff"], s["rain_threshold"])
    streak = streak_coverage(xp, tail, sheltered, s["time"], s["soiling_level"], s["streaks"])
    share = local_share(xp, xp.multiply_add(streak, 1.0 - coverage, coverage), point.spread)
    cover(xp, point, deposit_seen(xp, point.kd, s["deposit_color"], point.variation), share)


def lay_crust(xp, point):
    """The black crust: a matte layer of the pollution colour over whatever lies beneath (pores,
    deposit, water, salt), last of all layers."""
    s = point.state
    coverage = crust_coverage(
        xp,
        point.notes["sheltered"],
        s["edge_map"],
        s["time"],
        s["soiling_level"],
        s["front_width"],
        s["crust"],
        point.spread,
    )
    cover(xp, point, s["pollution_color"], coverage)
    point.notes["crust"] = coverage


BLACK_CRUST = Pattern(
    "black crust",
    NSD + "BlackCrust",
    (0.12, 0.12, 0.12),
    "solid",
    shown("crust"),
    10,
    "the black crust covers half the point or more (c >= 0.5, docs/model.md §6.1)",
)
SOILING = Pattern(
    "soiling",
    NSD + "Soiling",
    (0.62, 0.52, 0.40),
    "dots",
    darkened,
    40,
    "the visible reflectance has fallen by 30% or more (the cleaning threshold)",
)


MODE = Mode(
    name="soiling",
    label="Soiling",
    description="Atmospheric soiling: rain-washed white, sheltered grey and carbon-black areas",
    inputs=(
        TIME,
        FRONT_WIDTH,
        RAIN_MAP,
        RUNOFF_MAP,
        RUNOFF,
        RAIN_THRESHOLD,
        EDGE_MAP,
        SOILING_LEVEL,
        POLLUTION_COLOR,
        DEPOSIT_COLOR,
        STREAKS,
        CRUST,
    ),
    layers=(
        Layer(FILL_CARBON, fill_with_carbon),
        Layer(COVER_DEPOSIT, lay_deposit),
        Layer(COVER_CRUST, lay_crust),
    ),
    catalog="Soiling",
    asset_summary="Soiling (white, grey and black areas) from a rain, run-off and edge map",
    preview=dict(time=1.0, rain_map=0.0, edge_map=1.0),
    order=10,
    patterns=(BLACK_CRUST, SOILING),
)
