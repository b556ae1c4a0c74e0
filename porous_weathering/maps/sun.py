"""Sun exposure S (docs/model.md §9.1), baked by casting shadow rays.

S(p) = Σ_i w_i V(p, s_i) max(0, N·s_i): the year's clear-sky direct beam on p, shadowed by the
object and its occluders, over that on a surface always facing the sun; s_i are the sun's
positions over the year at the site's latitude and w_i their share of the year's beam
(``core.solar.year``, weights summing to 1).

Estimated at each point as the open plane's S₀(N) = Σ_i w_i max(0, N·s_i) (``solar.open_plane_exposures``)
less what shadows take of it, the mean of max(0, N·s) (1 − V) over ``samples`` suns drawn with
probability w (``solar.lattice_draws``: Roberts' lattice over the days and the hours, shifted at
random, so the estimate is unbiased and its draws spread over the year), V from a ray
towards each drawn sun in front of the surface (``shadow_rays``) through the object and its
occluders as the render sees them. A point nothing shadows gets S₀(N) exactly, with no noise; the
noise is where shadows fall. The points are the rain bake's (``sky_bake.Placed``: corners,
vertices of a scan) or the texels' centres (docs/maps.md, "Sun exposure", for the noise and the
time against the rain bake).

The site: ``latitude`` and ``north_angle`` of the settings where given; else the scene's Sun
Position add-on's (``scene.sun_pos_properties``: latitude in degrees, north offset in radians,
absent without the add-on), else ``DEFAULT_LATITUDE`` and north along +Y.
"""

import math
from collections.abc import Sequence
from dataclasses import dataclass

import bpy

import numpy as np

from ..blender import mesh_arrays, scratch_scene
from ..common.options import check, option
from ..contracts import map_attribute
from ..core import solar
from . import edges, neighbours, shadow_rays, sky_bake
from .registry import MapKind

#: The colour attribute a sun bake writes (per face corner).
SUN_ATTRIBUTE = map_attribute("sun")
#: The latitude where neither the settings nor the scene give one: 50° N, the site of
#: docs/model.md §9.1's figures (northern France, southern England, the Rhineland).
DEFAULT_LATITUDE = 50.0
#: Suns drawn per texel or corner (docs/maps.md, "Sun exposure").
DEFAULT_SAMPLES = 64
#: The most suns a point draws.
MAX_SAMPLES = 1 << 16
#: Draws held in memory at once (a direction and a cosine each), the points they are for with them.
DRAWS_AT_ONCE = 1 << 20
#: Draws made for a bake: shifts of the lattice the points share (``_Suns.exposure``).
DRAWS_DRAWN = 1 << 18


def north_angle_option(unset: str):
    """The ``--north-angle`` option, declared once for the commands that take it (the sun bake,
    the survey); ``unset``: what it means when not given."""
    return option(
        None,
        label="North Angle",
        flag="--north-angle",
        finite=True,
        auto=0.0,
        unit="degrees",
        metavar="DEG",
        tooltip=f"Angle from +Y to north, clockwise seen from above (0: +Y is north); {unset}",
    )


@dataclass(frozen=True)
class SunSettings:
    """The site: its latitude (degrees, south negative) and where its north lies (degrees
    clockwise from +Y seen from above); None: from the scene (see the module's docstring)."""

    latitude: float | None = option(
        None,
        label="Latitude",
        flag="--latitude",
        low=-90.0,
        high=90.0,
        auto=0.0,
        unit="degrees",
        metavar="DEG",
        tooltip="Latitude of the site, south negative; unset (0 in the bake dialog): the scene's Sun Position "
        f"latitude, else {DEFAULT_LATITUDE:g}",
    )
    north_angle: float | None = north_angle_option(
        "unset (0 in the bake dialog): the scene's Sun Position north offset, else 0"
    )
    samples: int = option(
        DEFAULT_SAMPLES,
        label="Sun Samples",
        flag="--sun-samples",
        low=1,
        high=MAX_SAMPLES,
        whole=True,
        metavar="N",
        estimate=True,
        tooltip="Suns drawn per texel or corner (docs/maps.md)",
    )
    seed: int = option(0, label="Sun Seed", whole=True, ui=False, estimate=True, tooltip="Seed of the sun bake's draws")

    def __post_init__(self):
        check(self)


