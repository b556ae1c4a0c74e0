"""Edge/cavity mask C (SPEC 5), two view-independent ways (docs/maps.md, "Edge/cavity mask").

- ``edge_mask_image``: the paper's Sobel filter ``(|S_h| + |S_v|) / 2`` (its Table 1 kernels)
  of the world-space normal map, in texture space.  The normals are baked by Cycles with the
  bake margin ``ADJACENT_FACES``, which fills the texels around each UV island from the faces
  across the seam, so the filter sees the real neighbourhood there: seams give no false
  edges, and the mesh's edges that lie on seams are still found.
- ``curvature`` / ``curvature_mask`` / ``write_edge_attribute``: the mean curvature of the
  evaluated mesh in world space, from the dihedral angles of its edges, smoothed over a
  radius in scene units, so it does not depend on tessellation density.  Convex > 0,
  concave < 0.
"""

import math
from dataclasses import dataclass

import bpy

import numpy as np

from . import mesh_arrays, scratch_scene
from .options import check, option

#: The paper's Table 1: S_h responds to changes along the rows (v), S_v along the columns (u).
SOBEL_H = np.array([[-1, -2, -1], [0, 0, 0], [1, 2, 1]], dtype=np.float32)
SOBEL_V = SOBEL_H.T.copy()

#: The colour attribute that carries the curvature mask C (per point, grey).
EDGE_ATTRIBUTE = "pw_edges"

#: Object types that evaluate to a mesh (``Object.to_mesh``).

#: Grids summed by ``smooth_over_radius`` (docs/maps.md: the spread along a straight edge).
SHIFTS = tuple(np.full(3, k / 4) for k in range(4))

#: The corners (dx, dy, dz) of a grid cell, as offsets from its lower corner.
CORNERS = np.array([(dx, dy, dz) for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)])

#: Points per block of the grid splat and gather: small enough that a block's temporaries
#: stay in the CPU cache, so the time per point does not grow with the mesh.
BLOCK = 1 << 14

#: The largest box of grid cells numbered directly (one bool and one int32 per cell).
DIRECT_CELLS_MAX = 1 << 25

#: Scene units over which the curvature of an attribute edge map is smoothed: a brick's arris.
DEFAULT_EDGE_RADIUS = 0.05


@dataclass(frozen=True)
class EdgeSettings:
    """How the edge/cavity mask is made (the curvature of attribute targets; image targets
    take the Sobel filter of the normal map, which has no setting)."""

    radius: float = option(
        DEFAULT_EDGE_RADIUS,
        label="Edge Radius",
        flag="--edge-radius",
        low=0.0,
        low_open=True,
        finite=True,
        unit="scene units",
        metavar="M",
        tooltip="Distance over which the curvature of attribute edge maps is smoothed (docs/maps.md)",
    )

    def __post_init__(self):
        check(self)


#: Default of ``curvature_mask``'s ``saturation``: the dimensionless curvature H * radius
#: at which C reaches 1.  A sharp 90-degree edge gives 0.5 to 0.75 (docs/maps.md).
DEFAULT_SATURATION = 0.45


# --- (a) Sobel filter of the world-space normal map, in texture space -----------------------


def edge_mask_image(obj, uv_map_name, resolution, *, margin=4):
    """C as a float32 (resolution, resolution) array in [0, 1], top row first (v = 1).

    C is the Sobel response of the world-space normal map encoded as (n + 1) / 2, per
    channel ``(|S_h| + |S_v|) / 2``; the three channels are combined by their Euclidean
    norm (so a crease gives the same C however the object is turned) and clipped at 1, as the
    paper's grey-level map saturates.  C is per texel, so it scales with the texel size.
    Around every UV island C is extended ``margin`` texels outwards (each texel taking the
    mean of its neighbours already set), so texture filtering never pulls in empty texels;
    further out it is 0.  UV islands must lie at least 2 texels apart and off the image
    border (as a lightmap layout with padding does), or the filter sees past their edge.
    """
    if obj.type != "MESH" or not obj.data.polygons:
        raise ValueError(f"object '{obj.name}' has no faces to bake an edge mask on")
    if uv_map_name not in obj.data.uv_layers:
        raise ValueError(f"object '{obj.name}' has no UV map '{uv_map_name}'")
    normals, islands = bake_world_normals(obj, uv_map_name, resolution)
    mask = sobel_edge_mask(normals)  # right on the islands, whose neighbours the bake filled
    known = islands
    for _ in range(margin):
        mask, known = grow(mask, known)
    return np.where(known, mask, 0.0).astype(np.float32)


