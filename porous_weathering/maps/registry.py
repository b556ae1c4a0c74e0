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
from . import damp, edges, efflorescence_map, rain, runoff


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
    #: hash_inputs(obj, options, digests) -> dict merged over the fields of the map's settings in
    #: its input hash (``inputs``): what else it depends on (rain's occluders), or a field's value
    #: as the bake uses it (edges' radius)
    hash_inputs: Callable[..., dict] = lambda obj, options, digests: {}
    #: BakeOptions keywords that set one field of the settings: {"edge_radius": "radius"}
    aliases: dict = field(default_factory=dict)
    #: The maps whose baked result this map's bake reads (the run-off reads the rain): baked
    #: before it in the same bake, or already for the object; their input hashes are in its own.
    reads: tuple[str, ...] = ()

    def inputs(self, obj: Any, options: Any, digests: Callable[[Any], str]) -> dict:
        """What the map's input hash holds besides the geometry and the bake's own options, under
        the map's name: every field of its settings (``options.settings[name]``), so that a change
        of any of them bakes it again, with what ``hash_inputs`` adds or replaces."""
        return {self.name: {**asdict(options.settings[self.name]), **self.hash_inputs(obj, options, digests)}}

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


# --- rain exposure E (docs/model.md §5) --------------------------------------------------------------------


def _occluders(obj, options):
    return rain.default_occluders(obj, options.occluder_collection())


def _rain_image(obj, uv_map, options, margin):
    settings = options.rain_settings
    return rain.bake_rain_image(obj, uv_map, options.resolution, settings, _occluders(obj, options), margin=margin)


def _rain_attribute(obj, options):
    values = rain.bake_rain_corners(obj, options.rain_settings, _occluders(obj, options))
    mesh_arrays.write_corner_attribute(obj.data, rain.RAIN_ATTRIBUTE, values)


def _rain_hash(obj, options, digests):
    return dict(occluders=sorted((o.name, digests(o)) for o in _occluders(obj, options)))


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


# --- edge/cavity mask C (docs/model.md §5) -------------------------------------------------------------------


def _edges_image(obj, uv_map, options, margin):
    return edges.edge_mask_image(obj, uv_map, options.resolution, options.edge_settings, margin=margin)


def _edges_attribute(obj, options):
    edges.write_curvature_attribute(obj, settings=options.edge_settings)


def _edges_hash(obj, options, digests):
    # the radius the mask is smoothed over, given or scale times the object's size: the same
    # radius given either way is the same map
    return dict(radius=edges.effective_radius(obj, options.edge_settings), scale=None)


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


# --- run-off R (docs/model.md §7) ------------------------------------------------------------------


def _runoff_image(obj, uv_map, options, margin):
    return runoff.bake_runoff_image(obj, uv_map, options, margin)


def _runoff_attribute(obj, options):
    mesh_arrays.write_corner_attribute(obj.data, runoff.RUNOFF_ATTRIBUTE, runoff.bake_runoff_corners(obj, options))


def _runoff_hash(obj, options, digests):
    # the drops fall along the rain's mean direction; unset lengths are fractions of the object's size
    size = edges.object_size(obj)
    return dict(lengths=options.runoff_settings.lengths(size), fall=options.rain_settings.towards_rain())


RUNOFF = MapKind(
    name="runoff",
    label="Run-off",
    description="Where the rain that lands runs: R = 1 - exp(-Q / L), Q the water collected along its path",
    attribute=runoff.RUNOFF_ATTRIBUTE,
    settings=runoff.RunoffSettings,
    options_field="runoff_settings",
    bake_image=_runoff_image,
    bake_attribute=_runoff_attribute,
    hash_inputs=_runoff_hash,
    reads=("rain",),
)


# --- rising damp D (docs/model.md §9.2) ------------------------------------------------------------


def _damp_image(obj, uv_map, options, margin):
    return damp.bake_damp_image(obj, uv_map, options.resolution, options.damp_settings, margin)


def _damp_attribute(obj, options):
    mesh_arrays.write_corner_attribute(
        obj.data, damp.DAMP_ATTRIBUTE, damp.bake_damp_corners(obj, options.damp_settings)
    )


def _damp_hash(obj, options, digests):
    # heights and thicknesses are read in metres: the same object at another unit scale is another map
    return dict(metres_per_unit=damp.metres_per_unit(obj))


DAMP = MapKind(
    name="damp",
    label="Rising Damp",
    description="Water drawn up from the ground: 1 below the steady front h = S (b / 2 e θ_w)^1/2, 0 above it",
    attribute=damp.DAMP_ATTRIBUTE,
    settings=damp.DampSettings,
    options_field="damp_settings",
    bake_image=_damp_image,
    bake_attribute=_damp_attribute,
    hash_inputs=_damp_hash,
)


register(RAIN)
register(EDGES)
register(DAMP)
register(RUNOFF)


# --- maps made, not baked: the efflorescence location map (docs/model.md §4) ------------------------------


@dataclass(frozen=True)
class MadeMap:
    """A map the artist makes with an operator of its own rather than bakes: the ``bake``
    command, ``BakeOptions``, Dask and the Bake operator never see it (they list ``all_kinds``);
    the panel offers its Make-map operator, and Make connects it as it connects a baked map."""

    name: str  #: as mode inputs name it (Input.map); the <map> of pw_<map>_image
    label: str
    description: str  #: the Make-map operator's tooltip
    #: make(obj, **params) -> bpy.types.Image: makes obj's map and points obj at it (pw_<map>_image)
    make: Callable[..., Any]

    @property
    def feeds(self) -> list[str]:
        """The weathering inputs (masks) this map feeds, from the mode registry."""
        return [item.name for item in weathering_modes.inputs().values() if item.map == self.name]


_MADE: dict[str, MadeMap] = {}


def register_made(kind: MadeMap) -> None:
    if kind.name in _MADE or kind.name in _REGISTRY:
        raise ValueError(f"a map named {kind.name!r} is registered already")
    _MADE[kind.name] = kind


def made_kinds() -> tuple[MadeMap, ...]:
    """The maps that are made, not baked, in the order registered."""
    return tuple(_MADE.values())


EFFLORESCENCE = MadeMap(
    name=efflorescence_map.MAP_NAME,
    label="Efflorescence",
    description="Efflorescence location map: where salt fills the pores first, from brick joints or a photograph",
    make=efflorescence_map.make_map,
)

register_made(EFFLORESCENCE)
