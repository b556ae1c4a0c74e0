"""The registry of weathering modes: one module per mode, each holding one ``Mode`` record, its
``MODE``.

The registry finds the records itself (``discover``, on import): it imports every module of
this package and keeps each one's ``MODE``, in the order of their ``order`` field, then their
name. Everything that lists modes or their inputs (the model, the node groups, the panel, the
asset library, the docs' tables) reads this registry, so adding a mode is one new module and
no list to edit (docs/architecture.md, "Add a mode").
"""

import importlib
import pkgutil
from collections.abc import Iterable, Mapping
from typing import Any

from .. import porous
from . import base
from .base import WATER_ROUGHNESS, Input, Layer, Mode, Point

__all__ = [
    "Input",
    "Layer",
    "Mode",
    "Point",
    "discover",
    "register",
    "unregister",
    "names",
    "get",
    "checked",
    "inputs",
    "inputs_of",
    "shader_inputs",
    "has_water_lobe",
    "weathered_weights",
    "weathered_point",
    "patterns",
]

_REGISTRY: dict[str, Mode] = {}  #: every mode, in order: those found, then those registered
_FOUND: dict[str, Mode] = {}  #: the ``MODE`` of each module of this package
_REGISTERED: dict[str, Mode] = {}  #: the modes given to ``register``


def _update(found: Mapping[str, Mode], registered: Mapping[str, Mode]) -> None:
    """Make the registry of ``found`` and ``registered``: names unique, and each input the same
    in every mode that declares it."""
    found, registered = dict(found), dict(registered)  # either may be _FOUND or _REGISTERED, cleared below
    for name in set(found) & set(registered):
        raise ValueError(f"a weathering mode named {name!r} is registered already")
    modes = sorted([*found.values(), *registered.values()], key=lambda mode: (mode.order, mode.name))
    known: dict[str, Input] = {}
    for mode in modes:
        for item in mode.inputs:
            if known.setdefault(item.name, item) != item:
                raise ValueError(f"mode {mode.name!r}: input {item.name!r} differs from the one other modes declare")
    _FOUND.clear()
    _FOUND.update(found)
    _REGISTERED.clear()
    _REGISTERED.update(registered)
    _REGISTRY.clear()
    _REGISTRY.update((mode.name, mode) for mode in modes)


def discover() -> None:
    """Find the modes again: the ``MODE`` of every module of this package (its ``__path__``).
    Done on import; again only after a module was added to the package's path."""
    found = {}
    for module in pkgutil.iter_modules(__path__):
        record = getattr(importlib.import_module(f"{__name__}.{module.name}"), "MODE", None)
        if isinstance(record, Mode):
            found[record.name] = record
    _update(found, _REGISTERED)


def register(mode: Mode) -> None:
    """Add ``mode`` from outside the package (a mode's module in the package needs no call); its
    inputs must agree with those of the same name in other modes."""
    if mode.name in _REGISTRY:
        raise ValueError(f"a weathering mode named {mode.name!r} is registered already")
    _update(_FOUND, {**_REGISTERED, mode.name: mode})


def unregister(name: str) -> None:
    _update(_FOUND, {key: mode for key, mode in _REGISTERED.items() if key != name})


def names() -> tuple[str, ...]:
    """The registered modes, in their order (the panel's and the groups' order)."""
    return tuple(_REGISTRY)


def get(name: str) -> Mode:
    return _REGISTRY[name]


def checked(modes: str | Iterable[str]) -> tuple[str, ...]:
    """``modes`` (one name or several) in registry order; ValueError for unknown names."""
    modes = (modes,) if isinstance(modes, str) else tuple(modes)
    unknown = set(modes) - set(_REGISTRY)
    if unknown:
        raise ValueError(f"unknown weathering modes {sorted(unknown)}; known: {names()}")
    return tuple(name for name in _REGISTRY if name in modes)


def inputs() -> dict[str, Input]:
    """Every input of every mode, each once, in socket order."""
    found: dict[str, Input] = {}
    for mode in _REGISTRY.values():
        for item in mode.inputs:
            found.setdefault(item.name, item)
    return found


def fields_of(modes: Iterable[str]) -> tuple[str, ...]:
    """The per-point fields of the point's place ``modes`` read (``Mode.fields``), each once."""
    return tuple(dict.fromkeys(name for mode in checked(modes) for name in _REGISTRY[mode].fields))


def inputs_of(modes: Iterable[str]) -> list[Input]:
    """The inputs ``modes`` use, in socket order."""
    wanted = {item.name for name in checked(modes) for item in _REGISTRY[name].inputs}
    return [item for name, item in inputs().items() if name in wanted]


def has_water_lobe(modes: Iterable[str]) -> bool:
    return any(_REGISTRY[name].water_lobe for name in checked(modes))


def shader_inputs(modes: Iterable[str]) -> list[Input]:
    """Group inputs that are not model inputs: the water lobe's roughness."""
    return [WATER_ROUGHNESS] if has_water_lobe(modes) else []


