"""The condition survey's classification (docs/model.md §10): each point of a weathered stone, at
an age, takes the pattern its modes produce there (``Mode.patterns``), by the rules of
``patterns`` read on the numpy model (``model.weathered_point``), face on in ambient light, as a
colorimeter reads a surface (``colorimetry.appearance``). No bpy."""

from collections.abc import Iterable, Mapping

import numpy as np
from numpy.typing import ArrayLike

from . import model
from . import modes as weathering_modes
from .colorimetry import RGB_TO_XYZ
from .patterns import NO_VISIBLE_CHANGE, Pattern, Reading


def survey_patterns(modes: Iterable[str]) -> tuple[Pattern, ...]:
    """The patterns a survey of a material of ``modes`` can find, in precedence order, with
    ``NO_VISIBLE_CHANGE`` last."""
    return (*weathering_modes.patterns(modes), NO_VISIBLE_CHANGE)


def visible_reflectance(kd_w: ArrayLike, ks_w: ArrayLike, water_w: ArrayLike | None = None) -> np.ndarray:
    """Y (CIE 1931, D65) of the light a point returns face on in ambient light: its diffuse,
    glossy and water weights summed, as a d/8 colorimeter reads them, specular included."""
    rgb = np.asarray(kd_w) + np.asarray(ks_w)[..., None]
    if water_w is not None:
        rgb = rgb + np.asarray(water_w)
    return rgb @ RGB_TO_XYZ[1]


def classify(
    kd: ArrayLike,
    ks: ArrayLike,
    m: ArrayLike,
    alpha: ArrayLike,
    sp: ArrayLike,
    modes: Iterable[str],
    *,
    receptivity: ArrayLike | None = None,
    fields: Mapping[str, tuple[ArrayLike, ...]] | None = None,
    **state: ArrayLike,
) -> tuple[np.ndarray, np.ndarray]:
    """(index, loss) per point: the index into ``survey_patterns(modes)`` of its pattern, the
    first in precedence order whose rule holds (``NO_VISIBLE_CHANGE`` where none does), and the
    fraction of the clean stone's visible reflectance it has lost. The arguments are
    ``model.weathered_point``'s (per point, broadcast; ``fields`` the modes' per-point fields,
    ``Mode.fields``), seen face on in ambient light."""
    modes = model.weathering_modes(modes)
    point = model.weathered_point(
        kd, ks, m, alpha, sp, None, 1.0, modes, receptivity=receptivity, fields=fields, **state
    )
    clean_kd, clean_ks = model.porous_coefficients(point.kd, np.asarray(ks), m, alpha, sp, None, 1.0)
    clean = visible_reflectance(clean_kd, clean_ks)
    loss = 1.0 - visible_reflectance(point.kd_w, point.ks_w, point.water_w) / np.maximum(clean, model.EPSILON)
    reading = Reading({key: np.asarray(value) for key, value in point.notes.items()}, loss)
    found = survey_patterns(modes)
    index = np.full(np.shape(loss), len(found) - 1, dtype=np.int64)
    for number, pattern in reversed(list(enumerate(found[:-1]))):
        index = np.where(np.broadcast_to(pattern.rule(reading), index.shape), number, index)
    return index, loss


#: The faces a forecast reports (docs/model.md §10.3): the four sides by the bearing of their outward
#: normal, and the surfaces facing up and down (more than 45° from the vertical plane).
FACES = ("north", "east", "south", "west", "up", "down")


def faces_of(normals: ArrayLike, north: ArrayLike = (0.0, 1.0)) -> np.ndarray:
    """The index into FACES of each unit normal (n, 3), for ``north`` a unit vector in world xy."""
    normals = np.asarray(normals, dtype=np.float64)
    north = np.asarray(north, dtype=np.float64)
    east = np.array([north[1], -north[0]])  # north turned clockwise, seen from above
    bearing = np.degrees(np.arctan2(normals[:, :2] @ east, normals[:, :2] @ north)) % 360.0
    side = np.floor(((bearing + 45.0) % 360.0) / 90.0).astype(np.int64)
    vertical = np.abs(normals[:, 2]) > np.sqrt(0.5)
    return np.where(vertical, np.where(normals[:, 2] > 0, 4, 5), side)
