"""Biological colonisation (docs/model.md §9.3, beyond the paper): where the stone stays damp and is
receptive, an algal film fills its pores and then covers it, green first and darkening with age to a
dark biofilm; lichens grow as round patches on damp, lit surfaces of clean-air sites.

The clock is years of exposure since the stone was last clean (``biological_years``), not the
soiling's t: algae come back within months, lichens grow at a fixed radial rate in millimetres a
year (docs/model.md §9.4 derives both clocks from years at a site).  ``biological_level = 0``
renders the material without life bit for bit.

The lichens' seeds are a field (``Mode.fields``): the shader reads them from a Voronoi texture at
the point's place in metres, one seed per cell of side 1/sqrt(lambda) (``LICHEN_SEEDS``: the nearest
and the second nearest seed, each its distance in cells and its own two random values, whether it
establishes and how large it grows); the numpy model is given them.
"""

import math

import numpy as np

from .. import voronoi
from ..patterns import NSD, Pattern, shown
from .base import (
    COVER_ALGAE,
    COVER_LICHEN,
    DAMP_MAP,
    FILL_ALGAE,
    RAIN_MAP,
    RUNOFF,
    RUNOFF_MAP,
    SUN_MAP,
    Input,
    Layer,
    Mode,
    blend,
    cover,
    filled_absorption,
    local_share,
    plain_stone,
    water_of,
)
from .soiling import polluted_diffuse

#: Dampness (docs/model.md §9.3): a surface no water reaches is still damp this share of the time
#: (dew, condensation, rain on the wind), water from above or below makes it wet (1); the sun dries
#: it, by up to DRYING at full sun; rain falling directly on it washes the film off, by up to WASH.
HUMIDITY = 0.5
DRYING = 0.8
WASH = 0.6

#: The film's clocks, years (docs/model.md §9.3): it grows towards what the point's dampness
#: allows with this time constant (colour change within a year on damp faces: Adamson et al. 2012),
#: and darkens towards the dark biofilm with the slower one.
ALGAE_YEARS = 1.0
BIOFILM_YEARS = 10.0
#: The biomass B at which the pores are full and the film starts covering the surface.
PORE_BIOMASS = 0.2

#: Lichens (docs/model.md §9.3): they establish this many years after cleaning (on rural samples by
#: the end of the second year: Adamson et al. 2012); where the sun is at least LIGHT_NEEDED they are
#: as lit as they need, and those of the orange species as orange as they get (their pigment is a
#: sunscreen); a thallus's rim blends over LICHEN_RIM metres, a seed's establishment over SEED_RIM.
LICHEN_LAG_YEARS = 1.5
LIGHT_NEEDED = 0.25
#: The share of the thalli that are of the orange species (Caloplaca, Xanthoria): one of the three
#: of a calcareous wall's community; the rest are grey (Aspicilia, Lecanora), the dark Verrucaria
#: left out (docs/model.md §9.3; judgement).
ORANGE_SHARE = 1.0 / 3.0
LICHEN_RIM = 3e-4
SEED_RIM = 0.02
#: Thalli of one wall differ in size (their growth rates differ, their seeds arrive over the years):
#: each is drawn with r(years) times its own factor, spread uniformly over 1 -+ SIZE_SPREAD and
#: scaled to a mean square of 1 (0.48 to 1.44), so that the Boolean model's cover 1 - exp(-lambda pi
#: E[r^2]) is that of r(years) (docs/model.md §9.3).
SIZE_SPREAD = 0.5
#: One seed per Voronoi cell covers more than the Boolean model of the same density (its thalli
#: overlap less): drawn with their radii over sqrt(1 + CROWDING lambda pi r^2), the cover of the two
#: nearest seeds' thalli is the Boolean law's within 0.03 for lambda pi r^2 up to 4 (docs/model.md
#: §9.3, measured by benchmarks/lichen_cover.py).
CROWDING = 0.16
#: On a stone a thallus grows further over its receptive spots and less far over its resistant
#: ones (bioreceptivity, docs/model.md §9.3): it reaches r sqrt(1 + REACH_SPREAD s) at a point of
#: the stone's uptake s in [-1, 1] (§8.7), radii 0.84 to 1.14 times r, its area's mean kept
#: (s of mean 0), so that its margin follows the stone's texture (judgement).
REACH_SPREAD = 0.3
#: The least density taken (per m²), so that the seeds' cells stay finite (one per hectare: none seen).
LEAST_DENSITY = 1e-4

#: Metres between the three planes' seed patterns (docs/model.md §9.3), so each plane has its own seeds.
PLANE_OFFSET = 1000.5

