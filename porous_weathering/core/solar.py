"""The sun's year at a site (docs/model.md §9.1): where the sun stands over a year, what beam it
sends, and the sun exposure S of an open plane.

Directions are in the site frame, x east, y north, z up, unless ``scene_directions`` turns them
into the scene's (its north ``north_angle`` degrees clockwise from +Y, seen from above). The
year is sampled at every day n = 1..365 and ``STEPS_PER_DAY`` instants of equal length a day,
each at the middle of its interval; each instant weighs its beam times its length, and the
weights sum to 1, the year's irradiation of a surface always facing the sun. Their sum over
max(0, n·s) is S of an open plane of normal n.
"""

import math

import numpy as np

from .arguments import real_number

#: Days of the year (Cooper's declination takes the day number n = 1..365).
DAYS = 365
#: Instants a day: every 5 minutes (the hour angle in 1.25° steps); S of any plane is then within
#: 1e-4 of the year integrated continuously in the time of day (tests/test_sun.py).
STEPS_PER_DAY = 288
#: The earth's obliquity in Cooper's declination (degrees).
OBLIQUITY = 23.44


def declination(day: np.ndarray) -> np.ndarray:
    """The sun's declination δ (radians) on day ``day`` (1..365): Cooper (1969),
    δ = 23.44° · sin(2π (284 + n) / 365)."""
    return np.radians(OBLIQUITY) * np.sin(2.0 * np.pi * (284.0 + np.asarray(day, dtype=np.float64)) / 365.0)


def sun_vector(latitude: float, declination: np.ndarray, hour_angle: np.ndarray) -> np.ndarray:
    """Unit vectors towards the sun (..., 3) in the site frame (x east, y north, z up), at latitude
    ``latitude`` (degrees, south negative), declination and hour angle in radians (the hour angle
    0 at solar noon, growing in the afternoon, when the sun is in the west)."""
    phi = math.radians(latitude)
    delta, omega = np.broadcast_arrays(np.asarray(declination, np.float64), np.asarray(hour_angle, np.float64))
    return np.stack(
        [
            -np.cos(delta) * np.sin(omega),
            math.cos(phi) * np.sin(delta) - math.sin(phi) * np.cos(delta) * np.cos(omega),
            math.sin(phi) * np.sin(delta) + math.cos(phi) * np.cos(delta) * np.cos(omega),
        ],
        axis=-1,
    )


def air_mass(cos_zenith: np.ndarray) -> np.ndarray:
    """Relative optical air mass at the zenith angle whose cosine is ``cos_zenith`` (> 0):
    Kasten & Young (1989), AM = 1 / (cos z + 0.50572 (96.07995° − z)^−1.6364)."""
    cos_zenith = np.asarray(cos_zenith, dtype=np.float64)
    zenith = np.degrees(np.arccos(np.clip(cos_zenith, -1.0, 1.0)))
    return 1.0 / (cos_zenith + 0.50572 * (96.07995 - zenith) ** -1.6364)


def beam(cos_zenith: np.ndarray) -> np.ndarray:
    """Clear-sky direct-beam irradiance at normal incidence, relative to above the atmosphere:
    0.7^(AM^0.678) (Meinel & Meinel 1976); 0 with the sun below the horizon."""
    cos_zenith = np.asarray(cos_zenith, dtype=np.float64)
    up = cos_zenith > 0.0
    relative = np.zeros_like(cos_zenith)
    relative[up] = 0.7 ** (air_mass(cos_zenith[up]) ** 0.678)
    return relative


def year_grid(latitude: float, steps_per_day: int = STEPS_PER_DAY) -> tuple[np.ndarray, np.ndarray]:
    """(directions (DAYS × steps_per_day, 3), beams): the sun at every instant of the year at
    ``latitude`` (degrees, south negative) in the site frame, day by day, below the horizon too,
    and its beam at normal incidence there (``beam``: 0 below the horizon)."""
    latitude = real_number("latitude", latitude)
    if not -90.0 <= latitude <= 90.0:
        raise ValueError(f"latitude must be in [-90, 90] degrees, not {latitude}")
    day = np.arange(1, DAYS + 1)
    hour_angle = 2.0 * np.pi * ((np.arange(steps_per_day) + 0.5) / steps_per_day - 0.5)
    directions = sun_vector(latitude, declination(day)[:, None], hour_angle[None, :]).reshape(-1, 3)
    return directions, beam(directions[:, 2])


