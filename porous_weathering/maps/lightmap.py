"""Lightmap UVs for baked maps: reuse a UV map that can hold a bake, or make one (docs/maps.md,
"The lightmap").

A UV map can hold a bake at a resolution when ``check_uvs`` passes it: every corner lies in
[0, 1]; no texel centre lies on two triangles; the texels each UV island touches lie at least
``padding`` texels from those of every other island; and at most 0.1% of the triangles get
under 1% of their fair (area-proportional) share of the map's texels.

A new map (``make_lightmap``) is made unit-free: the positions are centred and scaled to a mean
triangle area of 1, so millimetres, metres and normalised units give the same map. Small meshes
get xatlas' charts; scans get charts by projection on the axes (each face along the axis
closest to its normal smoothed over its neighbours, so that scan noise does not fragment them).
Where a chart folds over itself, those faces are charted again by xatlas; xatlas packs the
charts at the bake's resolution, and the map is checked: faces that still break it are charted
again and all is packed again, and a map that still fails is refused with what is wrong. A new
map is always a new UV layer (``LIGHTMAP_UV``); the user's own UV maps are never changed.

The bake's unwrap (``iter_lightmap``) runs in a child Python process (this file, run as a
script: it imports nothing but numpy and xatlas), so a caller stays responsive, sees its
progress and can stop it at once.
"""

import io
import json
import os
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Generator
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the child process that unwraps imports nothing but numpy and xatlas
    import bpy

LIGHTMAP_UV = "PW Lightmap"
#: Texels between UV islands (and packed between new charts) at and above PADDING_FULL_FROM.
PADDING = 4
#: Below this resolution islands need only 2 texels between them (a few charts could not fit).
PADDING_FULL_FROM = 256
#: A triangle is starved below this fraction of its area-proportional share of texels...
STARVED_SHARE = 0.01
#: ... and a map may starve at most this fraction of its triangles.
STARVED_MAX = 0.001
#: Meshes of up to this many triangles are charted by xatlas (fewer seams, no folds; about
#: 75-350 µs a triangle on 2 cores), larger ones by projection on the axes (benchmarks/bench_unwrap.py).
XATLAS_CHARTS = 20_000
#: Rounds of face -> vertex -> face averaging of the normals that choose a face's direction.
SMOOTHING_ROUNDS = 3
#: A face is projected along its smoothed direction only if its own normal is this close to it
#: (cosine), else along the axis closest to its own normal (never folded, never starved).
MIN_COSINE = 0.3
#: Rounds of "faces that break the map are charted again" before a map is refused, and the
#: rings of neighbours that go with them (a fold is found where a texel centre falls on it:
#: its neighbours are likely in it too, and the next packing would find them).
REPAIR_ROUNDS = 3
CULPRIT_RINGS = 4
#: Folds are looked for before packing with this many samples per texel (along each side) of
#: the bake, so that the texel centres of the bake are unlikely to find one the search missed.
FOLD_SAMPLING = 1.0
#: A texel centre this close to an edge (in texels² of the edge function) lies on it.
ON_EDGE = 1e-6
#: Candidate texels rasterised at once (bounds the check's memory).
RASTER_BLOCK = 1 << 22

AXES = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], dtype=np.float64)

Progress = Callable[[float, str], None]


def padding_for(resolution: int) -> int:
    """The texels a lightmap keeps between its UV islands at ``resolution``."""
    return PADDING if resolution >= PADDING_FULL_FROM else 2


# --- the mesh as arrays (bpy meshes, read in the caller's process) ---------------------------


def corner_uvs(mesh, name):
    """The UV map ``name`` as a float32 (len(mesh.loops), 2) array."""
    uvs = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers[name].data.foreach_get("uv", uvs)
    return uvs.reshape(-1, 2)


