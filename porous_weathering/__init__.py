"""Porous Weathering: porous stone, brick and plaster, and how they soil, wet and salt.

The public API (docs/api.md):
    porous_weathering.model                 the model of docs/model.md in plain numpy (no bpy)
    porous_weathering.make_porous_material  a porous material for EEVEE and Cycles
    porous_weathering.make_base_material    the same Diffuse + Glossy without porosity
    porous_weathering.make_weathered_material  soiling / wet / efflorescence over time
    porous_weathering.make_preset_material  a porous material from a preset (docs/presets.md)
and the modules of ``PUBLIC_MODULES`` at their documented places (``porous_weathering.bake``,
``porous_weathering.export``, ...): each is the module of its layer (docs/architecture.md).

Importing this package does not import bpy; the names that need it load on first use,
so ``porous_weathering.model`` works in plain Python too.
"""

import atexit
import importlib

#: The documented modules (a file each beside this one, the module of its layer under its
#: public name), loaded on first use as attributes: ``pw.weathering.animate_weathering``.
PUBLIC_MODULES = (
    "bake",
    "demo",
    "edges",
    "efflorescence_map",
    "export",
    "maps",
    "model",
    "modes",
    "options",
    "presets",
    "rain",
    "runoff",
    "runoff_flow",
    "scan_checks",
    "survey",
    "uv",
    "weathering",
)

_LAZY = {
    "make_porous_material": "shading.material",
    "make_base_material": "shading.material",
    "make_weathered_material": "shading.weathering",
    "make_preset_material": "shading.presets",
}


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    if name in PUBLIC_MODULES:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def register():
    from . import ui
    from .blender import compat
    from .cli import entry as cli_entry
    from .shading import assets

    ui.register()
    assets.register()
    cli_entry.register()
    if compat.UNREGISTER_BEFORE_EXIT:  # else bpy 4.5 segfaults at exit (docs/troubleshooting.md)
        atexit.register(unregister)


def unregister():
    from . import ui
    from .cli import entry as cli_entry
    from .shading import assets

    atexit.unregister(unregister)
    cli_entry.unregister()
    assets.unregister()
    ui.unregister()
