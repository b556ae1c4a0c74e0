"""Docs that run (docs/architecture.md, "Docs that run"): every shell and Python block of README.md and docs/*.md is
one test case (id ``file:line``) that runs it, unless the Markdown marks it as an illustration,
with a reason, in an HTML comment right before it (invisible when rendered):

    <!-- illustration: needs a SLURM cluster -->
    ```bash
    sbatch ...
    ```

Collected: fenced blocks marked ``sh``, ``bash``, ``shell``, ``console`` (its ``$ `` lines),
``python``, ``py`` or ``pycon``; unmarked fences and 4-space indented blocks whose first line is a
command (``python …``, ``scripts/…``, ``mkdir …``: formulas and quoted messages are not).

How a block runs:

- **Shell** (bash, ``set -eo pipefail``): cwd is a temporary workspace that holds the repository's
  code, scripts, tests and virtual environments as symbolic links, and copies of what a block may
  write (``sample_blends/``, ``node_groups/``; ``docs/images/`` empty), so that ``out/`` and the
  rest land there; ``python`` (first on PATH) is this test's interpreter, the environment's
  ``bin`` comes next (``dask``), ``PW_BLENDER`` names its Blender line, and ``/tmp/`` in the
  block is a folder of the test's own. A line that ends in ``# exit N`` must exit N.
- **Python**: a fresh subprocess of this interpreter, cwd the same workspace, as in Blender's
  Python console with a scene open: ``bpy`` imported, ``facade.blend`` (a copy of the bundled
  façade, saved, with its ``Sun``) open and its ``Wall`` active. ``>>>`` blocks are checked like
  doctests, a number to the digits the docs show.
- The few commands that would run for minutes are run the way the docs say makes them small
  (``ADAPTATIONS``, each with its reason).

``python tests/test_docs.py`` lists every block and what happens to it.
"""

import dataclasses
import functools
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import time

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

SHELL = {"sh", "bash", "shell", "console"}
PYTHON = {"python", "py", "pycon"}
MARKER = re.compile(r"<!--\s*illustration:(.*?)-->\s*$", re.S)
FENCE = re.compile(r"^(?P<indent> {0,3})(?P<fence>`{3,}|~{3,})\s*(?P<info>[^`\s]*)")
#: The first line of an unmarked or indented block that is a shell command.
COMMAND = re.compile(
    r"^(\$ )?(python3?|blender|scripts/\S+|tools/\S+|\.venv[^/\s]*/bin/\S+|mkdir|cp|cd|ln|pip|bash|dask|helm|kubectl"
    r"|[A-Z_]+=\S*\s+\S)(\s|$)"
)
EXIT = re.compile(r"\s#\s*exit (\d+)\b")
TIMEOUT = 900

#: Blocks run differently from how they are shown, and why: (files, regex on a shell line or on
#: Python code, replacement, reason). Each must be used by some block (test below).
ADAPTATIONS = [
    (
        ("README.md", "docs/quickstart.md"),
        r"^(scripts/test\.sh(?: --blender \S+)?)\b.*$",
        r"\1 tests/test_model.py -q -x -k hand_computed",
        "the whole suite would run this file again: one small test file shows the command works",
    ),
    (
        ("README.md", "docs/quickstart.md"),
        r"^(scripts/demo\.sh\b[^#]*?)\s*(#.*)?$",
        r"\1 --size 36 --samples 1 --bake-samples 4",
        "the main job and the docs' pictures at full size take minutes: their documented options make them small",
    ),
    (
        ("docs/api.md",),
        r"resolution=1024\b",
        "resolution=128",
        "two 1024² maps take two minutes on 2 cores: 128² runs the same code",
    ),
    (
        ("docs/cli.md", "docs/batch.md"),
        r"^(.*python -m porous_weathering bake\b[^#]*?)\s*(#.*)?$",
        lambda match: small_bake(match[1]) + (f"  {match[2]}" if match[2] else ""),
        "the shown rain and sun samples take minutes on 2 cores: --samples 8 --sun-samples 8 run the same code",
    ),
    (
        ("docs/batch.md",),
        r"^(python -m porous_weathering bake /tmp/pw/scans/limestone_facade\.blend .*--scheduler .*)$",
        r"\1 --resolution 256",
        "the façade's 22 image maps at 512² take minutes on 2 cores: at 256² (as in cli.md) the same code runs",
    ),
]