def sobel_edge_mask(encoded_normals):
    """C of an (H, W, 3) normal map: per channel (|S_h| + |S_v|) / 2, combined by the norm."""
    per_channel = (np.abs(correlate3x3(encoded_normals, SOBEL_H)) + np.abs(correlate3x3(encoded_normals, SOBEL_V))) / 2
    return np.minimum(np.linalg.norm(per_channel, axis=-1), 1.0)


def grow(values, known):
    """(values, known) grown by one ring: each unknown texel next to known ones (8-neighbours)
    takes the mean of their values.  ``values`` is (H, W) or (H, W, C)."""
    weight = known.astype(np.float32)
    count = correlate3x3(weight, np.ones((3, 3)))
    sums = correlate3x3(values * weight.reshape(weight.shape + (1,) * (values.ndim - 2)), np.ones((3, 3)))
    ring = ~known & (count > 0)
    grown = values.copy()
    grown[ring] = sums[ring] / count[ring].reshape(-1, *(1,) * (values.ndim - 2))
    return grown, known | ring


def correlate3x3(image, kernel):
    """``image`` (H, W, ...) correlated with a 3x3 ``kernel``, borders repeating the edge texels."""
    height, width = image.shape[:2]
    padded = np.pad(image, [(1, 1), (1, 1)] + [(0, 0)] * (image.ndim - 2), mode="edge")
    result = np.zeros(image.shape, dtype=np.float32)
    for row in range(3):
        for column in range(3):
            if kernel[row, column]:
                result += kernel[row, column] * padded[row : row + height, column : column + width]
    return result


def bake_world_normals(obj, uv_map_name, resolution):
    """(normals, islands): ``obj``'s world-space shading normals on ``uv_map_name``, encoded
    (n + 1) / 2, as float32 (H, W, 3), right on the UV islands and one texel around them
    (filled from the faces across each seam), and the (H, W) bool map of the islands.
    Both top row first.

    Exact Cycles EMIT bakes of a probe material that emits the normal, on a copy of the
    object in a temporary scene: the user's scene, materials and selection are untouched.
    """
    image = bpy.data.images.new("PW Normal Bake", resolution, resolution, alpha=True, float_buffer=True)
    probe = scratch_scene.normal_probe()
    scene = bpy.data.scenes.new("PW Normal Bake")
    copy = None
    try:
        texture = probe.node_tree.nodes.new("ShaderNodeTexImage")
        texture.image = image
        probe.node_tree.nodes.active = texture
        copy = scratch_scene.placed_copy(obj, scene, probe, own_mesh=True)
        scene.render.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.cycles.samples = 1  # deterministic; more samples only box-filter the normals
        context = scratch_scene.only_selected(copy)
        pixels = np.empty((2, resolution, resolution, 4), dtype=np.float32)
        for margin in (0, 1):
            image.pixels.foreach_set(np.zeros(resolution * resolution * 4, dtype=np.float32))
            with bpy.context.temp_override(**context):
                bpy.ops.object.bake(
                    type="EMIT",
                    target="IMAGE_TEXTURES",
                    uv_layer=uv_map_name,
                    margin=margin,
                    margin_type="ADJACENT_FACES",
                    use_clear=False,
                    use_selected_to_active=False,
                )
            image.pixels.foreach_get(pixels[margin].ravel())
        pixels = pixels[:, ::-1]  # Blender stores the bottom row first
        return pixels[1, ..., :3].copy(), pixels[0, ..., 3] > 0
    finally:
        if copy is not None:
            mesh = copy.data
            bpy.data.objects.remove(copy)
            bpy.data.meshes.remove(mesh)
        bpy.data.scenes.remove(scene)
        bpy.data.materials.remove(probe)
        bpy.data.images.remove(image)


# --- (b) mean curvature of the evaluated mesh, smoothed over a radius ------------------------


