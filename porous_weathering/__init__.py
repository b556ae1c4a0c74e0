"""Porous Weathering: porous stone, brick and plaster, and how they soil, wet, salt and green.

The public API (docs/api.md):
    porous_weathering.model                 the model of docs/model.md in plain numpy (no bpy)
    porous_weathering.make_porous_material  a porous material for EEVEE and Cycles
    porous_weathering.make_base_material    the same Diffuse + Glossy without porosity
    porous_weathering.make_weathered_material  how it weathers over time (every mode: soiling, wet, ...)
    porous_weathering.make_preset_material  a porous material from a preset (docs/presets.md)
    porous_weathering.ColorAttribute        a base colour read from a colour attribute (a scan's vertex colours)
and the modules of ``PUBLIC_MODULES`` at their documented places (``porous_weathering.bake``,
``porous_weathering.export``, ...) and each map's module (``porous_weathering.rain``,
``porous_weathering.sun``, ...: the map registry's ``maps.modules()``): each is the module of its
layer (docs/architecture.md), served by a finder this package installs; no file stands in for them.

Importing this package does not import bpy; the names that need it load on first use,
so ``porous_weathering.model`` works in plain Python too.
"""

import atexit
import importlib
import importlib.abc
import importlib.util
import sys

#: The documented modules (docs/api.md) but the maps' own, which the map registry names: each public
#: name at the top of the package and the module of its layer it is (docs/architecture.md, "The
#: public API"). ``porous_weathering.uv``
#: *is* ``porous_weathering.maps.lightmap``: one module with one state under both names.
PUBLIC_MODULES = {
    "bake": "maps.bake",
    "demo": "samples.demo",
    "export": "publish.export",
    "maps": "maps",
    "model": "core.model",
    "modes": "core.modes",
    "options": "common.options",
    "presets": "shading.presets",
    "runoff_flow": "maps.runoff_flow",
    "scan_checks": "maps.scan_checks",
    "survey": "survey",
    "uv": "maps.lightmap",
    "weathering": "shading.weathering",
}

_LAZY = {
    "make_porous_material": "shading.material",
    "make_base_material": "shading.material",
    "make_weathered_material": "shading.weathering",
    "make_preset_material": "shading.material",
    "ColorAttribute": "shading.material",
}


def _layer_module(package: str, name: str) -> str | None:
    """The module of its layer that ``<package>.<name>`` is: ``PUBLIC_MODULES``'s, or a map's own
    module (its record's, ``maps.modules()``: ``porous_weathering.sun`` is ``maps.sun``, with its
    settings), else None."""
    if name in PUBLIC_MODULES:
        return PUBLIC_MODULES[name]
    if importlib.util.find_spec(f"{package}.maps.{name}") is None:  # no map's module: nothing imported
        return None
    return f"maps.{name}" if name in importlib.import_module(f"{package}.maps").modules() else None


def _served(package: str, dotted: str) -> str | None:
    """The layer module that ``<package>.<dotted>`` is: a public name's (``_layer_module``), or a
    submodule of a public package (``porous_weathering.modes.soiling`` is ``core.modes.soiling``),
    else None (a module of the package's own, or none)."""
    name, _, rest = dotted.partition(".")
    layer = _layer_module(package, name)
    if layer in (None, name):
        return None
    return f"{layer}.{rest}" if rest else layer


class _PublicModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports ``<package>.<public name>`` (``import porous_weathering.uv``, ``from
    porous_weathering.bake import X``, ``import porous_weathering.modes.soiling``) as the module of
    its layer, loaded on first use: the placeholder module the import makes puts the layer's module
    in its place in ``sys.modules``, which the import then returns and sets on its parent. First
    on ``sys.meta_path``, so that a public package's submodule is not loaded a second time from the
    package's folder under the public name, where its relative imports would fail."""

    def __init__(self, package: str):
        self.package = package

    def find_spec(self, fullname, path=None, target=None):
        prefix = self.package + "."
        if not fullname.startswith(prefix) or _served(self.package, fullname[len(prefix) :]) is None:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def exec_module(self, module):
        served = _served(self.package, module.__name__[len(self.package) + 1 :])
        sys.modules[module.__name__] = importlib.import_module(f"{self.package}.{served}")


# one finder for this package, also when the add-on is loaded again
sys.meta_path[:] = [finder for finder in sys.meta_path if getattr(finder, "package", None) != __name__]
sys.meta_path.insert(0, _PublicModules(__name__))


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    if _layer_module(__name__, name) is not None:
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
