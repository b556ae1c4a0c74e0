"""Scans as they come (docs/scans.md): the bake warns, one line naming the object, when an
object's up axis looks wrong for rain, when stray floaters set its size, or when it is
flat-shaded as a scan saved without normals is. The checks are heuristics: they warn, the bake
goes on.

- **Lies on its side**: its bounding box is longest across (along X or Y), it has a flat
  base on a side and none underneath. A base is the faces within 11° of facing out of one side
  of the box, in the outer 1% of the box, covering at least 1% of the area (under 0.1%
  counts as none). A bust, statue or vase scanned on its plinth stands on such a base; read
  with the wrong up axis, the base faces sideways.
- **Faces the ground**: more than half of its area faces more than 30° below the horizon
  (an open scan, a relief or a façade's front, turned over): the rain reaches little of it.
- **Stray parts**: loose parts (a surface split at its seams counts as one) that hold under 1%
  of its area between them make the object's size (``edges.object_size``, from which the edge
  radius and the run-off's lengths are taken) over 1.25 times the size of the rest, its body: a
  scan's floaters. The warning counts those beyond the body's box by 5% of its size.
- **Faceted**: every face is flat-shaded, the mesh has no custom normals, and most of the
  edges between two faces bend by 1°-20°, as a curved surface shown by flat facets does: the
  renders and the rain see every facet, the edge mask takes smooth normals for it (edges.py)
  (a hard-surface model, whose faces meet
  flush or at sharp angles, is not warned about).
"""

import warnings

import numpy as np

from ..blender import mesh_arrays
from ..core import stones
from ..core.vectors import cross
from ..shading.material import object_metres_per_unit


class ScanWarning(UserWarning):
    """An object looks set up wrongly for the bake; the bake goes on."""


#: A base: faces whose normal is within this cosine (11°) of facing out of a side of the box...
BASE_COSINE = 0.98
#: ... whose centre lies within this fraction of the box's size from that side...
BASE_DEPTH = 0.01
#: ... covering at least this fraction of the object's area (a base), or less than
#: BASE_NONE (no base).
BASE_AREA = 0.01
BASE_NONE = 0.001
#: A face faces the ground when its normal's z is below this (30° below the horizon)...
DOWNWARD_Z = -0.5
#: ... and an object does when more than this fraction of its area does.
DOWNWARD_AREA = 0.5
#: The smallest loose parts holding this share of the area between them are strays...
STRAY_AREA = 0.01
#: ... worth a warning when the object's size with them is over this many times the body's;
#: the warning counts those beyond the body's box by this fraction of its size.
STRAY_SIZE = 1.25
STRAY_REACH = 0.05
#: Edges between two faces that bend between these angles (degrees) are facet edges...
FACET_DEGREES = (1.0, 20.0)
#: ... and a flat-shaded mesh with more than this fraction of them is faceted.
FACETED_EDGES = 0.5

_SIDES = {"+X": (0, 1), "-X": (0, -1), "+Y": (1, 1), "-Y": (1, -1)}


def problems(obj, rain: bool = True) -> list[str]:
    """The warnings for mesh object ``obj`` (the up axis only when ``rain`` is baked)."""
    found = [message for message in (unit_problem(obj),) if message]
    if rain:
        found += [message for message in (_up_axis(obj),) if message]
    found += [message for message in (_stray_parts(obj),) if message]
    if looks_faceted(obj.data):
        found.append(
            f"object '{obj.name}' is flat-shaded with no custom normals, as a scan saved without "
            "normals is: the renders and the rain see its facets (the edge mask takes smooth normals, "
            "the mesh is unchanged); Shade Smooth it if its "
            "surface is curved (docs/scans.md)"
        )
    return found


def unit_problem(obj) -> str | None:
    """The warning when ``obj``'s size is implausible for a stone object at its scene's unit
    scale (docs/model.md §8.4: ``stones.plausible_size``), else None."""
    advice = stones.plausible_size(float(max(obj.dimensions)), object_metres_per_unit(obj))
    return f"object '{obj.name}' {advice}" if advice else None


def warn(obj, rain: bool = True) -> None:
    """``problems(obj, rain)`` as ScanWarnings."""
    for message in problems(obj, rain):
        warnings.warn(message, ScanWarning, stacklevel=2)


