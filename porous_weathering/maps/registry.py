"""The registry of baked maps: one ``MapKind`` record per map, with its bake functions.

The command line's options, the bake operator's properties, the panel's map list,
``BakeOptions`` and the options forwarded to Dask workers are all generated from these
records and the option fields of their settings dataclasses (``options.py``), so adding a
map is one record and its bake function (docs/architecture.md, "Add a map").
"""

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

from ..blender import mesh_arrays
from ..core import modes as weathering_modes
from . import edges, rain


@dataclass(frozen=True)
class MapKind:
    name: str  #: the --maps word, the <map> of OUT/<object>.<map>.exr, an Outcome's map
    label: str
    description: str  #: the operator's and panel's tooltip
    attribute: str  #: the colour attribute of the attribute target
    settings: type  #: a dataclass whose fields are options (options.option)
    options_field: str  #: the BakeOptions keyword holding the settings, e.g. "rain_settings"
    #: bake_image(obj, uv_map, options, margin) -> float32 (size, size) array, top row first
    bake_image: Callable[..., Any]
    #: bake_attribute(obj, options) writes the map into ``attribute`` of obj's mesh
    bake_attribute: Callable[..., None]
    #: hash_inputs(obj, options, digests) -> dict of what, besides the geometry, the map depends on
    hash_inputs: Callable[..., dict] = lambda obj, options, digests: {}
    #: BakeOptions keywords that set one field of the settings: {"edge_radius": "radius"}
    aliases: dict = field(default_factory=dict)

    @property
    def image_suffix(self) -> str:
        return f".{self.name}.exr"

    @property
    def feeds(self) -> list[str]:
        """The weathering inputs (masks) this map feeds, from the mode registry."""
        return [item.name for item in weathering_modes.inputs().values() if item.map == self.name]


_REGISTRY: dict[str, MapKind] = {}


def register(kind: MapKind) -> None:
    if kind.name in _REGISTRY:
        raise ValueError(f"a map named {kind.name!r} is registered already")
    _REGISTRY[kind.name] = kind


def unregister(name: str) -> None:
    del _REGISTRY[name]


def names() -> tuple[str, ...]:
    return tuple(_REGISTRY)


def get(name: str) -> MapKind:
    return _REGISTRY[name]


def all_kinds() -> tuple[MapKind, ...]:
    return tuple(_REGISTRY.values())


def feeding(input_name: str) -> MapKind | None:
    """The map that feeds the weathering input ``input_name``, if a bake makes one."""
    item = weathering_modes.inputs().get(input_name)
    return _REGISTRY.get(item.map) if item is not None and item.map else None


# --- rain exposure E (SPEC 5) --------------------------------------------------------------------


def _rain_image(obj, uv_map, options, margin):
    occluders = rain.default_occluders(obj, options.occluder_collection())
    return rain.bake_rain_image(obj, uv_map, options.resolution, options.rain_settings, occluders, margin=margin)


def _rain_attribute(obj, options):
    occluders = rain.default_occluders(obj, options.occluder_collection())
    values = rain.bake_rain_corners(obj, options.rain_settings, occluders)
    mesh_arrays.write_corner_attribute(obj.data, rain.RAIN_ATTRIBUTE, values)


def _rain_hash(obj, options, digests):
    occluders = rain.default_occluders(obj, options.occluder_collection())
    return dict(rain=asdict(options.rain_settings), occluders=sorted((o.name, digests(o)) for o in occluders))


RAIN = MapKind(
    name="rain",
    label="Rain Exposure",
    description="Cosine-weighted fraction of the rain cone that reaches the surface",
    attribute=rain.RAIN_ATTRIBUTE,
    settings=rain.RainSettings,
    options_field="rain_settings",
    bake_image=_rain_image,
    bake_attribute=_rain_attribute,
    hash_inputs=_rain_hash,
)


# --- edge/cavity mask C (SPEC 5) -------------------------------------------------------------------


def _edges_image(obj, uv_map, options, margin):
    return edges.edge_mask_image(obj, uv_map, options.resolution, options.edge_settings, margin=margin)


def _edges_attribute(obj, options):
    edges.write_curvature_attribute(obj, settings=options.edge_settings)


def _edges_hash(obj, options, digests):
    settings = options.edge_settings
    radius = edges.effective_radius(obj, settings)
    return dict(edge_radius=radius, cavity_weight=settings.cavity_weight, edge_weight=settings.edge_weight)


EDGES = MapKind(
    name="edges",
    label="Edges",
    description="Edge/cavity mask: the surface's curvature smoothed over a radius relative to the object's size",
    attribute=edges.EDGE_ATTRIBUTE,
    settings=edges.EdgeSettings,
    options_field="edge_settings",
    bake_image=_edges_image,
    bake_attribute=_edges_attribute,
    hash_inputs=_edges_hash,
    aliases={
        "edge_radius": "radius",
        "edge_scale": "scale",
        "cavity_weight": "cavity_weight",
        "edge_weight": "edge_weight",
    },
)


register(RAIN)
register(EDGES)
