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
    "make_porous_material": "material",
    "make_base_material": "material",
    "make_weathered_material": "weathering",
    "make_preset_material": "presets",
}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def register():
    from . import assets, cli, ui

    ui.register()
    assets.register()
    cli.register()


def unregister():
    from . import assets, cli, ui

    cli.unregister()
    assets.unregister()
    ui.unregister()
