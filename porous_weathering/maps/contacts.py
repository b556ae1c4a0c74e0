"""Where parts meet (docs/maps.md, "Where parts meet"; docs/model.md §5): the corner between
two objects (a wall's recessed mortar and its bricks, a statue on its plinth), or between two
loose parts of one (a façade's sills on its wall), has no mesh edge, so the edge mask's curvature
(``curvature.mesh_surface``) does not see it. ``with_contacts`` adds it: at each sample of the
surface within a smoothing radius of another part, the curvature of the parts' union there, from
how much of the sample's ball the other parts fill (``curvature.contact_curvature``); the samples
another part covers are dropped, as no one sees them.

Which part a point lies in is read with rays (``shadow_rays``): the part whose face the ray from
it leaves through first (a back face). Of an open mesh (a ground plane), what lies behind its
faces counts as inside.
"""

from dataclasses import dataclass

import bpy

import numpy as np

from ..blender import mesh_arrays
from .curvature import BALL_POINTS, BALL_SETS, Samples, ball_points, contact_curvature, unit
from .lightmap import Geometry
from .shadow_rays import Occluders

#: How far off its face a sample's rays start, in smoothing radii: clear of the face in single
#: precision, well below anything the radius resolves.
LIFT = 1e-3
#: Points over each sample's area at which ``with_contacts`` asks whether another part covers
#: it: an even spread over the unit disc (Vogel's spiral).
COVER_POINTS = 16
COVER_DISC = np.stack(
    [
        np.sqrt((np.arange(COVER_POINTS) + 0.5) / COVER_POINTS)
        * np.cos(np.arange(COVER_POINTS) * np.pi * (3 - np.sqrt(5))),
        np.sqrt((np.arange(COVER_POINTS) + 0.5) / COVER_POINTS)
        * np.sin(np.arange(COVER_POINTS) * np.pi * (3 - np.sqrt(5))),
    ],
    axis=1,
)
#: Samples whose balls are asked about at once (a bounded number of rays in memory).
BALLS_AT_ONCE = 1 << 14


@dataclass(frozen=True)
class Triangles:
    """One mesh's triangles in world space: its ``points`` (V, 3), each triangle's ``corners``
    (T, 3) into them, turned to face out of the object as renders shade it, its loose ``part``
    (T,), numbered from 0, and each vertex's (V,), -1 for a vertex of no part."""

    points: np.ndarray
    corners: np.ndarray
    part: np.ndarray
    vertex_part: np.ndarray
    closed: bool  #: every edge between two faces or on a seam (no open border: a ground plane has one)

    @classmethod
    def of(cls, mesh: bpy.types.Mesh, matrix_world: np.ndarray, places: np.ndarray, islands: np.ndarray) -> "Triangles":
        """The triangles of ``mesh`` placed by ``matrix_world``, each face's loose part
        ``islands`` (``mesh_arrays.face_islands`` joined at the borders that lie on each other,
        ``places``: ``mesh_arrays.border_places``; the caller has read both)."""
        geometry = Geometry.of(mesh)
        matrix_world = np.asarray(matrix_world, dtype=np.float64)
        points = geometry.positions.astype(np.float64) @ matrix_world[:3, :3].T + matrix_world[:3, 3]
        outward = not mesh_arrays.winding_reversed(matrix_world, mesh_arrays.is_inside_out(mesh))
        corners = geometry.vertices if outward else geometry.vertices[:, ::-1]
        part = islands[geometry.polygons]
        repeated = repeats_another_part(points, corners, part)
        corners, part = corners[~repeated], part[~repeated]
        # A part that encloses negative volume about its own centre is the inner wall of a hollow
        # in the part around it (a vessel's inside, a box with walls), not a solid of its own:
        # left out, so that the solid is the part around it.
        centres = np.zeros((int(part.max(initial=-1)) + 1, 3))
        np.add.at(centres, part, points[corners].mean(axis=1))
        centres /= np.maximum(np.bincount(part, minlength=len(centres)), 1)[:, None]
        a, b, c = (points[corners[:, k]] - centres[part] for k in range(3))
        volume = np.bincount(part, np.einsum("ij,ij->i", a, np.cross(b, c)), minlength=len(centres))
        solid = volume[part] >= 0.0
        kept = np.unique(part[solid], return_inverse=True)[1].astype(np.int64).reshape(-1)
        vertex_part = np.full(len(points), -1, dtype=np.int64)
        vertex_part[corners[solid]] = kept[:, None]
        uses = mesh_arrays.edge_uses(mesh)  # closed: each edge between two faces, or a seam's
        closed = bool(np.all((uses == 2) | ((uses == 1) & ~mesh_arrays.open_edges(mesh, places))))
        return cls(points, corners[solid], kept, vertex_part, closed)