def year(latitude: float, steps_per_day: int = STEPS_PER_DAY) -> tuple[np.ndarray, np.ndarray]:
    """(directions (N, 3), weights (N,)): the sun's positions over the year at ``latitude``
    (degrees, south negative) in the site frame, those above the horizon only, and their share
    of the year's beam irradiation at normal incidence (beam × time step, summing to 1)."""
    directions, weights, _ = year_by_day(latitude, steps_per_day)
    return directions, weights


def year_by_day(latitude: float, steps_per_day: int = STEPS_PER_DAY) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``year``'s (directions, weights) and the day (0..DAYS − 1) of each position, day by day and
    in the order of the day's instants."""
    directions, weights = year_grid(latitude, steps_per_day)
    up = weights > 0.0
    days = np.repeat(np.arange(DAYS), steps_per_day)
    return directions[up], weights[up] / weights[up].sum(), days[up]


#: The step of Roberts' R2 sequence, (1/g, 1/g²) with g the plastic number (g³ = g + 1): the
#: additive recurrence in two dimensions whose points spread most evenly.
R2_STEP = np.array([0.7548776662466927, 0.5698402909980532])


def lattice_draws(weights: np.ndarray, days: np.ndarray, shifts: np.ndarray, count: int) -> np.ndarray:
    """(P, count) indices into ``year_by_day``'s positions, ``count`` for each of the P rows of
    ``shifts`` (P, 2) in [0, 1)²: the points shift + k · R2_STEP (mod 1), k < count, the first
    coordinate picking the day by its share of the year's weight, the second the instant within
    the day by its own. With uniform random shifts each draw is a position taken with probability
    its weight, so the mean of f over the draws is an unbiased estimate of Σ w f; the lattice
    spreads each row's draws over the days and the hours, where independent draws would bunch
    (docs/model.md §9.1)."""
    day_weight = np.bincount(days, weights=weights, minlength=DAYS)
    day_end = np.cumsum(day_weight)
    points = (shifts[:, None, :] + np.arange(count)[None, :, None] * R2_STEP) % 1.0
    day = np.minimum(np.searchsorted(day_end, points[..., 0] * day_end[-1], side="right"), DAYS - 1)
    within = day_end[day] - day_weight[day] + points[..., 1] * day_weight[day]
    return np.minimum(np.searchsorted(np.cumsum(weights), within, side="right"), len(weights) - 1)


def site_to_scene(north_angle: float) -> np.ndarray:
    """The rotation (3 x 3) from the site frame (x east, y north, z up) into the scene's, whose
    north lies ``north_angle`` degrees clockwise from +Y seen from above (0: +Y is north)."""
    angle = math.radians(real_number("north angle", north_angle))
    north = (math.sin(angle), math.cos(angle), 0.0)
    east = (math.cos(angle), -math.sin(angle), 0.0)
    return np.array([east, north, (0.0, 0.0, 1.0)]).T


def scene_directions(directions: np.ndarray, north_angle: float) -> np.ndarray:
    """Site-frame ``directions`` (N, 3) in the scene's frame (``site_to_scene``)."""
    return directions @ site_to_scene(north_angle).T


def open_plane_exposure(normal, latitude: float, north_angle: float = 0.0) -> float:
    """S of an unshadowed plane whose unit ``normal`` is given in the scene's frame: the year's
    beam on it over that on a surface always facing the sun (docs/model.md §9.1)."""
    directions, weights = year(latitude)
    cosines = scene_directions(directions, north_angle) @ np.asarray(normal, dtype=np.float64)
    return float(weights @ np.maximum(cosines, 0.0))


#: The open planes' S is summed over the year's suns in groups of GROUP_INSTANTS instants of
#: GROUP_DAYS days, each group's suns one vector Σ w s (a plane lit by all of a group takes its share
#: exactly; within 2e-4 of the sum over every sun, tests/test_sun.py), for each distinct normal; a
#: scan's normals (more distinct ones than OCTAHEDRAL_NODES²) read it bilinearly on a table over
#: the octahedral map of the normals, OCTAHEDRAL_NODES nodes a side (about 2° apart; ±x, ±y and
#: ±z among them): within 1e-3.
GROUP_DAYS, GROUP_INSTANTS = 3, 4
OCTAHEDRAL_NODES = 97


