"""A mesh's data as numpy arrays, and what the bakes ask of its shape."""

import numpy as np

from ..common import imageio
from ..core.vectors import cross

#: The property of an attribute's values by its data type (any other: "value").
_VALUE_PROPERTY = {"FLOAT_VECTOR": "vector", "FLOAT2": "vector", "FLOAT_COLOR": "color", "BYTE_COLOR": "color"}


def attribute(mesh, name, dtype, width=1):
    """The values of ``mesh``'s attribute ``name`` (e.g. "position", ".corner_vert", a UV map or
    a colour attribute) as an array of ``dtype``, (n, width) when ``width`` > 1: ~100x faster
    than MeshLoop, MeshUVLoop & co. (foreach_get copies Blender's own float32 and int32 whole;
    into another dtype it converts value by value)."""
    found = mesh.attributes[name]
    values = np.empty(len(found.data) * width, dtype=dtype)
    found.data.foreach_get(_VALUE_PROPERTY.get(found.data_type, "value"), values)
    return values.reshape(-1, width) if width > 1 else values


def loop_starts(mesh):
    """The index of every face's first corner, as int32 (faces,)."""
    starts = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_start", starts)
    return starts


def corner_faces(mesh):
    """Each face corner's face, as int32 (corners,)."""
    starts = loop_starts(mesh)
    return np.repeat(np.arange(len(starts), dtype=np.int32), np.diff(np.append(starts, len(mesh.loops))))


def edge_uses(mesh):
    """How many face corners use each of ``mesh``'s edges (edges,): 2 on a closed surface."""
    return np.bincount(attribute(mesh, ".corner_edge", np.int32), minlength=len(mesh.edges))


def encloses_negative_volume(edge_uses, face_points, area_vectors):
    """True when the faces close a volume (every edge between exactly two of them, by its
    count ``edge_uses``) whose signed volume, (1/3) Σ face point · area vector, is negative:
    their normals point inwards. Open meshes (a wall, a scan with holes) have no inside."""
    closed = len(area_vectors) > 0 and bool(np.all(edge_uses == 2))
    return closed and np.einsum("ij,ij->", face_points, area_vectors) < 0.0


def is_inside_out(mesh):
    """True when ``mesh`` is closed and its normals point inwards (``encloses_negative_volume``)."""
    starts = loop_starts(mesh)
    if not len(starts):
        return False
    points = attribute(mesh, "position", np.float32, 3).astype(np.float64)
    corners = points[attribute(mesh, ".corner_vert", np.int32)]
    return encloses_negative_volume(edge_uses(mesh), corners[starts], area_vectors(corners, starts))


def area_vectors(corners, starts):
    """Each face's area vector (faces, 3), its normal times its area, by Newell's sum over its
    corners' points ``corners`` (corners, 3), its first corner at ``starts``."""
    following = np.arange(1, len(corners) + 1)  # the next corner around the face
    following[np.append(starts[1:], len(corners)) - 1] = starts
    return np.add.reduceat(cross(corners, corners[following]), starts) / 2.0


def winding_reversed(matrix_world, inside_out):
    """True when the faces, placed by ``matrix_world`` (4, 4), must have their winding read
    reversed to face out of the object, as renders shade them: the transform mirrors (negative
    determinant) or the mesh is closed and inside out (``is_inside_out``), but not both."""
    return bool((np.linalg.det(np.asarray(matrix_world)[:3, :3]) < 0) != inside_out)


def grey_rgba(values):
    """``values`` (n,) as grey colours of alpha 1, flat float32 (n * 4,): what a colour
    attribute's ``foreach_set("color", ...)`` takes."""
    rgba = np.ones((len(values), 4), dtype=np.float32)
    rgba[:, :3] = np.asarray(values, dtype=np.float32)[:, None]
    return rgba.ravel()


def write_corner_attribute(mesh, name, values):
    """Replace the colour attribute ``name`` of ``mesh`` by grey per-corner ``values``; the old
    one is kept when they are not all finite (``imageio.NonFiniteMap``)."""
    imageio.check_finite(values, f"colour attribute '{name}'")
    colours = grey_rgba(values)
    if name in mesh.color_attributes:
        mesh.color_attributes.remove(mesh.color_attributes[name])
    mesh.color_attributes.new(name, "FLOAT_COLOR", "CORNER").data.foreach_set("color", colours)


def open_edges(mesh, places=None):
    """Whether each of ``mesh``'s edges is an open border (edges,): of one face, and not lying on
    another such edge end to end (``places``, its ``border_places`` if the caller has them: a seam
    where the surface is split, as importers leave a glTF's at its UV seams, is not open)."""
    uses = edge_uses(mesh)
    single = np.flatnonzero(uses == 1)
    places = border_places(mesh) if places is None else places
    keys = edge_keys(attribute(mesh, ".edge_verts", np.int32, 2)[single], places)
    _, same, counts = np.unique(keys, return_inverse=True, return_counts=True)
    found = np.zeros(len(uses), dtype=bool)
    found[single] = counts[same.reshape(-1)] == 1
    return found


