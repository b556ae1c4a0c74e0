"""The run-off map R (docs/model.md §7.1; docs/maps.md, "Run-off"): where the rain that lands
runs, from the rain map and the geometry.

The flow is computed on a sampling of the surface (``runoff_flow``, numpy) as fine as the map
needs, not on the mesh's faces: for an image, a node about every ``TEXELS_PER_NODE`` texels;
for a colour attribute, the mesh's median edge kept between ``size / ATTRIBUTE_FINEST`` and
``size / ATTRIBUTE_COARSEST`` (size: ``edges.object_size``), so one quad and a fine grid, a
millimetre and a metre object, get the same R at the same points. It reads the rain map of the
same bake (or the one baked before for the object), drops fall along the rain's mean direction
(its wind's lean) and land where that line meets the object (a BVH ray cast).
"""

import math
from dataclasses import dataclass

import bpy

import numpy as np
from mathutils import Vector
from mathutils.bvhtree import BVHTree

from ..blender import mesh_arrays, scratch_scene
from ..common import imageio
from ..common.options import check, option
from ..contracts import map_attribute
from ..core.vectors import cross
from . import edges, lightmap, runoff_flow
from .rain import RAIN_ATTRIBUTE
from .registry import MapKind

RUNOFF_ATTRIBUTE = map_attribute("runoff")
#: Unset lengths, as fractions of the object's size (``edges.object_size``): L, the run that
#: gives R = 0.63 under full rain, and l, over which the stone absorbs all but 1/e of a flow.
RUNOFF_LENGTH_FRACTION = 0.05
ABSORPTION_LENGTH_FRACTION = 0.25
DEFAULT_DRIP_ANGLE = 30.0
#: The sampling of an image map: a node per this many texels along the surface.
TEXELS_PER_NODE = 2.0
#: The sampling of an attribute map: the median edge, kept between size / FINEST and size / COARSEST.
ATTRIBUTE_FINEST, ATTRIBUTE_COARSEST = 512, 256


@dataclass(frozen=True)
class RunoffSettings:
    """The run-off: its length L (R = 1 - exp(-Q / L)), the stone's absorption length l and the
    angle below the horizontal past which a surface drips (docs/model.md §7.1)."""

    runoff_length: float | None = option(
        None,
        label="Run-off Length",
        flag="--runoff-length",
        low=0.0,
        low_open=True,
        finite=True,
        auto=0.0,
        unit="scene units",
        metavar="L",
        tooltip="Run of full rain that gives R = 0.63 (R = 1 - exp(-Q / L)); "
        f"unset (0 in the bake dialog): {RUNOFF_LENGTH_FRACTION:g} times the object's size",
    )
    absorption_length: float | None = option(
        None,
        label="Absorption Length",
        flag="--absorption-length",
        low=0.0,
        low_open=True,
        auto=0.0,
        unit="scene units",
        metavar="L",
        tooltip="Length of flow over which the stone absorbs all but 1/e of the water (inf: none); "
        f"unset (0 in the bake dialog): {ABSORPTION_LENGTH_FRACTION:g} times the object's size",
    )
    drip_angle: float = option(
        DEFAULT_DRIP_ANGLE,
        label="Drip Angle",
        flag="--drip-angle",
        low=0.0,
        high=90.0,
        unit="degrees",
        metavar="DEG",
        tooltip="Angle below the horizontal past which a surface drips: water leaves it and falls",
    )

    def __post_init__(self):
        check(self)

    def lengths(self, size: float) -> tuple[float, float]:
        """(L, l) in scene units for an object of ``size``."""
        runoff = self.runoff_length or RUNOFF_LENGTH_FRACTION * size
        absorption = self.absorption_length or ABSORPTION_LENGTH_FRACTION * size
        return runoff, absorption


@dataclass(frozen=True)
class _Mesh:
    """An object's mesh as the render sees it, in world space, as triangles wound so that their
    normals point out of the object as rendered (a mirroring transform reverses the winding, and
    a closed mesh turned inside out is read from outside)."""

    vertices: np.ndarray  #: (V, 3)
    triangles: np.ndarray  #: (T, 3) vertex indices
    corners: np.ndarray  #: (T, 3) face-corner (loop) indices
    border: np.ndarray  #: (T, 3) bool: the edge facing each corner is on the mesh's border
    uvs: np.ndarray | None  #: (T, 3, 2) the UV map the bake reads and writes through, if any
    inside_out: bool  #: the mesh is closed and its normals point inwards (``mesh_arrays.is_inside_out``)
    size: float  #: the object's size (``edges.object_size``)
    frame: edges.TexelFrame  #: where its texels are baked from (``edges.bake_texel_geometry``)


def _world_mesh(seen, uv_map=None):
    """The ``_Mesh`` of ``seen`` (``scratch_scene.rendered``), with the UVs of ``uv_map``."""
    return _triangles_of(seen.mesh, seen.matrix_world, uv_map)


def _triangles_of(mesh, matrix, uv_map=None):
    mesh.calc_loop_triangles()
    count = len(mesh.loop_triangles)
    triangles = np.empty(count * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    corners = np.empty(count * 3, np.int32)
    mesh.loop_triangles.foreach_get("loops", corners)
    points = mesh_arrays.attribute(mesh, "position", np.float32, 3).astype(np.float64)
    vertices = points @ matrix[:3, :3].T + matrix[:3, 3]
    # an open edge (of one face, not a seam where the surface is split) is on the border: the
    # triangles' edges that are polygon edges (a triangle's inner edges are not) by the polygon
    # edge of each triangle corner
    loop_edges = mesh_arrays.attribute(mesh, ".corner_edge", np.int32)
    open_edges = mesh_arrays.open_edges(mesh)
    loop_vertices = mesh_arrays.attribute(mesh, ".corner_vert", np.int32)
    ends = mesh_arrays.attribute(mesh, ".edge_verts", np.int32, 2)
    corners = corners.reshape(-1, 3)
    triangles = triangles.reshape(-1, 3)
    border = np.zeros(triangles.shape, bool)
    for k in range(3):  # the edge facing corner k runs from corner k + 1 to corner k + 2
        start = corners[:, (k + 1) % 3]
        edge = loop_edges[start]
        # the corner's polygon edge starts at its vertex: it is this triangle edge if it ends at the next
        along = ends[edge]
        follows = ((along[:, 0] == loop_vertices[start]) & (along[:, 1] == triangles[:, (k + 2) % 3])) | (
            (along[:, 1] == loop_vertices[start]) & (along[:, 0] == triangles[:, (k + 2) % 3])
        )
        border[:, k] = follows & open_edges[edge]
    # read from outside, as renders shade it: swap two corners (and the edges facing them)
    inside_out = mesh_arrays.is_inside_out(mesh)
    if mesh_arrays.winding_reversed(matrix, inside_out):
        triangles, corners, border = (array[:, [0, 2, 1]] for array in (triangles, corners, border))
    uvs = lightmap.corner_uvs(mesh, uv_map)[corners] if uv_map is not None else None
    box = edges.box_of_surface(points, triangles)
    frame = edges.texel_frame(box, matrix, inside_out)
    return _Mesh(vertices, triangles, corners, border, uvs, inside_out, edges.size_of_box(box, matrix), frame)


def spacing_for(obj: bpy.types.Object, world: _Mesh, target: str, resolution: int | None = None) -> float:
    """The sampling of the flow over ``world``, ``obj``'s mesh (with its UVs for an image), in
    scene units (see the module's docstring)."""
    size = world.size
    if target == "image":
        a, b, c = (world.vertices[world.triangles[:, k]] for k in range(3))
        area = 0.5 * np.linalg.norm(cross(b - a, c - a), axis=1).sum()
        du, dv = world.uvs[:, 1] - world.uvs[:, 0], world.uvs[:, 2] - world.uvs[:, 0]
        uv_area = 0.5 * np.abs(du[:, 0] * dv[:, 1] - du[:, 1] * dv[:, 0]).sum()
        texel = math.sqrt(area / max(uv_area, 1e-12)) / resolution
        return TEXELS_PER_NODE * texel
    median = edges._median_edge(obj)
    return float(np.clip(median, size / ATTRIBUTE_FINEST, size / ATTRIBUTE_COARSEST))


def _lander(world):
    """Where rays (world space) first meet the surface ``world``: a ray cast on a BVH of it, built
    about the centre of its surface (``world.frame``: the BVH holds single precision, of the
    object's size, not of its distance from the world's origin or from a stray vertex)."""
    centre = world.frame.centre
    tree = BVHTree.FromPolygons((world.vertices - centre).tolist(), world.triangles.tolist(), all_triangles=True)

    def land(origins, direction):
        hits = np.full((len(origins), 3), np.nan)
        towards = Vector(np.asarray(direction, float))
        for index, origin in enumerate(np.asarray(origins, float) - centre):
            location = tree.ray_cast(Vector(origin), towards)[0]
            if location is not None:
                hits[index] = np.array(location) + centre
        return hits

    return land


def flow(world: _Mesh, rain_at, spacing: float, settings: RunoffSettings, rain_settings) -> tuple:
    """(surface, flux, L) of an object whose mesh as rendered, in world space, is ``world``: the
    run-off flux Q of its surface's nodes under the rain ``rain_at(triangles, weights) -> E`` (at
    points given as barycentric weights of triangles)."""
    surface = runoff_flow.sample_surface(world.vertices, world.triangles, spacing, world.border, rain_at)
    runoff_length, absorption_length = settings.lengths(world.size)
    fall = -np.asarray(rain_settings.towards_rain(), float)
    result = runoff_flow.route(
        surface,
        surface.values,
        absorption_length=absorption_length,
        drip_angle=settings.drip_angle,
        fall=fall,
        land=_lander(world),
    )
    return surface, result, runoff_length


def bake_runoff_corners(obj: bpy.types.Object, options) -> np.ndarray:
    """R at every face corner of ``obj``, from its rain attribute (the bake refuses an attribute
    target whose modifiers change the corners, so the mesh as rendered has the mesh's corners)."""
    mesh = obj.data
    if RAIN_ATTRIBUTE not in mesh.color_attributes:
        raise ValueError(f"object '{obj.name}' has no rain map ({RAIN_ATTRIBUTE}): bake it with the run-off")
    rain = np.empty(len(mesh.loops) * 4, np.float32)
    mesh.color_attributes[RAIN_ATTRIBUTE].data.foreach_get("color", rain)
    rain = rain.reshape(-1, 4)[:, 0].astype(np.float64)
    with scratch_scene.rendered(obj) as seen:
        world = _world_mesh(seen)
        corner_rain = rain[world.corners]
        surface, result, runoff_length = flow(
            world,
            lambda tri, w: (corner_rain[tri] * w).sum(1),
            spacing_for(obj, world, "attribute"),
            options.runoff_settings,
            options.rain_settings,
        )
        # read at the vertices, and apart at the corners whose normals differ from their vertex's
        # (sharp edges, flat shading): a smooth scan's corners share their vertex's value
        vertex_of = mesh_arrays.attribute(seen.mesh, ".corner_vert", np.int32)
        corner_normals = world_corner_normals(seen, world.inside_out)
    vertex_normals = np.zeros_like(world.vertices)
    np.add.at(vertex_normals, vertex_of, corner_normals)
    vertex_normals /= np.maximum(np.linalg.norm(vertex_normals, axis=1), 1e-300)[:, None]
    flux = np.zeros(len(world.vertices))
    used = np.unique(vertex_of)  # loose vertices have no corner to read at
    flux[used] = runoff_flow.interpolate(surface, result.flux, world.vertices[used], vertex_normals[used])
    flux = flux[vertex_of]
    apart = np.einsum("ij,ij->i", corner_normals, vertex_normals[vertex_of]) < 0.999
    flux[apart] = runoff_flow.interpolate(surface, result.flux, world.vertices[vertex_of[apart]], corner_normals[apart])
    return runoff_flow.runoff_map(flux, runoff_length)


def world_corner_normals(seen, inside_out: bool):
    """The world-space unit normals of ``seen``'s corners, out of the object (normals transform
    by the inverse transpose, which keeps them outwards under a mirror; a closed mesh turned
    inside out, ``inside_out`` (``mesh_arrays.is_inside_out``), is read from outside, as renders
    shade it)."""
    normals = np.empty(len(seen.mesh.loops) * 3, np.float32)
    seen.mesh.corner_normals.foreach_get("vector", normals)
    normals = normals.reshape(-1, 3).astype(np.float64) @ np.linalg.inv(seen.matrix_world[:3, :3])
    if inside_out:
        normals = -normals
    return normals / np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]


def bake_runoff_image(obj: bpy.types.Object, uv_map: str, options, margin: int) -> np.ndarray:
    """R on ``uv_map`` at the bake's resolution, from the rain map baked for ``obj``; both read
    through the UVs of the mesh the render sees (modifiers applied)."""
    rain_path = imageio.image_path(options.out_dir, obj.name, "rain")
    try:
        rain_image = imageio.read_image(rain_path)[0][..., 0].astype(np.float64)
    except (OSError, ValueError) as error:
        raise ValueError(
            f"object '{obj.name}': no rain map to run off ({rain_path}): bake it with the run-off"
        ) from error
    with scratch_scene.rendered(obj) as seen:
        world = _world_mesh(seen, uv_map)
    size = rain_image.shape[0]

    def rain_at(tri, weights):
        uv = (world.uvs[tri] * weights[..., None]).sum(1)
        return _bilinear(rain_image, uv, size)

    spacing = spacing_for(obj, world, "image", options.resolution)
    surface, result, runoff_length = flow(world, rain_at, spacing, options.runoff_settings, options.rain_settings)
    positions, normals, islands = edges.bake_texel_geometry(obj, uv_map, options.resolution, frame=world.frame)
    values = np.zeros((options.resolution, options.resolution), np.float32)
    flux = runoff_flow.interpolate(surface, result.flux, positions[islands], normals[islands])
    values[islands] = runoff_flow.runoff_map(flux, runoff_length)
    return edges.with_margin(values, islands, margin)


