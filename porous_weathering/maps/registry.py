"""The registry of maps: one ``MapKind`` record per baked map and one ``MadeMap`` per map the
artist makes, each the ``MAP`` of its own module of the ``maps`` package.

The registry finds the records itself (``discover``): it imports every module of the package
and keeps each module's ``MAP``, in the order of their ``order`` field, then their name. So
adding a map is one module with its bake functions and its record, and no list to edit
(docs/architecture.md, "Add a map"). The command line's options, the bake operator's
properties, the panel's map list, ``BakeOptions`` and the options forwarded to Dask workers
are all generated from these records and the option fields of their settings dataclasses
(``common/options.py``). This module imports no map module by name: the maps import it.
"""

import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

from ..core import modes as weathering_modes

#: The ``order`` of a record that gives none: after the shipped maps, by name.
LAST = 1000


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
    #: Where the map comes in the registry's lists (the panel, ``--maps``, the bake): rain 10,
    #: edges 20, runoff 30; a new map takes the next free ten
    order: int = LAST

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


# --- maps made, not baked (the efflorescence location map, docs/model.md §4.3) -----------------------------


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
    #: Where the map comes among the made maps (efflorescence 10)
    order: int = LAST

    @property
    def feeds(self) -> list[str]:
        """The weathering inputs (masks) this map feeds, from the mode registry."""
        return [item.name for item in weathering_modes.inputs().values() if item.map == self.name]


_DISCOVERED: dict[str, MapKind | MadeMap] | None = None  #: the modules' records, once found
_MODULES: tuple[str, ...] = ()  #: the modules of the maps package that hold them
_REGISTERED: dict[str, MapKind | MadeMap] = {}  #: the records given to ``register``
_DISCOVERING = False


def discover() -> None:
    """Find the records again: the ``MAP`` of every module of the ``maps`` package (its
    ``__path__``). Done on first use; again only after a module was added to the package's path."""
    global _DISCOVERED, _DISCOVERING, _MODULES
    _DISCOVERED, _DISCOVERING = None, True
    found, modules = {}, []
    try:
        for module in pkgutil.iter_modules(importlib.import_module(__package__).__path__):
            record = getattr(importlib.import_module(f"{__package__}.{module.name}"), "MAP", None)
            if isinstance(record, MapKind | MadeMap):
                if record.name in found or record.name in _REGISTERED:
                    raise ValueError(f"two maps are named {record.name!r}")
                found[record.name] = record
                modules.append(module.name)
    finally:
        _DISCOVERING = False
    _DISCOVERED, _MODULES = found, tuple(modules)


def _records() -> dict[str, MapKind | MadeMap]:
    if _DISCOVERING:  # else a module's import would see only the records found before it
        raise RuntimeError("a module of the maps package reads the map registry while it is imported")
    if _DISCOVERED is None:
        discover()
    return {**_DISCOVERED, **_REGISTERED}


def _ordered(kind: type) -> tuple:
    return tuple(sorted((r for r in _records().values() if isinstance(r, kind)), key=lambda r: (r.order, r.name)))


def register(kind: MapKind | MadeMap) -> None:
    """Add a record from outside the package (a map's module in the package needs no call)."""
    if kind.name in _records():
        raise ValueError(f"a map named {kind.name!r} is registered already")
    _REGISTERED[kind.name] = kind


#: A map made, not baked, is registered the same way.
register_made = register


def unregister(name: str) -> None:
    del _REGISTERED[name]


def modules() -> tuple[str, ...]:
    """The modules of the maps package that hold a map's record (``"rain"``, ``"sun"``, ...): the
    package serves each at its top, ``porous_weathering.sun`` with its settings, as it serves the
    documented modules (docs/api.md)."""
    _records()
    return _MODULES


def names() -> tuple[str, ...]:
    """The baked maps, in their order."""
    return tuple(kind.name for kind in all_kinds())


def get(name: str) -> MapKind:
    kind = _records()[name]
    if not isinstance(kind, MapKind):
        raise KeyError(name)
    return kind


def all_kinds() -> tuple[MapKind, ...]:
    """The baked maps, in their order."""
    return _ordered(MapKind)


def made_kinds() -> tuple[MadeMap, ...]:
    """The maps that are made, not baked, in their order."""
    return _ordered(MadeMap)


def feeding(input_name: str) -> MapKind | None:
    """The map that feeds the weathering input ``input_name``, if a bake makes one."""
    item = weathering_modes.inputs().get(input_name)
    kind = _records().get(item.map) if item is not None and item.map else None
    return kind if isinstance(kind, MapKind) else None
