"""The curvature maths of the edge/cavity mask (docs/model.md §5, and docs/model.md §6.3;
docs/maps.md, "Edge/cavity mask"), on numpy arrays: no bpy (``edges`` reads the mesh, bakes the
texels and writes the attribute).

- ``mesh_surface``: the samples of a mesh's curvature and area (``Surface``): the dihedral
  angles of its edges and the areas of its faces, spread along long edges and across large
  faces so that the field does not depend on how coarse the mesh is.
- ``smooth_over_radius``: the signed mean curvature H at any points, smoothed over a radius (a
  grid splat and gather, linear in time).
- ``curvature_mask``: the mask C in [0, 1] from H, its concave and convex parts weighted apart.
"""

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..blender.mesh_arrays import encloses_negative_volume
from ..core.vectors import cross

#: Grids summed by ``smooth_over_radius`` (docs/maps.md: the spread along a straight edge).
SHIFTS = tuple(np.full(3, k / 4) for k in range(4))

#: The corners (dx, dy, dz) of a grid cell, as offsets from its lower corner.
CORNERS = np.array([(dx, dy, dz) for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)])

#: Channels per grid cell: the features (|n|, n_x, n_y, n_z) / sqrt(2) of the normals, whose
#: dot product weighs a source seen from a point by (1 + n_source . n_point) / 2.
CHANNELS = 4

#: Points per block of the grid splat and gather: small enough that a block's temporaries
#: stay in the CPU cache, so the time per point does not grow with the mesh.
BLOCK = 1 << 14

#: The largest box of grid cells numbered directly (one bool and one int32 per cell).
DIRECT_CELLS_MAX = 1 << 25

#: Longest distance, in smoothing radii, between the samples that carry an edge's curvature
#: or a face's area: edges and faces longer than this are sampled along and across
#: (docs/maps.md: coarse meshes get the same mask as fine ones).
SAMPLE_SPACING = 0.5

#: Most samples added along long edges and across large faces before a radius counts as too
#: small for the object (64 bytes each, plus their grid cells).
MAX_ADDED_SAMPLES = 1 << 23

#: Default weights of the concave (cavity) and convex (edge) parts of the mask (docs/maps.md,
#: "Why cavity weight 3"): a sculpture's or a building's hollows are rounded at the default
#: radius (|H| r under 0.2), and at weight 3 they reach C = 1, where its crusts form.
DEFAULT_CAVITY_WEIGHT = 3.0
DEFAULT_EDGE_WEIGHT = 0.5

#: Default of ``curvature_mask``'s ``saturation``: the dimensionless curvature H * radius
#: at which C reaches 1.  A sharp 90-degree edge gives about 0.6 (docs/maps.md).
DEFAULT_SATURATION = 0.45

#: Points of each sample's ball at which ``contacts`` asks whether another part fills it: the
#: share they give has a spread of about 0.07 at a sample, and the smoothing gathers some fifty
#: samples or more (docs/maps.md, "Where parts meet").
BALL_POINTS = 32
#: The sets of them the samples take turns with.
BALL_SETS = 256


def _too_small(name, radius):
    return ValueError(
        f"object '{name}': edge radius is too small for an object this size ({radius:.3g} scene units): "
        "give a larger --edge-radius, or a larger --edge-scale"
    )


# --- where parts meet ---------------------------------------------------------------------------


def ball_points(sets: int, seed: int = 0) -> np.ndarray:
    """(sets, BALL_POINTS, 3) points spread evenly in the unit ball, each set its own (the same
    for the same ``seed``): samples take turns with them, so that the smoothing averages their
    errors out."""
    rng = np.random.default_rng(seed)
    directions = unit(rng.normal(size=(sets * BALL_POINTS, 3)))
    lengths = rng.random(sets * BALL_POINTS) ** (1.0 / 3.0)
    return (directions * lengths[:, None]).reshape(sets, BALL_POINTS, 3)