def small_bake(command):
    """A bake command with few rain and sun samples: --samples 8 and --sun-samples 8, given or added."""
    for flag in ("--samples", "--sun-samples"):
        command, given = re.subn(rf"{flag} \d+", f"{flag} 8", command)
        if not given and not command.endswith("\\"):
            command += f" {flag} 8"
    return command


#: Blocks that take more than ~20 s: (file, a piece of their code).
SLOW = [
    ("README.md", "scripts/demo.sh"),
    ("docs/quickstart.md", "scripts/demo.sh --docs"),
    ("docs/quickstart.md", "render.render"),
    ("docs/batch.md", "--workers 2"),
    ("docs/batch.md", "dask scheduler"),
    ("docs/cli.md", "mkdir -p /tmp/pw-cli"),
]


@dataclasses.dataclass
class Block:
    file: str  # relative to the repository root
    line: int  # of the opening fence, or of the first indented line
    kind: str  # "shell" or "python"
    code: str
    illustration: str | None  # the marker's reason ("" when empty), None when not marked

    @property
    def id(self):
        return f"{self.file}:{self.line}"


def marker_before(lines, index):
    """The reason of an ``<!-- illustration: … -->`` comment ending on the last non-blank line
    before ``lines[index]``, or None."""
    end = index - 1
    while end >= 0 and not lines[end].strip():
        end -= 1
    if end < 0 or not lines[end].rstrip().endswith("-->"):
        return None
    start = end
    while start > 0 and "<!--" not in lines[start]:
        start -= 1
    match = MARKER.search("\n".join(lines[start : end + 1]))
    return " ".join(match.group(1).split()) if match else None


def console_commands(code):
    return "\n".join(line[2:] for line in code.splitlines() if line.startswith("$ "))


def collect(path, name=None):
    """Every shell and Python block of one Markdown file."""
    lines = path.read_text(encoding="utf-8").splitlines()
    name = name or path.relative_to(ROOT).as_posix()
    blocks, index, previous_blank = [], 0, True
    while index < len(lines):
        line = lines[index]
        fence = FENCE.match(line)
        if fence:
            mark, indent, info = fence["fence"], len(fence["indent"]), fence["info"].lower()
            body, end = [], index + 1
            while end < len(lines) and not lines[end].lstrip().startswith(mark):
                text = lines[end]
                body.append(text[min(indent, len(text) - len(text.lstrip(" "))) :])  # the fence's indent
                end += 1
            code = "\n".join(body) + "\n"
            kind = "shell" if info in SHELL else "python" if info in PYTHON else None
            if info == "console":
                code = console_commands(code) + "\n"
            if kind is None and not info and COMMAND.match(code.lstrip()):
                kind = "shell"
            if kind:
                blocks.append(Block(name, index + 1, kind, code, marker_before(lines, index)))
            index, previous_blank = end + 1, False
            continue
        if previous_blank and line.startswith("    ") and line.strip():
            end = index
            while end < len(lines) and (lines[end].startswith("    ") or not lines[end].strip()):
                end += 1
            body = [text[4:] for text in lines[index:end]]
            if COMMAND.match(body[0]):
                code = "\n".join(body).strip("\n") + "\n"
                blocks.append(Block(name, index + 1, "shell", code, marker_before(lines, index)))
            index, previous_blank = end, False
            continue
        previous_blank = not line.strip()
        index += 1
    return blocks


BLOCKS = [block for path in DOCS for block in collect(path)]


# --- the workspace a block runs in


@functools.cache
def interpreter_line():
    """The Blender line of this interpreter's bpy, e.g. "5.2" (without importing bpy here)."""
    out = subprocess.run(
        [sys.executable, "-c", "import importlib.metadata as m; print(m.version('bpy'))"],
        capture_output=True,
        text=True,
        check=True,
    )
    return ".".join(out.stdout.strip().split(".")[:2])


LINKED = ["porous_weathering", "tests", "tools", "benchmarks", "scripts", "requirements"]
LINKED += ["pyproject.toml", "blender_manifest.toml", "__init__.py", "LICENSE", "README.md", ".gitignore"]
COPIED = ["sample_blends", "node_groups"]


