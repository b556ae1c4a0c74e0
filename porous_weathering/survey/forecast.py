"""The forecast (docs/model.md §10): per object, face and pattern, the year the pattern first shows
and the year the face crosses the cleaning threshold, from the site's time law (``core.aging``),
read on a grid of ages (``FORECAST_AGES``)."""

from dataclasses import dataclass

import numpy as np

from ..core import aging, condition
from ..core.patterns import CLEANING_LOSS, NO_VISIBLE_CHANGE

#: The ages the forecast reads, t = 0.05, 0.10, ..., 1: a year it gives is the first of these at
#: which the pattern shows (so within one step, 5% of the way to t = 1, after it really does).
FORECAST_AGES = tuple(np.round(np.linspace(0.05, 1.0, 20), 4).tolist())

#: A pattern shows on a face once it covers this share of it (a survey maps nothing smaller).
SHOWS_SHARE = 0.01

#: The forecast reads about this many sample points on at most FORECAST_TRIANGLES triangles (every
#: n-th of a larger mesh): shares of faces to well within SHOWS_SHARE.
FORECAST_SAMPLES = 20_000
FORECAST_TRIANGLES = 50_000

#: The forecast table's columns (``DIR/<name>.forecast.csv``).
COLUMNS = ("object", "face", "pattern", "first_shows_years", "first_shows_t", "cleaning_years", "cleaning_t")


@dataclass(frozen=True)
class Row:
    face: str
    pattern: str
    first_shows_t: float | None  #: None: not by t = 1
    cleaning_t: float | None  #: when the face's mean visible reflectance has lost 30%; None: not by t = 1


def forecast(patterns: tuple, tallies: list) -> list[Row]:
    """The rows of one object from its ``tally.Tally`` at each of FORECAST_AGES: a row per face
    it has and pattern that shows on it by t = 1 (no row for 'no visible change')."""
    face_totals = tallies[-1].face_areas.sum(axis=1)
    rows = []
    for face, name in enumerate(condition.FACES):
        total = face_totals[face]
        if not total > 0.0:
            continue
        cleaning = next(
            (t for t, found in zip(FORECAST_AGES, tallies) if found.face_loss[face] / total >= CLEANING_LOSS), None
        )
        for index, pattern in enumerate(patterns):
            if pattern is NO_VISIBLE_CHANGE:
                continue
            shows = next(
                (t for t, found in zip(FORECAST_AGES, tallies) if found.face_areas[face, index] >= SHOWS_SHARE * total),
                None,
            )
            if shows is not None:
                rows.append(Row(name, pattern.name, shows, cleaning))
    return rows


def triangles(count: int) -> np.ndarray:
    """The triangles the forecast reads of a mesh of ``count``: every n-th, at most FORECAST_TRIANGLES."""
    return np.arange(0, count, max(1, -(-count // FORECAST_TRIANGLES)))


def years_of(age: float | None, elemental_carbon: float) -> float | None:
    """The years after which t reaches ``age`` (None stays None)."""
    return None if age is None else aging.years_for_age(age, elemental_carbon)