def contact_curvature(filled: np.ndarray, radius: float) -> np.ndarray:
    """The mean curvature another part adds at a sample of the surface, from the share
    ``filled`` of the sample's ball of ``radius`` that the other parts fill (and its own part
    does not): the union of the parts has there a ball that much fuller, and by the volume
    integral invariant (docs/model.md §5: V = 2 pi r^3 / 3 - pi H r^4 / 4) that much less
    mean curvature: -(4 / (pi r^4)) V.  Scaled by pi / 4, so that a right-angled corner where two
    parts meet carries, over both its faces, the integrated curvature of a right-angled mesh
    edge (theta x length / 2): -V / r^4, V = (4 pi / 3) r^3 x filled."""
    return -(4.0 * math.pi / 3.0) * np.asarray(filled, dtype=np.float64) / radius


# --- samples of the surface ----------------------------------------------------------------------


@dataclass(frozen=True)
class Samples:
    """Points on a surface in world space, each with a unit normal (0 where it has none), the
    integrated mean curvature it carries, the area around it and a vertex of the mesh's face or
    edge it lies on (so its loose part: ``contacts``)."""

    points: np.ndarray  #: (n, 3) float64
    normals: np.ndarray  #: (n, 3) float64
    curvature: np.ndarray  #: (n,) float64
    area: np.ndarray  #: (n,) float64
    vertex: np.ndarray  #: (n,) int64

    @staticmethod
    def joined(parts):
        return Samples(*(np.concatenate([getattr(part, name) for part in parts]) for name in Samples.__annotations__))


@dataclass(frozen=True)
class Surface:
    """What the mask needs of an evaluated mesh: its vertices (with their curvature and area),
    and every sample of curvature and area (the vertices, then samples along long edges and
    across large faces)."""

    vertices: Samples
    sources: Samples