#: The field the lichens read: the nearest seed's (distance in cells, value, size draw), then the
#: second nearest's (the Voronoi's F1 and F2; the values and draws in [0, 1]).
LICHEN_SEEDS = "lichen_seeds"
#: What the numpy model takes where it is given no seeds: no seed within reach (no lichen).
NO_SEEDS = (1e9, 1.0, 0.5) * 2

BIOLOGICAL_YEARS = Input(
    "biological_years",
    0.0,
    0.0,
    200.0,
    "Years since the stone was last clean: the biological clock (algae in months, lichens in years). "
    "Keyframe it to animate",
    clock="years",
)
BIOLOGICAL_LEVEL = Input(
    "biological_level",
    1.0,
    0.0,
    1.0,
    "How much life the site allows (0: none): scales the algal biomass and the lichens' establishment",
    panel=True,
)
# Linear RGB of CIELAB colours (D65), checked by tests/test_biological.py against colorimetry.
ALGAE_COLOR = Input(
    "algae_color",
    (0.193, 0.218, 0.064),
    0.0,
    1.0,
    "The young algal film (L* 52, a* -12, b* 30: yellow-green, so b* moves before a*)",
)
BIOFILM_COLOR = Input(
    "biofilm_color",
    (0.060, 0.065, 0.043),
    0.0,
    1.0,
    "The old, dark biofilm the algal film darkens to (L* 30, a* -4, b* 8)",
)
LICHEN_COLOR = Input(
    "lichen_color",
    (0.625, 0.286, 0.038),
    0.0,
    1.0,
    "The orange species' thalli in the sun (L* 65, a* 15, b* 55: Xanthoria, Caloplaca)",
)
LICHEN_GREY_COLOR = Input(
    "lichen_grey_color",
    (0.357, 0.345, 0.247),
    0.0,
    1.0,
    "The thalli without the sun's orange pigment (L* 65, a* -3, b* 12: the grey lichens of walls, "
    "and the orange ones in the shade)",
)
LICHEN_DENSITY = Input(
    "lichen_density",
    200.0,
    0.0,
    10000.0,
    "lambda: lichen seeds per square metre that can establish (0 in polluted air)",
    panel=True,
)
LICHEN_GROWTH = Input(
    "lichen_growth",
    2.0,
    0.0,
    20.0,
    "Diametral growth of a thallus, mm a year (Rhizocarpon 0.5-0.8; wall lichens faster)",
)


def wetness(xp, state):
    """1 - (1 - W)(1 - D): water from above (rain or run-off, W) or from below (rising damp, D)."""
    return 1.0 - (1.0 - water_of(xp, state)) * (1.0 - state["damp_map"])


def humid(xp, wet):
    """How much of the time a surface is damp before the sun dries it: HUMIDITY where no water
    reaches, 1 where it is wet."""
    return xp.multiply_add(wet, 1.0 - HUMIDITY, HUMIDITY)


def dampness(xp, state):
    """M (docs/model.md §9.3): damp where water reaches it, dried by the sun, washed by direct rain."""
    dried = humid(xp, wetness(xp, state)) * (1.0 - DRYING * state["sun_map"])
    return dried * (1.0 - WASH * state["rain_map"])


def decay(xp, years, receptivity, time_constant):
    """1 - exp(-r years / time_constant): how far a growth of that time constant has come at the
    point's local years r x ``years`` (docs/model.md §8.3), written exp(-years / time_constant)^r: where
    the years are the material's and r the stone's, a shader folds the inner power, and each growth
    costs one power per point (docs/model.md §8.9)."""
    return 1.0 - xp.power(xp.power(math.e, years * (-1.0 / time_constant)), receptivity)


def algal_biomass(xp, state, receptivity):
    """B in [0, 1] (docs/model.md §9.3): the level times the dampness, approached with ALGAE_YEARS at
    the point's local years, and times the receptivity: receptive stone is colonised faster
    (docs/model.md §8.3) and holds more, as it holds more water; without a stone (r = 1) B itself."""
    biomass = dampness(xp, state) * (
        state["biological_level"] * decay(xp, state["biological_years"], receptivity, ALGAE_YEARS)
    )
    if plain_stone(receptivity):
        return biomass
    return xp.minimum(biomass * receptivity, 1.0)


def film_colour(xp, state, receptivity):
    """The film's colour: the young algae darkening to the biofilm with BIOFILM_YEARS."""
    darkened = decay(xp, state["biological_years"], receptivity, BIOFILM_YEARS)
    return blend(xp, state["algae_color"], state["biofilm_color"], xp.channel(darkened))


