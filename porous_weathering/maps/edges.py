"""Edge/cavity mask C (docs/model.md §5, and docs/model.md §6.3; docs/maps.md, "Edge/cavity mask").

One field, two targets: the signed mean curvature H of the evaluated mesh in world space, from
the dihedral angles of its edges, smoothed over a physical radius (``EdgeSettings``: given in
scene units, or by default a fraction of the object's size), so that the same object in
millimetres or in metres gets the same mask and detail below the radius (scan noise, facets)
does not light it up.  Convex > 0, concave < 0.  The mask weighs the concave part (cavities)
and the convex part (edges) apart.

- ``curvature`` / ``write_curvature_attribute``: H at every vertex (attribute target, ``pw_edges``).
- ``edge_mask_image``: H at every texel of a UV map (image target): Cycles bakes each texel's
  world position and normal, and the texels read the same smoothed field as the vertices, so
  the image and the attribute agree at the same surface points whatever the UV layout.

The curvature maths, on numpy arrays, is ``curvature`` (``mesh_surface``, ``smooth_over_radius``,
``curvature_mask``: re-exported here, the documented ``edges`` module, docs/api.md); this module
is its bpy side: the radius of an object, its evaluated mesh read as arrays, the texel bake and
the attribute.
"""

import math
from collections.abc import Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace

import bpy

import numpy as np
from numpy.typing import ArrayLike

from ..blender import mesh_arrays, scratch_scene
from ..common import imageio
from ..common.options import check, option
from ..contracts import map_attribute
from . import contacts, lightmap, neighbours, scan_checks
from .curvature import (  # noqa: F401  (public: docs/api.md, the ``edges`` module)
    BLOCK,
    CHANNELS,
    CORNERS,
    DEFAULT_CAVITY_WEIGHT,
    DEFAULT_EDGE_WEIGHT,
    DEFAULT_SATURATION,
    DIRECT_CELLS_MAX,
    MAX_ADDED_SAMPLES,
    SAMPLE_SPACING,
    SHIFTS,
    Samples,
    Surface,
    curvature_mask,
    mesh_surface,
    smooth_over_radius,
    unit,
)
from .lightmap_check import surface_points
from .registry import MapKind

#: The colour attribute that carries the curvature mask C (per point, grey).
EDGE_ATTRIBUTE = map_attribute("edges")

#: The image mask is read at the vertices and drawn across the triangles when the mesh's
#: median edge is at most this many smoothing radii (a scan): the smoothed field then hardly
#: bends within a triangle, and reading it at every texel would cost minutes at 4096²
#: (docs/maps.md).  Coarser meshes (a façade's large faces) are read at every texel.
VERTEX_SPACING = 0.25

#: Default smoothing radius, as a fraction of the object's size (``object_size``; docs/maps.md:
#: measured on the bundled samples and the scan-like bust).
DEFAULT_EDGE_SCALE = 0.01


@dataclass(frozen=True)
class EdgeSettings:
    """How the edge/cavity mask is made: the smoothing radius (``radius`` in scene units, or
    ``scale`` times the object's size when ``radius`` is None) and the weights of its concave
    and convex parts."""

    radius: float | None = option(
        None,
        label="Edge Radius",
        flag="--edge-radius",
        low=0.0,
        low_open=True,
        finite=True,
        auto=0.0,
        unit="scene units",
        metavar="M",
        tooltip="Distance over which the surface's curvature is smoothed for the edge mask; "
        "unset (0 in the bake dialog): Edge Scale times the object's size (docs/maps.md)",
    )
    scale: float = option(
        DEFAULT_EDGE_SCALE,
        label="Edge Scale",
        flag="--edge-scale",
        low=0.0,
        high=1.0,
        low_open=True,
        metavar="F",
        tooltip="Edge radius as a fraction of the object's size (the bounding-box diagonal of its faces), "
        "when no Edge Radius is given",
    )
    cavity_weight: float = option(
        DEFAULT_CAVITY_WEIGHT,
        label="Cavity Weight",
        flag="--cavity-weight",
        low=0.0,
        finite=True,
        metavar="W",
        tooltip="Weight of the concave part of the edge mask (hollows, inner corners, grooves)",
    )
    edge_weight: float = option(
        DEFAULT_EDGE_WEIGHT,
        label="Edge Weight",
        flag="--edge-weight",
        low=0.0,
        finite=True,
        metavar="W",
        tooltip="Weight of the convex part of the edge mask (salient edges, arrises, ridges)",
    )

    def __post_init__(self):
        check(self)


# --- the radius --------------------------------------------------------------------------------