def mesh_surface(
    positions: np.ndarray,
    matrix_world: np.ndarray,
    corner_verts: np.ndarray,
    corner_edges: np.ndarray,
    edge_verts: np.ndarray,
    loop_starts: np.ndarray,
    radius: float,
    name: str = "",
) -> Surface:
    """The ``Surface`` of a mesh given as arrays (its vertices' local ``positions`` (V, 3), the
    vertex and edge of every face corner, the two vertices of every edge (E, 2), every face's
    first corner) placed by ``matrix_world`` (4, 4), for smoothing ``radius``; ``name`` names
    the object in errors.

    Curvature comes from the faces' area vectors (Newell) and the edges' dihedral angles, areas
    from the faces.  Both are spread along the edges and across the
    faces by the trapezoidal rule at ``SAMPLE_SPACING`` radii (``_edge_samples``,
    ``_fan_samples``): short edges and small faces give everything to their corners (the
    vertices), longer ones add samples in between, so the field does not depend on how coarse
    the mesh is, and it changes continuously with the vertices (a mesh in millimetres and the
    same one in metres differ by the rounding of their coordinates)."""
    matrix_world = np.asarray(matrix_world, dtype=np.float64)
    local = np.asarray(positions, dtype=np.float64)
    points = local @ matrix_world[:3, :3].T + matrix_world[:3, 3]
    if not np.isfinite(points).all():
        raise ValueError(f"object '{name}' has vertices at non-finite positions")
    spacing = SAMPLE_SPACING * radius
    loop_vertex, loop_edge, edge_vertices = corner_verts, corner_edges, edge_verts
    loop_bounds = np.append(loop_starts, len(loop_vertex))
    # A mirroring transform reverses the winding: flip so that normals still point out.
    side = 0.5 if np.linalg.det(matrix_world[:3, :3]) >= 0 else -0.5
    faces = _face_sums(points, loop_vertex, loop_edge, loop_bounds, side, len(edge_vertices), spacing)
    area_vectors, centres, area, normals, first_face, last_face, fanned = faces
    # the surface: the vertices of faces of non-zero area (not loose vertices, which carry nothing)
    on_surface = np.zeros(len(points), dtype=bool)
    on_surface[loop_vertex[np.repeat(np.linalg.norm(area_vectors, axis=1) > 0, np.diff(loop_bounds))]] = True
    if not on_surface.any():
        raise ValueError(f"object '{name}' has no face of non-zero area to measure curvature on")
    if np.ptp(points[on_surface], axis=0).max() / radius >= 2**20:  # the grid's cells could not be numbered
        raise _too_small(name, radius)
    edge_uses = np.bincount(loop_edge, minlength=len(edge_vertices))
    if encloses_negative_volume(edge_uses, centres, area_vectors):
        area_vectors, normals = -area_vectors, -normals  # inside out: renders shade it from outside
    face_normals = unit(area_vectors)
    normals = unit(normals)

    edge_lengths = np.linalg.norm(points[edge_vertices[:, 0]] - points[edge_vertices[:, 1]], axis=1)
    manifold = np.flatnonzero(edge_uses == 2)  # edges between exactly two faces carry curvature
    ratio = edge_lengths[manifold] / spacing
    fans = _fans(points, loop_vertex, loop_bounds, centres, area_vectors, np.flatnonzero(fanned))
    # Samples added: every node but an edge's ends, a fan triangle's apex row and its base's ends.
    rows, columns = _trapezoid_nodes(fans.heights / spacing), _trapezoid_nodes(fans.widths / spacing)
    if (_trapezoid_nodes(ratio) - 2).sum() + ((rows - 1) * columns - 2).sum() > MAX_ADDED_SAMPLES:
        raise _too_small(name, radius)

    vertices = Samples(points, normals, np.zeros(len(points)), area, np.arange(len(points)))
    added = [_fan_samples(fans, vertices, face_normals, spacing)]
    for block in _blocks(len(manifold)):
        edges = manifold[block]
        face_a, face_b = first_face[edges], last_face[edges]
        normal_a, normal_b = face_normals[face_a], face_normals[face_b]
        angle = np.arctan2(np.linalg.norm(cross(normal_a, normal_b), axis=1), (normal_a * normal_b).sum(1))
        # Convex when the faces lean away from each other: their normals part as their centres do.
        convex = ((normal_a - normal_b) * (centres[face_a] - centres[face_b])).sum(1) >= 0
        integrated = np.where(convex, angle, -angle) * edge_lengths[edges] / 2  # theta * length / 2
        short = ratio[block] <= 1  # all to its ends, as _edge_samples would give it
        np.add.at(vertices.curvature, edge_vertices[edges[short]].ravel(), np.repeat(integrated[short] / 2, 2))
        if not short.all():
            long = ~short
            middle = unit(normal_a[long] + normal_b[long])
            added.append(
                _edge_samples(edge_vertices[edges[long]], middle, integrated[long], ratio[block][long], vertices)
            )
    on_faces = Samples(*(getattr(vertices, name)[on_surface] for name in Samples.__annotations__))
    return Surface(vertices, Samples.joined([on_faces, *added]))


def unit(vectors: np.ndarray) -> np.ndarray:
    """Each row of ``vectors`` (n, 3) scaled to length 1 (a row of zeros stays 0)."""
    return vectors / np.maximum(np.linalg.norm(vectors, axis=1), np.finfo(float).tiny)[:, None]


