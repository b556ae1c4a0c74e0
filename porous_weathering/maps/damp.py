"""The rising-damp map D (docs/model.md §9.2; docs/maps.md, "Rising damp"): the water drawn up from
where the object meets the ground, to the steady height its local thickness allows.

Per point: its height above the ground (the lowest surface straight below the object's foot,
through what stands under it: ``ground_below``), and the local thickness of the body, the
distance along the inward normal to the opposite face (a ray cast through the mesh as rendered; a
single sheet, whose ray meets nothing, is ``sheet_thickness`` thick), both in metres through the
scene's unit scale; then D of ``core.rising_damp``. Only points below the highest front any
thickness gives are cast: the others are dry whatever their thickness, so the casts are bounded by
the damp band, not the mesh.
"""

from collections.abc import Sequence
from dataclasses import dataclass

import bpy

import numpy as np
from mathutils.bvhtree import BVHTree

from ..blender import mesh_arrays, scratch_scene
from ..common.options import check, option
from ..contracts import map_attribute
from ..core import rising_damp
from ..shading import material
from . import edges, neighbours
from .registry import MapKind
from .runoff import world_corner_normals

DAMP_ATTRIBUTE = map_attribute("damp")
#: Rays start this far (a fraction of the object's size) inside the surface, so that they leave
#: their own face behind; the distance is added back to the thickness.
RAY_START_FRACTION = 1e-5
#: Corners are read this fraction of the way from their vertex towards their face's centre, inside
#: the face, so that a ray from a corner on the body's edge does not graze the faces beside it.
CORNER_INSET = 1e-3
#: The foot: the object's points within this fraction of its size of its lowest one; the ground is
#: looked for straight below their middle (``ground_below``)...
FOOT_FRACTION = 1e-3
#: ... through at most this many surfaces of each object below it.
GROUND_HITS = 64


@dataclass(frozen=True)
class DampSettings:
    """The stone's sorptivity S and wet water content θ_w, the site's evaporation e and the thickness
    of a single sheet: the steady front h_ss = S (b / (2 e θ_w))^1/2 (docs/model.md §9.2)."""

    sorptivity: float = option(
        rising_damp.DEFAULT_SORPTIVITY,
        label="Sorptivity",
        flag="--sorptivity",
        low=0.0,
        low_open=True,
        finite=True,
        unit="mm/min^1/2",
        metavar="S",
        tooltip="The stone's sorptivity S: how fast it draws water up (about 0.8 for brick and porous limestone)",
    )
    evaporation: float = option(
        rising_damp.DEFAULT_EVAPORATION,
        label="Evaporation",
        flag="--evaporation",
        low=0.0,
        low_open=True,
        finite=True,
        unit="mm/day",
        metavar="E",
        tooltip="The site's evaporation e from the wall's faces (both together), per area of the wall (about 1 "
        "in a British climate; more where it is warm, dry or windy: the damp rises less)",
    )
    wet_water_content: float = option(
        rising_damp.DEFAULT_WET_WATER_CONTENT,
        label="Wet Water Content",
        flag="--wet-water-content",
        low=0.0,
        low_open=True,
        high=1.0,
        metavar="THETA",
        tooltip="The water content θ_w of the stone behind the wet front, a volume fraction (about its porosity)",
    )
    sheet_thickness: float = option(
        rising_damp.DEFAULT_SHEET_THICKNESS,
        label="Sheet Thickness",
        flag="--sheet-thickness",
        low=0.0,
        low_open=True,
        high=rising_damp.MAX_THICKNESS,
        unit="m",
        metavar="B",
        tooltip="The thickness b of a body modelled as a single sheet (a plane for a wall), where no opposite "
        "face is found",
    )

    def __post_init__(self):
        check(self)

    def front(self, thickness):
        """h_ss in metres for ``thickness`` b in metres."""
        return rising_damp.steady_height(
            rising_damp.sorptivity_si(self.sorptivity),
            thickness,
            rising_damp.evaporation_si(self.evaporation),
            self.wet_water_content,
        )