@contextmanager
def evaluated_mesh(obj: bpy.types.Object, depsgraph: bpy.types.Depsgraph | None = None):
    """(mesh, matrix_world) of ``obj`` evaluated in ``depsgraph``, or, without one (the bake's
    way), as the render sees it (``scratch_scene.rendered``: modifiers at their render settings)."""
    if depsgraph is None:
        with scratch_scene.rendered(obj) as seen:
            yield seen.mesh, seen.matrix_world
        return
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        yield mesh, np.array(evaluated.matrix_world, dtype=np.float64)
    finally:
        evaluated.to_mesh_clear()


def surface_box(obj: bpy.types.Object, depsgraph: bpy.types.Depsgraph | None = None) -> np.ndarray | None:
    """The (low, high) corners (2, 3), in ``obj``'s own space, of the box around its surface:
    the points its evaluated mesh's (``evaluated_mesh``) faces of non-zero area use
    (``surface_points``), so that loose vertices and edges and collapsed faces (a scan's stray
    point) play no part; None when it has no face of non-zero area."""
    with evaluated_mesh(obj, depsgraph) as (mesh, _):
        return box_of_faces(mesh)


def box_of_faces(mesh: bpy.types.Mesh) -> np.ndarray | None:
    """``surface_box`` of ``mesh``, read from it (an evaluated mesh the caller holds)."""
    return box_of_surface(mesh_arrays.attribute(mesh, "position", np.float32, 3), lightmap.triangle_corners(mesh)[1])


