"""Weathered materials (docs/model.md §4): the porous material plus soiling, wet surfaces,
efflorescence and life on stone, composed from only the modes a material uses, aged by their
clocks (t, and the years of life: docs/model.md §9.4)."""

import math
import os
import warnings
from collections.abc import Sequence

import bpy

import numpy as np

from ..blender import compat
from ..common import imageio
from ..common.imageio import UV_MAP_KEY
from ..contracts import GROUP_NODE, LIGHT_MODE_PROPERTY, MODES_PROPERTY, socket_name
from ..core import environments, model, stones
from ..core import modes as weathering_modes
from ..core.aging import age_for_years, ages_for_years  # noqa: F401  (public: docs/api.md, porous_weathering.weathering)
from ..core.arguments import choice, real_number
from ..core.shader_math import Graph
from . import material, nodes

#: File endings that make a string mask an image path rather than an attribute name.
IMAGE_EXTENSIONS = {".png", ".exr", ".tif", ".tiff", ".jpg", ".jpeg", ".hdr", ".bmp", ".tga", ".webp"}


#: A mask input's value: a number, an Image, an image file path or a colour attribute's name.
MaskValue = float | bpy.types.Image | str | os.PathLike


def make_weathered_material(
    name: str,
    *,
    modes: str | Sequence[str] = (model.SOILING,),
    base_color: material.ColorSource = (0.8, 0.8, 0.8),
    ks: float = 0.1,
    roughness: float = 0.4,
    porosity: float = 0.2,
    pore_depth_ratio: float = 2.0,
    key_light: "bpy.types.Object | str | None" = None,
    water_roughness: float = nodes.WATER_ROUGHNESS,
    environment: str | None = environments.DEFAULT_ENVIRONMENT,
    stone: str | None = None,
    variation: float = stones.DEFAULT_VARIATION,
    masonry: stones.Ashlar | stones.MeshBlocks | None = None,
    **weathering: MaskValue | Sequence[float],
) -> "bpy.types.Material":
    """A new material: the porous BRDF (as make_porous_material) weathered by ``modes``.

    ``modes`` is any of the registered modes (``modes.names()``: "soiling", "wet", ...); the
    material has the nodes of those modes only.  ``weathering`` sets their inputs (``time``, the
    levels, colours, thresholds, and the extensions beyond the paper ``crust`` and ``wet_darkening``,
    whose 0 renders the paper's equations exactly); each mask input (``rain_map``, ``edge_map``, ...:
    the inputs that name a map, docs/api.md) is a number, a
    ``bpy.types.Image``, an image file path (a string ending in an image extension or containing a
    path separator) or the name of a colour attribute.  Out-of-range values are clamped and a
    missing image becomes the mask's default constant, each with a PorousInputWarning; the
    material never renders NaN or the missing-texture pink.  ``water_roughness`` is the water lobe's roughness.
    ``environment`` (a key of ``environments.ENVIRONMENTS``, default "URBAN") sets the site's inputs
    the modes use (deposit and pollution colours, crust, streaks, efflorescence level, life's level
    and lichen density); the inputs given explicitly win; None leaves the API defaults.  ``stone``
    and ``variation`` give the stone's structure as in make_porous_material: through its
    receptivity every front follows it (docs/model.md §8.3), each fill and cover is taken at the
    point's share of the stone (§8.7), the deposit mixes with the stone's colour (§8.6) and the
    run-off gathers into its rivulets (§8.8); ``stone=None`` or ``variation=0`` is the uniform
    material.
    ``masonry`` lays the stone as ashlar with mortar joints, or in the mesh's own blocks, as in
    make_porous_material.
    """
    modes = model.weathering_modes(modes)
    weathering = {**environments.weathering_inputs(environment, modes), **weathering}
    masks = [item.name for item in weathering_modes.inputs().values() if item.mask]
    base_color, values = material.porous_parameters(base_color, ks, roughness, porosity, pore_depth_ratio)
    structure = material.stone_structure(stone, variation, masonry)
    light = material.resolve_key_light(key_light)
    light_mode = material.LIGHT_MODE_OF_TYPE[light.data.type] if light else nodes.AMBIENT
    sources = {mask: mask_source(mask, weathering.pop(mask)) for mask in masks if mask in weathering}
    linked = {mask: source for mask, source in sources.items() if isinstance(source, (bpy.types.Image, str))}
    constants = {
        mask: weathering_modes.inputs()[mask].default if mask in linked else source for mask, source in sources.items()
    }
    state = model.weathering_state(modes, {**weathering, **constants})
    if weathering_modes.has_water_lobe(modes):
        values["Water Roughness"] = float(
            model.sanitize("water_roughness", real_number("water_roughness", water_roughness), 0.0, 1.0)
        )
    new = compat.new_material(name)
    try:
        # the run-off gathers into the stone's rivulets where it has a map (docs/model.md §8.8)
        runoff = "runoff_map" in state and ("runoff_map" in linked or state["runoff_map"] > 0)
        rivulets = structure is not None and runoff
        group = nodes.weathered_group(modes, light_mode, receptive=structure is not None, rivulets=rivulets)
        group_node = material._replace_with_group(new, group)
        graph = Graph(new.node_tree)
        for input_socket, value in values.items():
            group_node.inputs[input_socket].default_value = value
        if nodes.METRES_PER_UNIT in group_node.inputs:  # the point's place is read (docs/model.md §8.8, §9.3)
            material.follow_unit_scale(group_node.inputs[nodes.METRES_PER_UNIT])
        if nodes.RIVULET_SPACING in group_node.inputs:
            group_node.inputs[nodes.RIVULET_SPACING].default_value = structure[0].rivulet_spacing
        for input_name, value in state.items():
            set_input(group_node, input_name, value)
        for mask, source in linked.items():
            if mask in state:
                graph.connect(mask_socket(graph, source), group_node.inputs[socket_name(mask)])
        material._connect_base_color(graph, group_node, base_color)
        if structure:
            material.connect_stone(graph, group_node, stone, *structure, base_color)
        if light:
            material.wire_key_light(graph, group_node, light)
    except Exception:
        bpy.data.materials.remove(new)
        raise
    new[LIGHT_MODE_PROPERTY] = light_mode
    new[MODES_PROPERTY] = ",".join(modes)
    return new