def site(settings: SunSettings, scene: bpy.types.Scene | None) -> tuple[float, float]:
    """(latitude, north angle) in degrees, as the bake takes them: each from ``settings`` where
    given, else from ``scene``'s Sun Position add-on where it has one, else ``DEFAULT_LATITUDE``
    and 0."""
    sun_position = getattr(scene, "sun_pos_properties", None)
    latitude, north_angle = DEFAULT_LATITUDE, 0.0
    if sun_position is not None:
        latitude, north_angle = float(sun_position.latitude), math.degrees(sun_position.north_offset)
    if settings.latitude is not None:
        latitude = float(settings.latitude)
    if settings.north_angle is not None:
        north_angle = float(settings.north_angle)
    return latitude, north_angle


def scene_of(obj: bpy.types.Object) -> bpy.types.Scene:
    """The scene whose site ``obj`` is baked at: its first scene, else the context's."""
    return obj.users_scene[0] if obj.users_scene else bpy.context.scene


def bake_sun_image(
    obj: bpy.types.Object,
    uv_map: str,
    size: int,
    settings: SunSettings = SunSettings(),
    occluders: Sequence[bpy.types.Object] = (),
    margin: int = 4,
) -> np.ndarray:
    """S on ``obj``'s UV map ``uv_map`` as a float32 (size, size) array, top row first, at the
    site ``site(settings, scene_of(obj))``: at every texel's centre (its position and normal as
    the render sees them), ``margin`` texels grown around every island; a scan whose image is
    hardly finer than its mesh (``sky_bake.bakes_at_vertices``) at its vertices, drawn across its
    triangles."""
    if obj.type != "MESH" or uv_map not in obj.data.uv_layers:
        raise ValueError(f"object '{obj.name}' has no UV map '{uv_map}'")
    suns = _Suns.at(settings, scene_of(obj))
    at_vertices = sky_bake.bakes_at_vertices(obj, size)
    with scratch_scene.rendered(obj) as seen:
        box = edges.box_of_faces(seen.mesh)
        placing = sky_bake.placing_for(box, np.array(obj.matrix_world, dtype=np.float64))
        placed = sky_bake.Placed(seen.mesh, placing @ seen.matrix_world)
        shadows = _occluders(seen, occluders, placing)
        lift = sky_bake.PROBE_SIZE * placed.mean_edge()
        if at_vertices:
            values = suns.exposure(shadows, *placed.vertex_points(), lift)
        else:
            frame = edges.texel_frame(box, seen.matrix_world, mesh_arrays.is_inside_out(seen.mesh))
    if at_vertices:
        return scratch_scene.bake_point_values(obj, uv_map, size, values, margin=margin)[0]
    positions, normals, islands = edges.bake_texel_geometry(obj, uv_map, size, frame=frame)
    points = positions[islands] @ placing[:3, :3].T + placing[:3, 3]  # placing: a scale and a shift
    image = np.zeros((size, size), np.float32)
    image[islands] = suns.exposure(shadows, points, edges.unit(normals[islands].astype(np.float64)), lift)
    return edges.with_margin(image, islands, margin)


def bake_sun_corners(
    obj: bpy.types.Object, settings: SunSettings = SunSettings(), occluders: Sequence[bpy.types.Object] = ()
) -> np.ndarray:
    """S at every face corner of ``obj``'s mesh, as a float32 array (len(mesh.loops),), at the
    site ``site(settings, scene_of(obj))``: once per vertex and normal its corners share, at the
    rain bake's points (``sky_bake.Placed.corner_points``)."""
    suns = _Suns.at(settings, scene_of(obj))
    with scratch_scene.rendered(obj) as seen:
        scratch_scene.check_corners_kept(obj, seen)
        placing = sky_bake.rendered_placing(obj, seen)
        placed = sky_bake.Placed(seen.mesh, placing @ seen.matrix_world)
        points, normals, corner_point = placed.corner_points(smooth=sky_bake.smooth_at_vertices(obj))
        shadows = _occluders(seen, occluders, placing)
        lift = sky_bake.PROBE_SIZE * placed.mean_edge()
    return suns.exposure(shadows, points, normals, lift)[corner_point]


def _occluders(seen, occluders, placing):
    """``shadow_rays.Occluders`` of everything that casts shadows: the target as ``seen`` and each
    of ``occluders`` as rendered, placed by ``placing`` (4 x 4)."""
    parts = [_placed_triangles(seen, placing)]
    for occluder in occluders:
        with scratch_scene.rendered(occluder) as shown:
            parts.append(_placed_triangles(shown, placing))
    offsets = np.cumsum([0] + [len(vertices) for vertices, _ in parts[:-1]])
    vertices = np.concatenate([vertices for vertices, _ in parts])
    return shadow_rays.Occluders(
        vertices, np.concatenate([faces + offset for (_, faces), offset in zip(parts, offsets)])
    )