def box_of_surface(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray | None:
    """``surface_box`` of the mesh whose vertex ``positions`` (V, 3) its ``triangles`` (T, 3) use."""
    points = surface_points(positions, triangles)
    return np.stack([points.min(axis=0), points.max(axis=0)]) if len(points) else None


def size_of_box(box: np.ndarray | None, matrix_world: np.ndarray) -> float:
    """``object_size`` of an object whose ``surface_box`` is ``box``, placed by ``matrix_world``."""
    return 0.0 if box is None else float(np.linalg.norm(matrix_world[:3, :3] @ (box[1] - box[0])))


def object_size(obj: bpy.types.Object, depsgraph: bpy.types.Depsgraph | None = None) -> float:
    """The object's size, from which every default that scales with it is taken: the diagonal
    of ``surface_box``, in world units (it turns with the object, so a rotation does not change
    it); 0 when it has no face of non-zero area."""
    with evaluated_mesh(obj, depsgraph) as (mesh, matrix_world):
        return size_of_box(box_of_faces(mesh), matrix_world)


def effective_radius(
    obj: bpy.types.Object, settings: EdgeSettings, depsgraph: bpy.types.Depsgraph | None = None
) -> float:
    """The smoothing radius of ``obj``'s edge mask in scene units: ``settings.radius`` when
    given, else ``settings.scale`` times ``object_size``."""
    if settings.radius is not None:
        return float(settings.radius)
    size = object_size(obj, depsgraph)
    if not (math.isfinite(size) and size > 0.0):
        raise ValueError(f"object '{obj.name}' has no size to scale the edge radius by: give --edge-radius")
    return settings.scale * size


# --- samples of the surface ----------------------------------------------------------------------


def surface(
    obj: bpy.types.Object,
    radius: float,
    depsgraph: bpy.types.Depsgraph | None = None,
    beside: Sequence[bpy.types.Object] = (),
) -> Surface:
    """The ``Surface`` of ``obj``'s evaluated mesh (``evaluated_mesh``: modifiers applied) for
    smoothing ``radius``, with the corners where its loose parts meet each other or the objects
    ``beside`` it that it meets (``contacts``, ``neighbours.meeting``)."""
    if not np.isfinite(radius) or radius <= 0:
        raise ValueError(f"curvature radius must be a positive number of scene units, not {radius}")
    if obj.type not in scratch_scene.GEOMETRY_TYPES:
        raise ValueError(f"object '{obj.name}' has no faces to measure curvature on")
    meeting = neighbours.meeting(obj, beside, radius)
    with evaluated_mesh(obj, depsgraph) as (mesh, matrix_world):
        if not mesh.polygons:
            raise ValueError(f"object '{obj.name}' has no faces to measure curvature on")
        places = mesh_arrays.border_places(mesh)  # a surface split at its seams is one
        found = _surface(mesh, matrix_world, radius, obj.name, places)
        islands = mesh_arrays.face_islands(mesh, places)
        if islands.max(initial=0) == 0 and not meeting:  # one part alone: no corner its mesh does not have
            return found
        own = contacts.Triangles.of(mesh, matrix_world, places, islands)
    met = []
    for other in meeting:
        with evaluated_mesh(other, depsgraph) as (mesh, matrix_world):
            seams = mesh_arrays.border_places(mesh)
            met.append(contacts.Triangles.of(mesh, matrix_world, seams, mesh_arrays.face_islands(mesh, seams)))
    if own.part.max(initial=0) == 0 and not met:  # a hollow's inner wall is not a part of its own
        return found
    origin = (own.points.min(axis=0) + own.points.max(axis=0)) / 2.0  # the rays' single precision about it
    own_parts, met_parts = contacts.Parts.of([own], origin), contacts.Parts.of(met, origin)
    sources = contacts.with_contacts(found.sources, own, own_parts, met_parts, radius)
    return Surface(found.vertices, sources)


def _surface(mesh, matrix_world, radius, name, places):
    """``mesh_surface`` of a bpy mesh, its arrays read through its attributes, read across the
    seams where its surface is split (``places``: ``mesh_arrays.border_places``; importers leave
    a glTF split at its UV seams and hard edges): the border vertices at one place are one vertex,
    the border edges on each other one edge between their two faces, so a seam carries its
    dihedral angle."""
    corner_verts = mesh_arrays.attribute(mesh, ".corner_vert", np.int32)
    corner_edges = mesh_arrays.attribute(mesh, ".corner_edge", np.int32)
    edge_verts = mesh_arrays.attribute(mesh, ".edge_verts", np.int32, 2)
    joined = np.flatnonzero(places != np.arange(len(places)))
    if len(joined):
        corner_verts = places[corner_verts].astype(np.int32)
        keys, edge_of = np.unique(mesh_arrays.edge_keys(edge_verts, places), return_inverse=True)
        edge_verts = np.stack([keys // len(places), keys % len(places)], axis=1).astype(np.int32)
        corner_edges = edge_of.reshape(-1)[corner_edges].astype(np.int32)
    found = mesh_surface(
        mesh_arrays.attribute(mesh, "position", np.float32, 3),
        matrix_world,
        corner_verts,
        corner_edges,
        edge_verts,
        mesh_arrays.loop_starts(mesh),
        radius,
        name,
    )
    if not len(joined):
        return found
    vertices = found.vertices
    normals = vertices.normals.copy()
    normals[joined] = normals[places[joined]]  # a joined vertex faces as the one it is joined to
    return Surface(Samples(vertices.points, normals, vertices.curvature, vertices.area, vertices.vertex), found.sources)


# --- the attribute target ------------------------------------------------------------------------


def curvature(
    obj: bpy.types.Object,
    radius: float,
    depsgraph: bpy.types.Depsgraph | None = None,
    beside: Sequence[bpy.types.Object] = (),
) -> np.ndarray:
    """Signed mean curvature H (1 / scene units) at every vertex of ``obj``'s evaluated mesh
    (modifiers applied) in world space, as float32 (V,): convex > 0, concave < 0, and a
    sphere of radius r gives 1 / r.

    Every edge carries the integrated mean curvature theta * length / 2 (theta its signed
    dihedral angle), every face its area; H at a vertex is the curvature over the area around
    it, both summed with weights that fall from 1 at the vertex to 0 at 2 * ``radius``
    (``smooth_over_radius``).  Boundary and non-manifold edges carry none; faces must be
    consistently oriented (a closed mesh turned inside out is read from outside, as renders
    shade it). Where its loose parts meet each other, or the objects ``beside`` it, the corner
    no edge carries is added (``surface``, ``contacts``).
    """
    found = surface(obj, radius, depsgraph, beside)
    return smooth_over_radius(found.sources, found.vertices.points, found.vertices.normals, radius)


def _settings_mask(values, radius, settings):
    return curvature_mask(values, radius, cavity_weight=settings.cavity_weight, edge_weight=settings.edge_weight)


def write_edge_attribute(obj: bpy.types.Object, mask: ArrayLike, name: str = EDGE_ATTRIBUTE) -> None:
    """Store ``mask`` (one value per vertex of ``obj``'s mesh) as the grey colour attribute
    ``name`` (FLOAT_COLOR, per point), replacing any old one only once the new one is whole;
    NaN or infinite values are a bug (``imageio.NonFiniteMap``): the old one stays."""
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
    imageio.check_finite(mask, f"colour attribute '{name}'")
    colours = mesh_arrays.grey_rgba(np.clip(mask, 0.0, 1.0))
    attributes = obj.data.color_attributes
    staging_name = f"{name} (new)"
    staging = attributes.new(staging_name, "FLOAT_COLOR", "POINT")
    try:
        staging.data.foreach_set("color", colours)
    except Exception:
        attributes.remove(staging)
        raise
    if name in attributes:
        attributes.remove(attributes[name])
    attributes[staging_name].name = name


def write_curvature_attribute(
    obj: bpy.types.Object,
    radius: float | None = None,
    *,
    settings: EdgeSettings | None = None,
    depsgraph: bpy.types.Depsgraph | None = None,
    beside: Sequence[bpy.types.Object] = (),
) -> np.ndarray:
    """The mask of ``settings`` (default ``EdgeSettings()``; ``radius``, in scene units,
    replaces its radius) at every vertex, with the corners ``obj`` makes with the objects
    ``beside`` it (``curvature``), written to ``pw_edges``; returns the mask."""
    settings = settings or EdgeSettings()
    if radius is not None:
        settings = replace(settings, radius=radius)
    smoothing = effective_radius(obj, settings, depsgraph)
    mask = _settings_mask(curvature(obj, smoothing, depsgraph, beside), smoothing, settings)
    write_edge_attribute(obj, mask)
    return mask


# --- the image target ----------------------------------------------------------------------------


def edge_mask_image(
    obj: bpy.types.Object,
    uv_map_name: str,
    resolution: int,
    settings: EdgeSettings | None = None,
    *,
    margin: int = 4,
    beside: Sequence[bpy.types.Object] = (),
) -> np.ndarray:
    """C as a float32 (resolution, resolution) array in [0, 1], top row first (v = 1).

    Every texel of a UV island gets the mask of the curvature field ``curvature`` gives the
    vertices, read at the texel's own world position (``bake_texel_geometry``), so the
    image and the attribute agree at the same surface points and the texel size does not
    matter; with the corners ``obj`` makes with the objects ``beside`` it, as ``curvature``.
    On a mesh much finer than the radius (``VERTEX_SPACING``: a scan) the field is
    read at the vertices and drawn across the triangles (``scratch_scene.bake_point_values``)
    instead.

    Around every UV island C is extended ``margin`` texels outwards (each texel taking the
    mean of its neighbours already set), so texture filtering never pulls in empty texels;
    further out it is 0.

    A faceted scan (``scan_checks.looks_faceted``: flat-shaded, no custom normals, facets
    bending a little, as a scan saved without normals is) is read with smooth normals (its mesh
    is not changed): the texels' normals only weigh the samples by how their normals agree, and
    the facets' own would make the mask depend on how the mesh is shaded.  The bake says so
    (``scan_checks.warn``).
    """
    settings = settings or EdgeSettings()
    if obj.type != "MESH" or not obj.data.polygons:
        raise ValueError(f"object '{obj.name}' has no faces to bake an edge mask on")
    if uv_map_name not in obj.data.uv_layers:
        raise ValueError(f"object '{obj.name}' has no UV map '{uv_map_name}'")
    radius = effective_radius(obj, settings)
    found = surface(obj, radius, beside=beside)
    if not obj.modifiers and _median_edge(obj) <= VERTEX_SPACING * radius:
        at_vertices = smooth_over_radius(found.sources, found.vertices.points, found.vertices.normals, radius)
        values, islands = scratch_scene.bake_point_values(obj, uv_map_name, resolution, at_vertices)
    else:
        smooth_normals = scan_checks.looks_faceted(obj.data)
        positions, normals, islands = bake_texel_geometry(obj, uv_map_name, resolution, smooth_normals=smooth_normals)
        values = np.zeros((resolution, resolution), dtype=np.float32)
        values[islands] = smooth_over_radius(found.sources, positions[islands], unit(normals[islands]), radius)
    return with_margin(_settings_mask(values, radius, settings), islands, margin)


def with_margin(values: np.ndarray, known: np.ndarray, margin: int) -> np.ndarray:
    """The (H, W) float32 image of ``values`` at the ``known`` texels (the UV islands), grown
    ``margin`` rings around them (``grow``: the bake's margin, so texture filtering never pulls in
    empty texels) and 0 further out."""
    for _ in range(margin):
        values, known = grow(values, known)
    return np.where(known, values, 0.0).astype(np.float32)


def grow(values: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(values, known) grown by one ring: each unknown texel next to known ones (8-neighbours)
    takes the mean of their values.  ``values`` is (H, W) or (H, W, C)."""
    weight = known.astype(np.float32)
    count = _box3x3(weight)
    sums = _box3x3(values * weight.reshape(weight.shape + (1,) * (values.ndim - 2)))
    ring = ~known & (count > 0)
    grown = values.copy()
    grown[ring] = sums[ring] / count[ring].reshape(-1, *(1,) * (values.ndim - 2))
    return grown, known | ring


def _box3x3(image):
    """The sum of each texel's 3 x 3 neighbourhood of ``image`` (H, W, ...), borders repeating
    the edge texels."""
    height, width = image.shape[:2]
    padded = np.pad(image, [(1, 1), (1, 1)] + [(0, 0)] * (image.ndim - 2), mode="edge")
    result = np.zeros(image.shape, dtype=np.float32)
    for row in range(3):
        for column in range(3):
            result += padded[row : row + height, column : column + width]
    return result


def _median_edge(obj):
    """The median length of ``obj``'s mesh edges in world space."""
    mesh = obj.data
    points = mesh_arrays.attribute(mesh, "position", np.float32, 3).astype(np.float64)
    points = points @ np.array(obj.matrix_world)[:3, :3].T
    ends = mesh_arrays.attribute(mesh, ".edge_verts", np.int32, 2)
    return float(np.median(np.linalg.norm(points[ends[:, 0]] - points[ends[:, 1]], axis=1))) if len(ends) else math.inf


@dataclass(frozen=True)
class TexelFrame:
    """Where ``bake_texel_geometry`` bakes an object's texels from: ``centre``, the world point
    (3,) its positions are baked about (the centre of its surface's box, ``surface_box``, so a
    stray point plays no part), and ``outward``, 1, or −1 for a closed mesh turned inside out
    (its normals turned, so it is read from outside as renders shade it)."""

    centre: np.ndarray
    outward: float


def texel_frame(box: np.ndarray | None, matrix_world: np.ndarray, inside_out: bool) -> TexelFrame:
    """The ``TexelFrame`` of an object whose ``surface_box`` is ``box``, placed by
    ``matrix_world``, its mesh inside out or not (``mesh_arrays.is_inside_out``)."""
    centre = np.zeros(3) if box is None else matrix_world[:3, :3] @ box.mean(axis=0) + matrix_world[:3, 3]
    return TexelFrame(centre, -1.0 if inside_out else 1.0)


def bake_texel_geometry(
    obj: bpy.types.Object,
    uv_map_name: str,
    resolution: int,
    *,
    smooth_normals: bool = False,
    frame: TexelFrame | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(positions, normals, islands): the world-space position (float64) and shading normal
    (float32; smooth ones with ``smooth_normals``), out of the object, of ``obj`` at the centre of
    every texel of ``uv_map_name``, (H, W, 3), and the (H, W) bool map of the texels on a UV
    island (the others are 0). All top row first. ``frame``: the object's ``texel_frame``, when
    the caller has its evaluated mesh at hand (else it is evaluated here once more)."""
    if frame is None:
        with evaluated_mesh(obj) as (mesh, matrix_world):
            frame = texel_frame(box_of_faces(mesh), matrix_world, mesh_arrays.is_inside_out(mesh))
    position, normal = scratch_scene.emit_bakes(
        obj,
        uv_map_name,
        resolution,
        [lambda graph, geometry, name=name: geometry.outputs[name] for name in ("Position", "Normal")],
        prepare=(lambda mesh: mesh.shade_smooth()) if smooth_normals else None,
        origin=frame.centre,
    )
    return position[..., :3] + frame.centre, frame.outward * normal[..., :3], position[..., 3] > 0


# --- the record (docs/architecture.md, "Add a map") ---------------------------------------------------------


def _edges_image(obj, uv_map, options, margin):
    beside = neighbours.options_occluders(obj, options)
    return edge_mask_image(obj, uv_map, options.resolution, options.edge_settings, margin=margin, beside=beside)


def _edges_attribute(obj, options):
    write_curvature_attribute(obj, settings=options.edge_settings, beside=neighbours.options_occluders(obj, options))


def _edges_hash(obj, options, digests):
    # the radius the mask is smoothed over, given or scale times the object's size: the same
    # radius given either way is the same map; the objects it meets, whose corners with it count
    radius = effective_radius(obj, options.edge_settings)
    met = neighbours.meeting(obj, neighbours.options_occluders(obj, options), radius)
    return dict(radius=radius, scale=None, meets=sorted((other.name, digests(other)) for other in met))


MAP = MapKind(
    name="edges",
    label="Edges",
    description="Edge/cavity mask: the surface's curvature smoothed over a radius relative to the object's size",
    attribute=EDGE_ATTRIBUTE,
    settings=EdgeSettings,
    options_field="edge_settings",
    bake_image=_edges_image,
    bake_attribute=_edges_attribute,
    hash_inputs=_edges_hash,
    aliases={
        "edge_radius": "radius",
        "edge_scale": "scale",
        "cavity_weight": "cavity_weight",
        "edge_weight": "edge_weight",
    },
    order=20,
)
