"""Rain exposure E (docs/model.md §5), baked with Cycles.

E(p) = ∫_cone V(p, ω) max(0, N·ω) dω / ∫_cone (D·ω) dω : the cosine-weighted fraction of the
rain cone (half-angle ``cone`` around the mean direction D towards the rain) that reaches p
unoccluded, so that an open face turned to the rain gets exactly 1.

Baked as a direct-light bake (``sky_bake``: irradiance / π, shadowed by the object and its
occluders). A sky of radiance L inside the cone gives an open face turned to D the irradiance
L·π·sin²(cone), so the sky is set to L = 1 / sin²(cone); a sun lamp of angular diameter 2·cone
is the same uniform cone (radiance strength / (π sin² cone)) and takes strength π. The sun lamp
is the default: it is sampled only inside the cone (see docs/maps.md for the measurement).
"""

import math
from collections.abc import Sequence
from dataclasses import dataclass

import bpy

import numpy as np

from ..blender import compat, mesh_arrays
from ..blender.scratch_scene import aim_sun
from ..common.options import check, option
from ..contracts import map_attribute
from ..core.shader_math import Graph, dot
from . import neighbours, sky_bake
from .registry import MapKind

#: The colour attribute a rain bake writes (per face corner).
RAIN_ATTRIBUTE = map_attribute("rain")
#: Samples per texel: see benchmarks/bench_rain.py and docs/maps.md.
DEFAULT_SAMPLES = 64


@dataclass(frozen=True)
class RainSettings:
    """The rain: a cone of half-angle ``cone`` (degrees) around the mean direction, which leans
    ``wind_tilt`` degrees from the vertical towards azimuth ``wind_azimuth`` (degrees from +X
    towards +Y: the side the rain is driven from, i.e. the windward side)."""

    cone: float = option(
        15.0,
        label="Rain Cone",
        flag="--rain-cone",
        low=0.0,
        high=89.0,
        low_open=True,
        unit="degrees",
        metavar="DEG",
        tooltip="Half-angle of the cone of rain directions",
    )
    wind_azimuth: float = option(
        0.0,
        label="Wind Azimuth",
        flag="--wind-azimuth",
        finite=True,
        unit="degrees",
        metavar="DEG",
        tooltip="Side the rain is driven from, measured from +X towards +Y",
    )
    wind_tilt: float = option(
        0.0,
        label="Wind Tilt",
        flag="--wind-tilt",
        low=0.0,
        high=90.0,
        unit="degrees",
        metavar="DEG",
        tooltip="Lean of the mean rain direction from the vertical (0: vertical rain)",
    )
    samples: int = option(
        DEFAULT_SAMPLES,
        label="Samples",
        flag="--samples",
        low=1,
        high=sky_bake.MAX_SAMPLES,
        whole=True,
        metavar="N",
        estimate=True,
        tooltip="Rain samples per texel or corner (docs/maps.md)",
    )
    seed: int = option(0, label="Seed", whole=True, ui=False, estimate=True, tooltip="Cycles seed of the rain bake")
    sky: str = option(
        "sun",
        label="Sky",
        choices=("sun", "world"),
        ui=False,
        estimate=True,
        tooltip="The rain cone as a sun lamp or a world texture (docs/maps.md)",
    )

    def __post_init__(self):
        check(self)

    def towards_rain(self):
        """Unit vector D from a surface towards where the rain comes from (+Z without wind)."""
        tilt, azimuth = math.radians(self.wind_tilt), math.radians(self.wind_azimuth)
        return (math.sin(tilt) * math.cos(azimuth), math.sin(tilt) * math.sin(azimuth), math.cos(tilt))


def sky(settings: RainSettings) -> sky_bake.Sky:
    """The rain as the light of a direct-light bake (``sky_bake``): a surface whose normal is
    more than 90° plus the cone's half-angle from the cone's axis (a bust's underside) takes none."""
    towards = np.array(settings.towards_rain())
    edge = -math.sin(math.radians(settings.cone)) - 1e-6
    return sky_bake.Sky(
        label="Rain",
        samples=settings.samples,
        seed=settings.seed,
        add=lambda scene, made: _add_sky(scene, settings, made),
        reaches=lambda normals: normals @ towards > edge,
    )


def bake_rain_image(
    obj: bpy.types.Object,
    uv_map: str,
    size: int,
    settings: RainSettings = RainSettings(),
    occluders: Sequence[bpy.types.Object] = (),
    margin: int = 4,
) -> np.ndarray:
    """E on ``obj``'s UV map ``uv_map`` as a float32 (size, size) array, top row first
    (``sky_bake.bake_image``: ``margin`` texels filled around every island, a scan drawn through
    its vertices)."""
    return sky_bake.bake_image(obj, uv_map, size, sky(settings), occluders, margin)


def bake_rain_corners(
    obj: bpy.types.Object, settings: RainSettings = RainSettings(), occluders: Sequence[bpy.types.Object] = ()
) -> np.ndarray:
    """E at every face corner of ``obj``'s mesh, as a float32 array (len(mesh.loops),)
    (``sky_bake.bake_corners``: a mesh smooth at its vertices baked once per vertex)."""
    return sky_bake.bake_corners(obj, sky(settings), occluders)


def _add_sky(scene, settings, made):
    cone = math.radians(settings.cone)
    towards = settings.towards_rain()
    if settings.sky == "sun":
        light = made.add(bpy.data.lights.new("PW Rain", "SUN"))
        light.energy = math.pi
        light.angle = 2.0 * cone
        sun = made.add(bpy.data.objects.new("PW Rain", light))
        scene.collection.objects.link(sun)
        aim_sun(sun, towards)
        return
    world = made.add(bpy.data.worlds.new("PW Rain"))
    compat.use_world_nodes(world)
    tree = world.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    direction = graph.wrap(graph.node("ShaderNodeTexCoord").outputs["Generated"])
    inside = graph.math("GREATER_THAN", dot(direction, towards), math.cos(cone))
    background = graph.node("ShaderNodeBackground", {"Color": 1.0, "Strength": inside / math.sin(cone) ** 2})
    graph.node("ShaderNodeOutputWorld", {"Surface": background.outputs[0]})
    world.cycles.sampling_method = "MANUAL"
    world.cycles.sample_map_resolution = 2048  # the cone is small: the importance map must resolve it
    scene.world = world


# --- the record (docs/architecture.md, "Add a map") ---------------------------------------------------------


def _rain_image(obj, uv_map, options, margin):
    occluders = neighbours.options_occluders(obj, options)
    return bake_rain_image(obj, uv_map, options.resolution, options.rain_settings, occluders, margin=margin)


def _rain_attribute(obj, options):
    values = bake_rain_corners(obj, options.rain_settings, neighbours.options_occluders(obj, options))
    mesh_arrays.write_corner_attribute(obj.data, RAIN_ATTRIBUTE, values)


def _rain_hash(obj, options, digests):
    return dict(occluders=neighbours.occluders_digest(obj, options, digests))


MAP = MapKind(
    name="rain",
    label="Rain Exposure",
    description="Cosine-weighted fraction of the rain cone that reaches the surface",
    attribute=RAIN_ATTRIBUTE,
    settings=RainSettings,
    options_field="rain_settings",
    bake_image=_rain_image,
    bake_attribute=_rain_attribute,
    hash_inputs=_rain_hash,
    order=10,
)