def repeats_another_part(points: np.ndarray, corners: np.ndarray, part: np.ndarray) -> np.ndarray:
    """(T,) whether each triangle repeats, corner for corner, one of a part numbered lower: the
    geometry duplicated in place (Shift+D in Edit Mode, cancelled; a mesh joined with its copy).
    The union of a part and its copy is the part, but which of two coincident faces a ray leaves
    through first is chance, so half of the part's inside would read as its copy's: a copy's
    faces are left out."""
    place = mesh_arrays.row_groups(points)[1]
    faces = mesh_arrays.row_groups(np.sort(place[corners], axis=1))[1]
    lowest = np.full(faces.max(initial=-1) + 1, np.iinfo(np.int64).max)
    np.minimum.at(lowest, faces, part)
    return part > lowest[faces]


@dataclass(frozen=True)
class Parts:
    """The loose parts of some meshes, ready for rays: their triangles about ``origin`` (in
    single precision, which the points asked about share), each triangle's part and unit normal
    out of it, and each part's box (low, high) in world space."""

    rays: Occluders
    origin: np.ndarray  #: (3,)
    part: np.ndarray  #: (T,)
    normals: np.ndarray  #: (T, 3)
    boxes: np.ndarray  #: (parts, 2, 3)
    closed: bool  #: every mesh closed (else a ray that meets nothing is cast the other way too)

    @classmethod
    def of(cls, meshes: list[Triangles], origin: np.ndarray) -> "Parts | None":
        """The parts of ``meshes``, each loose part of each its own, about ``origin`` (the
        world point the rays' single precision is centred on); None for no triangle."""
        meshes = [mesh for mesh in meshes if len(mesh.corners)]
        if not meshes:
            return None
        offsets = np.cumsum([0] + [len(mesh.points) for mesh in meshes])
        first_parts = np.cumsum([0] + [int(mesh.part.max()) + 1 for mesh in meshes])
        points = np.concatenate([mesh.points for mesh in meshes])
        corners = np.concatenate([mesh.corners + offset for mesh, offset in zip(meshes, offsets)])
        part = np.concatenate([mesh.part + first for mesh, first in zip(meshes, first_parts)])
        corner_points = points[corners]
        normals = unit(np.cross(corner_points[:, 1] - corner_points[:, 0], corner_points[:, 2] - corner_points[:, 0]))
        low = np.full((first_parts[-1], 3), np.inf)
        high = np.full((first_parts[-1], 3), -np.inf)
        np.minimum.at(low, part, corner_points.min(axis=1))
        np.maximum.at(high, part, corner_points.max(axis=1))
        rays = Occluders(points - origin, corners)
        closed = all(mesh.closed for mesh in meshes)
        return cls(rays, origin, part, normals.astype(np.float32), np.stack([low, high], axis=1), closed)

    def inside(self, points: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(N,) the part each of ``points`` (float32, about ``origin``) lies inside, -1 for none:
        the part whose face the ray towards its unit direction (float32) leaves through first.
        Among open meshes (a ground plane) a ray that meets nothing is cast the other way, so
        that all that lies behind an open part's faces is inside it, whichever way a ray goes."""
        triangle = self.rays.first_hits(points, directions)
        towards = directions
        if not self.closed:
            missed = np.flatnonzero(triangle < 0)
            towards = directions.copy()
            towards[missed] *= -1.0
            triangle[missed] = self.rays.first_hits(points[missed], towards[missed])
        hit = np.maximum(triangle, 0)
        leaving = (triangle >= 0) & (np.einsum("ij,ij->i", self.normals[hit], towards) > 0.0)
        return np.where(leaving, self.part[hit], -1)


def near_another(points: np.ndarray, part: np.ndarray, own: Parts, beside: Parts | None, radius: float) -> np.ndarray:
    """(N,) whether each of ``points``, on the part ``part`` of ``own`` (-1: none), lies within
    ``radius`` of another part's box, own or ``beside``. Each box asks only the points in its
    slab along X (the points sorted once), so that a scan's thousands of loose crumbs cost
    their slabs, not every point times every box."""
    boxes = own.boxes if beside is None else np.concatenate([own.boxes, beside.boxes])
    low, high = boxes[:, 0] - radius, boxes[:, 1] + radius
    near = np.zeros(len(points), dtype=bool)
    order = np.argsort(points[:, 0], kind="stable")
    along = points[order, 0]
    starts, ends = np.searchsorted(along, low[:, 0], side="left"), np.searchsorted(along, high[:, 0], side="right")
    for box in range(len(boxes)):
        held = order[starts[box] : ends[box]]
        held = held[~near[held] & (part[held] >= 0) & (part[held] != box)]  # own boxes are numbered as own parts
        across = points[held, 1:]
        near[held[np.all((across >= low[box, 1:]) & (across <= high[box, 1:]), axis=1)]] = True
    return near


def with_contacts(
    sources: Samples, mesh: Triangles, own: Parts, beside: Parts | None, radius: float, seed: int = 0
) -> Samples:
    """``sources`` (an object's samples of curvature and area, ``curvature.Surface.sources``, of
    its ``mesh``) with the corners where its loose parts (``own``: ``Parts.of([mesh])``) meet
    each other or the parts of the objects ``beside`` it (about the same origin): each sample
    within ``radius`` of another part's box carries, over its area, ``contact_curvature`` of the
    share of the ball about its open area that the other parts fill (and its own does not); what
    another part covers of a sample's area (``COVER_DISC``) carries nothing. Sources near no
    other part are returned as they are (an object of one part alone: all of them)."""
    sample_part = mesh.vertex_part[sources.vertex]
    near = near_another(sources.points, sample_part, own, beside, radius)
    near &= np.linalg.norm(sources.normals, axis=1) > 0.5  # a sample without a normal faces nowhere
    chosen = np.flatnonzero(near)
    if not len(chosen):
        return sources
    part, normals, area = sample_part[chosen], sources.normals[chosen], sources.area[chosen]
    points = (sources.points[chosen] - own.origin).astype(np.float32)

    def filled_by_others(at, ask, towards):
        """(len(at), k) whether each sample's points ``ask`` (its k of them, about the origin)
        lie in another part than its own: another of ``own``'s, or one of ``beside``'s."""
        shape = ask.shape[:2]
        ask, towards = ask.reshape(-1, 3), np.ascontiguousarray(np.broadcast_to(towards, ask.shape).reshape(-1, 3))
        in_own = own.inside(ask, towards).reshape(shape)
        filled = (in_own >= 0) & (in_own != part[at, None])
        if beside is not None:
            rest = np.flatnonzero((in_own < 0).ravel())
            filled.ravel()[rest] = beside.inside(ask[rest], towards[rest]) >= 0
        return filled

    # what of each sample's area the other parts cover: points over a disc of its area in its
    # plane, just off its face (a vertex on the line where a part meets it is half covered)
    tangent = unit(np.cross(normals, np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])))
    across = np.cross(normals, tangent)
    disc = np.sqrt(area / np.pi)[:, None, None] * (
        COVER_DISC[None, :, :1] * tangent[:, None, :] + COVER_DISC[None, :, 1:] * across[:, None, :]
    )
    on_face = points[:, None, :] + disc.astype(np.float32)
    lifted = on_face + (LIFT * radius * normals[:, None, :]).astype(np.float32)
    # off the normal by a little, so that no ray runs along an axis-aligned mesh's edges
    up = unit(normals + 0.1 * (0.6 * tangent + 0.8 * across)).astype(np.float32)[:, None, :]
    covered = filled_by_others(np.arange(len(chosen)), lifted, up) | (part < 0)[:, None]
    open_share = 1.0 - covered.mean(axis=1)
    # the ball about what is left open of each sample's area
    seen = np.flatnonzero((open_share > 0.0) & (area > 0.0))  # a sample of no area adds nothing
    centres = np.where(covered[seen, :, None], 0.0, on_face[seen]).sum(axis=1)
    centres /= (COVER_POINTS - covered[seen].sum(axis=1))[:, None]
    balls = radius * ball_points(BALL_SETS, seed).astype(np.float32)
    towards = unit(np.random.default_rng(seed).normal(size=(BALL_SETS * BALL_POINTS, 3))).astype(np.float32)
    towards = towards.reshape(BALL_SETS, BALL_POINTS, 3)
    filled = np.zeros(len(seen))
    for block in range(0, len(seen), BALLS_AT_ONCE):  # a bounded number of rays at once
        at = seen[block : block + BALLS_AT_ONCE]
        turn = chosen[at] % BALL_SETS  # each sample its set, whichever others are asked
        reach = centres[block : block + len(at), None, :].astype(np.float32) + balls[turn]
        filled[block : block + len(at)] = filled_by_others(at, reach, towards[turn]).mean(axis=1)
    added = np.zeros(len(chosen))
    added[seen] = contact_curvature(filled, radius) * area[seen]
    curvature, areas = sources.curvature.copy(), sources.area.copy()
    curvature[chosen] = (curvature[chosen] + added) * open_share
    areas[chosen] = area * open_share
    return Samples(sources.points, sources.normals, curvature, areas, sources.vertex)
