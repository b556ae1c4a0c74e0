"""The layers import only what their docstrings allow (docs/architecture.md, "The layers").

Every subpackage's ``__init__`` docstring says "May import: ..."; the layers it names there (before
any "not") are the only ones its modules may import, besides ``contracts`` and itself. Checked
with ``ast`` over every module of the subpackage (imports inside functions too), and for ``core``
and ``common``, which never import bpy, also at run time in a fresh interpreter.
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


def imports(path):
    """(line, absolute module name) of every import in the module at ``path``."""
    module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    package = package.removesuffix(".__init__")
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module
            if name == "porous_weathering":  # from .. import x: each x is a module of the package
                found += [(node.lineno, f"{name}.{alias.name}") for alias in node.names]
            else:
                found.append((node.lineno, name))
    return found


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
