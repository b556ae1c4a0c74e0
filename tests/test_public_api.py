"""Every name docs/api.md documents can be imported from where it documents it, and the
documented modules at the top of the package are the layer modules themselves
(docs/architecture.md, "The layers").

docs/api.md names its modules in headings (`` `porous_weathering.efflorescence_map` ``, or
several in one: `` (`porous_weathering.bake`, `.rain`, `.edges`) ``) and its names as the code
spans of headings (`` ### `make_porous_material(name, ...)` ``) and of the first column of its
``function`` and ``name`` tables (`` `bake_maps(objects, ...)` ``, `` `uv.check_uvs(...)` ``). A name
qualified with a module (``uv.check_uvs``) is relative to ``porous_weathering``; any other is
looked up in the modules of the heading above it, then in ``porous_weathering``, then in a module
a neighbour in the same cell is qualified with (``bake.option_entries()``,
``BakeOptions.to_argv()``).
"""

import importlib
import pathlib
import re
import sys

import pytest

import porous_weathering

ROOT = pathlib.Path(__file__).resolve().parent.parent
API = ROOT / "docs" / "api.md"
PACKAGE = "porous_weathering"

CODE = re.compile(r"`([^`]+)`")
NAME = re.compile(r"[A-Za-z_][\w.]*")


def resolve(dotted):
    """The object at ``dotted`` ('porous_weathering.uv.check_uvs'), importing modules on the way;
    AttributeError or ImportError if there is none."""
    parts = dotted.split(".")
    found = importlib.import_module(parts[0])
    for index, part in enumerate(parts[1:], start=2):
        try:
            found = getattr(found, part)
        except AttributeError:
            found = importlib.import_module(".".join(parts[:index]))
    return found


def heading_modules(text):
    """The modules a heading names: `porous_weathering.x`, and `.y` for porous_weathering.y."""
    return [
        span if span.startswith(PACKAGE) else PACKAGE + span
        for span in CODE.findall(text)
        if "(" not in span and (span.startswith(PACKAGE + ".") or re.fullmatch(r"\.\w+", span))
    ]


def documented():
    """[(line, name, candidate full names)] for every documented name, and [(line, module)] for
    every module a heading names."""
    names, modules = [], []
    section, table_of_names, previous = [], False, ""
    for number, line in enumerate(API.read_text(encoding="utf-8").splitlines(), start=1):
        header, previous = line.startswith("|") and not previous.startswith("|"), line
        if line.startswith("#"):
            named = heading_modules(line)
            modules += [(number, module) for module in named]
            if named or line.startswith("## ") or line.startswith("# "):
                section = named
            spans = [span for span in CODE.findall(line) if "(" in span]
            cells = [spans]
        elif line.startswith("|"):
            first = line.split("|")[1].strip()
            if header:  # the tables of names are headed "function" or "name"
                table_of_names = first in ("function", "name")
            if header or set(first) <= set("-: "):
                continue
            cells = [CODE.findall(first)] if table_of_names else []
        else:
            continue
        for spans in cells:
            cell_names = [NAME.match(span).group() for span in spans if NAME.match(span)]
            prefixes = {name.split(".")[0] for name in cell_names if "." in name}
            for name in cell_names:
                if name.startswith(PACKAGE + "."):
                    candidates = [name]
                elif name[0].islower() and "." in name:  # a module's name: uv.check_uvs
                    candidates = [f"{PACKAGE}.{name}"]
                else:
                    bases = [*section, PACKAGE, *(f"{PACKAGE}.{prefix}" for prefix in sorted(prefixes))]
                    candidates = [f"{base}.{name}" for base in dict.fromkeys(bases)]
                names.append((number, name, candidates))
    return names, modules


NAMES, MODULES = documented()


def test_the_parser_finds_the_documented_names():
    found = {name for _, name, _ in NAMES}
    assert len(found) > 60, sorted(found)
    assert {"bake_maps", "uv.check_uvs", "modes.Mode", "make_porous_material", "brick_joint_map"} <= found
    assert {module for _, module in MODULES} >= {f"{PACKAGE}.model", f"{PACKAGE}.efflorescence_map", f"{PACKAGE}.rain"}


@pytest.mark.parametrize("line, module", MODULES, ids=[module for _, module in MODULES])
def test_every_documented_module_imports(line, module):
    assert importlib.import_module(module).__name__, f"docs/api.md:{line}"


def _resolves(candidate):
    try:
        resolve(candidate)
    except (AttributeError, ImportError):
        return False
    return True


@pytest.mark.parametrize("line, name, candidates", NAMES, ids=[f"{line}:{name}" for line, name, _ in NAMES])
def test_every_documented_name_resolves(line, name, candidates):
    assert any(_resolves(candidate) for candidate in candidates), (
        f"docs/api.md:{line}: {name} is not at any of {candidates}"
    )


#: The documented modules at the top of the package and the layer module each one is.
ALIASES = {
    "bake": "maps.bake",
    "demo": "samples.demo",
    "edges": "maps.edges",
    "efflorescence_map": "maps.efflorescence_map",
    "export": "publish.export",
    "model": "core.model",
    "modes": "core.modes",
    "options": "common.options",
    "presets": "shading.presets",
    "rain": "maps.rain",
    "runoff": "maps.runoff",
    "runoff_flow": "maps.runoff_flow",
    "scan_checks": "maps.scan_checks",
    "sun": "maps.sun",
    "damp": "maps.damp",
    "uv": "maps.lightmap",
    "weathering": "shading.weathering",
}


def test_every_alias_module_is_listed():
    # the package's table serves them (and names the maps and survey subpackages), and the map
    # registry each map's own module; no file stands in for one
    served = set(porous_weathering.PUBLIC_MODULES) | set(porous_weathering.maps.modules())
    assert served == set(ALIASES) | {"maps", "survey"}
    assert {path.stem for path in (ROOT / PACKAGE).glob("*.py")} == {"__init__", "__main__", "contracts"}
    top = {module.split(".")[1] for _, module in MODULES if module.count(".") == 1}
    assert top <= served, "docs/api.md names a module the package does not serve"


def test_a_public_packages_submodule_is_its_layers(monkeypatch):
    # docs/api.md's modes.soiling.CRUST_DEFAULT, imported as a user writes it: the module of
    # core/modes/, not a second copy loaded under the public name (whose relative imports fail)
    monkeypatch.delitem(sys.modules, f"{PACKAGE}.modes.soiling", raising=False)
    soiling = importlib.import_module(f"{PACKAGE}.modes.soiling")
    assert soiling is importlib.import_module(f"{PACKAGE}.core.modes.soiling")
    assert soiling.CRUST_DEFAULT == porous_weathering.modes.soiling.CRUST_DEFAULT


def test_only_a_maps_own_module_is_served_beside_the_table():
    # a module of the maps package that holds no map's record is not public
    with pytest.raises(ImportError):
        importlib.import_module(f"{PACKAGE}.contacts")
    assert not hasattr(porous_weathering, "scan_checks_of_nothing")


@pytest.mark.parametrize("alias, layer_module", ALIASES.items())
def test_alias_module_is_the_layer_module(alias, layer_module):
    module = importlib.import_module(f"{PACKAGE}.{alias}")
    assert module is importlib.import_module(f"{PACKAGE}.{layer_module}")
    assert getattr(porous_weathering, alias) is module
