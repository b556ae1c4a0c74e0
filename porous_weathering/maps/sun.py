"""Sun exposure S (docs/model.md §9.1), baked with Cycles.

S(p) = Σ_i w_i V(p, s_i) max(0, N·s_i): the year's clear-sky direct beam on p, shadowed by the
object and its occluders, over that on a surface always facing the sun; s_i are the sun's
positions over the year at the site's latitude and w_i their share of the year's beam
(``core.solar.year``, weights summing to 1).

Baked as a direct-light bake (``sky_bake``: irradiance / π) under a world whose environment image
holds the year's sun path: each position's w_i falls in its pixel of an equirectangular image
(nearest-pixel lookup, so the radiance is constant over each pixel), as radiance π w_i / Ω, Ω the
pixel's solid angle; ∫ L max(0, N·ω) V dω / π is then S, within the pixel's size (a few tenths
of a degree). Cycles draws the world's directions from the image's own importance map, so the
samples go where the sun was (docs/maps.md, "Sun exposure", for the noise measured).

The site: ``latitude`` and ``north_angle`` of the settings where given; else the scene's Sun
Position add-on's (``scene.sun_pos_properties``: latitude in degrees, north offset in radians,
absent without the add-on), else ``DEFAULT_LATITUDE`` and north along +Y.
"""

import math
from collections.abc import Sequence
from dataclasses import dataclass

import bpy

import numpy as np

from ..blender import compat, mesh_arrays
from ..common.options import check, option
from ..contracts import map_attribute
from ..core import solar
from . import sky_bake
from .registry import MapKind

#: The colour attribute a sun bake writes (per face corner).
SUN_ATTRIBUTE = map_attribute("sun")
#: The latitude where neither the settings nor the scene give one: 50° N, the site of
#: docs/model.md §9.1's figures (northern France, southern England, the Rhineland).
DEFAULT_LATITUDE = 50.0
#: Samples per texel: the rain's count, at about twice its error (docs/maps.md, "Sun exposure").
DEFAULT_SAMPLES = 64
#: Width of the sky image (its height is half): pixels of 0.35°.
SKY_WIDTH = 1024


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
        high=sky_bake.MAX_SAMPLES,
        whole=True,
        metavar="N",
        estimate=True,
        tooltip="Sun samples per texel or corner (docs/maps.md)",
    )
    seed: int = option(0, label="Sun Seed", whole=True, ui=False, estimate=True, tooltip="Cycles seed of the sun bake")

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


def sky_radiance(directions: np.ndarray, weights: np.ndarray, width: int = SKY_WIDTH) -> np.ndarray:
    """The (width / 2, width) radiance image, bottom row first (Blender's order), of suns
    ``weights`` (N,) at unit ``directions`` (N, 3) in Cycles' equirectangular mapping
    (u = 1/2 − atan2(y, x) / 2π, v = 1 − θ / π, θ from +Z): each pixel holds π Σ w / Ω, Ω its
    solid angle, so that the direct DIFFUSE bake (irradiance / π) of a plane returns
    Σ w max(0, N·s) over the suns it sees."""
    height = width // 2
    u = 0.5 - np.arctan2(directions[:, 1], directions[:, 0]) / (2.0 * np.pi)
    v = 1.0 - np.arccos(np.clip(directions[:, 2], -1.0, 1.0)) / np.pi
    column = np.minimum((u * width).astype(np.int64), width - 1)
    row = np.minimum((v * height).astype(np.int64), height - 1)
    energy = np.bincount(row * width + column, weights=weights, minlength=width * height).reshape(height, width)
    edges = np.cos(np.pi * (1.0 - np.arange(height + 1) / height))  # cos θ at each row's lower and upper edge
    solid_angle = (2.0 * np.pi / width) * np.diff(edges)
    return np.pi * energy / solid_angle[:, None]


def sky(settings: SunSettings, latitude: float, north_angle: float) -> sky_bake.Sky:
    """The year's sun at the site as the light of a direct-light bake (``sky_bake``)."""
    directions, weights = solar.year(latitude)
    radiance = sky_radiance(solar.scene_directions(directions, north_angle), weights)
    return sky_bake.Sky(
        label="Sun",
        samples=settings.samples,
        seed=settings.seed,
        add=lambda scene, made: _add_sky(scene, radiance, made),
        # the sun stands somewhere above nearly every plane over a year: no surface is left out
        reaches=lambda normals: np.ones(len(normals), dtype=bool),
    )


def bake_sun_image(
    obj: bpy.types.Object,
    uv_map: str,
    size: int,
    settings: SunSettings = SunSettings(),
    occluders: Sequence[bpy.types.Object] = (),
    margin: int = 4,
) -> np.ndarray:
    """S on ``obj``'s UV map ``uv_map`` as a float32 (size, size) array, top row first
    (``sky_bake.bake_image``: ``margin`` texels filled around every island, a scan drawn through
    its vertices), at the site ``site(settings, scene_of(obj))``."""
    return sky_bake.bake_image(obj, uv_map, size, sky(settings, *site(settings, scene_of(obj))), occluders, margin)


def bake_sun_corners(
    obj: bpy.types.Object, settings: SunSettings = SunSettings(), occluders: Sequence[bpy.types.Object] = ()
) -> np.ndarray:
    """S at every face corner of ``obj``'s mesh, as a float32 array (len(mesh.loops),)
    (``sky_bake.bake_corners``), at the site ``site(settings, scene_of(obj))``."""
    return sky_bake.bake_corners(obj, sky(settings, *site(settings, scene_of(obj))), occluders)


def _add_sky(scene, radiance, made):
    height, width = radiance.shape
    image = made.add(bpy.data.images.new("PW Sun Sky", width, height, alpha=False, float_buffer=True))
    pixels = np.ones((height, width, 4), dtype=np.float32)
    pixels[..., :3] = radiance[..., None]
    image.pixels.foreach_set(pixels.ravel())
    world = made.add(bpy.data.worlds.new("PW Sun"))
    compat.use_world_nodes(world)
    tree = world.node_tree
    tree.nodes.clear()
    texture = tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = image
    texture.interpolation = "Closest"  # the radiance constant over each pixel, as sky_radiance has it
    background = tree.nodes.new("ShaderNodeBackground")
    tree.links.new(texture.outputs["Color"], background.inputs["Color"])
    output = tree.nodes.new("ShaderNodeOutputWorld")
    tree.links.new(background.outputs[0], output.inputs["Surface"])
    world.cycles.sampling_method = "MANUAL"
    world.cycles.sample_map_resolution = width  # the importance map at the image's own pixels
    scene.world = world


# --- the record (docs/architecture.md, "Add a map") ---------------------------------------------------------


def _sun_image(obj, uv_map, options, margin):
    occluders = sky_bake.options_occluders(obj, options)
    return bake_sun_image(obj, uv_map, options.resolution, options.sun_settings, occluders, margin=margin)


def _sun_attribute(obj, options):
    values = bake_sun_corners(obj, options.sun_settings, sky_bake.options_occluders(obj, options))
    mesh_arrays.write_corner_attribute(obj.data, SUN_ATTRIBUTE, values)


def _sun_hash(obj, options, digests):
    # the occluders, and the site as the bake takes it: unset, the scene's Sun Position (a change of it bakes again)
    latitude, north_angle = site(options.sun_settings, scene_of(obj))
    occluders = sky_bake.occluders_digest(obj, options, digests)
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
