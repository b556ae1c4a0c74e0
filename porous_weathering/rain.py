"""Rain exposure E (SPEC 5), baked with Cycles.

E(p) = ∫_cone V(p, ω) max(0, N·ω) dω / ∫_cone (D·ω) dω : the cosine-weighted fraction of the
rain cone (half-angle ``cone`` around the mean direction D towards the rain) that reaches p
unoccluded, so that an open face turned to the rain gets exactly 1.

Cycles' DIFFUSE bake with only the direct pass returns irradiance / π. A sky of radiance L
inside the cone gives an open face turned to D the irradiance L·π·sin²(cone), so the sky is
set to L = 1 / sin²(cone); a sun lamp of angular diameter 2·cone is the same uniform cone
(radiance strength / (π sin² cone)) and takes strength π. The sun lamp is the default: it
is sampled only inside the cone (see docs/maps.md for the measurement).

The bake runs in a temporary scene on copies of the objects (the target's mesh copied, the
occluders' meshes shared), all with plain opaque materials, so the user's scene, materials,
meshes and selection are never touched and nothing is left behind, even on failure.
"""

import math
from contextlib import contextmanager
from dataclasses import dataclass

import bpy

import numpy as np

from . import compat, mesh_arrays, scratch_scene
from .options import check, option
from .scratch_scene import aim_sun
from .shader_math import Graph, dot

#: The colour attribute a rain bake writes (per face corner).
RAIN_ATTRIBUTE = "pw_rain"
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
        whole=True,
        metavar="N",
        tooltip="Rain samples per texel or corner (docs/maps.md)",
    )
    seed: int = option(0, label="Seed", whole=True, ui=False, tooltip="Cycles seed of the rain bake")
    sky: str = option(
        "sun",
        label="Sky",
        choices=("sun", "world"),
        ui=False,
        tooltip="The rain cone as a sun lamp or a world texture (docs/maps.md)",
    )

    def __post_init__(self):
        check(self)

    def towards_rain(self):
        """Unit vector D from a surface towards where the rain comes from (+Z without wind)."""
        tilt, azimuth = math.radians(self.wind_tilt), math.radians(self.wind_azimuth)
        return (math.sin(tilt) * math.cos(azimuth), math.sin(tilt) * math.sin(azimuth), math.cos(tilt))


def default_occluders(target, collection=None):
    """The objects that can shelter ``target``: every renderable geometry object of its scenes,
    or only those of ``collection`` (a bpy Collection, children included)."""
    if collection is not None:
        candidates = collection.all_objects
    else:
        candidates = {o for scene in target.users_scene for o in scene.objects}
    geometry = scratch_scene.GEOMETRY_TYPES
    return [o for o in candidates if o.type in geometry and not o.hide_render and o != target]


def bake_rain_image(obj, uv_map, size, settings=RainSettings(), occluders=(), margin=4):
    """E on ``obj``'s UV map ``uv_map`` as a float32 (size, size) array, top row first.

    ``margin`` texels around every UV island are filled from the island's edge (Blender's
    bake margin, EXTEND), so that filtering and mip-mapping never pull in empty texels.
    """
    if obj.type != "MESH" or uv_map not in obj.data.uv_layers:
        raise ValueError(f"object '{obj.name}' has no UV map '{uv_map}'")
    image = bpy.data.images.new("PW Rain Bake", size, size, alpha=False, float_buffer=True)
    try:
        with _bake_scene(obj, occluders, settings) as copy:
            copy.data.uv_layers.active = copy.data.uv_layers[uv_map]
            texture = copy.active_material.node_tree.nodes.new("ShaderNodeTexImage")
            texture.image = image
            copy.active_material.node_tree.nodes.active = texture
            _bake(copy, target="IMAGE_TEXTURES", margin=margin)
        pixels = np.empty(size * size * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(size, size, 4)[::-1, :, 0].copy()  # Blender stores the bottom row first
    finally:
        bpy.data.images.remove(image)


def bake_rain_corners(obj, settings=RainSettings(), occluders=()):
    """E at every face corner of ``obj``'s mesh, as a float32 array (len(mesh.loops),)."""
    with _bake_scene(obj, occluders, settings) as copy:
        attribute = copy.data.color_attributes.new(RAIN_ATTRIBUTE, "FLOAT_COLOR", "CORNER")
        copy.data.color_attributes.active_color = attribute
        _bake(copy, target="VERTEX_COLORS", margin=0)
        colours = np.empty(len(attribute.data) * 4, dtype=np.float32)
        attribute.data.foreach_get("color", colours)
    return colours[0::4].copy()


def _bake(copy, target, margin):
    # Renders shade an inside-out mesh from outside (a back face turns its normal to the
    # viewer); the bake weighs rain by the stored normal, so it bakes the copy turned right
    # way out, then turns it back, which restores the order of its face corners.
    inside_out = mesh_arrays.is_inside_out(copy.data)
    if inside_out:
        copy.data.flip_normals()
    with bpy.context.temp_override(**scratch_scene.only_selected(copy)):
        bpy.ops.object.bake(
            type="DIFFUSE",
            pass_filter={"DIRECT"},
            target=target,
            margin=margin,
            margin_type="EXTEND",
            use_clear=True,
            use_selected_to_active=False,
        )
    if inside_out:
        copy.data.flip_normals()


@contextmanager
def _bake_scene(target, occluders, settings):
    """A temporary Cycles scene holding a copy of ``target`` (own mesh, a white diffuse material,
    returned) and copies of ``occluders`` (opaque), under the rain sky; all removed afterwards."""
    if target.type != "MESH":
        raise ValueError(f"{target.name}: a rain bake needs a mesh object, not {target.type.lower()}")
    scene = bpy.data.scenes.new("PW Rain Bake")
    made = {"objects": [], "meshes": [], "materials": [], "lights": [], "worlds": []}
    try:
        _configure_cycles(scene, settings)
        surface = compat.new_material("PW Rain Surface")
        made["materials"].append(surface)

        copy = scratch_scene.placed_copy(target, scene, surface, own_mesh=True)
        made["objects"].append(copy)
        made["meshes"].append(copy.data)
        for occluder in occluders:
            if occluder != target:
                made["objects"].append(scratch_scene.placed_copy(occluder, scene, surface))
        _add_sky(scene, settings, made)
        yield copy
    finally:
        for kind in ("objects", "meshes", "lights", "materials", "worlds"):
            collection = getattr(bpy.data, kind)
            for block in made[kind]:
                collection.remove(block)
        bpy.data.scenes.remove(scene)


def _configure_cycles(scene, settings):
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = settings.samples
    cycles.seed = settings.seed
    cycles.use_denoising = False
    cycles.use_adaptive_sampling = False
    cycles.max_bounces = 0  # direct light only: the rain reaches a point straight from the sky
    cycles.transparent_max_bounces = 0
    scene.world = None


def _add_sky(scene, settings, made):
    cone = math.radians(settings.cone)
    towards = settings.towards_rain()
    if settings.sky == "sun":
        light = bpy.data.lights.new("PW Rain", "SUN")
        made["lights"].append(light)
        light.energy = math.pi
        light.angle = 2.0 * cone
        sun = bpy.data.objects.new("PW Rain", light)
        made["objects"].append(sun)
        scene.collection.objects.link(sun)
        aim_sun(sun, towards)
        return
    world = bpy.data.worlds.new("PW Rain")
    made["worlds"].append(world)
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