def fill_with_algae(xp, point):
    """The film in the pores: it replaces the light they return, as carbon does (eq. 7), over the
    pore fill B / PORE_BIOMASS."""
    s = point.state
    biomass = algal_biomass(xp, s, point.receptivity)
    fill = xp.minimum(biomass * (1.0 / PORE_BIOMASS), 1.0)
    colour = film_colour(xp, s, point.receptivity)
    ap = filled_absorption(xp, point.ka, point.sp, fill, point.theta_i, point.theta_r)
    point.kd_w = blend(xp, point.kd_w, polluted_diffuse(xp, point.kd, colour, point.pore, ap), xp.channel(fill))
    point.notes["biomass"], point.notes["film_colour"] = biomass, colour


def lay_algae(xp, point):
    """The film over the surface, once the pores are full: coverage (B - PORE_BIOMASS) / (1 - PORE_BIOMASS)."""
    coverage = xp.maximum(point.notes["biomass"] - PORE_BIOMASS, 0.0) * (1.0 / (1.0 - PORE_BIOMASS))
    cover(xp, point, point.notes["film_colour"], coverage)
    point.notes["algae"] = coverage


def lichen_radius(xp, state):
    """r(years) in metres: half the diametral growth a year, from LICHEN_LAG_YEARS after cleaning."""
    return xp.maximum(state["biological_years"] - LICHEN_LAG_YEARS, 0.0) * (state["lichen_growth"] * 0.0005)


def lichen_light(xp, state):
    """How lit a thallus is, in [0, 1]: the sun map up to LIGHT_NEEDED."""
    return xp.minimum(state["sun_map"] * (1.0 / LIGHT_NEEDED), 1.0)


def lichen_suitability(xp, state, light):
    """L in [0, 1]: the share of seeds that establish, damp (as ``humid``) and lit (``light``),
    times the level."""
    return state["biological_level"] * humid(xp, wetness(xp, state)) * light


def size_factor(size):
    """A thallus's radius over r(years), from its seed's size draw ``size`` in [0, 1]: uniform over
    1 -+ SIZE_SPREAD, of mean square 1 (docs/model.md §9.3)."""
    scale = 1.0 / math.sqrt(1.0 + SIZE_SPREAD * SIZE_SPREAD / 3.0)
    return (1.0 - SIZE_SPREAD) * scale + (2.0 * SIZE_SPREAD * scale) * size


def thallus_cover(xp, seed, suitability, spacing, radius):
    """The cover at a point of one seed's thallus, ``seed`` = (its distance in cells of ``spacing``
    metres, its value, its size draw): the seed established (its value under the point's L,
    ``suitability``) and the point within ``radius`` times the seed's size_factor."""
    distance, value, size = seed
    radius = size_factor(size) * radius
    inside = 1.0 - xp.smoothstep(radius - LICHEN_RIM, radius, distance * spacing)
    return inside * xp.smoothstep(value, value + SEED_RIM, suitability)


def thalli_covers(xp, state, seeds, suitability=None, spread=None):
    """(the nearest seed's thallus cover, the second nearest's) at a point whose seeds are ``seeds``
    (LICHEN_SEEDS), each thallus_cover with r(years) over sqrt(1 + CROWDING lambda pi r^2), and on a
    stone times sqrt(1 + REACH_SPREAD s), s the point's uptake ``spread`` (None: no stone).
    ``suitability``: the point's L, if the caller has it."""
    if suitability is None:
        suitability = lichen_suitability(xp, state, lichen_light(xp, state))
    density = xp.maximum(state["lichen_density"], LEAST_DENSITY)
    spacing = 1.0 / xp.power(density, 0.5)  # metres per cell
    radius = lichen_radius(xp, state)
    crowding = 1.0 + (CROWDING * math.pi) * (density * radius * radius)
    if spread is not None:  # one power for both: r sqrt((1 + K s) / crowding)
        crowding = crowding / xp.multiply_add(spread, REACH_SPREAD, 1.0)
    radius = radius / xp.power(crowding, 0.5)
    return tuple(thallus_cover(xp, seed, suitability, spacing, radius) for seed in (seeds[:3], seeds[3:]))


def in_either(xp, first, second):
    """The cover of two thalli's covers ``first`` and ``second`` together: c_1 + c_2 (1 - c_1)."""
    return xp.multiply_add(second, 1.0 - first, first)


def lichen_cover(xp, state, seeds, suitability=None):
    """The lichens' cover at a point whose seeds are ``seeds`` (LICHEN_SEEDS): within either of
    its two nearest seeds' thalli (thalli_covers)."""
    return in_either(xp, *thalli_covers(xp, state, seeds, suitability))


def lichen_seeds_at(metres, normals, state, kind):
    """The lichens' seeds (LICHEN_SEEDS) at points ``metres`` (..., 3) from their object's origin
    whose surface faces ``normals`` (..., 3), as the shader's Voronoi texture gives them with the
    hash ``kind`` of the Blender that renders it (docs/model.md §9.3; ``voronoi``: the same hash, in
    single precision): on the world plane the surface faces most, each plane shifted by
    PLANE_OFFSET, one seed per cell of side 1/sqrt(lambda)."""
    metres, normals = np.asarray(metres, dtype=np.float32), np.abs(np.asarray(normals, dtype=np.float32))
    ax, ay, az = np.moveaxis(normals, -1, 0)
    x, y, z = np.moveaxis(metres, -1, 0)
    faces_z = az > np.maximum(ax, ay) - np.float32(1e-6)  # tops and bottoms
    faces_x = ~faces_z & (ax > ay)  # faces along y (their normal along x)
    offset = np.float32(PLANE_OFFSET)
    u = np.where(faces_x, y + offset, x)
    v = np.where(faces_z, y + offset, z)
    density = np.maximum(np.asarray(state["lichen_density"], dtype=np.float32), np.float32(LEAST_DENSITY))
    return tuple(field.astype(np.float64) for field in voronoi.voronoi_f1_f2(u, v, np.sqrt(density), kind))


def lichen_colour(xp, state, value, suitability, light):
    """A thallus's colour (docs/model.md §9.3): grey, or, for the ORANGE_SHARE of the seeds that
    establish with the lowest values (its seed's ``value``: below ORANGE_SHARE x L), orange as far
    as it is lit (its pigment is a sunscreen, made as far as the sun reaches it)."""
    orange = xp.smoothstep(value, value + SEED_RIM, suitability * ORANGE_SHARE)
    return blend(xp, state["lichen_grey_color"], state["lichen_color"], xp.channel(orange * light))


def lay_lichens(xp, point):
    """The thalli of the point's two nearest seeds, the nearest's over the other's."""
    seeds = point.fields.get(LICHEN_SEEDS, NO_SEEDS)
    light = lichen_light(xp, point.state)
    # the share of seeds that establish, at the point's share of the stone (docs/model.md §8.7)
    suitability = local_share(xp, lichen_suitability(xp, point.state, light), point.spread)
    first, second = thalli_covers(xp, point.state, seeds, suitability, point.spread)
    others = lichen_colour(xp, point.state, seeds[4], suitability, light)
    nearest = lichen_colour(xp, point.state, seeds[1], suitability, light)
    coverage = in_either(xp, first, second)
    cover(xp, point, blend(xp, others, nearest, xp.channel(first)), coverage)
    point.notes["lichen"] = coverage


#: The condition survey's patterns (docs/model.md §10): a lichen thallus lies over the algal film,
#: and both over the salt and the water; the black crust hides them.
LICHEN = Pattern(
    "lichen",
    NSD + "Lichen",
    (0.93, 0.62, 0.18),
    "grid",
    shown("lichen"),
    12,
    "lichen thalli cover half the point or more (cover >= 0.5, docs/model.md §9.3)",
)
ALGAE = Pattern(
    "algae",
    NSD + "Algae",
    (0.35, 0.58, 0.27),
    "back lines",
    shown("algae"),
    15,
    "the algal film covers half the point or more (cover >= 0.5, docs/model.md §9.3)",
)


MODE = Mode(
    name="biological",
    label="Biological",
    description="Life on damp stone: a green algal film darkening to biofilm, and round lichen patches",
    inputs=(
        BIOLOGICAL_YEARS,
        RAIN_MAP,
        RUNOFF_MAP,
        RUNOFF,
        DAMP_MAP,
        SUN_MAP,
        BIOLOGICAL_LEVEL,
        ALGAE_COLOR,
        BIOFILM_COLOR,
        LICHEN_COLOR,
        LICHEN_GREY_COLOR,
        LICHEN_DENSITY,
        LICHEN_GROWTH,
    ),
    layers=(
        Layer(FILL_ALGAE, fill_with_algae),
        Layer(COVER_ALGAE, lay_algae),
        Layer(COVER_LICHEN, lay_lichens),
    ),
    catalog="Biological",
    asset_summary="Algae and lichens from a rain, run-off, rising-damp and sun map",
    preview=dict(biological_years=20.0, sun_map=0.3, rain_map=0.0),
    fields=(LICHEN_SEEDS,),
    order=40,
    patterns=(LICHEN, ALGAE),
)