def curvature(obj, radius, depsgraph=None):
    """Signed mean curvature H (1 / scene units) at every vertex of ``obj``'s evaluated mesh
    (modifiers applied) in world space, as float32 (V,): convex > 0, concave < 0, and a
    sphere of radius r gives 1 / r.

    Every edge carries the integrated mean curvature theta * length / 2 (theta its signed
    dihedral angle); H at a vertex is that curvature over the area around it, both summed
    with weights that fall from 1 at the vertex to 0 at 2 * ``radius`` (``smooth_over_radius``).
    Boundary and non-manifold edges carry none; faces must be consistently oriented (a closed
    mesh turned inside out is read from outside, as renders shade it).
    """
    if not np.isfinite(radius) or radius <= 0:
        raise ValueError(f"curvature radius must be a positive number of scene units, not {radius}")
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh() if obj.type in scratch_scene.GEOMETRY_TYPES else None
    try:
        if mesh is None or not mesh.polygons:
            raise ValueError(f"object '{obj.name}' has no faces to measure curvature on")
        points, normals, integrated, area = _vertex_curvature(mesh, np.array(evaluated.matrix_world))
    finally:
        if mesh is not None:
            evaluated.to_mesh_clear()
    if not np.isfinite(points).all():
        raise ValueError(f"object '{obj.name}' has vertices at non-finite positions")
    return smooth_over_radius(points, normals, integrated, area, radius)


def _vertex_curvature(mesh, matrix_world):
    """World positions, unit normals (0 on loose vertices), integrated mean curvature and
    area per vertex, all float64, from the faces' area vectors (Newell) and edges' angles."""

    def attribute(name, dtype, width=1):
        return mesh_arrays.attribute(mesh, name, dtype, width)

    local = attribute("position", np.float32, 3).astype(np.float64)
    points = local @ matrix_world[:3, :3].T + matrix_world[:3, 3]
    loop_vertex = attribute(".corner_vert", np.int32)
    loop_edge = attribute(".corner_edge", np.int32)
    edge_vertices = attribute(".edge_verts", np.int32, 2)
    loop_bounds = np.append(mesh_arrays.loop_starts(mesh), len(loop_vertex))
    # A mirroring transform reverses the winding: flip so that normals still point out.
    side = 0.5 if np.linalg.det(matrix_world[:3, :3]) >= 0 else -0.5
    faces = _face_sums(points, loop_vertex, loop_edge, loop_bounds, side, len(edge_vertices))
    area_vectors, centres, area, normals, first_face, last_face = faces
    edge_uses = np.bincount(loop_edge, minlength=len(edge_vertices))
    if mesh_arrays.encloses_negative_volume(edge_uses, centres, area_vectors):
        area_vectors, normals = -area_vectors, -normals  # inside out: renders shade it from outside
    face_normals = area_vectors / np.maximum(np.linalg.norm(area_vectors, axis=1), np.finfo(float).tiny)[:, None]

    integrated = np.zeros(len(points))
    manifold = np.flatnonzero(edge_uses == 2)
    for block in _blocks(len(manifold)):  # edges used by exactly two faces
        pairs = manifold[block]
        face_a, face_b = first_face[pairs], last_face[pairs]
        normal_a, normal_b = face_normals[face_a], face_normals[face_b]
        angle = np.arctan2(np.linalg.norm(np.cross(normal_a, normal_b), axis=1), (normal_a * normal_b).sum(1))
        # Convex when the faces lean away from each other: their normals part as their centres do.
        convex = ((normal_a - normal_b) * (centres[face_a] - centres[face_b])).sum(1) >= 0
        ends = edge_vertices[pairs]
        length = np.linalg.norm(points[ends[:, 0]] - points[ends[:, 1]], axis=1)
        half_edge_curvature = np.where(convex, angle, -angle) * length / 4  # theta * length / 2, halved per end
        np.add.at(integrated, ends.ravel(), np.repeat(half_edge_curvature, 2))
    normals /= np.maximum(np.linalg.norm(normals, axis=1), np.finfo(float).tiny)[:, None]
    return points, normals, integrated, area


