"""The registry of weathering modes: one module per mode, each one ``Mode`` record.

Everything that lists modes or their inputs (the model, the node groups, the panel, the
asset library, the docs' tables) reads this registry, so adding a mode is one new module
registered here (docs/architecture.md, "Add a mode").
"""

from collections.abc import Iterable, Mapping
from typing import Any

from .. import porous
from . import base, biological, efflorescence, soiling, wet
from .base import WATER_ROUGHNESS, Input, Layer, Mode, Point

__all__ = [
    "Input",
    "Layer",
    "Mode",
    "Point",
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
]

_REGISTRY: dict[str, Mode] = {}


def register(mode: Mode) -> None:
    """Add ``mode``; its inputs must agree with those of the same name in other modes."""
    if mode.name in _REGISTRY:
        raise ValueError(f"a weathering mode named {mode.name!r} is registered already")
    known = inputs()
    for item in mode.inputs:
        if item.name in known and known[item.name] != item:
            raise ValueError(f"mode {mode.name!r}: input {item.name!r} differs from the one other modes declare")
    _REGISTRY[mode.name] = mode


def unregister(name: str) -> None:
    del _REGISTRY[name]


def names() -> tuple[str, ...]:
    """The registered modes, in registration order (the panel's and the groups' order)."""
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
    fields: Mapping[str, Any] | None = None,
) -> tuple[Any, Any, Any]:
    """(k_d, k_s, k_water or None): the weights of the diffuse lobe, the glossy lobe (roughness
    m) and the near-mirror water lobe of a point weathered by ``modes`` (already checked);
    ``state`` holds every input they use.  At time 0 the weights are the porous ones exactly.
    ``receptivity`` (the stone's structure, docs/model.md §8.3; None: the model without it) scales
    how fast the point's pores fill: every layer reads the local age min(r t, 1).  ``fields`` holds
    the per-point values the modes' records name in ``Mode.fields`` (docs/model.md §9.3)."""
    state = {item.name: xp.clip(state[item.name], item.low, item.high) for item in inputs_of(modes)}
    receptivity = 1.0 if receptivity is None else xp.maximum(receptivity, 0.0)
    if "time" in state and not (isinstance(receptivity, float) and receptivity == 1.0):
        state["time"] = base.local_age(xp, state["time"], receptivity)
    kd, ks = porous.valid_albedo(xp, kd, ks)
    m = xp.maximum(m, 0.0)
    alpha = xp.clip(alpha, 0.0, 1.0)
    sp = xp.maximum(sp, 0.0)
    n_dot_v = xp.clip(n_dot_v, 0.0, 1.0)  # pore_geometry clamps it likewise (no second node)
    gp, theta_i, theta_r = porous.pore_geometry(xp, m, n_dot_l, n_dot_v)
    ka = 1.0 - xp.channel(ks) - kd
    kd_w, ks_w = porous.porous_weights(xp, kd, ks, alpha, gp, porous.pore_return(xp, kd, ks, sp, theta_i, theta_r))
    point = Point(kd, ka, m, sp, xp.channel(alpha * gp), theta_i, theta_r, n_dot_v, kd_w, ks_w, state)
    point.receptivity, point.fields = receptivity, dict(fields or {})
    layers = sorted((layer for name in modes for layer in _REGISTRY[name].layers), key=lambda layer: layer.stage)
    for layer in layers:
        layer.apply(xp, point)
    return point.kd_w, point.ks_w, point.water_w


for _mode in (soiling.MODE, wet.MODE, efflorescence.MODE, biological.MODE):
    register(_mode)
