"""Run-off: where the rain that lands on a surface goes (docs/model.md §7), in numpy (no bpy).

The flow runs on a sampling of the surface (``sample_surface``), not on the mesh's faces, so
that one quad and a fine grid, millimetres and metres, give the same flux at the same points:
the surface is cut into cells of side ``spacing`` (a voxel and one of six normal directions,
so that the two faces of a thin wall stay apart), one node per cell with its position, normal
and area. ``route`` computes at steady state the run-off flux Q of each node (the rain
collected along the path, per unit width: E x length), from the highest node down:

- water moves along the steepest descent d = g - (g.N) N, shared among the lower neighbours
  that lie in the direction of d (paths merge where they converge and split where they diverge);
- along a path it gains the rain that lands and loses what the stone absorbs, dQ/ds = E - Q / l,
  solved exactly across each node (Q = E l (1 - exp(-s / l)) on a uniform slope);
- at a node that faces down by more than the drip angle the water drips: it falls along the
  rain's direction and lands where that line first meets the surface (``land``), or leaves;
- flats and hollows: elevations are filled from the outlets (Priority-Flood with a tiny rise
  across flats: Barnes, Lehman & Mulla 2014), so a hollow fills and overflows at its lowest
  rim and a level roof drains to its nearest edges, losing and making no water.

Everything is vectorised over the nodes but the priority flood, a heap of Python floats, and
that only over the nodes whose descent does not reach an outlet (hollows, flats: ``filled_elevation``).
"""

import heapq
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.vectors import cross
from .lightmap_check import surface_points

