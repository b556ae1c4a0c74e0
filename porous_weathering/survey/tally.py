"""An object's patterns counted at one age (docs/model.md §10): every sample point of its surface
(``points``) classed by the numpy model (``core.condition.classify``) and its area added to its
pattern's, over the whole object and per face (``core.condition.FACES``); and, for a drawing, the
small triangle each sample point stands for, in its pattern."""

from dataclasses import dataclass

import numpy as np

from ..blender.compat import VORONOI_HASH
from ..core import condition
from ..core import modes as weathering_modes
from ..core.modes import biological
from . import points

#: Sample points classified per call of the model (bounds the memory a scan takes).
CHUNK = 250_000

#: The numpy side of each per-point field a mode's record names (``Mode.fields``), as
#: shading/nodes.py's FIELDS builds it in the shader: (metres from the object's origin (n, s, 3),
#: unit normals (n, s, 3), the material's inputs at the points) -> the field (docs/model.md §10.1).
FIELDS = {
    biological.LICHEN_SEEDS: lambda metres, normals, inputs: biological.lichen_seeds_at(
        metres, normals, inputs, VORONOI_HASH
    )
}


@dataclass(frozen=True)
class Tally:
    """Areas in m² at one age: per pattern (P,), per face and pattern (F, P), the loss of visible
    reflectance times area per face (F,); and for a drawing, the sample points (m,) as the small
    triangles they stand for (their triangle and which of its k² parts: ``points.small_triangles``)
    and the pattern of each (None: not asked for)."""

    areas: np.ndarray
    face_areas: np.ndarray
    face_loss: np.ndarray
    drawn_points: tuple[np.ndarray, np.ndarray] | None = None
    drawn_patterns: np.ndarray | None = None


def union(materials) -> tuple:
    """The patterns of every material (``points.Material``), each once, in precedence order."""
    found = {}
    for material in materials:
        for pattern in condition.survey_patterns(material.modes):
            found.setdefault(pattern.name, pattern)
    return tuple(sorted(found.values(), key=lambda pattern: pattern.precedence))


def tally(
    found,
    materials: dict,
    patterns: tuple,
    clocks: dict,
    faces: np.ndarray,
    *,
    drawn: bool = False,
    triangles: np.ndarray | None = None,
    target: int = points.TARGET_SAMPLES,
) -> Tally:
    """The ``Tally`` of ``found`` (``points.Surface``) at the age ``clocks`` ({clock input: value}:
    ``time`` t and the clocks in years, docs/model.md §9.4); ``materials`` {slot: Material},
    ``faces`` the face index of each triangle; ``drawn``: keep the sample points and their patterns
    too (``Tally.drawn_points``), so that a drawing shows what the areas count.
    ``triangles`` (default: all) and about ``target`` sample points on them: a coarser tally
    (the forecast's, which reads shares of faces)."""
    count, faces_count = len(patterns), len(condition.FACES)
    areas = np.zeros(count)
    face_areas = np.zeros(faces_count * count)
    face_loss = np.zeros(faces_count)
    pieces, parts, kinds = [], [], []
    names = [pattern.name for pattern in patterns]
    chosen_triangles = np.arange(len(found.areas_m2)) if triangles is None else triangles
    splits = found.splits(target, chosen_triangles)
    for k in np.unique(splits):
        bary = points.barycentric_centroids(int(k))
        step = max(1, CHUNK // len(bary))
        for slot, material in materials.items():
            chosen = chosen_triangles[(splits == k) & (found.slots[chosen_triangles] == slot)]
            local = np.array([names.index(pattern.name) for pattern in condition.survey_patterns(material.modes)])
            for start in range(0, len(chosen), step):
                triangles = chosen[start : start + step]
                inputs = {key: read(triangles, bary) for key, read in material.readers.items()}
                for clock, value in clocks.items():  # t, and the clocks in years (a material may have none)
                    if clock in inputs:
                        inputs[clock] = np.full((len(triangles), len(bary)), float(value))
                stone = [inputs.pop(key) for key in points.STONE_INPUTS]
                fields = _fields(found, material.modes, triangles, bary, inputs)
                index, loss = condition.classify(*stone, material.modes, fields=fields, **inputs)
                index = local[index]
                weight = np.broadcast_to((found.areas_m2[triangles] / len(bary))[:, None], index.shape)
                areas += np.bincount(index.ravel(), weight.ravel(), minlength=count)
                face = np.broadcast_to(faces[triangles][:, None], index.shape)
                face_areas += np.bincount((face * count + index).ravel(), weight.ravel(), minlength=faces_count * count)
                face_loss += np.bincount(face.ravel(), (loss * weight).ravel(), minlength=faces_count)
                if drawn:
                    pieces.append(np.repeat(triangles, len(bary)).astype(np.int32))
                    parts.append(np.tile(np.arange(len(bary), dtype=np.int16), len(triangles)))
                    kinds.append(index.ravel().astype(np.int16))
    if not drawn:
        return Tally(areas, face_areas.reshape(faces_count, count), face_loss)
    empty = (np.zeros(0, np.int32), np.zeros(0, np.int16), np.zeros(0, np.int16))
    which, part, kind = (np.concatenate(chunks) for chunks in (pieces, parts, kinds)) if pieces else empty
    return Tally(areas, face_areas.reshape(faces_count, count), face_loss, (which, part), kind)


def _fields(found, modes, triangles, bary, inputs):
    """{field: value} of the per-point fields ``modes`` read, at the sample points ``bary`` of
    ``triangles``: from the points' place in metres from the object's origin and their triangle's
    normal (a smooth-shaded surface's shader reads its interpolated normal instead)."""
    names = weathering_modes.fields_of(modes)
    if not names:
        return None
    metres = np.einsum("nkc,sk->nsc", found.triangles_m[triangles], bary) - found.origin_m
    normals = np.broadcast_to(found.normals[triangles][:, None, :], metres.shape)
    return {name: FIELDS[name](metres, normals, inputs) for name in names}