def set_input(group_node: bpy.types.Node, input_name: str, value: float | Sequence[float]) -> None:
    """Set the weathering input ``input_name`` (a model name such as 'time') on a group node."""
    value = np.asarray(value, dtype=np.float64)
    socket = group_node.inputs[socket_name(input_name)]
    socket.default_value = (*value.tolist(), 1.0) if value.ndim else float(value)


def animate_weathering(
    material_: "bpy.types.Material",
    frame_start: int,
    frame_end: int,
    *,
    input_name: str = "time",
    start: float = 0.0,
    end: float = 1.0,
) -> None:
    """Keyframe a weathering input from ``start`` at ``frame_start`` to ``end`` at ``frame_end``.

    The default is the aging animation (time 0 -> 1); ``input_name="wet_level"`` with
    start 1, end 0 dries a wet material.  ValueError for an empty frame range, an unknown input
    or what is not a number, before any keyframe.
    """
    _check_frame_range(frame_start, frame_end)
    item = weathering_modes.inputs()[choice("weathering input", input_name, weathering_modes.inputs())]
    values = [
        float(model.sanitize(input_name, real_number(name, value), item.low, item.high))
        for name, value in (("start", start), ("end", end))
    ]
    _keyframe(material_, input_name, zip((frame_start, frame_end), values))


def _check_frame_range(frame_start, frame_end):
    """ValueError unless the frames are finite numbers and the last comes after the first (an
    animation needs two frames)."""
    first, last = real_number("frame_start", frame_start), real_number("frame_end", frame_end)
    if not (math.isfinite(first) and math.isfinite(last) and last > first):
        raise ValueError(f"frame range {frame_start}-{frame_end}: the last frame must come after the first")


def _keyframe(material_, input_name, frames_and_values):
    socket = material_.node_tree.nodes[GROUP_NODE].inputs[socket_name(input_name)]
    for frame, value in frames_and_values:
        socket.default_value = value
        socket.keyframe_insert("default_value", frame=frame)


#: At most this many keyframes follow the soiling law over a frame range (animate_years).
YEAR_KEYFRAMES = 100


