"""Meshes as numpy arrays (vertices, triangles), for the run-off's cases with known answers:
quads and grids, boxes, a sphere, a V-groove, a bowl; a ray caster over them (where drops
land) and which edges are on the border. Also added to a scene as objects (``add_to_scene``)."""

import bpy

import numpy as np


def grid(nu, nv, point):
    """A triangulated patch: ``point(u, v)`` -> (..., 3) for u, v in [0, 1] on an nu x nv grid."""
    u, v = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    vertices = point(u.ravel(), v.ravel())
    index = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    a, b, c, d = index[:-1, :-1].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    return vertices, np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def merge(*parts):
    vertices, triangles, offset = [], [], 0
    for part_vertices, part_triangles in parts:
        vertices.append(part_vertices)
        triangles.append(part_triangles + offset)
        offset += len(part_vertices)
    return np.concatenate(vertices), np.concatenate(triangles)


def facing(vertices, triangles, outward):
    """The triangles wound so that their normals point along ``outward(centroids)`` (N, 3)."""
    normals = np.cross(
        vertices[triangles[:, 1]] - vertices[triangles[:, 0]], vertices[triangles[:, 2]] - vertices[triangles[:, 0]]
    )
    flip = np.einsum("ij,ij->i", normals, outward(vertices[triangles].mean(1))) < 0
    triangles = triangles.copy()
    triangles[flip] = triangles[flip][:, [0, 2, 1]]
    return triangles


def quad(origin, du, dv, n=1, normal=None):
    """The parallelogram origin + u du + v dv on an n x n (or nu x nv) grid, facing ``normal``
    (du x dv if None)."""
    origin, du, dv = (np.asarray(x, float) for x in (origin, du, dv))
    nu, nv = (n, n) if np.isscalar(n) else n
    vertices, triangles = grid(nu, nv, lambda u, v: origin + u[:, None] * du + v[:, None] * dv)
    normal = np.cross(du, dv) if normal is None else np.asarray(normal, float)
    return vertices, facing(vertices, triangles, lambda centres: np.broadcast_to(normal, centres.shape))


def box(low, high, n=1):
    """A closed box, normals outwards."""
    (x0, y0, z0), (x1, y1, z1) = low, high
    sides = [
        ((x0, y0, z1), (x1 - x0, 0, 0), (0, y1 - y0, 0), (0, 0, 1)),
        ((x0, y0, z0), (x1 - x0, 0, 0), (0, y1 - y0, 0), (0, 0, -1)),
        ((x0, y0, z0), (x1 - x0, 0, 0), (0, 0, z1 - z0), (0, -1, 0)),
        ((x0, y1, z0), (x1 - x0, 0, 0), (0, 0, z1 - z0), (0, 1, 0)),
        ((x0, y0, z0), (0, y1 - y0, 0), (0, 0, z1 - z0), (-1, 0, 0)),
        ((x1, y0, z0), (0, y1 - y0, 0), (0, 0, z1 - z0), (1, 0, 0)),
    ]
    return merge(*(quad(o, du, dv, n, normal) for o, du, dv, normal in sides))


def sphere(n=48, radius=1.0):
    """A UV sphere about the origin, normals outwards."""

    def point(u, v):
        theta, phi = np.pi * u, 2 * np.pi * v
        return radius * np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])

    vertices, triangles = grid(n, 2 * n, point)
    return vertices, facing(vertices, triangles, lambda centres: centres)


def ray_caster(vertices, triangles):
    """land(origins, direction) -> (M, 3) first hits of the rays, NaN where none (brute force)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    e1, e2 = b - a, c - a

    def land(origins, direction):
        d = np.asarray(direction, float)
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        hits = np.full((len(origins), 3), np.nan)
        with np.errstate(all="ignore"):
            for index, origin in enumerate(origins):
                s = origin - a
                u = np.einsum("ij,ij->i", s, p) / det
                q = np.cross(s, e1)
                v = (q @ d) / det
                t = np.einsum("ij,ij->i", e2, q) / det
                hit = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9)
                if hit.any():
                    hits[index] = origin + d * t[hit].min()
        return hits

    return land


def border_edges(vertices, triangles):
    """(T, 3) bool: whether the edge facing each corner of each triangle is shared by no other
    triangle (vertices welded by position)."""
    _, welded_triangles = welded(vertices, triangles)
    edges = np.sort(
        np.stack([welded_triangles[:, [1, 2]], welded_triangles[:, [2, 0]], welded_triangles[:, [0, 1]]], 1), 2
    )
    keys = edges[..., 0] * (welded_triangles.max() + 1) + edges[..., 1]
    _, inverse, counts = np.unique(keys.ravel(), return_inverse=True, return_counts=True)
    return (counts[inverse] == 1).reshape(-1, 3)


def welded(vertices, triangles):
    """The same mesh with the vertices that share a position made one."""
    unique, weld = np.unique(np.round(vertices, 9), axis=0, return_inverse=True)
    return unique, weld.ravel()[triangles]


def add_to_scene(name, vertices, triangles):
    """The mesh, welded, as an object of the active scene."""
    vertices, triangles = welded(np.asarray(vertices, float), np.asarray(triangles))
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices.tolist(), [], triangles.tolist())
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj
