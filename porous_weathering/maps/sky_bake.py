"""Direct-light bakes: what a sky sends straight to every point of an object, shadowed by the
object itself and its occluders, baked with Cycles. The rain map (``rain``, docs/model.md §5) is
such a bake under its own sky (``Sky``); the sun map (``sun``, §9.1) casts its own rays from the
same points (``Placed``, ``bakes_at_vertices``).

Cycles' DIFFUSE bake with only the direct pass returns irradiance / π: ∫ L(ω) max(0, N·ω) V dω / π
over the directions ω the sky lights, V the visibility. A sky sets its radiance L so that this is
the map.

The bake runs in a temporary scene on copies of the objects (the target's mesh copied, the
occluders' meshes shared), all with plain opaque materials, so the user's scene, materials,
meshes and selection are never touched and nothing is left behind, even on failure.
"""

from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property

import bpy

import numpy as np
from mathutils import Matrix

from ..blender import compat, mesh_arrays, scratch_scene
from . import edges, lightmap

#: The most samples Cycles takes (its own upper bound, 2^24).
MAX_SAMPLES = 1 << 24
#: A probe's size and height above the surface, in mean edge lengths (``_bake_points``).
PROBE_SIZE = 0.01
#: Where a flat corner's probe sits: this share of the way from its vertex towards the centres of
#: the faces whose corners share it, inside them, as Cycles' own per-corner bake samples a corner
#: (at the vertex itself, the foot of a step sees half its sky hidden by the step's wall; the
#: attribute spreads the corner's value over its face).  On the main job's façade the rain map
#: then agrees with Cycles' per-corner bake to 0.0035 per corner on average (docs/maps.md).
CORNER_INSET = 0.1
#: An image of a mesh smooth at its vertices is baked at the vertices and drawn across the
#: triangles when it has at most this many texels (resolution²) per vertex: about 20 the bake
#: fills, so they are hardly finer than the mesh, and per texel the map would cost more samples
#: for little more detail (docs/maps.md).
TEXELS_PER_VERTEX = 32


@dataclass(frozen=True)
class Sky:
    """The light of a direct-light bake: ``add(scene, ledger)`` puts it into the bake's scene
    (lamps or a world, recorded in ``ledger``); ``reaches(normals)`` says, for unit normals
    (V, 3) in the scene's frame, which surfaces any of it can reach (the others get exactly 0,
    unbaked); ``samples`` and ``seed`` are Cycles' per texel or corner; ``label`` names the
    temporary datablocks ("PW <label> Bake")."""

    label: str
    samples: int
    seed: int
    add: Callable[[bpy.types.Scene, scratch_scene.Ledger], None]
    reaches: Callable[[np.ndarray], np.ndarray]


def bake_image(
    obj: bpy.types.Object,
    uv_map: str,
    size: int,
    sky: Sky,
    occluders: Sequence[bpy.types.Object] = (),
    margin: int = 4,
) -> np.ndarray:
    """The map of ``sky`` on ``obj``'s UV map ``uv_map`` as a float32 (size, size) array, top row
    first.

    ``margin`` texels around every UV island are filled from the island's edge (Blender's bake
    margin, EXTEND), so that filtering and mip-mapping never pull in empty texels.
    A mesh smooth at its vertices whose image has at most TEXELS_PER_VERTEX texels per vertex
    (a scan) is baked at its vertices and drawn across its triangles
    (``scratch_scene.bake_point_values``).
    """
    if obj.type != "MESH" or uv_map not in obj.data.uv_layers:
        raise ValueError(f"object '{obj.name}' has no UV map '{uv_map}'")
    with _bake_scene(obj, occluders, sky, unit_placing(obj)) as copy:
        if bakes_at_vertices(obj, size):
            at_vertices = _bake_vertices(obj, copy, sky)
        else:
            return _bake_image(copy, uv_map, size, margin, sky.label)
    return scratch_scene.bake_point_values(obj, uv_map, size, at_vertices, margin=margin)[0]


def bakes_at_vertices(obj: bpy.types.Object, size: int) -> bool:
    """Whether a size² image of ``obj`` is baked at its vertices and drawn across its triangles:
    its mesh is smooth at its vertices and has at most TEXELS_PER_VERTEX texels per vertex."""
    return smooth_at_vertices(obj) and size**2 <= TEXELS_PER_VERTEX * len(obj.data.vertices)


