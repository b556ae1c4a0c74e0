"""Porous Weathering: porous stone, brick and plaster, and how they soil, wet and salt.

The public API (docs/api.md):
    porous_weathering.model                 the SPEC model in plain numpy (no bpy)
    porous_weathering.make_porous_material  a porous material for EEVEE and Cycles
    porous_weathering.make_base_material    the same Diffuse + Glossy without porosity
    porous_weathering.make_weathered_material  soiling / wet / efflorescence over time
    porous_weathering.make_preset_material  a porous material from a preset (docs/presets.md)

Importing this package does not import bpy; the names that need it load on first use,
so ``porous_weathering.model`` works in plain Python too.
"""

_LAZY = {
    "make_porous_material": "shading.material",
    "make_base_material": "shading.material",
    "make_weathered_material": "shading.weathering",
    "make_preset_material": "shading.presets",
}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def register():
    from .cli import entry as cli_entry
    from .shading import assets
    from .ui import panel

    panel.register()
    assets.register()
    cli_entry.register()


def unregister():
    from .cli import entry as cli_entry
    from .shading import assets
    from .ui import panel

    cli_entry.unregister()
    assets.unregister()
    panel.unregister()