def edge_keys(ends, places):
    """One int64 for each edge of ``ends`` (E, 2), the same for edges whose two ends have the same
    ``places`` (``border_places``), either way round."""
    ends = np.sort(places[ends], axis=1).astype(np.int64)
    return ends[:, 0] * len(places) + ends[:, 1]


def border_places(mesh):
    """Each vertex's number (vertices,), the same for the vertices a seam joins: two open borders
    (edges of one face) that lie on each other end to end bit for bit, and no third, are a seam
    where the surface was split (as importers leave a glTF's at its UV seams and hard edges); its
    ends are one place, numbered by the least vertex of all it joins. Borders where more meet
    (split blocks touching face to face) join nothing; every other vertex is its own number."""
    place = np.arange(len(mesh.vertices))
    ends = attribute(mesh, ".edge_verts", np.int32, 2)[edge_uses(mesh) == 1]
    on_border = np.zeros(len(place), dtype=bool)
    on_border[ends.ravel()] = True  # a mask, not np.unique: a triangle soup's millions of ends
    border = np.flatnonzero(on_border)
    if not len(border):
        return place
    first, same = row_groups(attribute(mesh, "position", np.float32, 3)[border])
    at = place.copy()
    at[border] = border[first][same]  # each border vertex by its position
    keys = edge_keys(ends, at)
    order = np.argsort(keys)  # the borders that lie on each other, side by side
    starts = np.flatnonzero(np.diff(keys[order], prepend=-1))
    two = starts[np.diff(np.append(starts, len(order))) == 2]  # two borders on an edge, no third
    pair = np.stack([order[two], order[two + 1]], axis=1)
    one, other = ends[pair[:, 0]], ends[pair[:, 1]]
    crossed = at[one[:, 0]] != at[other[:, 0]]  # the other edge runs the other way
    other[crossed] = other[crossed, ::-1]
    return components(place, np.stack([one.ravel(), other.ravel()], axis=1))  # each end to its twin


def components(label, links):
    """Each of ``label``'s items (a range's numbers, each its own at first) numbered by the least
    item it is joined to through ``links`` (L, 2): each pass takes the least label among an
    item's links (grouped once, as ``np.minimum.at`` is many times slower), then jumps pointers."""
    if not len(links):
        return label
    ends = np.concatenate([links, links[:, ::-1]])
    ends = ends[np.argsort(ends[:, 0])]
    starts = np.flatnonzero(np.diff(ends[:, 0], prepend=-1))  # each item's first link
    items = ends[starts, 0]
    while True:
        spread = label.copy()
        spread[items] = np.minimum(label[items], np.minimum.reduceat(label[ends[:, 1]], starts))
        spread = spread[spread[spread]]  # pointer jumping, twice: fewer passes
        if np.array_equal(spread, label):
            return label
        label = spread


def row_groups(rows):
    """(first, group) of the rows of ``rows`` (N, k) equal bit for bit: each group's first row and
    each row's group, as ``np.unique``'s index and inverse over the rows, each row read as one
    value (a row-wise ``np.unique`` sorts column by column, several times slower)."""
    rows = np.ascontiguousarray(rows)
    whole = rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
    _, first, group = np.unique(whole, return_index=True, return_inverse=True)
    return first, group.reshape(-1)


def face_islands(mesh, places=None):
    """Each face's loose part (faces joined through shared vertices), numbered 0, 1, ... in the
    order of their first faces, as int32 (faces,). With ``places`` (each vertex's number,
    ``border_places``), vertices of one number are one: a surface split along its seams is one
    part (as importers leave a glTF's; tiles laid edge to edge), while closed parts that touch,
    and split ones that touch face to face, stay apart. Labels spread along the corners to the
    least of each part, with pointer jumping, so a part of any shape takes a few dozen passes."""
    starts = loop_starts(mesh)
    if not len(starts):
        return np.zeros(0, dtype=np.int32)
    corner_face = corner_faces(mesh)
    corner_vertex = attribute(mesh, ".corner_vert", np.int32)
    if places is not None:
        corner_vertex = places[corner_vertex]
    label = np.arange(len(mesh.vertices))
    while True:
        face_least = np.full(len(starts), len(label))
        np.minimum.at(face_least, corner_face, label[corner_vertex])
        spread = label.copy()
        np.minimum.at(spread, corner_vertex, face_least[corner_face])
        spread = spread[spread]  # pointer jumping: each label to its own label's
        if np.array_equal(spread, label):
            break
        label = spread
    _, part = np.unique(face_least, return_inverse=True)
    first_face = np.unique(part, return_index=True)[1]
    rank = np.argsort(np.argsort(first_face))  # parts numbered in the order of their first faces
    return rank[part].astype(np.int32)