def _bake_image(copy, uv_map, size, margin, label):
    """The map baked at every texel of ``copy``'s UV map ``uv_map`` (size, size), top row first."""
    with scratch_scene.Ledger() as made:
        image = made.add(bpy.data.images.new(f"PW {label} Bake", size, size, alpha=False, float_buffer=True))
        copy.data.uv_layers.active = copy.data.uv_layers[uv_map]
        texture = copy.active_material.node_tree.nodes.new("ShaderNodeTexImage")
        texture.image = image
        copy.active_material.node_tree.nodes.active = texture
        _bake(copy, margin=margin)
        pixels = np.empty(size * size * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(size, size, 4)[::-1, :, 0].copy()  # Blender stores the bottom row first


def bake_corners(obj: bpy.types.Object, sky: Sky, occluders: Sequence[bpy.types.Object] = ()) -> np.ndarray:
    """The map of ``sky`` at every face corner of ``obj``'s mesh, as a float32 array
    (len(mesh.loops),), read on the mesh the render makes of it (its modifiers must keep its
    corners, as attribute maps need).

    Corners that share a vertex and a normal share the map (the same point, lit alike), so the
    mesh is baked once per such pair (``_bake_points``): once per vertex where it is smooth,
    about six corners, and once per vertex and face plane where it is flat, four corners of a
    wall cut into quads, the probe just inside the pair's faces (CORNER_INSET)."""
    if obj.type != "MESH":
        raise ValueError(f"{obj.name}: a {sky.label.lower()} bake needs a mesh object, not {obj.type.lower()}")
    with scratch_scene.rendered(obj) as seen:
        scratch_scene.check_corners_kept(obj, seen)
        placing = rendered_placing(obj, seen)
        with _bake_scene(obj, occluders, sky, placing) as copy:
            placed = Placed(seen.mesh, np.array(copy.matrix_world, dtype=np.float64))
            points, normals, corner_point = placed.corner_points(smooth=smooth_at_vertices(obj))
            return _bake_points(placed, copy, sky, points, normals)[corner_point]


def smooth_at_vertices(obj: bpy.types.Object) -> bool:
    """Whether every corner of ``obj`` shades with its vertex's normal: its mesh is smooth-shaded
    all over, with no sharp edges and no custom normals, and no modifier changes it."""
    mesh = obj.data
    if obj.modifiers or mesh.has_custom_normals or not len(mesh.polygons):
        return False
    smooth = np.empty(len(mesh.polygons), dtype=bool)
    mesh.polygons.foreach_get("use_smooth", smooth)
    sharp = "sharp_edge" in mesh.attributes and mesh_arrays.attribute(mesh, "sharp_edge", bool).any()
    return bool(smooth.all()) and not sharp


@dataclass(frozen=True)
class Placed:
    """A mesh placed in the bake's scene by ``matrix`` (4 x 4): its copy's there."""

    mesh: bpy.types.Mesh
    matrix: np.ndarray

    @cached_property
    def positions(self) -> np.ndarray:
        """The vertices (V, 3), read once: the points and the probes' size both need them."""
        return mesh_arrays.attribute(self.mesh, "position", np.float32, 3) @ self.matrix[:3, :3].T + self.matrix[:3, 3]

    def normals(self, normals: np.ndarray) -> np.ndarray:
        """Unit ``normals`` (N, 3) of the mesh, as the bake's scene and its shading see them."""
        normals = normals.reshape(-1, 3) @ np.linalg.inv(self.matrix[:3, :3])  # by the inverse transpose
        if mesh_arrays.is_inside_out(self.mesh):  # baked from outside, as renders shade it (see _bake)
            normals = -normals
        return normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)

    def mean_edge(self) -> float:
        ends = self.positions[mesh_arrays.attribute(self.mesh, ".edge_verts", np.int32, 2)]
        return float(np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1).mean())

    def vertex_points(self) -> tuple[np.ndarray, np.ndarray]:
        """The vertices (V, 3) and their unit normals (V, 3)."""
        normals = np.empty(len(self.mesh.vertices) * 3, dtype=np.float32)
        self.mesh.vertex_normals.foreach_get("vector", normals)
        return self.positions, self.normals(normals)

    def corner_points(self, smooth: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The distinct (vertex, normal) pairs of the corners, as points (P, 3) and unit normals
        (P, 3), and each corner's pair (C,); ``smooth``: every corner has its vertex's normal."""
        corner_vertex = mesh_arrays.attribute(self.mesh, ".corner_vert", np.int32)
        if smooth:
            return *self.vertex_points(), corner_vertex
        normals = np.empty(len(corner_vertex) * 3, dtype=np.float32)
        self.mesh.corner_normals.foreach_get("vector", normals)
        normals = normals.reshape(-1, 3)
        # a face plane's corners hold its normal to float32 rounding: 2^-16 tells planes apart
        keys = np.column_stack([corner_vertex, np.round(normals * 65536.0).astype(np.int64)])
        _, first, corner_point = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        corner_point = corner_point.ravel()
        inward = self._towards_faces(corner_vertex, corner_point, len(first))
        return self.positions[corner_vertex[first]] + CORNER_INSET * inward, self.normals(normals[first]), corner_point

    def _towards_faces(self, corner_vertex, corner_point, count):
        """(count, 3): from each pair's vertex to the mean of its corners' face centres."""
        corner_face = mesh_arrays.corner_faces(self.mesh)
        corner_position = self.positions[corner_vertex]
        centres = np.zeros((len(self.mesh.polygons), 3))
        np.add.at(centres, corner_face, corner_position)
        centres /= np.bincount(corner_face, minlength=len(centres))[:, None]
        towards = np.zeros((count, 3))
        np.add.at(towards, corner_point, centres[corner_face] - corner_position)
        return towards / np.bincount(corner_point, minlength=count)[:, None]


def _bake_vertices(target, copy, sky):
    """The map at every vertex of ``target`` (V,), baked in ``copy``'s scene (``_bake_points``)."""
    placed = Placed(target.data, np.array(copy.matrix_world, dtype=np.float64))
    return _bake_points(placed, copy, sky, *placed.vertex_points())


def _bake_points(placed, copy, sky, points, normals):
    """The map at ``points`` (P, 3) of the ``placed`` surface, facing unit ``normals`` (P, 3),
    baked in ``copy``'s scene: one texel per point of an image, each on a probe, a tiny triangle
    across the normal (a hundredth of a mean edge across, a hundredth of an edge above the
    surface, so that the mesh does not shade it where its faces meet), whose UVs hold that
    texel's centre alone.

    A point whose normal the sky cannot reach (``Sky.reaches``: a bust's underside under the
    rain) gets no probe: the map is exactly 0 there, as the bake would give it (the diffuse
    surface takes no light from behind)."""
    lit = sky.reaches(normals)
    exposure = np.zeros(len(points), dtype=np.float32)
    if lit.any():
        exposure[lit] = _bake_probes(copy, points[lit], normals[lit], PROBE_SIZE * placed.mean_edge())
    return exposure


def _bake_probes(copy, points, normals, step):
    """The map baked at ``points`` (P, 3) on probes across their unit ``normals``, ``step`` in size
    (``_bake_points``), in ``copy``'s scene."""
    count = len(points)
    u, v = np.moveaxis(lightmap.tangent_bases(normals), 1, 0)
    centre = points + step * normals
    across = 0.75**0.5 * v
    corners = np.stack([centre + step * u, centre - step * (u / 2 - across), centre - step * (u / 2 + across)], axis=1)

    side = int(np.ceil(np.sqrt(count)))
    texel = (np.stack([np.arange(count) % side, np.arange(count) // side], axis=1) + 0.5) / side
    uvs = texel[:, None, :] + np.array([(0.4, 0.0), (-0.2, 0.35), (-0.2, -0.35)]) / side

    with scratch_scene.Ledger() as made:
        probe_mesh = made.add(bpy.data.meshes.new("PW Probes"))
        probe_mesh.vertices.add(3 * count)
        probe_mesh.vertices.foreach_set("co", corners.astype(np.float32).ravel())
        probe_mesh.loops.add(3 * count)
        probe_mesh.loops.foreach_set("vertex_index", np.arange(3 * count, dtype=np.int32))
        probe_mesh.polygons.add(count)
        probe_mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * count, 3, dtype=np.int32))
        probe_mesh.update(calc_edges=True)
        probe_mesh.uv_layers.new(name="Probes").data.foreach_set("uv", uvs.astype(np.float32).ravel())
        probe_mesh.materials.append(copy.active_material)
        probe = made.add(bpy.data.objects.new("PW Probes", probe_mesh))
        image = made.add(bpy.data.images.new("PW Probes", side, side, alpha=False, float_buffer=True))
        copy.users_scene[0].collection.objects.link(probe)
        texture = copy.active_material.node_tree.nodes.new("ShaderNodeTexImage")
        texture.image = image
        copy.active_material.node_tree.nodes.active = texture
        scratch_scene.bake_alone(probe, type="DIFFUSE", pass_filter={"DIRECT"}, margin=0, use_clear=True)
        pixels = np.empty(side * side * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        return pixels[0::4][:count].copy()  # texel (column i % side, row i // side from the bottom)


def _bake(copy, margin):
    # Renders shade an inside-out mesh from outside (a back face turns its normal to the
    # viewer); the bake weighs the light by the stored normal, so it bakes the copy turned right
    # way out, then turns it back, which restores the order of its face corners.
    inside_out = mesh_arrays.is_inside_out(copy.data)
    if inside_out:
        copy.data.flip_normals()
    scratch_scene.bake_alone(
        copy,
        type="DIFFUSE",
        pass_filter={"DIRECT"},
        target="IMAGE_TEXTURES",
        margin=margin,
        margin_type="EXTEND",
        use_clear=True,
        use_selected_to_active=False,
    )
    if inside_out:
        copy.data.flip_normals()


@contextmanager
def _bake_scene(target, occluders, sky, placing):
    """A temporary Cycles scene holding a copy of ``target`` (own mesh, a white diffuse material,
    returned) and copies of ``occluders`` (opaque), all moved and scaled by ``placing``
    (``unit_placing`` of ``target``: 4 x 4), under ``sky``; all removed afterwards. ``target`` is a
    mesh object (its callers check it first, each with its own message)."""
    with scratch_scene.Ledger() as made:
        scene = scratch_scene.temporary_scene(made, f"PW {sky.label} Bake", samples=sky.samples, seed=sky.seed)
        # direct light only (no bounce, transparent or not): the light reaches a point straight from the sky
        scene.cycles.transparent_max_bounces = 0
        scene.world = None
        surface = made.add(compat.new_material(f"PW {sky.label} Surface"))

        copy = scratch_scene.placed_copy(target, scene, surface, own_mesh=True, ledger=made)
        copies = [copy]
        for occluder in occluders:
            if occluder != target:
                copies.append(scratch_scene.placed_copy(occluder, scene, surface, ledger=made))
        for each in copies:
            each.matrix_world = Matrix((placing @ np.array(each.matrix_world, dtype=np.float64)).tolist())
        sky.add(scene, made)
        yield copy


def unit_placing(target: bpy.types.Object) -> np.ndarray:
    """The transform (4 x 4, float64) that centres the bounding box of ``target``'s surface
    (``edges.surface_box``: its faces, not a stray point) on the origin and scales its diagonal
    to 1. The maps depend on directions only, but Cycles offsets its rays by fixed distances:
    the same smooth scan in millimetres and in metres, baked per corner, had 3% of its corners
    more than 1e-3 apart at 16 samples; at one size none (docs/scans.md)."""
    return placing_for(edges.surface_box(target), np.array(target.matrix_world, dtype=np.float64))


def rendered_placing(obj: bpy.types.Object, seen: "scratch_scene.Rendered") -> np.ndarray:
    """``unit_placing`` of ``obj`` read from ``seen``, its rendered mesh the caller holds (the
    object not evaluated once more)."""
    return placing_for(edges.box_of_faces(seen.mesh), np.array(obj.matrix_world, dtype=np.float64))


def placing_for(box: np.ndarray | None, matrix: np.ndarray) -> np.ndarray:
    """``unit_placing`` of an object whose ``edges.surface_box`` is ``box``, placed by ``matrix``
    (4 x 4), for a caller that holds its evaluated mesh (``edges.box_of_faces``)."""
    placing = np.eye(4)
    if box is None:
        return placing
    corners = np.array([[box[i, 0], box[j, 1], box[k, 2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    corners = corners @ matrix[:3, :3].T + matrix[:3, 3]
    low, high = corners.min(axis=0), corners.max(axis=0)
    size = np.linalg.norm(high - low)
    if size > 0:
        placing[:3, :3] /= size
        placing[:3, 3] = -(low + high) / (2 * size)
    return placing