def workspace(tmp_path):
    """A folder that looks like the repository root to a block, and where its output lands."""
    work = tmp_path / "work"
    work.mkdir()
    for name in LINKED:
        if (ROOT / name).exists():
            (work / name).symlink_to(ROOT / name)
    for name in COPIED:
        shutil.copytree(ROOT / name, work / name, ignore=shutil.ignore_patterns("__pycache__"))
    (work / "docs" / "images").mkdir(parents=True)
    for venv in ROOT.glob(".venv-*"):
        (work / venv.name).symlink_to(venv)
    shutil.copy(ROOT / "sample_blends" / "limestone_facade.blend", work / "facade.blend")
    (tmp_path / "tmp").mkdir()
    shim = tmp_path / "bin"
    shim.mkdir()
    (shim / "python").write_text(f'#!/bin/sh\nexec "{sys.executable}" "$@"\n')
    (shim / "python").chmod(0o755)
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(shim), os.path.dirname(sys.executable), env.get("PATH", "")])
    env.update(PW_BLENDER=interpreter_line(), PYTHONDONTWRITEBYTECODE="1", PYTHONUNBUFFERED="1")
    env["TMPDIR"] = str(tmp_path / "tmp")  # what a block's background jobs leave (Dask's scratch space)
    env.pop("PYTHONPATH", None)
    return work, env


def own_tmp(code, tmp_path):
    return re.sub(r"(?<![\w.~-])/tmp/", f"{tmp_path / 'tmp'}/", code)


def adapt(block):
    """The block's code with ADAPTATIONS applied."""
    code = block.code
    for files, pattern, replacement, _reason in ADAPTATIONS:
        if block.file in files:
            code = re.sub(pattern, replacement, code, flags=re.M)
    return code


def logical_lines(code):
    """Shell lines with their backslash continuations joined (here-documents kept as they are)."""
    out, pending = [], ""
    for line in code.splitlines():
        if line.endswith("\\") and not line.endswith("\\\\"):
            pending += line + "\n"
        else:
            out.append(pending + line)
            pending = ""
    return out + ([pending] if pending else [])


def expect_exits(code):
    """A line ``COMMAND   # exit N: why`` must exit N; set -e stops the block at any other failure."""
    out = []
    for line in logical_lines(code):
        outside_quotes = (m for m in EXIT.finditer(line) if line.count('"', 0, m.start()) % 2 == 0)
        match = next((m for m in outside_quotes if line.count("'", 0, m.start()) % 2 == 0), None)
        if match:
            command, status = line[: match.start()], match.group(1)
            quoted = command.replace("'", "'\\''")
            line = (
                f'__pw_rc=0; {command} || __pw_rc=$?; if [ "$__pw_rc" != {status} ]; then '
                f"echo \"docs: exit $__pw_rc, the docs say {status}: \"'{quoted}' >&2; exit 1; fi"
            )
        out.append(line)
    return "\n".join(out) + "\n"


RUNNER = r'''
import contextlib, doctest, io, os, re, sys

import bpy

NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def same(expected, got):
    """Doctest output equality, a number to the digits the docs show, whitespace ignored."""
    flat = lambda text: "".join(NUMBER.sub("#", text).split())
    if flat(expected) != flat(got):
        return False
    for shown, value in zip(NUMBER.findall(expected), NUMBER.findall(got)):
        digits = len(shown.partition(".")[2].partition("e")[0].partition("E")[0])
        if abs(float(shown) - float(value)) > 0.5 * 10.0**-digits * (1 + 1e-9):
            return False
    return True


sys.path.insert(0, os.getcwd())  # as in the console and python -c: the cwd imports
bpy.ops.wm.open_mainfile(filepath=os.path.abspath("facade.blend"))
wall = bpy.data.objects["Wall"]
bpy.context.view_layer.objects.active = wall
wall.select_set(True)
name, code = sys.argv[1], open(sys.argv[2], encoding="utf-8").read()
namespace = {"__name__": "__main__", "bpy": bpy}
if ">>> " not in code:
    exec(compile(code, name, "exec"), namespace)
else:
    for example in doctest.DocTestParser().get_examples(code, name):
        with contextlib.redirect_stdout(io.StringIO()) as shown:
            exec(compile(example.source, name, "single"), namespace)  # as at the >>> prompt
        got = shown.getvalue()
        if not same(example.want, got):
            shown, source = example.want.strip(), example.source.strip()
            sys.exit(f"{name}: {source}\n  the docs show: {shown}\n  it gives:      {got.strip()}")
print("docs block ran:", name)
'''