def _bilinear(image, uv, size):
    """``image`` (top row first) at UVs, bilinearly, texel centres at (i + 0.5) / size."""
    x = np.clip(uv[:, 0] * size - 0.5, 0, size - 1)
    y = np.clip((1.0 - uv[:, 1]) * size - 0.5, 0, size - 1)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    x1, y1 = np.minimum(x0 + 1, size - 1), np.minimum(y0 + 1, size - 1)
    fx, fy = x - x0, y - y0
    top = image[y0, x0] * (1 - fx) + image[y0, x1] * fx
    bottom = image[y1, x0] * (1 - fx) + image[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


# --- the record (docs/architecture.md, "Add a map") ---------------------------------------------------------


def _runoff_image(obj, uv_map, options, margin):
    return bake_runoff_image(obj, uv_map, options, margin)


def _runoff_attribute(obj, options):
    mesh_arrays.write_corner_attribute(obj.data, RUNOFF_ATTRIBUTE, bake_runoff_corners(obj, options))


def _runoff_hash(obj, options, digests):
    # the drops fall along the rain's mean direction; unset lengths are fractions of the object's size
    size = edges.object_size(obj)
    return dict(lengths=options.runoff_settings.lengths(size), fall=options.rain_settings.towards_rain())


MAP = MapKind(
    name="runoff",
    label="Run-off",
    description="Where the rain that lands runs: R = 1 - exp(-Q / L), Q the water collected along its path",
    attribute=RUNOFF_ATTRIBUTE,
    settings=RunoffSettings,
    options_field="runoff_settings",
    bake_image=_runoff_image,
    bake_attribute=_runoff_attribute,
    hash_inputs=_runoff_hash,
    reads=("rain",),
    order=30,
)
