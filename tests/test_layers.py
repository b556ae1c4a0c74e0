"""The layers import only what their docstrings allow, and no module imports itself through
others (docs/architecture.md, "The layers").

Every subpackage's ``__init__`` docstring says "May import: ..."; the layers it names there (before
any "not") are the only ones its modules may import, besides ``contracts`` and itself. Checked
with ``ast`` over every module of the subpackage (imports inside functions too), and for ``core``
and ``common``, which never import bpy, also at run time in a fresh interpreter. The same imports
make the package's import graph, module to module (``from . import x`` names the module ``x``,
``from .registry import X`` the module ``registry``), which must have no cycle, within a layer
or across layers.
"""

import ast
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "porous_weathering"
LAYERS = sorted(path.parent.name for path in PACKAGE.glob("*/__init__.py"))
BPY = {"bpy", "bmesh", "mathutils", "gpu", "bl_math"}
WITHOUT_BPY = ("core", "common")


def allowed_layers(layer):
    """The layers named in the "May import:" sentence of ``layer``'s docstring, before any "not"."""
    docstring = ast.get_docstring(ast.parse((PACKAGE / layer / "__init__.py").read_text(encoding="utf-8"))) or ""
    match = re.search(r"May import:(.*?)(?:\n\n|$)", docstring, re.S)
    assert match, f"porous_weathering/{layer}/__init__.py: its docstring says no 'May import: ...'"
    allowed = re.split(r"\bnot\b", match.group(1))[0]
    return {name for name in re.findall(r"``(\w+)``", allowed) if name in LAYERS}


def module_name(path):
    """The dotted name of the module at ``path`` ('porous_weathering.maps' for its __init__)."""
    return ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")


MODULES = {module_name(path): path for path in PACKAGE.rglob("*.py")}


def _run_time_nodes(tree):
    """The nodes of ``tree`` but those under ``if TYPE_CHECKING:`` (imported for type hints only)."""
    skipped = {
        id(inner)
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
        for branch in node.body
        for inner in ast.walk(branch)
    }
    return [node for node in ast.walk(tree) if id(node) not in skipped]


def imports(path):
    """(line, absolute module name) of every import in the module at ``path``: ``from p import x``
    gives the module ``p.x`` where there is one, else ``p``."""
    module = module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in _run_time_nodes(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module
            found += [
                (node.lineno, f"{name}.{alias.name}" if f"{name}.{alias.name}" in MODULES else name)
                for alias in node.names
            ]
    return list(dict.fromkeys(found))


def violations(layer):
    allowed = allowed_layers(layer) | {layer, "contracts"}
    lines = []
    for path in sorted((PACKAGE / layer).rglob("*.py")):
        where = path.relative_to(ROOT)
        for line, name in imports(path):
            parts = name.split(".")
            if parts[0] == "porous_weathering" and len(parts) > 1 and parts[1] not in allowed:
                lines.append(f"{where}:{line}: imports {name} (may import {sorted(allowed)})")
            if layer in WITHOUT_BPY and parts[0] in BPY:
                lines.append(f"{where}:{line}: imports {name} (never bpy)")
    return lines


@pytest.mark.parametrize("layer", LAYERS)
def test_a_layer_imports_only_the_layers_its_docstring_allows(layer):
    found = violations(layer)
    assert not found, "\n".join(found)


@pytest.mark.parametrize("layer", WITHOUT_BPY)
def test_a_layer_without_bpy_loads_no_bpy(layer):
    modules = sorted(
        ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        for path in (PACKAGE / layer).rglob("*.py")
    )
    script = "import importlib, sys\n"
    script += "".join(f"importlib.import_module({module!r})\n" for module in modules)
    script += f"print(sorted(set(sys.modules) & {BPY!r}))\n"
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]", f"importing {modules} loads {done.stdout.strip()}"


#: The modules of maps/ that import no bpy (maps/__init__.py says which), so that the numpy maths
#: and the unwrap's child process run without Blender.
MAPS_WITHOUT_BPY = ("curvature", "runoff_flow", "lightmap_check", "lightmap_child")


def test_the_maps_numpy_modules_load_no_bpy():
    script = "import sys\n"
    script += "".join(f"import porous_weathering.maps.{name}\n" for name in MAPS_WITHOUT_BPY)
    script += f"print(sorted(set(sys.modules) & {BPY!r}))\n"
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]", f"importing maps.{MAPS_WITHOUT_BPY} loads {done.stdout.strip()}"


def import_graph():
    """{module: {module it imports: first line}} among the package's modules; a documented name at
    the package's top (``porous_weathering.uv``) is the layer's module it serves."""
    import porous_weathering

    graph = {}
    for module, path in MODULES.items():
        edges = graph.setdefault(module, {})
        for line, name in imports(path):
            top, _, rest = name.partition(".")
            public = top == "porous_weathering" and rest and "." not in rest  # a name at the package's top
            served = porous_weathering._layer_module(top, rest) if public else None
            if served is not None:
                name = f"porous_weathering.{served}"
            if name in MODULES and name != module:
                edges.setdefault(name, line)
    return graph


def cycles(graph):
    """Every strongly connected group of more than one module (Tarjan), each as its import lines."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(module):
        index[module] = low[module] = len(index)
        stack.append(module)
        on_stack.add(module)
        for target in graph[module]:
            if target not in index:
                visit(target)
                low[module] = min(low[module], low[target])
            elif target in on_stack:
                low[module] = min(low[module], index[target])
        if low[module] == index[module]:
            group = set()
            while module not in group:
                member = stack.pop()
                on_stack.discard(member)
                group.add(member)
            if len(group) > 1:
                found.append(
                    sorted(
                        f"{MODULES[a].relative_to(ROOT)}:{line}: imports {b}"
                        for a in group
                        for b, line in graph[a].items()
                        if b in group
                    )
                )

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return found


def test_the_import_graph_has_no_cycle():
    found = cycles(import_graph())
    assert not found, "import cycles:\n" + "\n\n".join("\n".join(group) for group in found)


def test_the_cycle_finder_finds_a_cycle():
    """Checked on a graph with one: a -> b -> c -> a, and d -> a outside it."""
    graph = {"a": {"b": 1}, "b": {"c": 2}, "c": {"a": 3}, "d": {"a": 4}}
    saved = dict(MODULES)
    MODULES.update({name: ROOT / f"{name}.py" for name in graph})
    try:
        assert cycles(graph) == [["a.py:1: imports b", "b.py:2: imports c", "c.py:3: imports a"]]
    finally:
        MODULES.clear()
        MODULES.update(saved)