def run(block, tmp_path):
    work, env = workspace(tmp_path)
    code = own_tmp(adapt(block), tmp_path)
    if block.kind == "shell":
        script = tmp_path / "block.sh"
        script.write_text("set -eo pipefail\n" + expect_exits(code))
        command = ["bash", str(script)]
    else:
        (tmp_path / "block.py").write_text(code)
        (tmp_path / "runner.py").write_text(RUNNER)
        command = [sys.executable, str(tmp_path / "runner.py"), block.id, str(tmp_path / "block.py")]
    process = subprocess.Popen(
        command, cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True
    )
    try:
        output, _ = process.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        output = "(timed out)"
    finally:
        try:  # background jobs a block leaves (a Dask scheduler, its workers)
            os.killpg(process.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        process.wait()
    return process.returncode, output


def params():
    out = []
    for block in BLOCKS:
        slow = any(file == block.file and piece in block.code for file, piece in SLOW)
        out.append(pytest.param(block, id=block.id, marks=[pytest.mark.slow] if slow else []))
    return out


@pytest.mark.parametrize("block", params())
def test_block_runs_or_is_an_illustration(block, tmp_path):
    if block.illustration is not None:
        assert block.illustration, f"{block.id}: an illustration marker needs a reason"
        pytest.skip(f"illustration: {block.illustration}")
    needed = set(re.findall(r"\.venv-[\w.]+", block.code))
    if re.search(r"^scripts/", block.code, re.M):
        needed.add(f".venv-{interpreter_line()}")
    missing = sorted(name for name in needed if not (ROOT / name / "bin" / "python").exists())
    if missing:
        pytest.skip(f"needs {', '.join(missing)} (scripts/test.sh --blender X makes it)")
    start = time.monotonic()
    status, output = run(block, tmp_path)
    tail = "\n".join(output.splitlines()[-60:])
    assert status == 0, f"{block.id} exits {status} after {time.monotonic() - start:.0f} s:\n{block.code}\n{tail}"


def test_every_adaptation_is_used():
    for files, pattern, _replacement, reason in ADAPTATIONS:
        assert reason
        for file in files:
            assert any(
                b.file == file and b.illustration is None and re.search(pattern, b.code, re.M) for b in BLOCKS
            ), f"{file}: no block matches {pattern!r}"
    for file, piece in SLOW:
        assert any(b.file == file and piece in b.code for b in BLOCKS), f"{file}: no block holds {piece!r}"


def test_collects_the_block_kinds(tmp_path):
    """Fences of each language, console prompts, indented commands; not formulas or messages."""
    text = textwrap.dedent(
        """\
        ```sh
        echo sh
        ```

        <!-- illustration: on
             two lines -->
        ```python
        print(1)
        ```

        ```console
        $ echo hi
        hi
        ```

            python -m porous_weathering --help

        A formula and a message are not commands:

            f = (1 − F) · base/π

        nor

            error: a quoted message

        ```toml
        a = 1
        ```
        """
    )
    path = tmp_path / "probe.md"
    path.write_text(text)
    blocks = collect(path, "probe.md")
    assert [(b.line, b.kind, b.code, b.illustration) for b in blocks] == [
        (1, "shell", "echo sh\n", None),
        (7, "python", "print(1)\n", "on two lines"),
        (11, "shell", "echo hi\n", None),
        (16, "shell", "python -m porous_weathering --help\n", None),
    ]


def heading_anchor(heading: str) -> str:
    """The anchor GitHub gives a Markdown heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors_of(path: pathlib.Path) -> set:
    """The anchors of ``path``'s headings (outside code fences)."""
    found, fenced = set(), False
    for line in path.read_text(encoding="utf-8").splitlines():
        fenced ^= bool(FENCE.match(line))
        if not fenced and line.startswith("#"):
            found.add(heading_anchor(line.lstrip("#")))
    return found


def test_every_link_between_the_docs_reaches_its_file_and_heading():
    broken = []
    for doc in DOCS:
        for link in re.findall(r"\]\(([^)\s]+)\)", doc.read_text(encoding="utf-8")):
            if re.match(r"[a-z]+:", link):
                continue
            path, _, anchor = link.partition("#")
            target = (doc.parent / path).resolve() if path else doc
            if not target.exists():
                broken.append(f"{doc.name}: {link} (no such file)")
            elif anchor and target.suffix == ".md" and anchor not in anchors_of(target):
                broken.append(f"{doc.name}: {link} (no such heading)")
    assert not broken, "\n".join(broken)
    assert heading_anchor(" 8.2 The parameters at a point, and the physical scale") == (
        "82-the-parameters-at-a-point-and-the-physical-scale"
    )


if __name__ == "__main__":
    for block in BLOCKS:
        what = f"illustration: {block.illustration}" if block.illustration is not None else "run"
        if block.illustration is None and adapt(block) != block.code:
            what += " (adapted)"
        print(f"{block.id:28} {block.kind:6} {what}")
