"""An object's maps and the material wired to them: finding the maps made for an object (an
Image named in its ``pw_<map>_image`` property, ``contracts.map_image_property``, or a baked
colour attribute), the maps some weathering modes still lack, and the weathered material whose
mask inputs read them (each map connected to the inputs it feeds, ``Input.map``). The panel's
Make button is a thin wrapper over ``weathered_material_for``.

May import: bpy, ``core``, ``common``, ``blender``, ``shading``, ``maps.registry`` and ``maps.scan_checks``.
"""

import json
import warnings
from collections.abc import Iterable, Mapping
from typing import Any

import bpy

from ..common import imageio
from ..contracts import map_image_property
from ..core import environments, model, stones
from ..core import modes as weathering_modes
from ..shading import material, presets, weathering
from . import registry, scan_checks

#: The base colour of a material made from the object's own material when it has no image.
DEFAULT_BASE_COLOR = (0.8, 0.8, 0.8)


def known_maps() -> tuple[registry.MapKind | registry.MadeMap, ...]:
    """Every map an object may have: the baked ones (``registry.all_kinds``), then the ones
    made, not baked (``registry.made_kinds``)."""
    return (*registry.all_kinds(), *registry.made_kinds())


def discover_maps(obj: "bpy.types.Object") -> dict[str, "bpy.types.Image | str"]:
    """{map name: source} of the maps made for ``obj``: an Image (named in its ``pw_<map>_image``
    property) or, for a baked map, the name of the colour attribute it was baked into."""
    found = {}
    for kind in known_maps():
        image = bpy.data.images.get(obj.get(map_image_property(kind.name), ""))
        attribute = getattr(kind, "attribute", None)
        if image is not None:
            found[kind.name] = image
        elif obj.type == "MESH" and attribute and attribute in obj.data.attributes:
            found[kind.name] = attribute
    return found


def recorded_settings(obj: "bpy.types.Object", map_name: str) -> dict[str, Any] | None:
    """The settings ``obj``'s map ``map_name`` was baked with, as its map records them (the EXR
    header of its image, or its attribute's mesh property; ``bake``'s ``SETTINGS_KEY``), or
    None when the object has no such map or it records none."""
    source = discover_maps(obj).get(map_name)
    if isinstance(source, bpy.types.Image):
        text = imageio.read_metadata(bpy.path.abspath(source.filepath)).get(imageio.SETTINGS_KEY)
    elif isinstance(source, str):
        text = obj.data.get(f"{source}_settings")
    else:
        return None
    return json.loads(text) if isinstance(text, str) else None


def _source(item, have):
    """The map of ``have`` that feeds the mask ``item``: its own, else its fallback's, else None."""
    return have.get(item.map) or have.get(item.fallback_map)


def missing_maps(obj: "bpy.types.Object", modes: Iterable[str]) -> list[str]:
    """The maps that ``modes`` read and ``obj`` lacks (with no fallback map in their place), sorted."""
    have = discover_maps(obj)
    return sorted({item.map for item in weathering_modes.inputs_of(modes) if item.map and not _source(item, have)})


def map_inputs(obj: "bpy.types.Object", modes: Iterable[str]) -> dict[str, "bpy.types.Image | str"]:
    """{weathering input: source} of ``obj``'s maps, for each mask input ``modes`` read: its own
    map, or where ``obj`` has none its fallback map (``Input.fallback_map``)."""
    have = discover_maps(obj)
    found = {item.name: _source(item, have) for item in weathering_modes.inputs_of(modes) if item.map}
    return {name: source for name, source in found.items() if source is not None}


