"""Lightmap UVs for baked maps: reuse a UV map that can hold a bake, or make one with xatlas.

A map can hold a bake when it lies in [0, 1]² and no two faces cover the same texel. A new
map is always a new, named UV layer (``LIGHTMAP_UV``); the user's own UV maps are never
changed. xatlas packs charts with ``padding`` texels between them, and the bake's margin fills
those gaps from the island edges, so bilinear filtering never reads an empty texel.
"""

import numpy as np

LIGHTMAP_UV = "PW Lightmap"


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


def find_bakeable_uv_map(mesh, resolution):
    """The name of a UV map of ``mesh`` that can hold a bake at ``resolution``, or None.

    Our own lightmap comes first, then the user's maps in their order.
    """
    names = sorted(layer.name for layer in mesh.uv_layers if layer.name == LIGHTMAP_UV)
    names += [layer.name for layer in mesh.uv_layers if layer.name != LIGHTMAP_UV]
    corners, _ = triangle_corners(mesh)
    for name in names:
        uvs = corner_uvs(mesh, name)
        if uvs.size and uvs.min() >= 0.0 and uvs.max() <= 1.0 and overlapping_texels(uvs[corners], resolution) == 0:
            return name
    return None


def overlapping_texels(triangle_uvs, resolution):
    """How many texel centres of a ``resolution``² image lie strictly inside two or more of the
    UV triangles ``triangle_uvs`` (T, 3, 2). Shared edges do not count."""
    points = np.asarray(triangle_uvs, dtype=np.float64) * resolution - 0.5  # texel centres on integers
    low = np.clip(np.ceil(points.min(axis=1)), 0, resolution - 1).astype(np.int64)
    high = np.clip(np.floor(points.max(axis=1)), 0, resolution - 1).astype(np.int64)
    size = np.maximum(high - low + 1, 0)
    counts = size[:, 0] * size[:, 1]
    triangle = np.repeat(np.arange(len(points)), counts)
    offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    x = low[triangle, 0] + offset % size[triangle, 0]
    y = low[triangle, 1] + offset // size[triangle, 0]

    a, b, c = (points[triangle, k] for k in range(3))
    orientation = np.sign(_cross(b - a, c - a))
    eps = 1e-6
    inside = orientation != 0
    for start, end in ((a, b), (b, c), (c, a)):
        inside &= orientation * _cross(end - start, np.stack([x, y], axis=1) - start) > eps
    covered = np.bincount(y[inside] * resolution + x[inside], minlength=resolution * resolution)
    return int(np.count_nonzero(covered > 1))


def _cross(u, v):
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def lightmap_uvs(mesh, resolution, padding=4):
    """Non-overlapping UVs for every face corner of ``mesh`` (float32 (len(loops), 2)), by xatlas.

    xatlas charts triangles; when it cuts a polygon along a diagonal (which a per-corner UV map
    cannot express), those polygons become charts of their own and everything is packed again.
    """
    import xatlas

    corners, vertices = triangle_corners(mesh)
    positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", positions)
    positions = positions.reshape(-1, 3)
    pack = xatlas.PackOptions()
    pack.resolution = resolution
    pack.padding = padding
    pack.bilinear = True

    atlas = xatlas.Atlas()
    atlas.add_mesh(positions, vertices.astype(np.uint32))
    atlas.generate(pack_options=pack)
    _, indices, uvs = atlas[0]
    triangle_uvs = uvs[indices]
    result = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    result[corners] = triangle_uvs
    split = np.any(np.abs(result[corners] - triangle_uvs) > 1e-7, axis=(1, 2))
    if not split.any():
        return result
    return _repack_with_whole_polygons(mesh, positions, corners, vertices, triangle_uvs, split, pack)


def _repack_with_whole_polygons(mesh, positions, corners, vertices, triangle_uvs, split, pack):
    import xatlas

    polygon_of = np.empty(len(corners), dtype=np.int64)
    mesh.loop_triangles.foreach_get("polygon_index", polygon_of)
    split_polygon = np.zeros(len(mesh.polygons), dtype=bool)
    split_polygon[polygon_of[split]] = True
    cut = split_polygon[polygon_of]  # every triangle of a polygon that was cut

    # xatlas' charts in scene units, so that they and the projected polygons share one scale
    kept = ~cut
    scale = np.sqrt(_area(positions[vertices[kept]]).sum() / max(_area(triangle_uvs[kept]).sum(), 1e-30))
    input_uvs = triangle_uvs * scale
    normals = np.empty(len(mesh.polygons) * 3, dtype=np.float32)
    mesh.polygons.foreach_get("normal", normals)
    input_uvs[cut] = _planar_projection(positions[vertices[cut]], normals.reshape(-1, 3)[polygon_of[cut]])

    # one xatlas vertex per (mesh vertex, UV) pair, so UV islands are what connects triangles
    keys = np.concatenate([vertices.reshape(-1, 1).astype(np.float64), input_uvs.reshape(-1, 2)], axis=1)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    atlas = xatlas.Atlas()
    atlas.add_mesh(
        positions[vertices.reshape(-1)[first]],
        inverse.reshape(-1, 3).astype(np.uint32),
        uvs=input_uvs.reshape(-1, 2)[first].astype(np.float32),
    )
    charts = xatlas.ChartOptions()
    charts.use_input_mesh_uvs = True
    atlas.generate(chart_options=charts, pack_options=pack)
    _, indices, uvs = atlas[0]
    result = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    result[corners] = uvs[indices]
    return result


def _area(triangles):
    """Areas of triangles (T, 3, 2 or 3)."""
    u, v = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    if triangles.shape[-1] == 2:
        return 0.5 * np.abs(_cross(u, v))
    return 0.5 * np.linalg.norm(np.cross(u, v), axis=1)


def _planar_projection(triangles, normals):
    """Each triangle (T, 3, 3) projected onto the plane of its polygon's normal (T, 3): (T, 3, 2)."""
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(normals, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(normals, u)
    return np.stack([np.einsum("tkd,td->tk", triangles, u), np.einsum("tkd,td->tk", triangles, v)], axis=-1)


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