def triangle_corners(mesh):
    """(corner indices (T, 3), vertex indices (T, 3)) of the mesh's loop triangles."""
    mesh.calc_loop_triangles()
    count = len(mesh.loop_triangles)
    loops = np.empty(count * 3, dtype=np.int64)
    vertices = np.empty(count * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    mesh.loop_triangles.foreach_get("vertices", vertices)
    return loops.reshape(-1, 3), vertices.reshape(-1, 3)


@dataclass
class Geometry:
    """A mesh's loop triangles: vertex positions (V, 3), and per triangle its face corners (T, 3),
    vertices (T, 3) and polygon (T,)."""

    positions: np.ndarray
    corners: np.ndarray
    vertices: np.ndarray
    polygons: np.ndarray

    @classmethod
    def of(cls, mesh) -> "Geometry":
        corners, vertices = triangle_corners(mesh)
        polygons = np.empty(len(corners), dtype=np.int64)
        mesh.loop_triangles.foreach_get("polygon_index", polygons)
        positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", positions)
        return cls(positions.reshape(-1, 3), corners, vertices, polygons)

    def areas(self):
        """The triangles' areas (T,), in the mesh's units."""
        return _areas(self.positions.astype(np.float64)[self.vertices])


def _areas(triangles):
    """Areas of triangles (T, 3, 2 or 3)."""
    u, v = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    if triangles.shape[-1] == 2:
        return 0.5 * np.abs(_cross(u, v))
    return 0.5 * np.linalg.norm(np.cross(u, v), axis=1)


def _cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


# --- checking a UV map -------------------------------------------------------------------------


@dataclass(frozen=True)
class LightmapReport:
    """What ``check_uvs`` found in a UV map at ``resolution``² with ``padding`` texels between
    islands: triangles with a corner outside [0, 1] (``outside``), texel centres inside two or
    more triangles (``overlapping``), texels of an island within ``padding`` texels of another
    island's (``crowded``), triangles under 1% of their fair share of texels (``starved``, of
    ``triangles`` that have an area), texels whose centre a triangle covers (``covered``) and
    UV ``islands``."""

    resolution: int
    padding: int
    triangles: int
    outside: int
    overlapping: int
    crowded: int
    starved: int
    covered: int
    islands: int

    @property
    def utilisation(self) -> float:
        """The fraction of the image's texels that the bake fills (their centre on a triangle)."""
        return self.covered / self.resolution**2

    @property
    def ok(self) -> bool:
        return not self.problems()

    def problems(self) -> list[str]:
        """Why the map cannot hold a bake, one phrase per reason (empty when it can)."""
        size = f"at {self.resolution}²"
        found = []
        if self.outside:
            found.append(f"{self.outside} triangles leave [0, 1]")
        if self.overlapping:
            found.append(f"{self.overlapping} texels lie on two triangles {size}")
        if self.crowded:
            found.append(f"{self.crowded} texels lie within {self.padding} texels of another island {size}")
        if self.starved > STARVED_MAX * self.triangles:
            found.append(
                f"{self.starved} of {self.triangles} triangles get under {STARVED_SHARE:.0%} of their "
                f"fair share of texels {size}"
            )
        return found


def check_uvs(
    triangle_uvs: np.ndarray, areas: np.ndarray, resolution: int, padding: int | None = None
) -> LightmapReport:
    """Check per-triangle UVs ``triangle_uvs`` (T, 3, 2) of triangles of 3D ``areas`` (T,) as a
    bake target of ``resolution``² texels (see the module docstring)."""
    return _inspect(triangle_uvs, areas, resolution, padding_for(resolution) if padding is None else padding)[0]


def overlapping_texels(triangle_uvs, resolution):
    """How many texel centres of a ``resolution``² image lie on two or more of the UV triangles
    ``triangle_uvs`` (T, 3, 2). A centre on an edge two triangles share is on one of them."""
    return check_uvs(triangle_uvs, np.ones(len(triangle_uvs)), resolution).overlapping


def _inspect(triangle_uvs, areas, resolution, padding):
    """(LightmapReport, the triangles (T,) bool that overlap another or are starved)."""
    uvs = np.asarray(triangle_uvs, dtype=np.float64)
    areas = np.asarray(areas, dtype=np.float64)
    outside = int(np.count_nonzero(np.any((uvs < 0.0) | (uvs > 1.0), axis=(1, 2))))
    islands, rim = _islands(np.asarray(triangle_uvs, dtype=np.float32))
    uv_areas = _areas(uvs)
    share = uv_areas / max(uv_areas.sum(), 1e-300)
    fair = areas / max(areas.sum(), 1e-300)
    solid = fair > 0
    starved = solid & (share < STARVED_SHARE * fair)
    # Islands come closest at their rims, so only rim triangles' footprints are kept apart (an
    # island inside another's would overlap it); a triangle without an area is never seen, one
    # without a UV area is starved.
    footprint = rim & solid & (share > 0)
    centre, centre_triangle, touched, touched_triangle = _rasterise(uvs * resolution, resolution, footprint)
    cover = np.bincount(centre, minlength=resolution * resolution)  # triangles on each texel centre
    crowded = _crowded(touched, islands[touched_triangle], resolution, padding)
    culprits = starved.copy()
    culprits[centre_triangle[cover[centre] > 1]] = True
    report = LightmapReport(
        resolution,
        padding,
        int(np.count_nonzero(solid)),
        outside,
        int(np.count_nonzero(cover > 1)),
        crowded,
        int(np.count_nonzero(starved)),
        int(np.count_nonzero(cover)),
        int(np.unique(islands).size),
    )
    return report, culprits


def _islands(triangle_uvs):
    """(the UV island of every triangle (T,), whether it lies on its island's rim (T,) bool):
    triangles are joined where they share a UV point; a rim triangle has an edge no other
    triangle shares."""
    bits = np.ascontiguousarray(triangle_uvs, dtype=np.float32).view(np.uint32).astype(np.uint64)
    keys = (bits[..., 0] << np.uint64(32)) | bits[..., 1]
    _, points = np.unique(keys.ravel(), return_inverse=True)
    points = points.reshape(-1, 3)
    count = int(points.max()) + 1 if points.size else 0
    first, second = np.concatenate([points[:, :2], points[:, 1:], points[:, ::2]]).T
    edges = np.minimum(first, second) * count + np.maximum(first, second)
    _, index, uses = np.unique(edges, return_inverse=True, return_counts=True)
    rim = (uses[index] == 1).reshape(3, -1).any(axis=0)
    return connected_components(count, first, second)[points[:, 0]], rim


def connected_components(count: int, first, second) -> np.ndarray:
    """The component of each of ``count`` nodes joined by the edges ``first[i]``-``second[i]``,
    as the smallest node of the component (hooking of roots and pointer jumping, vectorised)."""
    label = np.arange(count)
    first, second = np.asarray(first), np.asarray(second)
    while True:
        low, high = label[first], label[second]
        apart = low != high
        if not apart.any():
            return label
        first, second, low, high = first[apart], second[apart], low[apart], high[apart]
        np.minimum.at(label, np.maximum(low, high), np.minimum(low, high))
        while True:  # every node points at its root again
            jumped = label[label]
            if np.array_equal(jumped, label):
                break
            label = jumped


def _rasterise(points, resolution, footprint):
    """For triangles ``points`` (T, 3, 2) in texel units: (texels whose centre lies strictly
    inside a triangle, and that triangle, one entry per pair; texels a triangle where
    ``footprint`` (T,) touches at all, and that triangle). Texels are numbered
    row * resolution + column.

    Triangles go in groups of one bounding-box shape (in texels), so each group is a dense
    (triangles, texels of the box) array of candidates."""
    low = np.clip(np.floor(points.min(axis=1)), 0, resolution - 1)
    extent = (np.clip(np.floor(points.max(axis=1)), 0, resolution - 1) - low + 1).astype(np.int64)
    local = points - low[:, None, :]  # small numbers: the edge functions stay exact enough
    orientation = np.sign(_cross(local[:, 1] - local[:, 0], local[:, 2] - local[:, 0]))
    edges = np.roll(local, -1, axis=1) - local  # (T, 3, 2): a -> b, b -> c, c -> a
    # the edge function orientation * cross(edge, p - start) = along_x * x + along_y * y + offset
    along_x, along_y = -orientation[:, None] * edges[..., 1], orientation[:, None] * edges[..., 0]
    offset = -(along_x * local[..., 0] + along_y * local[..., 1])
    reach = 0.5 * (np.abs(edges[..., 0]) + np.abs(edges[..., 1]))  # of a texel's square, across the edge
    # a centre on an edge two triangles share is theirs once: the triangle the edge faces right
    # (or up) owns it; "on" allows for rounding, as each computes the edge function its own way
    owns = (along_x > 0) | ((along_x == 0) & (along_y > 0))
    origin = (low[:, 1] * resolution + low[:, 0]).astype(np.int64)  # the box's first texel

    shapes, group = np.unique(extent[:, 0] * (resolution + 1) + extent[:, 1], return_inverse=True)
    order = np.argsort(group, kind="stable")
    starts = np.searchsorted(group[order], np.arange(len(shapes) + 1))
    found = {"centre": [], "centre_triangle": [], "touched": [], "touched_triangle": []}
    for shape, first, last in zip(shapes, starts[:-1], starts[1:]):
        width, height = divmod(int(shape), resolution + 1)
        dy, dx = np.divmod(np.arange(width * height), width)
        x, y, step = dx + 0.5, dy + 0.5, dy * resolution + dx
        members = order[first:last]
        for block in np.array_split(members, max(1, members.size * width * height // RASTER_BLOCK)):
            inside = meets = True
            for k in range(3):  # (a degenerate triangle's edge functions are all 0: inside none)
                value = along_x[block, k, None] * x + along_y[block, k, None] * y + offset[block, k, None]
                inside = inside & ((value > ON_EDGE) | ((value >= -ON_EDGE) & owns[block, k, None]))
                meets = meets & (value >= -reach[block, k, None])
            texel = origin[block, None] + step
            meets &= footprint[block, None]
            for mask, where, which in ((inside, "centre", "centre_triangle"), (meets, "touched", "touched_triangle")):
                found[where].append(texel[mask])
                found[which].append(np.broadcast_to(block[:, None], mask.shape)[mask])
    return tuple(np.concatenate(found[name]) if found[name] else np.empty(0, np.int64) for name in found)


def _crowded(texels, islands, resolution, padding):
    """How many touched ``texels`` (of ``islands``) lie within ``padding`` texels (Chebyshev)
    of another island's, or are touched by two islands."""
    label = np.full(resolution * resolution, -1, dtype=np.int32)
    label[texels] = islands
    shared = np.unique(texels[label[texels] != islands])
    label = label.reshape(resolution, resolution)
    empty = label < 0
    highest = _window(label, padding, np.maximum)
    lowest = _window(np.where(empty, np.iinfo(np.int32).max, label), padding, np.minimum)
    near = ~empty & ((highest > label) | (lowest < label))
    near.reshape(-1)[shared] = True
    return int(np.count_nonzero(near))


def _window(image, radius, pick):
    """``pick`` (np.maximum or np.minimum) over the (2 radius + 1)² square around every texel
    (the square cut at the image's border)."""
    result = image.copy()
    for axis in (0, 1):
        source = result.copy()
        for shift in range(1, radius + 1):
            ahead = [slice(None)] * 2
            behind = [slice(None)] * 2
            ahead[axis], behind[axis] = slice(shift, None), slice(None, -shift)
            pick(result[tuple(ahead)], source[tuple(behind)], out=result[tuple(ahead)])
            pick(result[tuple(behind)], source[tuple(ahead)], out=result[tuple(behind)])
    return result


# --- making a lightmap -------------------------------------------------------------------------


def normalised(positions, vertices):
    """``positions`` centred on their bounding box and scaled to a mean triangle area of 1."""
    positions = np.asarray(positions, dtype=np.float64)
    centred = positions - (positions.min(axis=0) + positions.max(axis=0)) / 2
    mean_area = _areas(centred[vertices]).mean() if len(vertices) else 0.0
    return centred / np.sqrt(mean_area) if mean_area > 0 else centred


def polygon_normals(positions, vertices, polygons):
    """Each polygon's area vector (P, 3): its normal times twice its area, summed over its triangles."""
    a, b, c = (positions[vertices[:, k]] for k in range(3))
    area_vectors = np.cross(b - a, c - a)
    return np.stack([np.bincount(polygons, area_vectors[:, k]) for k in range(3)], axis=1)


def chart_directions(vertices, polygons, normals):
    """The axis (an index into AXES) each polygon is projected along (P,): the axis closest to
    its normal (``normals``, area vectors) smoothed over SMOOTHING_ROUNDS rings of neighbours,
    if its own normal is within MIN_COSINE of it, else the axis closest to its own normal."""
    smooth = normals
    corners = vertices.ravel()
    for _ in range(SMOOTHING_ROUNDS):
        spread = np.repeat(smooth[polygons], 3, axis=0)
        at_vertex = np.stack([np.bincount(corners, spread[:, k]) for k in range(3)], axis=1)
        gathered = at_vertex[vertices].sum(axis=1)
        smooth = np.stack([np.bincount(polygons, gathered[:, k], minlength=len(normals)) for k in range(3)], axis=1)
    direction = np.argmax(smooth @ AXES.T, axis=1)
    cosine = (normals @ AXES.T) / np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]
    astray = cosine[np.arange(len(normals)), direction] < MIN_COSINE
    direction[astray] = np.argmax(cosine[astray], axis=1)
    return direction


def tangent_bases(normals):
    """(N, 2, 3): two unit vectors u, v across each of ``normals`` (N, 3), u × v along it."""
    normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(normals, helper)
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    return np.stack([u, np.cross(normals, u)], axis=1)


def cube_charts(points, vertices, polygons, normals):
    """(corner keys (T, 3), corner UVs (T, 3, 2)) of charts made by projecting every polygon along
    its axis (``chart_directions``): corners share a UV point when they share the key, a
    vertex projected along an axis, so the connected faces of one axis make one chart."""
    direction = chart_directions(vertices, polygons, normals)[polygons]
    uvs = np.empty(vertices.shape + (2,))
    for axis, basis in enumerate(tangent_bases(AXES)):
        along = direction == axis
        uvs[along] = points[vertices[along]] @ basis.T
    return vertices * len(AXES) + direction[:, None], uvs


def xatlas_charts(points, vertices, polygons, normals):
    """(corner keys (T, 3), corner UVs (T, 3, 2)) of xatlas' own charts (in the units of
    ``points``). xatlas charts triangles: a polygon it cuts along a diagonal (which one UV per
    face corner cannot express) becomes a chart of its own, on its own plane."""
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(points.astype(np.float32), vertices.astype(np.uint32))
    atlas.generate()
    _, keys, atlas_uvs = atlas[0]
    keys, uvs = keys.astype(np.int64), atlas_uvs[keys].astype(np.float64)
    # its charts at the scale of the mesh, so that they and any polygon on its own plane agree
    uvs *= np.sqrt(_areas(points[vertices]).sum() / max(_areas(uvs).sum(), 1e-300))
    # a polygon is cut where one of its vertices has two keys: sort its corners by (polygon, vertex)
    polygon, vertex, key = np.repeat(polygons, 3), vertices.ravel(), keys.ravel()
    order = np.lexsort((vertex, polygon))
    polygon, vertex, key = polygon[order], vertex[order], key[order]
    same_corner = (polygon[1:] == polygon[:-1]) & (vertex[1:] == vertex[:-1])
    cut = np.zeros(len(normals), dtype=bool)
    cut[polygon[1:][same_corner & (key[1:] != key[:-1])]] = True
    return _alone(keys, uvs, points, vertices, polygons, normals, cut)


def _alone(keys, uvs, points, vertices, polygons, normals, alone):
    """``keys`` and ``uvs`` with the polygons ``alone`` (P,) each a chart of its own, on its own
    plane (its area vector in ``normals``)."""
    lone = alone[polygons]
    if not lone.any():
        return keys, uvs
    keys, uvs = keys.copy(), uvs.copy()
    keys[lone] = keys.max() + 1 + vertices[lone] * len(alone) + polygons[lone, None]
    uvs[lone] = np.einsum("tkd,tjd->tkj", points[vertices[lone]], tangent_bases(normals[polygons[lone]]))
    return keys, uvs


def _rechart(keys, uvs, points, vertices, polygons, normals, chosen):
    """``keys`` and ``uvs`` with the polygons ``chosen`` (P,) charted again by xatlas, on their
    own: xatlas' charts do not fold (it checks them), and the few faces where a projection
    folds are quick to chart."""
    picked = chosen[polygons]
    if not picked.any():
        return keys, uvs
    used, local_vertices = np.unique(vertices[picked], return_inverse=True)
    kept, local_polygons = np.unique(polygons[picked], return_inverse=True)
    local_keys, local_uvs = xatlas_charts(points[used], local_vertices.reshape(-1, 3), local_polygons, normals[kept])
    keys, uvs = keys.copy(), uvs.copy()
    keys[picked] = keys.max() + 1 + local_keys
    uvs[picked] = local_uvs
    return keys, uvs


def _chart_points(keys, uvs):
    """(UV points (N, 2), triangles over them (T, 3)): one point per key."""
    _, first, triangles = np.unique(keys.ravel(), return_index=True, return_inverse=True)
    return uvs.reshape(-1, 2)[first], triangles.reshape(-1, 3)


def _charts_of(uvs, triangles):
    """The chart (0, 1, ...) of each UV point (N,): points joined by triangles make one."""
    first, second = np.concatenate([triangles[:, :2], triangles[:, 1:]]).T
    return np.unique(connected_components(len(uvs), first, second), return_inverse=True)[1]


def _folds(uvs, triangles, chart, texels_per_unit):
    """The triangles (T,) bool on which a texel centre falls twice when every chart is
    sampled apart, at ``texels_per_unit``: where a chart folds over itself."""
    count = int(chart.max()) + 1
    low, high = np.full((count, 2), np.inf), np.full((count, 2), -np.inf)
    np.minimum.at(low, chart, uvs)
    np.maximum.at(high, chart, uvs)
    cell = float((high - low).max()) * texels_per_unit + 2  # texels: the largest chart and a border
    per_row = int(np.ceil(np.sqrt(count)))
    corner = np.stack([chart % per_row, chart // per_row], axis=1) * cell + 1
    placed = (uvs - low[chart]) * texels_per_unit + corner
    centre, triangle, _, _ = _rasterise(placed[triangles], int(per_row * cell) + 2, np.zeros(len(triangles), bool))
    order = np.argsort(centre, kind="stable")
    centre, triangle = centre[order], triangle[order]
    twice = centre[1:] == centre[:-1]
    folded = np.zeros(len(triangles), dtype=bool)
    folded[triangle[1:][twice]] = True
    folded[triangle[:-1][twice]] = True
    return folded


def pack(uvs, triangles, chart, resolution, spacing):
    """Per-triangle UVs (T, 3, 2) in [0, 1]: the charts of ``uvs`` (``chart`` of each point)
    packed by xatlas, ``spacing`` texels around each (xatlas keeps about twice that between
    charts).

    xatlas takes every chart flat, as its UVs, each at a height of its own: given the mesh's
    positions, it sees the points where charts meet as one (and let charts overlap, on a
    sculpted sample). It picks a scale that fills ``resolution`` only roughly: a larger atlas
    (by up to about a quarter) is shrunk to fit, which narrows the gaps by as much;
    ``make_lightmap`` checks them."""
    import xatlas

    points = np.concatenate([uvs, chart.reshape(-1, 1)], axis=1)

    charts = xatlas.ChartOptions()
    charts.use_input_mesh_uvs = True
    options = xatlas.PackOptions()
    options.resolution = resolution
    options.padding = spacing
    options.bilinear = True
    atlas = xatlas.Atlas()
    atlas.add_mesh(points.astype(np.float32), triangles.astype(np.uint32), uvs=uvs.astype(np.float32))
    atlas.generate(chart_options=charts, pack_options=options)
    if atlas.atlas_count != 1:
        raise LightmapError(f"xatlas packed the charts into {atlas.atlas_count} atlases, not one")
    _, indices, atlas_uvs = atlas[0]
    texels = atlas_uvs * np.array([atlas.width, atlas.height], dtype=np.float64)
    return (texels / max(atlas.width, atlas.height, resolution))[indices].astype(np.float32)  # as stored


class LightmapError(ValueError):
    """No lightmap that passes ``check_uvs`` could be made."""


def make_lightmap(positions, vertices, polygons, resolution: int, padding: int, progress: Progress = None):
    """(per-triangle UVs (T, 3, 2), LightmapReport) of a new lightmap of the triangles
    ``vertices`` (T, 3) of polygons ``polygons`` (T,) over ``positions`` (V, 3), checked at
    ``resolution``² with ``padding`` texels between islands. Meshes of up to XATLAS_CHARTS
    triangles get xatlas' charts, larger ones ``cube_charts`` (benchmarks/bench_unwrap.py).
    Where the charts fold over themselves (``_folds``, before packing) those faces and
    CULPRIT_RINGS rings of neighbours are charted again by xatlas; faces the check then finds
    overlapping or starved likewise, and everything is packed again, up to REPAIR_ROUNDS times;
    then LightmapError says what is still wrong. ``progress(fraction, stage)``."""
    progress = progress or (lambda fraction, stage: None)
    progress(0.0, "charts")
    points = normalised(positions, vertices)
    areas = _areas(points[vertices])
    normals = polygon_normals(points, vertices, polygons)
    charts = xatlas_charts if len(vertices) <= XATLAS_CHARTS else cube_charts
    keys, uvs = charts(points, vertices, polygons, normals)
    chart_uvs, triangles = _chart_points(keys, uvs)
    progress(0.1, "folds")
    # where the projection folds, at a little finer than the bake's texels will be (about 60% used)
    texels_per_unit = FOLD_SAMPLING * np.sqrt(0.6 * resolution**2 / max(_areas(chart_uvs[triangles]).sum(), 1e-300))
    folded = _folds(chart_uvs, triangles, _charts_of(chart_uvs, triangles), texels_per_unit)
    again = _grown(polygons[folded], vertices, polygons, len(normals), CULPRIT_RINGS)
    spacing = padding // 2 + 1  # xatlas keeps about twice this between charts, less once shrunk to fit
    for attempt in range(REPAIR_ROUNDS + 1):
        # the first round takes most of the time (packing and checking about 40% each, at 2M
        # triangles), a repair round as long again, but it is rarely needed: the bar never goes back
        low, high = (0.2, 0.9) if not attempt else (1 - 0.1 / attempt, 1 - 0.1 / (attempt + 1))
        progress(low, f"packing, {again.sum()} faces charted again" if again.any() else "packing")
        chart_uvs, triangles = _chart_points(*_rechart(keys, uvs, points, vertices, polygons, normals, again))
        triangle_uvs = pack(chart_uvs, triangles, _charts_of(chart_uvs, triangles), resolution, spacing)
        progress(low + 0.5 * (high - low), "checking")
        report, culprits = _inspect(triangle_uvs, areas, resolution, padding)
        if report.ok:
            return triangle_uvs, report
        again |= _grown(polygons[culprits], vertices, polygons, len(again), CULPRIT_RINGS)
        spacing += report.crowded > 0  # xatlas' shrunk atlas came too close
    raise LightmapError(f"no lightmap at {resolution}² passes: {'; '.join(report.problems())}")


def _grown(chosen, vertices, polygons, count, rings):
    """The polygons (count,) bool ``chosen`` and those within ``rings`` rings of them (sharing a vertex)."""
    found = np.zeros(count, dtype=bool)
    found[chosen] = True
    for _ in range(rings):
        touched = np.zeros(int(vertices.max()) + 1, dtype=bool)
        touched[vertices[found[polygons]]] = True
        found[polygons[touched[vertices].any(axis=1)]] = True
    return found


# --- the unwrap, in a child process ----------------------------------------------------------

#: Seconds the caller waits for news from the unwrap before it yields control anyway.
POLL_SECONDS = 0.1
_PROGRESS, _ERROR = "PW-PROGRESS", "PW-ERROR"


@dataclass(frozen=True)
class Lightmap:
    """What ``iter_lightmap`` settled on: the UV map ``name`` to bake on, ``uvs`` per face
    corner when that map is new (None when the mesh's own map is reused) and its report."""

    name: str
    uvs: np.ndarray | None
    report: LightmapReport


def iter_lightmap(
    mesh: "bpy.types.Mesh", resolution: int, padding: int | None = None
) -> Generator[tuple[float, str], None, Lightmap]:
    """The lightmap of ``mesh`` for a bake at ``resolution``², as a generator of
    (fraction, stage) while it runs in a child process (closing it stops that process at once);
    its return value (``StopIteration.value``) is the Lightmap.

    The mesh's own "PW Lightmap", then its other UV maps in order, are reused if they pass
    ``check_uvs``; else a new lightmap is made, unless the mesh has a "PW Lightmap" (made for
    another resolution, or since distorted): that is refused (ValueError saying what is wrong),
    as maps baked on it would no longer match it. A lightmap that cannot be made raises
    LightmapError."""
    padding = padding_for(resolution) if padding is None else padding
    geometry = Geometry.of(mesh)
    names = _candidates(mesh)
    job = io.BytesIO()
    np.savez(
        job,
        positions=geometry.positions,
        vertices=geometry.vertices,
        polygons=geometry.polygons,
        candidates=np.stack([corner_uvs(mesh, name)[geometry.corners] for name in names])
        if names
        else np.zeros((0, len(geometry.vertices), 3, 2), np.float32),
        settings=np.array([resolution, padding, LIGHTMAP_UV not in names]),
    )
    # No files: pipes work where a disk is full or file sizes are limited, and leave nothing behind.
    process = subprocess.Popen(
        [sys.executable, "-P", os.path.abspath(__file__)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=dict(os.environ, PYTHONPATH=os.pathsep.join(path for path in sys.path if path)),
    )
    try:
        news, result = queue.Queue(), []
        threading.Thread(target=_forward_lines, args=(process.stderr, news), daemon=True).start()
        reader = threading.Thread(target=lambda: result.append(process.stdout.read()), daemon=True)
        reader.start()
        try:
            process.stdin.write(len(job.getbuffer()).to_bytes(8, "little") + job.getbuffer())
            process.stdin.flush()  # and kept open: the child ends when it closes (this process died)
        except BrokenPipeError:  # the child died first: its last words say why
            pass
        fraction, stage, errors, started = 0.0, "starting", [], time.monotonic()
        while True:
            try:
                line = news.get(timeout=POLL_SECONDS)
            except queue.Empty:
                line = ""
            if line is None:  # the child closed its stderr: it is done
                break
            if line.startswith(_PROGRESS):
                _, value, stage = line.rstrip("\n").split(" ", 2)
                fraction = float(value)
            elif line.strip():
                errors.append(line.strip())
            yield fraction, f"{stage} ({time.monotonic() - started:.0f} s)"
        code = process.wait()
        reader.join()
        failure = next((line[len(_ERROR) :].strip() for line in errors if line.startswith(_ERROR)), None)
        if failure is not None:
            raise LightmapError(failure)
        if code != 0 or not result:
            raise RuntimeError(f"the lightmap unwrap stopped (exit code {code}): {' / '.join(errors[-3:])}")
        with np.load(io.BytesIO(result[0])) as found:
            report = LightmapReport(**json.loads(str(found["report"])))
            chosen = int(found["chosen"])
            if chosen >= 0:
                return Lightmap(names[chosen], None, report)
            if LIGHTMAP_UV in names:
                raise ValueError(
                    f"mesh '{mesh.name}': its UV map '{LIGHTMAP_UV}' cannot hold a bake at {resolution}²: "
                    f"{'; '.join(report.problems())}. Bake at the resolution it was made for, or remove "
                    "it to let the bake make a new one (the maps baked on it are then baked again)"
                )
            uvs = np.zeros((len(mesh.loops), 2), dtype=np.float32)
            uvs[geometry.corners] = found["uvs"]
            return Lightmap(LIGHTMAP_UV, uvs, report)
    finally:
        if process.poll() is None:
            process.kill()
        process.wait()
        for stream in (process.stdin, process.stdout, process.stderr):
            stream.close()


def _forward_lines(stream, lines):
    for line in stream:
        lines.put(line.decode(errors="replace"))
    lines.put(None)


def lightmap_uvs(mesh: "bpy.types.Mesh", resolution: int, padding: int | None = None) -> np.ndarray:
    """A new lightmap of ``mesh`` for ``resolution``² (float32 (len(loops), 2)), whatever UV
    maps it has (``make_lightmap``, in this process)."""
    padding = padding_for(resolution) if padding is None else padding
    geometry = Geometry.of(mesh)
    triangle_uvs, _ = make_lightmap(geometry.positions, geometry.vertices, geometry.polygons, resolution, padding)
    uvs = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    uvs[geometry.corners] = triangle_uvs
    return uvs


def find_bakeable_uv_map(mesh: "bpy.types.Mesh", resolution: int, padding: int | None = None) -> str | None:
    """The name of a UV map of ``mesh`` that can hold a bake at ``resolution``² (``check_uvs``),
    or None. Our own lightmap comes first, then the user's maps in their order."""
    geometry = Geometry.of(mesh)
    areas = geometry.areas()
    return next(
        (
            name
            for name in _candidates(mesh)
            if check_uvs(corner_uvs(mesh, name)[geometry.corners], areas, resolution, padding).ok
        ),
        None,
    )


def _candidates(mesh):
    """The UV maps a bake may reuse, in order: our own lightmap, then the user's maps."""
    return [LIGHTMAP_UV] * (LIGHTMAP_UV in mesh.uv_layers) + [
        layer.name for layer in mesh.uv_layers if layer.name != LIGHTMAP_UV
    ]


def add_uv_map(mesh, name, uvs):
    """A new UV map ``name`` on ``mesh`` holding per-corner ``uvs``; the active map is unchanged."""
    if name in mesh.uv_layers:
        raise ValueError(f"{mesh.name}: there is already a UV map named {name!r}")
    active = mesh.uv_layers.active
    layer = mesh.uv_layers.new(name=name, do_init=False)
    layer.data.foreach_set("uv", np.ascontiguousarray(uvs, dtype=np.float32).reshape(-1))
    if active is not None:
        mesh.uv_layers.active = active
    return layer


def _child():
    """The child process: the job on stdin (its length, then an npz), progress and errors on
    stderr, the result (an npz) on stdout. It checks the job's candidate UV maps in order and
    picks the first that passes, or makes a lightmap."""
    size = int.from_bytes(sys.stdin.buffer.read(8), "little")
    job = np.load(io.BytesIO(sys.stdin.buffer.read(size)))
    threading.Thread(target=lambda: (os.read(0, 1), os._exit(1)), daemon=True).start()  # the caller died

    def progress(fraction, stage):
        print(f"{_PROGRESS} {fraction:.3f} {stage}", file=sys.stderr, flush=True)

    def answer(**result):
        found = io.BytesIO()
        np.savez(found, **result)
        sys.stdout.buffer.write(found.getbuffer())
        sys.stdout.buffer.flush()

    positions, vertices, polygons, candidates = (
        job[name] for name in ("positions", "vertices", "polygons", "candidates")
    )
    resolution, padding, make = (int(value) for value in job["settings"])
    areas = _areas(positions.astype(np.float64)[vertices])
    reports = []
    for number, candidate in enumerate(candidates):
        progress(number / len(candidates), f"checking UV map {number + 1}/{len(candidates)}")
        reports.append(check_uvs(candidate, areas, resolution, padding))
        if reports[-1].ok:
            return answer(chosen=number, report=json.dumps(asdict(reports[-1])))
    if not make:  # the first candidate is our own lightmap: refused, with its report
        return answer(chosen=-1, report=json.dumps(asdict(reports[0])))
    try:
        triangle_uvs, report = make_lightmap(positions, vertices, polygons, resolution, padding, progress)
    except LightmapError as error:
        print(f"{_ERROR} {error}", file=sys.stderr, flush=True)
        os._exit(3)
    progress(1.0, "done")
    answer(chosen=-1, uvs=triangle_uvs, report=json.dumps(asdict(report)))


if __name__ == "__main__":
    _child()
    os._exit(0)  # not waiting for the thread that watches the caller