def animate_years(
    material_: "bpy.types.Material",
    frame_start: int,
    frame_end: int,
    years: float,
    elemental_carbon: float,
    *,
    law: str = "sqrt",
) -> None:
    """Keyframe the time so that the frame range spans ``years`` of exposure (0 at ``frame_start``)
    at ``elemental_carbon`` µg/m³: t follows ``age_for_years`` (the square root of the dose by
    default, not a straight line), one keyframe per frame up to YEAR_KEYFRAMES of them; the
    biological clock, if the material has it, the years themselves (``ages_for_years``).
    ValueError for an empty frame range or bad years, concentration or law, before any keyframe."""
    _check_frame_range(frame_start, frame_end)
    age_for_years(years, elemental_carbon, law)  # checks the arguments
    frames = sorted(
        {
            round(frame)
            for frame in np.linspace(frame_start, frame_end, min(int(frame_end - frame_start) + 1, YEAR_KEYFRAMES))
        }
    )
    # every age before the first keyframe; the share of the range first: years x frames overflows
    span = frame_end - frame_start
    ages = [ages_for_years(years * ((frame - frame_start) / span), elemental_carbon, law) for frame in frames]
    group = material_.node_tree.nodes[GROUP_NODE]
    for clock in ages[0]:  # the clocks the material's modes have (docs/model.md §9.4)
        if socket_name(clock) in group.inputs:
            _keyframe(material_, clock, zip(frames, (age[clock] for age in ages)))


def mask_source(mask: str, value: MaskValue) -> float | str | bpy.types.Image:
    """What a mask value means: a float, an Image, or an attribute name (str).

    A path that does not lead to a readable image gives the mask's default constant and a
    warning, so the material renders without the missing-texture pink.
    """
    default = weathering_modes.inputs()[mask].default
    if isinstance(value, str) and not _looks_like_path(value):
        if not any(value in mesh.attributes for mesh in bpy.data.meshes):
            _warn(f"{mask}: no mesh has an attribute {value!r} yet; it reads 0 where missing")
        return value
    if isinstance(value, (str, os.PathLike)):
        path = os.fspath(value)
        if not os.path.isfile(bpy.path.abspath(path)):
            _warn(f"{mask}: image {path!r} not found; using the constant {default}")
            return default
        value = bpy.data.images.load(path, check_existing=True)
    if isinstance(value, bpy.types.Image):
        return _checked_image(mask, value, default)
    return value


def _warn(message):
    warnings.warn(message, model.PorousInputWarning, stacklevel=3)


def _looks_like_path(text):
    return os.sep in text or "/" in text or os.path.splitext(text)[1].lower() in IMAGE_EXTENSIONS


def _checked_image(mask, image, default):
    """``image`` as a mask (non-colour data), or ``default`` with a warning if it has no pixels."""
    if image.size[0] == 0:
        _warn(f"{mask}: image {image.name!r} has no pixels (missing file?); using the constant {default}")
        return default
    if image.source == "FILE" and image.colorspace_settings.name != "Non-Color":
        image.colorspace_settings.name = "Non-Color"  # masks are data; this reloads the file
    pixels = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(pixels)
    if not np.isfinite(pixels).all() or pixels.min() < 0.0 or pixels.max() > 1.0:
        _warn(f"{mask}: image {image.name!r} has values outside [0, 1]; the shader clamps them")
    uv_map = image_uv_map(image)
    if uv_map and not any(uv_map in mesh.uv_layers for mesh in bpy.data.meshes):
        _warn(f"{mask}: image {image.name!r} was baked on the UV map {uv_map!r}, which no mesh has")
    return image


def image_uv_map(image: bpy.types.Image) -> str | None:
    """The UV map an image mask was baked on, or None (then the mesh's active UV map reads it):
    the Image's custom property ``UV_MAP_KEY`` ("pw:uv_map"), else that field of its file's
    header, which the bake writes."""
    name = image.get(UV_MAP_KEY)
    if name is None and image.source == "FILE" and image.filepath:
        name = imageio.read_metadata(bpy.path.abspath(image.filepath, library=image.library)).get(UV_MAP_KEY)
    return name or None


def mask_socket(graph: Graph, source: str | bpy.types.Image) -> bpy.types.NodeSocket:
    """The output socket that reads a mask source (Image or attribute name) in ``graph``.

    An image baked on a UV map of its own (``image_uv_map``, e.g. the bake's lightmap) is read
    through a UV Map node naming it, whatever UV map of the mesh is active."""
    if isinstance(source, bpy.types.Image):
        uv_map = image_uv_map(source)
        coordinates = {"Vector": graph.node("ShaderNodeUVMap", depth=0, uv_map=uv_map).outputs["UV"]} if uv_map else {}
        node = graph.node(
            "ShaderNodeTexImage", coordinates, depth=1, image=source, interpolation="Linear", extension="EXTEND"
        )
        return node.outputs["Color"]
    node = graph.node("ShaderNodeAttribute", depth=1, attribute_name=source)
    return node.outputs["Fac"]