def _face_sums(points, loop_vertex, loop_edge, loop_bounds, side, edge_count, spacing):
    """(area vectors (F, 3), centres (F, 3), area per vertex (V,), sum of its faces' area
    vectors per vertex (V, 3), first and last face of every edge (E,), fanned faces (F,) bool).

    A face's area vector is ``side`` times its Newell sum.  A triangle no longer than
    ``spacing`` gives a third of its area to each corner here (what ``_fan_samples`` would
    give it: its centre cuts it into three equal fan triangles); the other faces are fanned.
    The faces go in blocks of about ``BLOCK`` corners, so that no temporary outgrows the CPU
    cache: the time stays linear in the corner count."""
    face_count = len(loop_bounds) - 1
    area_vectors, centres = np.empty((face_count, 3)), np.empty((face_count, 3))
    fanned = np.empty(face_count, dtype=bool)
    vertex_area, vertex_vectors = np.zeros(len(points)), np.zeros((3, len(points)))
    first_face, last_face = np.full(edge_count, face_count), np.full(edge_count, -1)
    faces_per_block = max(1, BLOCK * face_count // max(int(loop_bounds[-1]), 1))
    for faces in _blocks(face_count, faces_per_block):
        loops = slice(loop_bounds[faces.start], loop_bounds[faces.stop])
        starts = loop_bounds[faces] - loops.start
        counts = np.diff(loop_bounds[faces.start : faces.stop + 1])
        vertices = loop_vertex[loops]
        corners = points[vertices]
        following = np.arange(1, len(corners) + 1)  # the next corner around the face
        following[starts + counts - 1] = starts
        vectors = side * np.add.reduceat(cross(corners, corners[following]), starts)
        area_vectors[faces] = vectors
        centres[faces] = np.add.reduceat(corners, starts) / counts[:, None]
        longest = np.maximum.reduceat(np.linalg.norm(corners[following] - corners, axis=1), starts)
        fanned[faces] = (counts != 3) | (longest > spacing)

        corner_face = np.repeat(np.arange(len(counts)), counts)
        third = np.where(fanned[faces], 0.0, np.linalg.norm(vectors, axis=1) / 3)
        np.add.at(vertex_area, vertices, third[corner_face])
        for axis in range(3):
            np.add.at(vertex_vectors[axis], vertices, vectors[corner_face, axis])
        np.minimum.at(first_face, loop_edge[loops], corner_face + faces.start)
        np.maximum.at(last_face, loop_edge[loops], corner_face + faces.start)
    return area_vectors, centres, vertex_area, vertex_vectors.T, first_face, last_face, fanned


def _trapezoid_nodes(ratio):
    """How many nodes ``_trapezoid`` puts on a length of ``ratio`` spacings: 2 up to one
    spacing, one more per spacing (the last cell may be shorter)."""
    whole = np.floor(ratio).astype(np.int64)
    return whole + 1 + (ratio > whole)


def _trapezoid(ratio):
    """The trapezoidal rule on [0, 1] cut into cells of 1 / ``ratio`` (the last one shorter),
    for each of the (n,) ``ratio``: (owner (m,), x (m,), weight (m,)), the nodes of each in
    order from 0 to 1, their weights summing to 1.  A new node appears at 1 with weight 0 as
    the length passes a whole number of spacings: the rule changes continuously."""
    ratio = np.asarray(ratio, dtype=np.float64)
    counts = _trapezoid_nodes(ratio)
    owner = np.repeat(np.arange(len(ratio)), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    node = np.arange(len(owner)) - first
    x = np.minimum(node / np.maximum(ratio[owner], np.finfo(float).tiny), 1.0)
    x[first + counts[owner] - 1 == np.arange(len(owner))] = 1.0
    cells = np.diff(x, append=1.0)
    last = node == counts[owner] - 1
    cells[last] = 0.0
    before = np.concatenate([[0.0], cells[:-1]])
    before[node == 0] = 0.0
    return owner, x, (before + cells) / 2


def _edge_samples(ends, normals, integrated, ratio, vertices):
    """The integrated curvature of edges (their end vertices ``ends`` (n, 2), the mean
    ``normals`` of their two faces) spread by the trapezoidal rule: the end nodes' shares go
    to ``vertices``, the others become samples on the edge."""
    owner, x, weight = _trapezoid(ratio)
    share = integrated[owner] * weight
    at_end = (x == 0) | (x == 1)
    np.add.at(vertices.curvature, ends[owner[at_end], (x[at_end] == 1).astype(int)], share[at_end])
    owner, x, share = owner[~at_end], x[~at_end, None], share[~at_end]
    points = vertices.points[ends[owner, 0]] * (1 - x) + vertices.points[ends[owner, 1]] * x
    return Samples(points, normals[owner], share, np.zeros(len(share)), ends[owner, 0])


@dataclass(frozen=True)
class Fans:
    """The triangles that fan every face from its centre, one per face corner: apex (the
    face's centre), base (the corner and the next one), area (its share of the face's area),
    height (apex to the base's middle) and width (the base's length)."""

    face: np.ndarray
    corner: np.ndarray  #: the base's vertices (n, 2)
    apex: np.ndarray
    areas: np.ndarray
    heights: np.ndarray
    widths: np.ndarray


def _fans(points, loop_vertex, loop_bounds, centres, area_vectors, faces):
    """The ``Fans`` of ``faces``: no diagonal is chosen, so nothing jumps when a quad is
    nearly square, and the fan's areas are scaled to the face's (they add up to more where a
    face is concave)."""
    counts = np.diff(loop_bounds)[faces]
    face = np.repeat(faces, counts)
    first = np.cumsum(counts) - counts
    loops = np.repeat(loop_bounds[faces] - first, counts) + np.arange(len(face))
    following = np.where(loops + 1 < loop_bounds[face + 1], loops + 1, loop_bounds[face])
    corner = np.stack([loop_vertex[loops], loop_vertex[following]], axis=1)
    apex = centres[face]
    base = points[corner]
    areas = np.linalg.norm(cross(base[:, 0] - apex, base[:, 1] - apex), axis=1) / 2
    fan_area = np.add.reduceat(areas, first) if len(faces) else np.empty(0)
    areas *= (np.linalg.norm(area_vectors[faces], axis=1) / np.maximum(fan_area, np.finfo(float).tiny))[
        np.repeat(np.arange(len(faces)), counts)
    ]
    heights = np.linalg.norm(base.mean(axis=1) - apex, axis=1)
    widths = np.linalg.norm(base[:, 1] - base[:, 0], axis=1)
    return Fans(face, corner, apex, areas, heights, widths)


def _fan_samples(fans, vertices, face_normals, spacing):
    """The faces' areas spread by the trapezoidal rule over their fan triangles, each mapped
    from the unit square (s from the apex to the base, t along the base: p = apex + s (corner -
    apex + t (next - corner)), area element 2 s ds dt): the base's end nodes give their shares
    to ``vertices`` (so a small face gives half of each fan triangle to each of its base's
    corners), the apex's weigh nothing, the others become samples with the face's normal.
    A sliver is sampled along its length only."""
    rows = _trapezoid_nodes(fans.heights / spacing)
    columns = _trapezoid_nodes(fans.widths / spacing)
    small = (rows == 2) & (columns == 2)  # nodes at the apex and the base's ends only
    np.add.at(vertices.area, fans.corner[small].ravel(), np.repeat(fans.areas[small] / 2, 2))
    large = np.flatnonzero(~small)
    if not len(large):
        return Samples(*(np.empty((0, 3)),) * 2, *(np.empty(0),) * 2, np.empty(0, dtype=np.int64))
    s_owner, s, s_weight = _trapezoid(fans.heights[large] / spacing)
    t_owner, t, t_weight = _trapezoid(fans.widths[large] / spacing)
    s_first = np.cumsum(rows[large]) - rows[large]
    t_first = np.cumsum(columns[large]) - columns[large]
    counts = rows[large] * columns[large]
    triangle = np.repeat(np.arange(len(large)), counts)
    node = np.arange(len(triangle)) - np.repeat(np.cumsum(counts) - counts, counts)
    i = s_first[triangle] + node // columns[large][triangle]
    j = t_first[triangle] + node % columns[large][triangle]
    s, t = s[i], t[j]
    share = fans.areas[large][triangle] * 2 * s * s_weight[i] * t_weight[j]
    fan = large[triangle]
    at_corner = (s == 1) & ((t == 0) | (t == 1))
    np.add.at(vertices.area, fans.corner[fan[at_corner], (t[at_corner] == 1).astype(int)], share[at_corner])
    inside = ~at_corner & (s > 0)
    fan, s, t, share = fan[inside], s[inside, None], t[inside, None], share[inside]
    a, b = fans.corner[fan, 0], fans.corner[fan, 1]
    apex = fans.apex[fan]
    points = apex + s * (vertices.points[a] - apex + t * (vertices.points[b] - vertices.points[a]))
    return Samples(points, face_normals[fans.face[fan]], np.zeros(len(share)), share, a)


def _blocks(count, size=None):
    """Slices of ``range(count)`` of ``size`` items (default ``BLOCK``)."""
    size = size or BLOCK
    return [slice(start, min(start + size, count)) for start in range(0, count, size)]


# --- smoothing over a radius ---------------------------------------------------------------------


def smooth_over_radius(
    sources: Samples, points: np.ndarray, normals: np.ndarray, radius: float, shifts: Sequence[np.ndarray] = SHIFTS
) -> np.ndarray:
    """H at ``points`` (n, 3) with unit ``normals``: sum(w * curvature) / sum(w * area) over the
    ``sources`` around each point, as float32 (n,).

    The weights are a grid splat and gather: each source spreads its values trilinearly onto
    the corners of a grid of cell ``radius`` and each point reads them back the same way, so a
    point weighs the sources around it by a tent of half-width between ``radius`` and 2
    ``radius``, in time linear in the number of sources and points whatever the tessellation.
    ``shifts`` grids, offset along the diagonal, are summed, so the weights hardly depend on
    where the grid lies.  Each weight is also multiplied by (1 + n_source . n_point) / 2, from 1
    for parallel normals to 0 for opposite ones, so the two sides of a thin wall never mix;
    this factor is the dot product of the features ``(1, n) / sqrt(2)`` of both normals, so the
    grid holds 4 channels per cell.  Points with no source around them get 0.
    """
    points = np.asarray(points, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    # only the points within two radii of the sources' box can get a weight: the others (a
    # loose vertex far away) would only stretch the grid
    low, high = sources.points.min(axis=0) - 2 * radius, sources.points.max(axis=0) + 2 * radius
    near = np.all((points >= low) & (points <= high), axis=1)
    if not near.all():
        values = np.zeros(len(points), dtype=np.float32)
        values[near] = smooth_over_radius(sources, points[near], normals[near], radius, shifts)
        return values
    numerator = np.zeros(len(points))
    denominator = np.zeros(len(points))
    for shift in shifts:
        grid_numerator, grid_denominator = _grid_sums(sources, points, normals, radius, shift)
        numerator += grid_numerator
        denominator += grid_denominator
    covered = denominator > 1e-12 * max(sources.area.sum(), np.finfo(float).tiny)
    return np.where(covered, numerator / np.where(covered, denominator, 1.0), 0.0).astype(np.float32)


def _grid_sums(sources, points, normals, radius, shift):
    """(numerator, denominator) of ``smooth_over_radius`` on one grid of cell ``radius``,
    offset by ``shift`` cells: every source splats its curvature and area onto the 8 corners
    of its cell, and every point gathers the corner sums back, with the same trilinear and
    normal (``_features``) weights.

    Sources and points go in blocks of ``BLOCK``, from their positions on, so that no
    temporary outgrows the CPU cache, and the corners are numbered without sorting
    (``_cell_numbering``): time grows linearly."""
    # the grid stands on the centre of the sources' box, not on the world's origin: where the
    # object stands changes nothing (and far from the origin, the cells keep their precision)
    anchor = (sources.points.min(axis=0) + sources.points.max(axis=0)) / 2.0
    low = np.floor(
        (np.minimum(sources.points.min(axis=0), points.min(axis=0, initial=np.inf)) - anchor) / radius + shift
    )
    high = np.floor(
        (np.maximum(sources.points.max(axis=0), points.max(axis=0, initial=-np.inf)) - anchor) / radius + shift
    )
    width, height, depth = (high - low).astype(np.int64) + 2
    corner_offsets = (CORNERS[:, 0] * height + CORNERS[:, 1]) * depth + CORNERS[:, 2]

    def cells(where, block):
        """(key of the cell (n,), position in it (n, 3)) of the points ``where[block]``."""
        scaled = (where[block] - anchor) / radius + shift - low
        cell = np.floor(scaled)
        index = cell.astype(np.int64)
        return (index[:, 0] * height + index[:, 1]) * depth + index[:, 2], scaled - cell

    source_blocks = _blocks(len(sources.points))
    number, cell_count = _cell_numbering(
        lambda block: cells(sources.points, block)[0], corner_offsets, int(width * height * depth), source_blocks
    )
    # Curvature and area per (corner cell, normal channel); the last cell stands for every
    # cell no source touches, and stays 0.
    sums = np.zeros((2, CHANNELS * (cell_count + 1)))
    for block in source_blocks:
        keys, fractions = cells(sources.points, block)
        corner_cells = number(keys[:, None] + corner_offsets)
        buckets, weights = _corner_weights(corner_cells, fractions, _features(sources.normals[block]))
        np.add.at(sums[0], buckets.ravel(), (weights * sources.curvature[block, None]).ravel())
        np.add.at(sums[1], buckets.ravel(), (weights * sources.area[block, None]).ravel())
    gathered = np.empty((2, len(points)))
    for block in _blocks(len(points)):
        keys, fractions = cells(points, block)
        buckets, weights = _corner_weights(number(keys[:, None] + corner_offsets), fractions, _features(normals[block]))
        gathered[:, block] = np.einsum("ij,kij->ki", weights, np.take(sums, buckets, axis=1))
    return gathered[0], gathered[1]


def _cell_numbering(source_keys, corner_offsets, box_size, blocks):
    """(number, count): ``number(keys)`` numbers the corner cells the sources touch 0 .. count
    - 1, and gives every other cell of the box the number ``count``; ``source_keys(block)``
    gives the cell keys of a block of sources.

    A box of at most ``DIRECT_CELLS_MAX`` cells is numbered directly (a running count of the
    cells in use, linear time); a larger, sparse one (a radius far below the object's size)
    by sorting its keys."""
    if box_size > DIRECT_CELLS_MAX:
        used = np.unique(np.concatenate([(source_keys(block)[:, None] + corner_offsets).ravel() for block in blocks]))

        def number(keys):
            found = np.minimum(np.searchsorted(used, keys), len(used) - 1)
            return np.where(used[found] == keys, found, len(used))

        return number, len(used)
    in_use = np.zeros(box_size, dtype=bool)
    for block in blocks:
        in_use[source_keys(block)[:, None] + corner_offsets] = True
    numbers = np.cumsum(in_use, dtype=np.int32) - 1
    count = int(numbers[-1]) + 1
    numbers[~in_use] = count
    return numbers.__getitem__, count


def _features(normals):
    """(n, CHANNELS): ``(|n|, n_x, n_y, n_z) / sqrt(2)`` of each normal (0 for a point without one)."""
    return np.concatenate([np.linalg.norm(normals, axis=1)[:, None], normals], axis=1) * math.sqrt(0.5)


def _corner_weights(corner_cells, fraction, features):
    """(buckets, weights), both (n, 32): for each of the 8 corners of a point's cell, its
    ``CHANNELS`` normal channels, weighted by the trilinear weight of the corner times the
    point's ``features``."""
    x, y, z = (np.stack([1 - fraction[:, k], fraction[:, k]], axis=1) for k in range(3))  # lower, upper corner
    trilinear = (x[:, :, None, None] * y[:, None, :, None] * z[:, None, None, :]).reshape(-1, len(CORNERS))
    buckets = CHANNELS * corner_cells[:, :, None] + np.arange(CHANNELS)
    weights = trilinear[:, :, None] * features[:, None, :]
    return buckets.reshape(len(fraction), -1), weights.reshape(len(fraction), -1)


# --- the mask ---------------------------------------------------------------------------------------


def curvature_mask(
    curvature_values: ArrayLike,
    radius: float,
    *,
    cavity_weight: float = DEFAULT_CAVITY_WEIGHT,
    edge_weight: float = DEFAULT_EDGE_WEIGHT,
    saturation: float = DEFAULT_SATURATION,
) -> np.ndarray:
    """C in [0, 1] from signed curvature: the dimensionless H * radius / ``saturation``, its
    convex part (H > 0) times ``edge_weight`` plus its concave part (H < 0) times
    ``cavity_weight``, clipped to [0, 1]."""
    if not (math.isfinite(saturation) and saturation > 0.0):
        raise ValueError(f"saturation must be a positive number, not {saturation}")
    for name, weight in (("cavity_weight", cavity_weight), ("edge_weight", edge_weight)):
        if not (math.isfinite(weight) and weight >= 0.0):
            raise ValueError(f"{name} must be a number at least 0, not {weight}")
    scaled = np.asarray(curvature_values, dtype=np.float64) * radius / saturation
    weighted = np.where(scaled > 0, edge_weight * scaled, -cavity_weight * scaled)
    return np.clip(weighted, 0.0, 1.0).astype(np.float32)