def weathered_weights(
    xp: Any,
    kd: Any,
    ks: Any,
    m: Any,
    alpha: Any,
    sp: Any,
    n_dot_l: Any,
    n_dot_v: Any,
    modes: Iterable[str],
    state: Mapping[str, Any],
    receptivity: Any = None,
    field: Any = None,
    variation: Any = None,
    fields: Mapping[str, Any] | None = None,
    rivulets: tuple[Any, Any, Any] | None = None,
) -> tuple[Any, Any, Any]:
    """(k_d, k_s, k_water or None): the weights of the diffuse lobe, the glossy lobe (roughness
    m) and the near-mirror water lobe of a point weathered by ``modes`` (already checked);
    ``state`` holds every input they use.  At time 0 the weights are the porous ones exactly.
    ``receptivity`` (the stone's structure, docs/model.md §8.3; None: the model without it) scales
    how fast the point's pores fill: every front and cover reads the local age min(r t, 1), and life
    its years at r (docs/model.md §9.3).  ``field`` (the
    stone's porosity field z_p) and ``variation`` (its v) give the stone's uptake (docs/model.md §8.7):
    every fill and cover is taken at the point's place in the stone; and ``variation`` the deposit's
    mix with the stone's own colour (docs/model.md §8.6).  None: the model without them.  ``fields``
    holds the per-point values the modes' records name in ``Mode.fields`` (docs/model.md §9.3).
    ``rivulets`` (the point's place across the fall line, the face's horizontal part h and the
    rivulet spacing: docs/model.md §8.8) gathers the run-off map into the stone's rivulets, by its
    ``variation``, wherever the map holds run-off; None: the run-off as the map gives it."""
    point = weathered_point(
        xp, kd, ks, m, alpha, sp, n_dot_l, n_dot_v, modes, state, receptivity, field, variation, fields, rivulets
    )
    return point.kd_w, point.ks_w, point.water_w


def weathered_point(
    xp: Any,
    kd: Any,
    ks: Any,
    m: Any,
    alpha: Any,
    sp: Any,
    n_dot_l: Any,
    n_dot_v: Any,
    modes: Iterable[str],
    state: Mapping[str, Any],
    receptivity: Any = None,
    field: Any = None,
    variation: Any = None,
    fields: Mapping[str, Any] | None = None,
    rivulets: tuple[Any, Any, Any] | None = None,
) -> Point:
    """The weathered ``Point`` of ``weathered_weights``: its lobes' weights and the notes its
    layers leave (what the condition survey reads, docs/model.md §10)."""
    state = {item.name: xp.clip(state[item.name], item.low, item.high) for item in inputs_of(modes)}
    receptivity = 1.0 if receptivity is None else xp.maximum(receptivity, 0.0)
    if "time" in state and not base.plain_stone(receptivity):
        state["time"] = base.local_age(xp, state["time"], receptivity)
    kd, ks = porous.valid_albedo(xp, kd, ks)
    m = xp.maximum(m, 0.0)
    alpha = xp.clip(alpha, 0.0, 1.0)
    sp = xp.maximum(sp, 0.0)
    n_dot_v = xp.clip(n_dot_v, 0.0, 1.0)  # pore_geometry clamps it likewise (no second node)
    gp, theta_i, theta_r = porous.pore_geometry(xp, m, n_dot_l, n_dot_v)
    # below 1, so that pores a fill has filled (n_b = 0) return what fills them on a black stone
    # too: (1 - k_a)^0 is 1 in both backends, where the shader's 0^0 is 0 (docs/model.md §4.0)
    ka = xp.minimum(1.0 - xp.channel(ks) - kd, 1.0 - porous.EPSILON)
    kd_w, ks_w = porous.porous_weights(xp, kd, ks, alpha, gp, porous.pore_return(xp, kd, ks, sp, theta_i, theta_r))
    point = Point(kd, ka, m, sp, xp.channel(alpha * gp), theta_i, theta_r, n_dot_v, kd_w, ks_w, state)
    if variation is not None:
        point.variation = xp.clip(variation, 0.0, 1.0)
        if field is not None:
            point.spread = base.uptake_spread(xp, field, point.variation)
        if rivulets is not None and "runoff_map" in state:
            excess = base.rivulet_excess(xp, *rivulets, 0.0 if field is None else field, point.variation)
            state["runoff_map"] = base.in_rivulets(xp, state["runoff_map"], *excess)
    point.receptivity, point.fields = receptivity, dict(fields or {})
    layers = sorted((layer for name in modes for layer in _REGISTRY[name].layers), key=lambda layer: layer.stage)
    for layer in layers:
        layer.apply(xp, point)
    return point


def patterns(modes: Iterable[str]) -> tuple:
    """The condition-survey patterns of ``modes`` (each mode's ``patterns``), in precedence order."""
    found = {pattern.name: pattern for name in checked(modes) for pattern in _REGISTRY[name].patterns}
    return tuple(sorted(found.values(), key=lambda pattern: pattern.precedence))


discover()