@dataclass(frozen=True)
class _Body:
    """The object as rendered in world space: its triangles' BVH about the centre of its surface,
    ``frame.centre`` (the BVH holds single precision: of the object's size rather than of its
    distance from the world's origin; ``frame`` is also where its texels are baked from,
    ``edges.texel_frame``), its ground (world z) and the metres per scene unit."""

    tree: BVHTree
    ground: float
    metres: float
    start: float  #: how far inside the surface rays start, scene units
    frame: edges.TexelFrame


def _world_triangles(seen) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(positions in the object's space, the same in the world, triangles) of a mesh as rendered."""
    mesh, matrix = seen.mesh, seen.matrix_world
    mesh.calc_loop_triangles()
    triangles = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    positions = mesh_arrays.attribute(mesh, "position", np.float32, 3).astype(np.float64)
    return positions, positions @ matrix[:3, :3].T + matrix[:3, 3], triangles.reshape(-1, 3)


def ground_below(foot: np.ndarray, occluders: Sequence[bpy.types.Object] = ()) -> float:
    """The ground's height (world z) under an object whose lowest points are ``foot`` (n, 3), world:
    the lowest surface of ``occluders`` (as rendered) on the vertical line through the foot's
    middle, from just above the foot down, or the foot's own height where nothing lies below it
    (docs/model.md §9.2). A wall standing on its plinth, a capital on its pilaster, a cornice over
    the wall, all on a ground plane, draw their water from the ground plane, as one body would."""
    lowest = float(foot[:, 2].min())
    middle = foot.mean(axis=0)
    for other in occluders:
        low, high = neighbours.world_box(other)
        if not (low[0] <= middle[0] <= high[0] and low[1] <= middle[1] <= high[1] and low[2] < lowest):
            continue  # the line misses its box, or it lies wholly above the foot
        with scratch_scene.rendered(other) as seen:
            positions, points, triangles = _world_triangles(seen)
            box = edges.box_of_surface(positions, triangles)
            step = RAY_START_FRACTION * max(edges.size_of_box(box, seen.matrix_world), 1e-12)
        if box is None:  # no face to stand on
            continue
        # about the line's top, so that the BVH's single precision is of the objects' sizes
        top = np.array([middle[0], middle[1], max(float(high[2]), lowest)])
        tree = BVHTree.FromPolygons((points - top).tolist(), triangles.tolist(), all_triangles=True)
        start = (lowest - top[2]) + step
        for _ in range(GROUND_HITS):  # every surface the line crosses, down to the last
            hit = tree.ray_cast((0.0, 0.0, start), (0.0, 0.0, -1.0))
            if hit[0] is None:
                break
            lowest = min(lowest, top[2] + hit[0][2])
            start = hit[0][2] - step
    return lowest


def _body(obj, seen, occluders):
    positions, points, triangles = _world_triangles(seen)
    if not len(triangles):
        raise ValueError(f"object '{obj.name}' has no faces to draw damp up")
    box = edges.box_of_surface(positions, triangles)
    frame = edges.texel_frame(box, seen.matrix_world, mesh_arrays.is_inside_out(seen.mesh))
    tree = BVHTree.FromPolygons((points - frame.centre).tolist(), triangles.tolist(), all_triangles=True)
    size = max(edges.size_of_box(box, seen.matrix_world), 1e-12)
    used = points[np.unique(triangles)]  # the points a face uses
    foot = used[used[:, 2] <= used[:, 2].min() + FOOT_FRACTION * size]
    start = RAY_START_FRACTION * size
    return _Body(tree, ground_below(foot, occluders), material.object_metres_per_unit(obj), start, frame)


def damp_at(body: _Body, points: np.ndarray, normals: np.ndarray, settings: DampSettings) -> np.ndarray:
    """D at world ``points`` (n, 3) with outward unit ``normals`` (n, 3) of ``body``."""
    heights = (points[:, 2] - body.ground) * body.metres
    values = np.zeros(len(points))
    highest = float(settings.front(rising_damp.MAX_THICKNESS)) * (1.0 + rising_damp.FRINGE)
    low = np.flatnonzero(heights < highest)
    cast = body.tree.ray_cast
    origins = (points[low] - body.frame.centre - normals[low] * body.start).tolist()
    hits = [cast(origin, inwards) for origin, inwards in zip(origins, (-normals[low]).tolist())]
    reached = np.array([np.nan if hit[0] is None else hit[3] for hit in hits], dtype=np.float64)
    thickness = np.where(np.isnan(reached), settings.sheet_thickness, (reached + body.start) * body.metres)
    thickness = np.minimum(thickness, rising_damp.MAX_THICKNESS)
    values[low] = rising_damp.damp(heights[low], settings.front(thickness))
    return values


def bake_damp_corners(
    obj: bpy.types.Object, settings: DampSettings, occluders: Sequence[bpy.types.Object] = ()
) -> np.ndarray:
    """D at every face corner of ``obj`` (the bake refuses an attribute target whose modifiers change
    the corners, so the mesh as rendered has the mesh's corners): at the corner, a little inside its
    face (``CORNER_INSET``), along the corner's normal; once for the corners of a vertex that share
    its normal (a smooth mesh: once per vertex). The ground is found among ``occluders``
    (``ground_below``)."""
    with scratch_scene.rendered(obj) as seen:
        body = _body(obj, seen, occluders)
        mesh, matrix = seen.mesh, seen.matrix_world
        positions = mesh_arrays.attribute(mesh, "position", np.float32, 3).astype(np.float64)
        vertex_of = mesh_arrays.attribute(mesh, ".corner_vert", np.int32)
        corners = positions[vertex_of]
        centres = np.empty(len(mesh.polygons) * 3, np.float32)
        mesh.polygons.foreach_get("center", centres)
        sizes = np.empty(len(mesh.polygons), np.int32)
        mesh.polygons.foreach_get("loop_total", sizes)
        face_centres = np.repeat(centres.reshape(-1, 3).astype(np.float64), sizes, axis=0)
        normals = world_corner_normals(seen, inside_out=body.frame.outward < 0)
    keys = np.ascontiguousarray(np.column_stack([vertex_of, normals]).astype(np.float64))
    _, first, shared = np.unique(keys.view(np.dtype((np.void, 32))).ravel(), return_index=True, return_inverse=True)
    inside = corners[first] + CORNER_INSET * (face_centres[first] - corners[first])
    points = inside @ matrix[:3, :3].T + matrix[:3, 3]
    return damp_at(body, points, normals[first], settings)[shared.ravel()]


def bake_damp_image(
    obj: bpy.types.Object,
    uv_map: str,
    resolution: int,
    settings: DampSettings,
    margin: int,
    occluders: Sequence[bpy.types.Object] = (),
):
    """D on ``uv_map`` at ``resolution``, texel by texel (its centre's position and normal as the render
    sees them), the ``margin`` grown from the islands; the ground found among ``occluders``."""
    with scratch_scene.rendered(obj) as seen:
        body = _body(obj, seen, occluders)
    positions, normals, islands = edges.bake_texel_geometry(obj, uv_map, resolution, frame=body.frame)
    found = edges.unit(normals[islands].astype(np.float64))
    values = np.zeros((resolution, resolution), np.float32)
    values[islands] = damp_at(body, positions[islands].astype(np.float64), found, settings)
    return edges.with_margin(values, islands, margin)


# --- the record (docs/architecture.md, "Add a map") ------------------------------------------------


def _image(obj, uv_map, options, margin):
    occluders = neighbours.options_occluders(obj, options)
    return bake_damp_image(obj, uv_map, options.resolution, options.damp_settings, margin, occluders)


def _attribute(obj, options):
    values = bake_damp_corners(obj, options.damp_settings, neighbours.options_occluders(obj, options))
    mesh_arrays.write_corner_attribute(obj.data, DAMP_ATTRIBUTE, values)


def _hash(obj, options, digests):
    # heights and thicknesses are read in metres: the same object at another unit scale is another map;
    # the ground is what stands below it: moving what it stands on moves its front
    return dict(
        metres_per_unit=material.object_metres_per_unit(obj),
        occluders=neighbours.occluders_digest(obj, options, digests),
    )


MAP = MapKind(
    name="damp",
    label="Rising Damp",
    description="Water drawn up from the ground: 1 below the steady front h = S (b / 2 e θ_w)^1/2, 0 above it",
    attribute=DAMP_ATTRIBUTE,
    settings=DampSettings,
    options_field="damp_settings",
    bake_image=_image,
    bake_attribute=_attribute,
    hash_inputs=_hash,
    order=50,
)