def _up_axis(obj):
    mesh = obj.data
    mesh.calc_loop_triangles()
    corners = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", corners)
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    points = mesh_arrays.attribute(mesh, "position", np.float32, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    a, b, c = (points[corners[k::3]] for k in range(3))
    area_vectors = cross(b - a, c - a) * np.sign(np.linalg.det(matrix[:3, :3]))  # a mirror keeps them out
    areas = np.linalg.norm(area_vectors, axis=1)
    total = areas.sum()
    if not total > 0:
        return None
    normals = area_vectors / np.maximum(areas, 1e-300)[:, None]
    downward = areas[normals[:, 2] < DOWNWARD_Z].sum() / total
    if downward > DOWNWARD_AREA:
        return (
            f"object '{obj.name}' faces the ground: {downward:.0%} of its area faces down, so rain "
            "reaches little of it; check the up axis of its import (docs/scans.md)"
        )
    low, high = points.min(axis=0), points.max(axis=0)
    size, centres = high - low, (a + b + c) / 3

    def base(axis, sign):
        facing = sign * normals[:, axis] > BASE_COSINE
        side = high[axis] - centres[:, axis] if sign > 0 else centres[:, axis] - low[axis]
        return areas[facing & (side <= BASE_DEPTH * size[axis])].sum() / total

    side_bases = {name: base(axis, sign) for name, (axis, sign) in _SIDES.items()}
    side, widest = max(side_bases.items(), key=lambda item: item[1])
    if size[:2].max() > size[2] and widest >= BASE_AREA and base(2, -1) < BASE_NONE:
        return (
            f"object '{obj.name}' looks as if it lies on its side (its flat base faces {side}, none faces "
            "down, and it is longest across): rain would fall on its side; check the up axis of its "
            "import (docs/scans.md)"
        )
    return None


def _stray_parts(obj):
    mesh = obj.data
    if not len(mesh.polygons):
        return None
    islands = mesh_arrays.face_islands(mesh, mesh_arrays.border_places(mesh))
    if not islands.max(initial=0):
        return None
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    points = mesh_arrays.attribute(mesh, "position", np.float32, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    corners = mesh_arrays.attribute(mesh, ".corner_vert", np.int32)
    starts = mesh_arrays.loop_starts(mesh)
    faces = mesh_arrays.corner_faces(mesh)
    areas = np.linalg.norm(mesh_arrays.area_vectors(points[corners], starts), axis=1)
    part_area = np.bincount(islands, areas, minlength=islands.max() + 1)
    by_area = np.argsort(part_area)  # the smallest first: the strays are those under STRAY_AREA between them
    stray = np.zeros(len(part_area), dtype=bool)
    stray[by_area[np.cumsum(part_area[by_area]) < STRAY_AREA * part_area.sum()]] = True
    on_surface = areas[faces] > 0  # corners of faces of some area (a stray point plays no part)
    in_body = on_surface & ~stray[islands[faces]]
    if not stray.any() or not in_body.any():
        return None
    body = points[corners[in_body]]
    body_size = np.linalg.norm(np.ptp(body, axis=0))
    ratio = np.linalg.norm(np.ptp(points[corners[on_surface]], axis=0)) / max(body_size, 1e-300)
    if ratio <= STRAY_SIZE:
        return None
    reach = STRAY_REACH * body_size  # a crumb on the body's rim is on it
    low, high = body.min(axis=0) - reach, body.max(axis=0) + reach
    beyond = on_surface & np.any((points[corners] < low) | (points[corners] > high), axis=1)
    outside = np.unique(islands[faces[beyond]])
    count, share = len(outside), part_area[outside].sum() / part_area.sum()
    return (
        f"object '{obj.name}' has {count} loose part{'s' if count > 1 else ''} holding "
        f"{f'{share:.1%}' if share >= 0.001 else 'under 0.1%'} of its surface outside its body, which make "
        f"its size {ratio:.1f} times the body's (its edge radius and run-off lengths scale with it): delete "
        "them if they are a scan's floaters (docs/scans.md)"
    )


def looks_faceted(mesh) -> bool:
    """True when ``mesh`` is flat-shaded all over, has no custom normals and most of its edges
    between two faces bend by FACET_DEGREES (a curved surface shown by flat facets)."""
    if mesh.has_custom_normals or not len(mesh.polygons):
        return False
    smooth = np.empty(len(mesh.polygons), dtype=bool)
    mesh.polygons.foreach_get("use_smooth", smooth)
    if smooth.any():
        return False
    normals = np.empty(len(mesh.polygons) * 3, dtype=np.float32)
    mesh.polygons.foreach_get("normal", normals)
    sizes = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", sizes)
    corner_edge = mesh_arrays.attribute(mesh, ".corner_edge", np.int32)
    order = np.argsort(corner_edge, kind="stable")
    edge, face = corner_edge[order], np.repeat(np.arange(len(sizes)), sizes)[order]
    uses = np.bincount(edge, minlength=len(mesh.edges))
    pairs = uses[edge] == 2
    first = face[pairs][0::2]
    second = face[pairs][1::2]
    if not len(first):
        return False
    normals = normals.reshape(-1, 3)
    cosine = np.clip(np.einsum("ij,ij->i", normals[first], normals[second]), -1.0, 1.0)
    bend = np.degrees(np.arccos(cosine))
    low, high = FACET_DEGREES
    return np.count_nonzero((bend > low) & (bend < high)) > FACETED_EDGES * len(bend)