def open_plane_exposures(
    normals: np.ndarray, directions: np.ndarray, weights: np.ndarray, days: np.ndarray
) -> np.ndarray:
    """S of open planes of unit ``normals`` (P, 3) under ``year_by_day``'s suns (``directions``
    turned into the normals' frame, ``weights``, ``days``): Σ w max(0, n·s), summed as
    ``GROUP_DAYS`` says."""
    first = np.r_[0, np.flatnonzero(np.diff(days)) + 1]  # each day's first position
    instant = np.arange(len(days)) - np.repeat(first, np.diff(np.r_[first, len(days)]))
    _, group = np.unique(days // GROUP_DAYS * STEPS_PER_DAY + instant // GROUP_INSTANTS, return_inverse=True)
    grouped = np.zeros((group.max() + 1, 3))
    np.add.at(grouped, group.ravel(), weights[:, None] * directions)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    distinct, inverse = np.unique(normals, axis=0, return_inverse=True)
    if len(distinct) <= OCTAHEDRAL_NODES**2:
        return _summed(distinct, grouped)[inverse.ravel()]
    side = np.linspace(-1.0, 1.0, OCTAHEDRAL_NODES)
    u, v = np.meshgrid(side, side, indexing="ij")
    table = _summed(_from_octahedral(u.ravel(), v.ravel()), grouped).reshape(u.shape)
    u, v = _to_octahedral(normals)
    x, y = (u + 1.0) / 2.0 * (OCTAHEDRAL_NODES - 1), (v + 1.0) / 2.0 * (OCTAHEDRAL_NODES - 1)
    i, j = (np.clip(np.floor(t).astype(np.int64), 0, OCTAHEDRAL_NODES - 2) for t in (x, y))
    fx, fy = x - i, y - j
    low = table[i, j] * (1 - fx) + table[i + 1, j] * fx
    high = table[i, j + 1] * (1 - fx) + table[i + 1, j + 1] * fx
    return low * (1 - fy) + high * fy


def _summed(normals, suns, at_once=1 << 20):
    """Σ max(0, n·s) over ``suns`` (N, 3, each its weight long) for each of ``normals`` (P, 3), in
    single precision (a sum of some 4000 terms, to 1e-6) and in blocks of ``at_once`` products."""
    normals, suns = normals.astype(np.float32), suns.astype(np.float32)
    exposure = np.empty(len(normals))
    rows = max(1, at_once // max(1, len(suns)))
    for start in range(0, len(normals), rows):
        cosines = normals[start : start + rows] @ suns.T
        exposure[start : start + rows] = np.maximum(cosines, 0.0, out=cosines).sum(axis=1, dtype=np.float64)
    return exposure


def _to_octahedral(normals):
    """(u, v) in [-1, 1]² of unit ``normals``: +z at the centre, ±x and ±y at the edges' middles,
    −z at the corners (the lower half folded out over the diagonals)."""
    n = normals / np.abs(normals).sum(axis=1, keepdims=True)
    u, v = n[:, 0], n[:, 1]
    below = n[:, 2] < 0.0
    folded_u = (1.0 - np.abs(v)) * np.where(u >= 0.0, 1.0, -1.0)
    folded_v = (1.0 - np.abs(u)) * np.where(v >= 0.0, 1.0, -1.0)
    return np.where(below, folded_u, u), np.where(below, folded_v, v)


def _from_octahedral(u, v):
    """The unit normals (N, 3) at (u, v) of the octahedral map (``_to_octahedral``'s inverse)."""
    z = 1.0 - np.abs(u) - np.abs(v)
    below = z < 0.0
    x = np.where(below, (1.0 - np.abs(v)) * np.where(u >= 0.0, 1.0, -1.0), u)
    y = np.where(below, (1.0 - np.abs(u)) * np.where(v >= 0.0, 1.0, -1.0), v)
    n = np.column_stack([x, y, z])
    return n / np.linalg.norm(n, axis=1, keepdims=True)