def follow_fallback(obj: "bpy.types.Object", map_name: str) -> str:
    """Let the masks ``map_name`` feeds read their fallback map on ``obj`` (``Input.fallback_map``:
    the efflorescence's is the run-off, the absorbed water): forget the map made for ``obj`` (its
    ``pw_<map>_image`` property; the file and the Image stay). Returns the fallback's name;
    ValueError, nothing changed, when ``obj`` has no fallback map baked."""
    fallbacks = sorted(
        {item.fallback_map for item in weathering_modes.inputs().values() if item.map == map_name and item.fallback_map}
    )
    have = discover_maps(obj)
    found = [name for name in fallbacks if name in have]
    if not found:
        wanted = " or ".join(fallbacks) or "other"
        raise ValueError(f"has no {wanted} map to take the place of its {map_name} map: bake it first")
    obj.pop(map_image_property(map_name), None)
    return found[0]


def scan_colours(obj: "bpy.types.Object") -> "material.ColorAttribute | None":
    """The colour attribute holding ``obj``'s own colours (a scan's vertex colours, as a PLY or OBJ
    import makes them): its render colour attribute, else its first, leaving out the maps baked
    into colour attributes; None for an object without one."""
    if obj.type != "MESH":
        return None
    baked = {kind.attribute for kind in registry.all_kinds()}
    found = [attribute.name for attribute in obj.data.color_attributes if attribute.name not in baked]
    render = obj.data.color_attributes.render_color_index
    chosen = obj.data.color_attributes[render].name if 0 <= render < len(obj.data.color_attributes) else None
    name = chosen if chosen in found else next(iter(found), None)
    return material.ColorAttribute(name) if name else None


def weathered_material_for(
    obj: "bpy.types.Object",
    modes: tuple[str, ...],
    *,
    preset: str | None,
    key_light: "bpy.types.Object | None" = None,
    values: Mapping[str, Any] | None = None,
    environment: str | None = environments.DEFAULT_ENVIRONMENT,
    stone: Mapping[str, Any] | None = None,
    variation: float = stones.DEFAULT_VARIATION,
    masonry: "stones.Ashlar | stones.MeshBlocks | None" = None,
) -> "bpy.types.Material":
    """A new material for ``obj``: porous, weathered by ``modes`` (none: porous only) with the
    weathering input ``values``, every mask input read from the map of ``obj`` that feeds it
    (``map_inputs``), lit by ``key_light``. From the stone ``preset`` (a key of
    ``presets.PRESETS``), or, with None, from ``obj``'s own material: its base colour and
    roughness images are kept, or its vertex colours (the colour attribute its material's base
    colour reads, else ``scan_colours``). ``environment`` sets the site's inputs ``values`` leave out;
    ``stone`` replaces material keywords (a measured ``base_color``: ``presets.from_colorimetry``).
    A preset's material has its stone's structure at ``variation`` (docs/model.md §8), laid in
    ``masonry`` if not None (§8.5; ignored without a preset: masonry lays a stone); an object
    whose size is implausible at the scene's unit scale gets a PorousInputWarning saying how to
    set the unit (§8.4). ValueError on a bad input (see ``make_weathered_material``)."""
    if preset is None:
        textures = material.principled_textures(obj.active_material)
        params = {"base_color": textures.get("Base Color") or scan_colours(obj) or DEFAULT_BASE_COLOR}
        name = f"{obj.active_material.name if obj.active_material else obj.name} Porous"
    else:
        chosen = presets.PRESETS[preset]
        textures = {}
        params = {**chosen.material_params(), "stone": preset, "variation": variation, "masonry": masonry}
        name = f"{obj.name} {chosen.label}"
    params.update(stone or {})
    if modes:
        new = weathering.make_weathered_material(
            name,
            modes=modes,
            key_light=key_light,
            environment=environment,
            **params,
            **dict(values or {}),
            **map_inputs(obj, modes),
        )
    else:
        new = material.make_porous_material(name, key_light=key_light, **params)
    if "Roughness" in textures:
        material.connect_roughness_image(new, textures["Roughness"])
    problem = scan_checks.unit_problem(obj)
    if problem:
        warnings.warn(problem, model.PorousInputWarning, stacklevel=2)
    return new