#: Normal directions a cell is split by (+x, -x, +y, -y, +z, -z): opposite faces stay apart.
_DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
#: Neighbours whose normals are further apart than this (a cosine) are two sides of a thin wall.
_OPPOSED = -0.25
#: How closely the flow follows the steepest descent among the lower neighbours (a cosine's power).
FOCUS = 8.0
#: The flux per unit width is measured over each node and its neighbours this many steps away:
#: a single node's share of a stream depends on how the cells happen to cut it.
SMOOTHING_RINGS = 2
#: Neighbours on one face (a cosine), over which the flux is measured.
_SAME_FACE = np.cos(np.radians(45.0))
#: The 27 voxel offsets around a cell (its own included).
_OFFSETS = np.array(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij")).reshape(3, -1).T
_GRAVITY = np.array([0.0, 0.0, -1.0])
#: Where the cells start below the mesh's lowest corner, in cells: not whole numbers, so that the
#: faces of a mesh modelled on a grid do not lie on cell boundaries, where the rounding of a
#: scaled copy (millimetres against metres) would put their points in other cells.
_GRID_OFFSET = np.array([1.2071, 1.3183, 1.1537])
#: Points read or sampled at a time (``interpolate``, ``_triangle_samples``): a bounded working set.
_CHUNK = 1 << 16
#: Nodes whose neighbours ``_neighbours`` lists at a time.
_NODES_AT_A_TIME = 1 << 18


@dataclass(frozen=True)
class Surface:
    """Samples of a surface, one node per cell of side ``spacing`` (scene units)."""

    positions: np.ndarray  #: (N, 3)
    normals: np.ndarray  #: (N, 3) unit
    areas: np.ndarray  #: (N,)
    border: np.ndarray  #: (N,) bool: the cell holds a border of an open mesh (water may leave there)
    spacing: float
    indptr: np.ndarray  #: CSR neighbours: node i's are indices[indptr[i]:indptr[i + 1]]
    indices: np.ndarray
    cells: np.ndarray  #: (N,) sorted cell keys (voxel << 3 | direction)
    origin: np.ndarray  #: (3,) corner of voxel (0, 0, 0)
    values: np.ndarray | None = None  #: (N,) the quantity sampled with the surface (``values_at``)

    def voxels_of(self, points: np.ndarray) -> np.ndarray:
        return np.floor((np.asarray(points, float) - self.origin) / self.spacing).astype(np.int64)


def _pack(voxel: np.ndarray) -> np.ndarray:
    """One int64 per voxel: 20 bits an axis (a million cells a side)."""
    return (voxel[:, 0] << 40) | (voxel[:, 1] << 20) | voxel[:, 2]


def _triangle_samples(vertices, triangles, spacing, per_point=()):
    """Points covering every triangle of non-zero area about spacing / 2 apart: the centroids
    of a regular subdivision of each triangle. Returns the points' coordinates (3, P), and per
    triangle its face normal, the area of each of its points, its number of points and its
    index, for the triangles in the order of their points; and for each function of
    ``per_point`` (``f(triangles, weights)``: a quantity at points given by their triangle and
    barycentric weights) its value at every point."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    area_vectors = cross(b - a, c - a)
    double_area = np.linalg.norm(area_vectors, axis=1)
    normals = area_vectors / np.maximum(double_area, 1e-300)[:, None]
    longest = np.maximum(
        np.maximum(np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1)), np.linalg.norm(a - c, axis=1)
    )
    parts = np.maximum(1, np.ceil(longest / (0.5 * spacing))).astype(np.int64)
    del area_vectors, longest
    each = 0.5 * double_area / (parts * parts)
    solid = each > 0  # degenerate triangles (a sphere's poles) hold no surface
    # the triangles grouped by their number of parts (stable: in their order within a group)
    order = np.nonzero(solid)[0]
    order = order[np.argsort(parts[order], kind="stable")]
    total = int((parts[order] ** 2).sum())
    coords = np.empty((3, total))
    values = [np.empty(total) for _ in per_point]
    at, groups = 0, np.unique(parts[order])
    start = np.searchsorted(parts[order], groups)
    stop = np.append(start[1:], len(order))
    for n, lo, hi in zip(groups.tolist(), start.tolist(), stop.tolist()):
        chosen = order[lo:hi]
        # the n^2 sub-triangles' centroids as barycentric weights: n(n+1)/2 upright, n(n-1)/2 inverted
        i, j = np.nonzero(np.add.outer(np.arange(n), np.arange(n)) < n)
        k, m = np.nonzero(np.add.outer(np.arange(n), np.arange(n)) < n - 1)
        uv = np.concatenate([np.stack([i + 1 / 3, j + 1 / 3], 1), np.stack([k + 2 / 3, m + 2 / 3], 1)]) / n
        w0, w1, w2 = np.column_stack([1 - uv.sum(1), uv]).T
        size = len(chosen) * len(uv)
        scratch = np.empty((len(chosen), len(uv)))
        for d in range(3):
            out = coords[d, at : at + size].reshape(len(chosen), len(uv))
            np.multiply(a[chosen, d, None], w0, out=out)  # w0 a + w1 b + w2 c, in that order
            out += np.multiply(b[chosen, d, None], w1, out=scratch)
            out += np.multiply(c[chosen, d, None], w2, out=scratch)
        # the quantities at the points, a bounded number of points at a time (a scan's millions of
        # triangles would otherwise hold several (points, 3) arrays at once)
        step = max(1, _CHUNK // len(uv))
        for first in range(0, len(chosen) if per_point else 0, step):
            part = chosen[first : first + step]
            weights = np.tile(np.column_stack([w0, w1, w2]), (len(part), 1))
            where = slice(at + first * len(uv), at + (first + len(part)) * len(uv))
            for value, function in zip(values, per_point):
                value[where] = function(np.repeat(part, len(uv)), weights)
        at += size
    return coords, normals[order], each[order], parts[order] ** 2, order, values


def sample_surface(
    vertices: np.ndarray,
    triangles: np.ndarray,
    spacing: float,
    border_edges: np.ndarray | None = None,
    values_at: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> Surface:
    """The nodes of a triangle mesh's surface at ``spacing``. ``border_edges`` ((T, 3) bool: the
    edge facing each corner is on the mesh's border): the nodes within ``spacing`` of such an
    edge are where water may leave an open mesh. ``values_at(triangles, weights)``: a quantity
    (the rain E) at points given by their triangle and barycentric weights, averaged over each
    node as ``Surface.values``."""
    vertices = np.asarray(vertices, float)
    triangles = np.asarray(triangles, np.int64)
    per_point = [near_border(vertices, triangles, border_edges, spacing)] if border_edges is not None else []
    per_point += [values_at] if values_at is not None else []
    coords, normals, each, repeats, _, sampled = _triangle_samples(vertices, triangles, spacing, per_point)
    point_border = sampled.pop(0) > 0 if border_edges is not None else None
    point_values = sampled.pop(0) if values_at is not None else None
    origin = surface_points(vertices, triangles).min(0) - spacing * _GRID_OFFSET  # not below a loose vertex
    voxel = []
    for d in range(3):  # np.floor((coords[d] - origin[d]) / spacing), with fewer temporaries
        scaled = coords[d] - origin[d]
        scaled /= spacing
        voxel.append(np.floor(scaled, out=scaled).astype(np.int64))
    del scaled
    direction = np.argmax(normals @ _DIRECTIONS.T, axis=1)  # per triangle
    # the cells: the sorted distinct keys (voxel, direction). Sorting the keys with each
    # point's index packed into the low bits is an argsort at the speed of a plain sort.
    low = [int(v.min()) for v in voxel]
    extent = [int(v.max()) - lo + 1 for v, lo in zip(voxel, low)]
    points = len(voxel[0])
    index_bits = max(1, points - 1).bit_length()
    if (extent[0] * extent[1] * extent[2] * 8) << index_bits < 1 << 62:
        key = (voxel[0] - low[0]) * extent[1]
        key += voxel[1] - low[1]
        key *= extent[2]
        key += voxel[2] - low[2]
        key <<= 3
        key |= np.repeat(direction, repeats)
        key <<= index_bits
        key |= np.arange(points)
        key.sort()
        perm = key & ((1 << index_bits) - 1)
        key >>= index_bits
        new = np.empty(points, bool)
        new[0] = True
        np.not_equal(key[1:], key[:-1], out=new[1:])
        compact = key[new]
        node = np.empty(points, np.int64)
        node[perm] = np.cumsum(new) - 1
        del key, perm, new
        cell_dir = compact & 7
        compact >>= 3
        cell_voxel = np.empty((len(compact), 3), np.int64)
        cell_voxel[:, 2] = compact % extent[2] + low[2]
        compact //= extent[2]
        cell_voxel[:, 1] = compact % extent[1] + low[1]
        cell_voxel[:, 0] = compact // extent[1] + low[0]
        cells = (_pack(cell_voxel) << 3) | cell_dir
    else:  # too many cells to pack a point's index beside its key
        keys = (_pack(np.column_stack(voxel)) << 3) | np.repeat(direction, repeats)
        cells, node = np.unique(keys, return_inverse=True)
    del voxel
    count = len(cells)
    areas = np.repeat(each, repeats)
    area = np.bincount(node, areas, count)
    position = np.column_stack([np.bincount(node, areas * coords[k], count) for k in range(3)]) / area[:, None]
    del coords
    normal = np.column_stack([np.bincount(node, np.repeat(each * normals[:, k], repeats), count) for k in range(3)])
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
    border = np.zeros(count, bool)
    if point_border is not None:
        border[node[point_border]] = True
    values = None if point_values is None else np.bincount(node, areas * point_values, count) / area
    del node, areas, point_border, point_values  # the points are summed up: free them for the neighbours
    indptr, indices = _neighbours(cells, normal)
    return Surface(position, normal, area, border, float(spacing), indptr, indices, cells, origin, values)


def near_border(vertices, triangles, border_edges, spacing):
    """f(triangles, weights): 1 at points within ``spacing`` of an edge of ``border_edges``
    (the distance to the edge facing corner k is the weight of k times the triangle's height)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    double_area = np.linalg.norm(cross(b - a, c - a), axis=1)
    lengths = np.linalg.norm(np.stack([c - b, a - c, b - a], 1), axis=2)  # the edge facing each corner
    heights = double_area[:, None] / np.maximum(lengths, 1e-300)
    flags = np.asarray(border_edges, bool)

    def near(tri, weights):
        return ((weights * heights[tri] < spacing) & flags[tri]).any(1).astype(float)

    return near


def _cells_around(cells: np.ndarray, voxels: np.ndarray):
    """(query index, node) pairs: the nodes in the 27 voxels around each query voxel, searched
    once per distinct voxel (points read at texels share their voxels)."""
    distinct, which = np.unique(_pack(voxels), return_inverse=True)
    one = np.empty(len(distinct), np.int64)
    one[which] = np.arange(len(which))  # a query of each distinct voxel (np.unique's return_index sorts stably: slower)
    around, nodes = _cells_around_distinct(cells, voxels[one])
    # each query takes its voxel's pairs: the pairs grouped by voxel, then repeated per query
    order = np.argsort(around, kind="stable")
    around, nodes = around[order], nodes[order]
    count = np.bincount(around, minlength=len(distinct))
    start = np.cumsum(count) - count
    taken = count[which]
    queries = np.repeat(np.arange(len(which)), taken)
    pair = np.repeat(start[which] - np.cumsum(taken) + taken, taken) + np.arange(len(queries))
    return queries, nodes[pair]


def _cells_around_distinct(cells: np.ndarray, voxels: np.ndarray):
    """(index into ``voxels``, node) pairs for distinct voxels, in the order of their keys."""
    cell_voxels = cells >> 3
    queries, nodes = [], []
    for offset in _OFFSETS:
        wanted = _pack(voxels + offset)
        low = np.searchsorted(cell_voxels, wanted, "left")
        high = np.searchsorted(cell_voxels, wanted, "right")
        for extra in range(len(_DIRECTIONS)):  # the directions that share a voxel
            hit = np.nonzero(low + extra < high)[0]
            if not len(hit):
                break
            queries.append(hit)
            nodes.append(low[hit] + extra)
    if not queries:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(queries), np.concatenate(nodes)


def _search_sorted(haystack, needles, chunk=1 << 16):
    """np.searchsorted(haystack, needles) for sorted needles, a chunk of needles at a time in
    the stretch of haystack that holds their answers: a binary search over the whole of a
    large array misses the cache at every step."""
    if len(needles) <= chunk:
        return np.searchsorted(haystack, needles)
    found = np.empty(len(needles), np.int64)
    bounds = np.searchsorted(haystack, needles[::chunk])
    bounds = np.append(bounds, len(haystack))
    for k in range(len(bounds) - 1):
        lo, hi = bounds[k], bounds[k + 1]
        found[k * chunk : (k + 1) * chunk] = lo + np.searchsorted(haystack[lo:hi], needles[k * chunk : (k + 1) * chunk])
    return found


def _edge_cosines(normals, sources, targets):
    """The cosines between the normals of ``sources`` and ``targets``: np.einsum("ij,ij->i")
    over the pairs, a column at a time (in the order einsum sums them: x, z, then y), in
    reused buffers, without gathering (E, 3) arrays."""
    cosine, mine, theirs = (np.empty(len(targets)) for _ in range(3))
    for step, k in enumerate((0, 2, 1)):
        column = np.ascontiguousarray(normals[:, k])
        np.take(column, sources, out=mine, mode="clip")  # (no buffering: indices are valid)
        np.take(column, targets, out=theirs, mode="clip")
        if step:
            theirs *= mine
            cosine += theirs
        else:
            np.multiply(mine, theirs, out=cosine)
    return cosine


def _neighbours(cells, normals):
    """CSR lists of the nodes in the 26 surrounding cells and in the cell's other directions,
    but for those whose normals are opposed (the far side of a thin wall). Each node's list is
    in the order of the 27 offsets, and of the nodes within a voxel."""
    count = len(cells)
    cell_voxels = cells >> 3
    head = np.concatenate([[True], cell_voxels[1:] != cell_voxels[:-1]])
    voxels = cell_voxels[head]  # sorted, distinct
    first = np.nonzero(head)[0]  # each voxel's first node
    size = np.diff(np.append(first, count))  # its nodes (one a direction)
    voxel_of = np.cumsum(head) - 1
    # the voxels around each voxel: (voxel, offset) in that order, as a (voxels, 27) table. The
    # offsets come in threes along z: one search finds the first, the next two follow it.
    found = np.zeros((len(_OFFSETS), len(voxels)), bool)  # (offset, voxel): rows written whole
    target = np.zeros((len(_OFFSETS), len(voxels)), np.int32 if len(voxels) < 2**31 else np.int64)
    last = len(voxels) - 1
    for k in range(0, len(_OFFSETS), 3):
        dx, dy, dz = _OFFSETS[k].tolist()  # dz = -1
        wanted = voxels + ((dx << 40) + (dy << 20) + dz)  # sorted like voxels: a fast search
        if dx == 0 and dy == 0:
            own = np.arange(len(voxels))
            below = np.maximum(own - 1, 0)
            at = np.where(voxels[below] == wanted, below, own)
        else:
            at = np.minimum(_search_sorted(voxels, wanted), last)
        for step in range(3):
            hit = voxels[at] == wanted
            found[k + step] = hit
            target[k + step] = at
            if step < 2:
                at = np.minimum(at + hit, last)
                wanted += 1
    flat = np.flatnonzero(np.ascontiguousarray(found.T))  # by voxel, then offset
    source_voxel, offset = np.divmod(flat, len(_OFFSETS))
    target = target.ravel().take(offset * len(voxels) + source_voxel).astype(np.int64)
    # a voxel's row: the nodes of its neighbouring voxels, in order
    width = size[target]
    row_length = np.bincount(source_voxel, width, len(voxels)).astype(np.int64)
    row = np.repeat(first[target] - np.cumsum(width) + width, width) + np.arange(int(width.sum()))
    row_start = np.cumsum(row_length) - row_length
    # each node takes its voxel's row, a bounded number of nodes at a time (a scan's millions of
    # candidate pairs would otherwise be held several times over)
    degrees, lists = [], []
    for start in range(0, count, _NODES_AT_A_TIME):
        voxels_here = voxel_of[start : start + _NODES_AT_A_TIME]
        length = row_length[voxels_here]
        sources = np.repeat(np.arange(start, start + len(voxels_here)), length)
        at = np.repeat(row_start[voxels_here] - np.cumsum(length) + length, length) + np.arange(int(length.sum()))
        targets = row[at]
        keep = (sources != targets) & (_edge_cosines(normals, sources, targets) > _OPPOSED)
        degrees.append(np.bincount(sources[keep] - start, minlength=len(voxels_here)))
        lists.append(targets[keep])
    indptr = np.concatenate([[0], np.cumsum(np.concatenate(degrees))]) if count else np.zeros(1, np.int64)
    return indptr, np.concatenate(lists) if lists else np.zeros(0, np.int64)


def nearest_nodes(surface: Surface, points: np.ndarray, normals: np.ndarray | None = None) -> np.ndarray:
    """The node nearest each point among the 27 cells around it (facing the same side as the
    point's normal, when given), -1 where there is none."""
    points = np.asarray(points, float).reshape(-1, 3)
    if not len(points):
        return np.zeros(0, np.int64)
    queries, nodes = _cells_around(surface.cells, surface.voxels_of(points))
    best = np.full(len(points), -1)
    if not len(queries):  # every point far from the surface
        return best
    distance = np.linalg.norm(surface.positions[nodes] - points[queries], axis=1)
    if normals is not None:
        normals = np.broadcast_to(np.asarray(normals, float), points.shape)
        facing = np.einsum("ij,ij->i", surface.normals[nodes], normals[queries]) > 0.0
        distance = np.where(facing, distance, np.inf)
    order = np.lexsort((distance, queries))
    first = np.concatenate([[True], queries[order][1:] != queries[order][:-1]])
    chosen = order[first]
    found = np.isfinite(distance[chosen])
    best[queries[chosen][found]] = nodes[chosen][found]
    return best


def drip_nodes(surface: Surface, drip_angle: float) -> np.ndarray:
    """Nodes facing down by more than ``drip_angle`` degrees below the horizontal."""
    return surface.normals[:, 2] < -np.sin(np.radians(drip_angle))


def filled_elevation(surface: Surface, outlets: np.ndarray) -> np.ndarray:
    """Elevations with every hollow filled to its spill point and a tiny rise across flats
    towards where they drain (Priority-Flood + epsilon), flooded from ``outlets`` (and from the
    lowest node of any part that has none). The rise of a step is in proportion to its length,
    so that a flat drains to the outlet nearest along the surface, not in steps across the cells
    (a pond overflows all along a level rim, not towards its corners)."""
    # The flood gives each node the least, over the paths from an outlet, of the level reached
    # along the path (the level rises to each node's z, or by the step's rise, whichever is higher):
    # a monotone path cost, so the values do not depend on how ties are broken. A node with a
    # path to an outlet that falls by at least ``rise`` at every step (here: always to its
    # lowest such neighbour) is flooded at its own z. Those nodes are found without a heap, by
    # pointer jumping to the end of each node's descent; only the others ("trapped": in the
    # catchment of a hollow or a flat) are flooded, from the untrapped nodes round them at their
    # z (the same values the full flood gives: a path into a trapped region is no worse for
    # starting at the last untrapped node it passes), then from the lowest node of any part
    # that has no outlet at all.
    z = surface.positions[:, 2].astype(float)
    count = len(z)
    outlets = np.asarray(outlets, bool)
    indptr, indices = surface.indptr, surface.indices
    rise = 1e-9 * surface.spacing
    degree = np.diff(indptr)
    src = np.repeat(np.arange(count), degree)
    step_rise = rise * np.linalg.norm(surface.positions[indices] - surface.positions[src], axis=1) / surface.spacing
    below = z[src] >= z[indices] + step_rise  # exactly the flood's test: z_i is not lifted by z_j + rise
    receiver = np.arange(count)
    ls, ld = src[below], indices[below]  # sorted by ls (CSR order)
    if len(ls):
        zl = z[ld]
        head = np.nonzero(np.concatenate([[True], ls[1:] != ls[:-1]]))[0]
        lowest = np.minimum.reduceat(zl, head)  # each node's lowest such neighbour
        best = zl == np.repeat(lowest, np.diff(np.append(head, len(ls))))
        receiver[ls[best]] = ld[best]
    receiver[outlets] = np.nonzero(outlets)[0]
    while True:
        jumped = receiver[receiver]
        if np.array_equal(jumped, receiver):
            break
        receiver = jumped
    trapped = ~outlets[receiver]
    filled = z.copy()
    if not trapped.any():
        return filled
    # the trapped nodes' neighbourhood, in local indices (their order kept)
    local = np.cumsum(trapped) - 1
    nodes = np.nonzero(trapped)[0]
    edge_trapped = trapped[src]
    es, ed, er = src[edge_trapped], indices[edge_trapped], step_rise[edge_trapped]
    inner = trapped[ed]
    # from the untrapped nodes round them: a trapped node's first level
    start = np.full(count, np.inf)
    if (~inner).any():
        np.minimum.at(start, es[~inner], z[ed[~inner]] + er[~inner])
    start = start[nodes]
    reached = np.isfinite(start)
    start[reached] = np.maximum(z[nodes][reached], start[reached])
    es, ed, er = local[es[inner]], local[ed[inner]], er[inner]
    starts = np.concatenate([[0], np.cumsum(np.bincount(es, minlength=len(nodes)))]).tolist()
    neighbours = ed.tolist()  # es is sorted (CSR order)
    rises = er.tolist()
    zt = z[nodes]
    zz = zt.tolist()  # Python floats: the heap compares them many times
    level_of = [0.0] * len(nodes)
    done = bytearray(len(nodes))
    heap = list(zip(start[reached].tolist(), np.nonzero(reached)[0].tolist()))
    heapq.heapify(heap)
    seeds = iter(np.argsort(zt, kind="stable").tolist())
    pop, push = heapq.heappop, heapq.heappush
    while True:
        if not heap:
            seed = next((i for i in seeds if not done[i]), None)
            if seed is None:
                break
            heap.append((zz[seed], seed))
        level, i = pop(heap)
        if done[i]:
            continue
        done[i] = 1
        level_of[i] = level
        for k in range(starts[i], starts[i + 1]):
            j = neighbours[k]
            if not done[j]:
                least = level + rises[k]
                push(heap, (zz[j] if zz[j] > least else least, j))
    filled[nodes] = level_of
    return filled


@dataclass(frozen=True)
class Flow:
    """The steady run-off over a surface's nodes; volumes in E x area."""

    flux: np.ndarray  #: Q per node, E x scene units
    rain: float  #: the rain that landed
    absorbed: float  #: what the stone took in
    left: float  #: what left the surface (over a border, or dripping onto nothing)
    absorbed_per_node: np.ndarray


def route(
    surface: Surface,
    rain: np.ndarray,
    *,
    absorption_length: float = np.inf,
    drip_angle: float = 30.0,
    fall: np.ndarray | tuple = (0.0, 0.0, -1.0),
    land: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> Flow:
    """The run-off of ``surface`` under the rain exposure ``rain`` (E per node). ``fall``: the
    direction drops fall in (the rain's, with the wind's lean); ``land(origins, direction)``:
    where rays from ``origins`` first meet a surface ((M, 3), NaN for none); without it, drops
    leave the surface."""
    count = len(surface.areas)
    rain = np.clip(np.nan_to_num(np.asarray(rain, float)), 0.0, None)
    spacing, positions, normals = surface.spacing, surface.positions, surface.normals
    drips = drip_nodes(surface, drip_angle)
    filled = filled_elevation(surface, drips | surface.border)

    # flow edges: to lower (filled) neighbours, weighted by how well they follow the descent
    src = np.repeat(np.arange(count), np.diff(surface.indptr))
    dst = surface.indices
    lower = (filled[dst] < filled[src]) & ~drips[src]
    src, dst = src[lower], dst[lower]
    step = positions[dst] - positions[src]
    distance = np.maximum(np.linalg.norm(step, axis=1), 1e-12 * spacing)
    descent = _GRAVITY - normals * (normals @ _GRAVITY)[:, None]
    slope = np.linalg.norm(descent, axis=1)
    direction = descent / np.maximum(slope, 1e-12)[:, None]
    advance = np.einsum("ij,ij->i", step, direction[src])
    weight = np.where(slope[src] > 1e-3, np.maximum(advance / distance, 0.0) ** FOCUS, 0.0)
    # level ground, filled hollows, and nodes whose lower neighbours all lie across the descent:
    # down the filled elevations
    flat = np.bincount(src, weight, count)[src] <= 1e-12
    weight = np.where(flat, (filled[src] - filled[dst]) / distance, weight)
    share = weight / np.maximum(np.bincount(src, weight, count)[src], 1e-300)
    # how far a node's water advances: the length of its flow tube through it (area = width x length)
    length = np.bincount(src, share * np.where(flat, distance, np.maximum(advance, 0.0)), count)
    # where water leaves (a border, a drip, the lowest node) a node's width is taken as a cell's
    length = np.where(length > 0, length, surface.areas / spacing)

    # across a node, dV/ds = E w - V / l: V_out = V_in q + E a (1 - q) / x, q = exp(-x), x = s / l
    landed = rain * surface.areas
    keep, gain = np.exp(-length / absorption_length), landed * _landed_share_leaving(length / absorption_length)

    # drips: a drip node's water lands on the node nearest where its fall meets the surface
    fall = np.asarray(fall, float) / np.linalg.norm(fall)
    drip_src = np.nonzero(drips)[0]
    drip_dst = np.full(len(drip_src), -1)
    if land is not None and len(drip_src):
        hits = np.asarray(land(positions[drip_src] + fall * spacing, fall), float)
        found = np.isfinite(hits).all(1)
        drip_dst[found] = nearest_nodes(surface, hits[found], -fall)
    dripping = drip_dst >= 0
    edge_src = np.concatenate([src, drip_src[dripping]])
    edge_dst = np.concatenate([dst, drip_dst[dripping]])
    edge_share = np.concatenate([share, np.ones(int(dripping.sum()))])
    inflow, outflow = _accumulate(count, edge_src, edge_dst, edge_share, keep, gain)

    absorbed = inflow + landed - outflow
    ends = np.bincount(edge_src, minlength=count) == 0
    carried = 0.5 * (inflow + outflow) * length  # V l = Q w l = Q a
    carried_sum, area_sum = _neighbourhood_sum(surface, np.stack([carried, surface.areas]))
    flux = carried_sum / area_sum
    return Flow(flux, float(landed.sum()), float(absorbed.sum()), float(outflow[ends].sum()), absorbed)


def _landed_share_leaving(x: np.ndarray) -> np.ndarray:
    """(1 - exp(-x)) / x, x = s / l: the share of the rain landing on a node that leaves it,
    finite for every l > 0: 1 at x = 0 (l = inf, or so long that s / l underflows), where the
    form (l / s)(1 - exp(-s / l)) would overflow to inf x 0 = NaN."""
    x = np.asarray(x, float)
    positive = x > 0.0
    return np.where(positive, -np.expm1(-x) / np.where(positive, x, 1.0), 1.0)


def _accumulate(count, edge_src, edge_dst, edge_share, keep, gain):
    """In- and outflow of every node, in topological order (Kahn's algorithm, a whole frontier
    of nodes at a time). A loop (water dripping back to where it came from) is cut open: its
    nodes pass on nothing of what reached them through it."""
    order = np.argsort(edge_src, kind="stable")
    edge_src, edge_dst, edge_share = edge_src[order], edge_dst[order], edge_share[order]
    starts = np.concatenate([[0], np.cumsum(np.bincount(edge_src, minlength=count))])
    pending = np.bincount(edge_dst, minlength=count)
    inflow, outflow = np.zeros(count), np.zeros(count)
    frontier = np.nonzero(pending == 0)[0]
    while len(frontier):  # a node joins the frontier when its last inflow is in
        out = inflow[frontier] * keep[frontier] + gain[frontier]
        outflow[frontier] = out
        first, lengths = starts[frontier], starts[frontier + 1] - starts[frontier]
        edge = np.repeat(first - np.cumsum(lengths) + lengths, lengths) + np.arange(lengths.sum())
        targets = edge_dst[edge]
        np.add.at(inflow, targets, np.repeat(out, lengths) * edge_share[edge])
        targets, arrived = np.unique(targets, return_counts=True)
        pending[targets] -= arrived
        frontier = targets[pending[targets] == 0]
    cut = pending > 0  # never reached the frontier: on a loop
    outflow[cut] = inflow[cut] * keep[cut] + gain[cut]
    return inflow, outflow


def _neighbourhood_sum(surface: Surface, values: np.ndarray, rings: int = SMOOTHING_RINGS) -> np.ndarray:
    """Sum over each node and its neighbours ``rings`` steps away on the same face (normals
    within 45 degrees: a flux is not averaged round a corner). ``values``: (N,), or (k, N) for
    k sums over the same neighbourhoods."""
    values = np.asarray(values, float)
    count = values.shape[-1]
    degree = np.diff(surface.indptr)
    src = np.repeat(np.arange(count), degree)
    dst = surface.indices
    same = _edge_cosines(surface.normals, src, dst) > _SAME_FACE
    src, dst = src[same], dst[same]
    sums = []
    for total in values.reshape(-1, count):
        for _ in range(rings):
            total = total + np.bincount(src, total[dst], count)
        sums.append(total)
    return np.array(sums).reshape(values.shape)


def interpolate(surface: Surface, values: np.ndarray, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``values`` (one per node) at ``points`` with ``normals``: the mean of the nodes within
    1.5 cells on the same side (normals within 60 degrees), weighted by closeness; the nearest
    node facing the same side where there is none; 0 where there is no node at all."""
    points = np.asarray(points, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    if len(points) > _CHUNK:  # a bounded working set, whatever the number of points
        # read in the order of the cells: the searches of neighbouring points then fall near
        # each other (numpy's search starts from the last answer for rising keys)
        order = np.argsort(_pack(surface.voxels_of(points)), kind="stable")
        result = np.empty(len(points))
        for i in range(0, len(points), _CHUNK):
            chunk = order[i : i + _CHUNK]
            result[chunk] = interpolate(surface, values, points[chunk], normals[chunk])
        return result
    result = np.zeros(len(points))
    if not len(points):
        return result
    queries, nodes = _cells_around(surface.cells, surface.voxels_of(points))
    distance = np.linalg.norm(surface.positions[nodes] - points[queries], axis=1)
    agree = np.einsum("ij,ij->i", surface.normals[nodes], normals[queries]) > 0.5
    weight = np.where(agree, np.maximum(0.0, 1.0 - distance / (1.5 * surface.spacing)), 0.0)
    total = np.bincount(queries, weight, len(points))
    result = np.bincount(queries, weight * values[nodes], len(points)) / np.maximum(total, 1e-300)
    alone = total <= 0.0
    if alone.any():
        nearest = nearest_nodes(surface, points[alone], normals[alone])
        result[np.nonzero(alone)[0]] = np.where(nearest >= 0, values[np.maximum(nearest, 0)], 0.0)
    return result


def runoff_map(flux: np.ndarray, runoff_length: float) -> np.ndarray:
    """R = 1 - exp(-Q / L) (docs/model.md §7.1)."""
    return -np.expm1(-np.asarray(flux, float) / runoff_length)
