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
    directions, weights = year_grid(latitude, steps_per_day)
    up = weights > 0.0
    return directions[up], weights[up] / weights[up].sum()


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