def _placed_triangles(shown, placing):
    """(vertices (V, 3), triangles (T, 3)) of ``shown`` (``scratch_scene.Rendered``) placed by ``placing``."""
    mesh = shown.mesh
    mesh.calc_loop_triangles()
    triangles = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    matrix = placing @ shown.matrix_world
    vertices = mesh_arrays.attribute(mesh, "position", np.float32, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    return vertices, triangles.reshape(-1, 3)


@dataclass(frozen=True)
class _Suns:
    """The year's suns at a site, in the scene's frame (``solar.year_by_day``), and the draws a
    bake takes of them: ``samples`` per point, shifted by a generator seeded with ``seed``."""

    directions: np.ndarray
    weights: np.ndarray
    days: np.ndarray
    samples: int
    seed: int

    @classmethod
    def at(cls, settings: SunSettings, scene: bpy.types.Scene) -> "_Suns":
        latitude, north_angle = site(settings, scene)
        directions, weights, days = solar.year_by_day(latitude)
        return cls(solar.scene_directions(directions, north_angle), weights, days, settings.samples, settings.seed)

    def exposure(
        self, shadows: shadow_rays.Occluders, points: np.ndarray, normals: np.ndarray, lift: float
    ) -> np.ndarray:
        """S at ``points`` (P, 3) facing unit ``normals`` (P, 3), float32: S₀(N) less the mean of
        max(0, N·s) over the point's draws s whose ray, from ``lift`` above the point, meets
        ``shadows``; rays are cast only towards suns in front of the surface. The estimate is
        held to [0, 1] (where shadows fall, a few draws can take more than S₀ would lose).

        The draws are made once for up to ``DRAWS_DRAWN // samples`` random shifts of the lattice,
        and each point takes one of them at random: each point's estimate is as unbiased and as
        spread over the year as with a shift of its own, at a gather's cost."""
        open_plane = solar.open_plane_exposures(normals, self.directions, self.weights, self.days)
        generator = np.random.default_rng(self.seed)
        shifts = generator.random((max(1, min(len(points), DRAWS_DRAWN // self.samples)), 2))
        drawn = self.directions[solar.lattice_draws(self.weights, self.days, shifts, self.samples)].astype(np.float32)
        shift_of = generator.integers(len(shifts), size=len(points))
        origins = (points + lift * normals).astype(np.float32)
        normals = normals.astype(np.float32)
        shaded = np.zeros(len(points))
        at_once = max(1, DRAWS_AT_ONCE // self.samples)
        for start in range(0, len(points), at_once):
            chunk = slice(start, start + at_once)
            suns = drawn[shift_of[chunk]]
            cosines = np.einsum("pkj,pj->pk", suns, normals[chunk])
            point, draw = np.nonzero(cosines > 0.0)
            blocked = shadows.blocked(origins[chunk][point], suns[point, draw])
            lost = cosines[point[blocked], draw[blocked]]
            shaded[chunk] = np.bincount(point[blocked], weights=lost, minlength=len(cosines)) / self.samples
        return np.clip(open_plane - shaded, 0.0, 1.0).astype(np.float32)


# --- the record (docs/architecture.md, "Add a map") ---------------------------------------------------------


def _sun_image(obj, uv_map, options, margin):
    occluders = neighbours.options_occluders(obj, options)
    return bake_sun_image(obj, uv_map, options.resolution, options.sun_settings, occluders, margin=margin)


def _sun_attribute(obj, options):
    values = bake_sun_corners(obj, options.sun_settings, neighbours.options_occluders(obj, options))
    mesh_arrays.write_corner_attribute(obj.data, SUN_ATTRIBUTE, values)


def _sun_hash(obj, options, digests):
    # the occluders, and the site as the bake takes it: unset, the scene's Sun Position (a change of it bakes again)
    latitude, north_angle = site(options.sun_settings, scene_of(obj))
    occluders = neighbours.occluders_digest(obj, options, digests)
    return dict(occluders=occluders, latitude=latitude, north_angle=north_angle)


MAP = MapKind(
    name="sun",
    label="Sun Exposure",
    description="The year's direct sun on the surface, shadowed, over that on a surface always facing the sun",
    attribute=SUN_ATTRIBUTE,
    settings=SunSettings,
    options_field="sun_settings",
    bake_image=_sun_image,
    bake_attribute=_sun_attribute,
    hash_inputs=_sun_hash,
    order=40,
)