def _face_sums(points, loop_vertex, loop_edge, loop_bounds, side, edge_count):
    """(area vectors (F, 3), centres (F, 3), area per vertex (V,), sum of its faces' area
    vectors per vertex (V, 3), first and last face of every edge (E,)).

    A face's area vector is ``side`` times its Newell sum, and its area is shared equally by
    its corners.  The faces go in blocks of about ``BLOCK`` corners, so that no temporary
    outgrows the CPU cache: the time stays linear in the corner count."""
    face_count = len(loop_bounds) - 1
    area_vectors, centres = np.empty((face_count, 3)), np.empty((face_count, 3))
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
        vectors = side * np.add.reduceat(np.cross(corners, corners[following]), starts)
        area_vectors[faces] = vectors
        centres[faces] = np.add.reduceat(corners, starts) / counts[:, None]

        corner_face = np.repeat(np.arange(len(counts)), counts)
        np.add.at(vertex_area, vertices, (np.linalg.norm(vectors, axis=1) / counts)[corner_face])
        for axis in range(3):
            np.add.at(vertex_vectors[axis], vertices, vectors[corner_face, axis])
        np.minimum.at(first_face, loop_edge[loops], corner_face + faces.start)
        np.maximum.at(last_face, loop_edge[loops], corner_face + faces.start)
    return area_vectors, centres, vertex_area, vertex_vectors.T, first_face, last_face


def _blocks(count, size=None):
    """Slices of ``range(count)`` of ``size`` items (default ``BLOCK``)."""
    size = size or BLOCK
    return [slice(start, min(start + size, count)) for start in range(0, count, size)]


def smooth_over_radius(points, normals, integrated, area, radius, shifts=SHIFTS):
    """sum(w * integrated) / sum(w * area) at every point, over the points around it, as float32.

    The weights are a grid splat and gather: each point spreads its values trilinearly onto
    the corners of a grid of cell ``radius`` and reads them back the same way, so a point
    weighs its neighbours by a tent of half-width between ``radius`` and 2 ``radius``, in time
    linear in the number of points whatever the tessellation.  ``shifts`` grids, offset along
    the diagonal, are summed, so the weights hardly depend on where the grid lies.  The grid
    is kept apart per normal direction (six bins, +-X, +-Y, +-Z, weighted by the normal's
    squared components), so the two sides of a thin wall, whose normals are opposite, never mix.
    """
    numerator = np.zeros(len(points))
    denominator = np.zeros(len(points))
    for shift in shifts:
        grid_numerator, grid_denominator = _grid_sums(points / radius + shift, normals, integrated, area)
        numerator += grid_numerator
        denominator += grid_denominator
    # Loose vertices (no area and no normal around them) get 0.
    covered = denominator > 1e-12 * max(area.sum(), np.finfo(float).tiny)
    return np.where(covered, numerator / np.where(covered, denominator, 1.0), 0.0).astype(np.float32)


def _grid_sums(scaled, normals, integrated, area):
    """(numerator, denominator) of ``smooth_over_radius`` on one grid of unit cells: every
    point splats ``integrated`` and ``area`` onto the 8 corners of its cell and gathers the
    corner sums back, with the same trilinear and normal-direction weights.

    The points go in blocks of ``BLOCK`` so that every temporary stays in the CPU cache, and
    the corners are numbered without sorting (``_cell_numbering``): time grows linearly."""
    cell = np.floor(scaled)
    fraction = scaled - cell
    cell = (cell - cell.min(axis=0)).astype(np.int64)
    if cell.max() >= 2**20:
        raise ValueError("curvature radius is too small for an object this size")
    base_keys, corner_offsets, box_size = _corner_keys(cell)
    blocks = _blocks(len(scaled))
    number, cell_count = _cell_numbering(base_keys, corner_offsets, box_size, blocks)

    def buckets_and_weights(block):
        corner_cells = number(base_keys[block, None] + corner_offsets)
        return _corner_buckets(corner_cells, fraction[block], normals[block])

    sums = np.zeros((2, 6 * cell_count))  # curvature and area per (corner cell, direction bin)
    for block in blocks:
        buckets, weights = buckets_and_weights(block)
        np.add.at(sums[0], buckets.ravel(), (weights * integrated[block, None]).ravel())
        np.add.at(sums[1], buckets.ravel(), (weights * area[block, None]).ravel())
    gathered = np.empty((2, len(scaled)))
    for block in blocks:
        buckets, weights = buckets_and_weights(block)
        gathered[:, block] = np.einsum("ij,kij->ki", weights, sums[:, buckets])
    return gathered[0], gathered[1]


def _corner_keys(cell):
    """(base keys (N,), corner offsets (8,), box size): cell ``cell + (dx, dy, dz)`` of the box
    of all cells and their corners has the key ``base + offset``, numbered row by row."""
    height, depth = cell[:, 1].max() + 2, cell[:, 2].max() + 2
    base_keys = (cell[:, 0] * height + cell[:, 1]) * depth + cell[:, 2]
    corner_offsets = (CORNERS[:, 0] * height + CORNERS[:, 1]) * depth + CORNERS[:, 2]
    return base_keys, corner_offsets, int(cell[:, 0].max() + 2) * int(height) * int(depth)


