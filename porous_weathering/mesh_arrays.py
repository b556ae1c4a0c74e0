"""A mesh's data as numpy arrays, and what the bakes ask of its shape."""

import numpy as np


def attribute(mesh, name, dtype, width=1):
    """The values of ``mesh``'s attribute ``name`` (e.g. "position", ".corner_vert") as an
    array of ``dtype``, (n, width) when ``width`` > 1: ~100x faster than MeshLoop & co."""
    values = np.empty(len(mesh.attributes[name].data) * width, dtype=dtype)
    mesh.attributes[name].data.foreach_get("vector" if name == "position" else "value", values)
    return values.reshape(-1, width) if width > 1 else values


def is_inside_out(mesh):
    """True when ``mesh`` is closed (every edge between exactly two faces) and its normals point
    inwards: its signed volume, (1/3) Σ_faces centre · area vector, is negative.

    Open meshes (a wall, a scan with holes) have no inside: their normals are taken as given.
    """
    loop_edge = attribute(mesh, ".corner_edge", np.int32)
    if not len(loop_edge) or np.any(np.bincount(loop_edge, minlength=len(mesh.edges)) != 2):
        return False
    points = attribute(mesh, "position", np.float32, 3).astype(np.float64)
    corners = points[attribute(mesh, ".corner_vert", np.int32)]
    loop_start = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_start", loop_start)
    loop_next = np.arange(1, len(corners) + 1)
    loop_next[np.append(loop_start[1:], len(corners)) - 1] = loop_start
    # Each face as the fan of tetrahedra (origin, p_0, p_i, p_next): the terms of its first and
    # last corners vanish, so one sum over all corners gives the volume.
    face_first = np.repeat(loop_start, np.diff(loop_start, append=len(corners)))
    volume = np.einsum("ij,ij->", corners[face_first], np.cross(corners, corners[loop_next])) / 6.0
    return volume < 0.0
