"""Rising damp (docs/model.md §9.2): the steady height of the water drawn up from the ground by
sharp-front theory (Hall & Hoff 2007), the damp D ∈ [0, 1] at a height above the ground, and the
tide mark at its top where the water evaporates and its salts crystallise.

Lengths in metres, times in seconds, except where a name says otherwise (the options' units:
sorptivity in mm min^-1/2, evaporation in mm/day, as building physics quotes them).
"""

import numpy as np

SECONDS_PER_MINUTE = 60.0
SECONDS_PER_DAY = 86400.0

#: S, mm min^-1/2: a brick or a porous limestone (docs/model.md §9.2).
DEFAULT_SORPTIVITY = 0.8
#: e, mm/day: what evaporates from a wall, both faces together, per unit area of its elevation, in
#: a British climate (docs/model.md §9.2).
DEFAULT_EVAPORATION = 1.0
#: θ_w: the water content behind the wet front, volume fraction.
DEFAULT_WET_WATER_CONTENT = 0.2
#: b, m, where the body has no opposite face (a single sheet): Hall & Hoff's example wall.
DEFAULT_SHEET_THICKNESS = 0.5
#: Thicknesses are capped here, m: the thickest masonry walls; the ray through a point of a
#: larger solid finds its far side, not the wall the water rises in.
MAX_THICKNESS = 2.0
#: The band above the front over which D falls from 1 to 0, as a fraction of the front's height.
FRINGE = 0.1


def sorptivity_si(mm_per_sqrt_minute):
    """S in m s^-1/2 from mm min^-1/2."""
    return np.asarray(mm_per_sqrt_minute, float) * 1e-3 / np.sqrt(SECONDS_PER_MINUTE)


def evaporation_si(mm_per_day):
    """e in m/s from mm/day."""
    return np.asarray(mm_per_day, float) * 1e-3 / SECONDS_PER_DAY


def steady_height(sorptivity, thickness, evaporation, wet_water_content):
    """h_ss = S (b / (2 e θ_w))^1/2 (docs/model.md §9.2), SI units: the height at which the water the
    wall draws up through its base, b S² / (2 θ_w h) per unit length, equals what its faces lose,
    e h."""
    return sorptivity * np.sqrt(np.asarray(thickness, float) / (2.0 * evaporation * wet_water_content))


def damp(height, front):
    """D: 1 up to the ``front`` (h_ss), falling smoothly (smoothstep) to 0 at front (1 + FRINGE),
    0 above it and below the ground (negative heights never occur on the body)."""
    height, front = np.asarray(height, float), np.asarray(front, float)
    t = np.clip((height - front) / np.maximum(FRINGE * front, 1e-12), 0.0, 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t)


def tide_mark(xp, damp_map):
    """T = 4 D (1 − D): where the damp evaporates, at the top of the wet zone (docs/model.md §9.2);
    0 below the front (D = 1) and above the fringe (D = 0), 1 halfway up the fringe."""
    return 4.0 * damp_map * (1.0 - damp_map)