def _cell_numbering(base_keys, corner_offsets, box_size, blocks):
    """(number, count): ``number(keys)`` numbers the corner cells in use 0 .. count - 1.

    A box of at most ``DIRECT_CELLS_MAX`` cells is numbered directly (a running count of the
    cells in use, linear time); a larger, sparse one (a radius far below the object's size)
    by sorting its keys."""
    if box_size > DIRECT_CELLS_MAX:
        used = np.unique(base_keys[:, None] + corner_offsets)
        return (lambda keys: np.searchsorted(used, keys)), len(used)
    in_use = np.zeros(box_size, dtype=bool)
    for block in blocks:
        in_use[base_keys[block, None] + corner_offsets] = True
    numbers = np.cumsum(in_use, dtype=np.int32) - 1
    return numbers.__getitem__, int(numbers[-1]) + 1


def _corner_buckets(corner_cells, fraction, normals):
    """(buckets, weights), both (n, 24): for each of the 8 corners of a point's cell, its
    three direction bins (the sign of each normal component) weighted by the trilinear
    weight of the corner times the squared normal component."""
    axis_weights = np.stack([1 - fraction, fraction], axis=1)  # (n, lower/upper corner, axis)
    dx, dy, dz = CORNERS.T
    trilinear = axis_weights[:, dx, 0] * axis_weights[:, dy, 1] * axis_weights[:, dz, 2]
    direction_bin = 2 * np.arange(3) + (normals < 0)
    buckets = 6 * corner_cells[:, :, None] + direction_bin[:, None, :]
    weights = trilinear[:, :, None] * (normals**2)[:, None, :]
    return buckets.reshape(len(fraction), -1), weights.reshape(len(fraction), -1)


def curvature_mask(curvature_values, radius, part="both", saturation=DEFAULT_SATURATION):
    """C in [0, 1] from signed curvature: the dimensionless H * radius / ``saturation``,
    of the convex part (H > 0), the concave part (H < 0) or both (|H|), clipped to [0, 1]."""
    if not (math.isfinite(saturation) and saturation > 0.0):
        raise ValueError(f"saturation must be a positive number, not {saturation}")
    scaled = np.asarray(curvature_values, dtype=np.float64) * radius / saturation
    parts = {"convex": scaled, "concave": -scaled, "both": np.abs(scaled)}
    if part not in parts:
        raise ValueError(f"part must be one of {sorted(parts)}, not {part!r}")
    return np.clip(parts[part], 0.0, 1.0).astype(np.float32)


def write_edge_attribute(obj, mask, name=EDGE_ATTRIBUTE):
    """Store ``mask`` (one value per vertex of ``obj``'s mesh) as the grey colour attribute
    ``name`` (FLOAT_COLOR, per point), replacing any old one only once the new one is whole."""
    if obj.type != "MESH":
        raise ValueError(
            f"object '{obj.name}' is not a mesh (its type is {obj.type}): an edge attribute needs mesh vertices"
        )
    mask = np.asarray(mask, dtype=np.float32)
    if mask.shape != (len(obj.data.vertices),):
        raise ValueError(
            f"object '{obj.name}': {mask.shape[0] if mask.ndim else 0} mask values for "
            f"{len(obj.data.vertices)} mesh vertices (modifiers that add vertices must be applied first)"
        )
    colours = np.ones((len(mask), 4), dtype=np.float32)
    colours[:, :3] = np.clip(np.nan_to_num(mask), 0.0, 1.0)[:, None]
    attributes = obj.data.color_attributes
    staging_name = f"{name} (new)"
    staging = attributes.new(staging_name, "FLOAT_COLOR", "POINT")
    try:
        staging.data.foreach_set("color", colours.ravel())
    except Exception:
        attributes.remove(staging)
        raise
    if name in attributes:
        attributes.remove(attributes[name])
    attributes[staging_name].name = name


def write_curvature_attribute(obj, radius, *, part="both", saturation=DEFAULT_SATURATION, depsgraph=None):
    """``curvature`` -> ``curvature_mask`` -> ``write_edge_attribute``; returns the mask."""
    mask = curvature_mask(curvature(obj, radius, depsgraph), radius, part, saturation)
    write_edge_attribute(obj, mask)
    return mask
