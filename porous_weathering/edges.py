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

import bpy
import numpy as np

from . import scratch_scene, studio

#: The paper's Table 1: S_h responds to changes along the rows (v), S_v along the columns (u).
SOBEL_H = np.array([[-1, -2, -1], [0, 0, 0], [1, 2, 1]], dtype=np.float32)
SOBEL_V = SOBEL_H.T.copy()

#: The colour attribute that carries the curvature mask C (per point, grey).
EDGE_ATTRIBUTE = "pw_edges"

#: Object types that evaluate to a mesh (``Object.to_mesh``).

#: Grids summed by ``smooth_over_radius`` (docs/maps.md: the spread along a straight edge).
SHIFTS = tuple(np.full(3, k / 4) for k in range(4))

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
                result += kernel[row, column] * padded[row:row + height, column:column + width]
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
    probe = studio.normal_probe()
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
                bpy.ops.object.bake(type="EMIT", target="IMAGE_TEXTURES", uv_layer=uv_map_name, margin=margin,
                                    margin_type="ADJACENT_FACES", use_clear=False, use_selected_to_active=False)
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
    Boundary and non-manifold edges carry none; faces must be consistently oriented.
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
    def attribute(name, dtype, width=1):  # attribute arrays read ~100x faster than MeshLoop etc.
        values = np.empty(len(mesh.attributes[name].data) * width, dtype=dtype)
        mesh.attributes[name].data.foreach_get("vector" if name == "position" else "value", values)
        return values.reshape(-1, width) if width > 1 else values

    local = attribute("position", np.float32, 3).astype(np.float64)
    points = local @ matrix_world[:3, :3].T + matrix_world[:3, 3]
    loop_vertex = attribute(".corner_vert", np.int32)
    loop_edge = attribute(".corner_edge", np.int32)
    edge_vertices = attribute(".edge_verts", np.int32, 2)
    loop_start = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_start", loop_start)
    loop_total = np.diff(loop_start, append=len(loop_vertex))
    vertex_count, face_count = len(points), len(loop_start)

    loop_face = np.repeat(np.arange(face_count), loop_total)
    loop_next = np.arange(1, len(loop_vertex) + 1)
    loop_next[loop_start + loop_total - 1] = loop_start
    corners = points[loop_vertex]
    # A mirroring transform reverses the winding: flip so that normals still point out.
    side = 0.5 if np.linalg.det(matrix_world[:3, :3]) >= 0 else -0.5
    area_vectors = side * sum_rows(loop_face, np.cross(corners, corners[loop_next]), face_count)
    areas = np.linalg.norm(area_vectors, axis=1)
    face_normals = area_vectors / np.maximum(areas, np.finfo(float).tiny)[:, None]
    centres = sum_rows(loop_face, corners, face_count) / loop_total[:, None]

    # The two faces of every edge used by exactly two faces (its loops are adjacent once sorted).
    uses = np.bincount(loop_edge, minlength=len(edge_vertices))
    first_use = np.cumsum(uses) - uses
    manifold = np.flatnonzero(uses == 2)
    by_edge = np.argsort(loop_edge, kind="stable")
    face_a = loop_face[by_edge[first_use[manifold]]]
    face_b = loop_face[by_edge[first_use[manifold] + 1]]
    normal_a, normal_b = face_normals[face_a], face_normals[face_b]
    angle = np.arctan2(np.linalg.norm(np.cross(normal_a, normal_b), axis=1), (normal_a * normal_b).sum(1))
    # Convex when the faces lean away from each other: their normals part as their centres do.
    convex = ((normal_a - normal_b) * (centres[face_a] - centres[face_b])).sum(1) >= 0
    ends = edge_vertices[manifold]
    length = np.linalg.norm(points[ends[:, 0]] - points[ends[:, 1]], axis=1)
    half_edge_curvature = np.where(convex, angle, -angle) * length / 4  # theta * length / 2, halved per end

    integrated = np.bincount(ends.ravel(), np.repeat(half_edge_curvature, 2), minlength=vertex_count)
    area = np.bincount(loop_vertex, (areas / loop_total)[loop_face], minlength=vertex_count)
    normals = sum_rows(loop_vertex, area_vectors[loop_face], vertex_count)
    normals /= np.maximum(np.linalg.norm(normals, axis=1), np.finfo(float).tiny)[:, None]
    return points, normals, integrated, area


def sum_rows(index, rows, count):
    """(count, k) sums of the (n, k) ``rows`` grouped by ``index`` (n,)."""
    return np.stack([np.bincount(index, column, minlength=count) for column in rows.T], axis=1)


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
    cell = np.floor(scaled)
    fraction = scaled - cell
    cell = (cell - cell.min(axis=0)).astype(np.int64)
    if cell.max() >= 2**20:
        raise ValueError("curvature radius is too small for an object this size")
    direction_bin = 2 * np.arange(3) + (normals < 0)
    direction_weight = normals ** 2
    axis_weights = (1 - fraction, fraction)  # trilinear weights of the lower and upper corner

    corners = [(dx, dy, dz) for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)]
    keys = np.stack([((cell[:, 0] + dx) << 42) | ((cell[:, 1] + dy) << 21) | (cell[:, 2] + dz)
                     for dx, dy, dz in corners], axis=1)
    unique_keys, corner_cell = np.unique(keys, return_inverse=True)
    corner_cell = corner_cell.reshape(keys.shape)
    bucket_count = 6 * len(unique_keys)

    def buckets_and_weights(corner):
        dx, dy, dz = corners[corner]
        trilinear = axis_weights[dx][:, 0] * axis_weights[dy][:, 1] * axis_weights[dz][:, 2]
        return 6 * corner_cell[:, corner, None] + direction_bin, trilinear[:, None] * direction_weight

    curvature_sum = np.zeros(bucket_count)
    area_sum = np.zeros(bucket_count)
    for corner in range(8):
        buckets, weights = buckets_and_weights(corner)
        curvature_sum += np.bincount(buckets.ravel(), (weights * integrated[:, None]).ravel(), bucket_count)
        area_sum += np.bincount(buckets.ravel(), (weights * area[:, None]).ravel(), bucket_count)
    numerator = np.zeros(len(scaled))
    denominator = np.zeros(len(scaled))
    for corner in range(8):
        buckets, weights = buckets_and_weights(corner)
        numerator += np.einsum("ij,ij->i", weights, curvature_sum[buckets])
        denominator += np.einsum("ij,ij->i", weights, area_sum[buckets])
    return numerator, denominator


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
        raise ValueError(f"object '{obj.name}' is not a mesh (its type is {obj.type}): "
                         "an edge attribute needs mesh vertices")
    mask = np.asarray(mask, dtype=np.float32)
    if mask.shape != (len(obj.data.vertices),):
        raise ValueError(f"object '{obj.name}': {mask.shape[0] if mask.ndim else 0} mask values for "
                         f"{len(obj.data.vertices)} mesh vertices (modifiers that add vertices must be applied first)")
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
