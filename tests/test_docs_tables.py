"""Records, not lists, in the docs too: the hand-written tables of docs/api.md (the weathering
inputs: keyword, modes, default) and docs/cli.md (the ``bake`` command's flags and defaults) say
what the registries say, both ways. A mode, an input, a map or a bake option added to a registry
without its row fails here, and so does a row the registries lack (a toy mode and a toy map,
defined below, show it)."""

import argparse
import pathlib
import re

from porous_weathering.cli import bake as bake_command
from porous_weathering.core import model, modes
from porous_weathering.maps import bake
from porous_weathering.maps import registry as maps

DOCS = pathlib.Path(__file__).resolve().parent.parent / "docs"
CODE = re.compile(r"`([^`]*)`")
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?")


def cells(line):
    """The cells of one Markdown table row (``\\|`` inside a cell is not a separator)."""
    return [cell.strip().replace("\\|", "|") for cell in re.split(r"(?<!\\)\|", line.strip().strip("|"))]


def table(text, header, after=None):
    """The rows (lists of cells) of the table whose header row starts with ``header``, the first
    one after the line ``after`` when given."""
    lines = text.splitlines()
    start = lines.index(after) if after else 0
    for index in range(start, len(lines)):
        if lines[index].startswith(header):
            rows = []
            for line in lines[index + 2 :]:
                if not line.startswith("|"):
                    break
                rows.append(cells(line))
            return rows
    raise AssertionError(f"no table with the header {header!r}" + (f" after {after!r}" if after else ""))


def same_number(text, value):
    found = NUMBER.findall(text)
    return len(found) == 1 and float(found[0]) == float(value)


# --- docs/api.md: the weathering inputs of make_weathered_material


def api_text():
    return (DOCS / "api.md").read_text(encoding="utf-8")


def weathering_rows(text):
    """{keyword: (modes cell, default cell)} of api.md's table of weathering inputs."""
    rows = {}
    for keyword, used_by, default, *_ in table(text, "| keyword | modes | default |"):
        for name in CODE.findall(keyword):
            assert name not in rows, f"api.md: {name!r} has two rows"
            rows[name] = (used_by, default)
    return rows


def documented_modes(cell):
    return set(modes.names()) if cell == "all" else {word.strip() for word in cell.split(",")}


def documented_default(cell, default):
    """Whether the default cell shows ``default``: a number, or a colour as (r, g, b)."""
    if isinstance(default, tuple):
        found = NUMBER.findall(cell)
        return len(found) == len(default) and all(float(a) == float(b) for a, b in zip(found, default))
    return same_number(cell, default)


def weathering_problems(text=None):
    """What api.md's weathering table and the mode registry disagree on (empty: nothing)."""
    rows, registry = weathering_rows(api_text() if text is None else text), model.WEATHERING_INPUTS
    problems = [f"api.md lists {name!r}, which no registered mode has" for name in rows if name not in registry]
    for item in modes.inputs().values():
        default, _low, _high, used_by = registry[item.name]
        assert default == item.default
        if item.name not in rows:
            problems.append(f"api.md lacks the weathering input {item.name!r}")
            continue
        modes_cell, default_cell = rows[item.name]
        if documented_modes(modes_cell) != set(used_by):
            problems.append(f"api.md: {item.name!r} is used by {', '.join(used_by)}, not {modes_cell!r}")
        if not documented_default(default_cell, default):
            problems.append(f"api.md: {item.name!r} defaults to {default!r}, not {default_cell!r}")
    return problems


def test_api_weathering_table_is_the_mode_registry():
    assert weathering_problems() == []


# --- docs/cli.md: the bake command's flags


def flag_rows(heading):
    """{flag: default cell} of the cli.md table under ``heading``."""
    text = (DOCS / "cli.md").read_text(encoding="utf-8")
    rows = {}
    for words, _meaning, default in table(text, "| option | meaning | default |", after=heading):
        spans = CODE.findall(words)
        assert spans, f"cli.md: a row without its option in code: {words!r}"
        flag = spans[0].split()[0]
        assert flag not in rows, f"cli.md: {flag} has two rows"
        rows[flag] = default
    return rows


def shows_default(cell, default):
    """Whether a default cell shows ``default``: None is "unset: …"; a string is the first code
    span; no maps at all (``()``) is every registered map, named in the code span."""
    if default is None:
        return cell.startswith("unset")
    spans = CODE.findall(cell)
    if isinstance(default, tuple):
        return bool(spans) and spans[0] == ",".join(default or maps.names())
    if isinstance(default, bool):
        return cell.split(":")[0] == ("on" if default else "off")
    if isinstance(default, str):
        return bool(spans) and spans[0] == default
    return same_number(cell, default)


def bake_option_problems():
    """What cli.md's bake-option table and the option registry disagree on (empty: nothing)."""
    rows = flag_rows("## Bake options")
    flagged = [entry for entry in bake.option_entries() if entry.option.flag]
    known = {entry.option.flag for entry in flagged}
    problems = [f"cli.md lists {flag}, which no bake option has" for flag in rows if flag not in known]
    for entry in flagged:
        flag = entry.option.flag
        if flag not in rows:
            problems.append(f"cli.md lacks the bake option {flag} ({entry.owner or 'general'}: {entry.name})")
        elif not shows_default(rows[flag], entry.default):
            problems.append(f"cli.md: {flag} defaults to {entry.default!r}, not {rows[flag]!r}")
    return problems


def test_cli_bake_option_table_is_the_option_registry():
    assert bake_option_problems() == []


def test_cli_own_arguments_table_is_the_parser():
    """The other table holds the command's own arguments: every one of them, and nothing else."""
    parser = argparse.ArgumentParser()
    bake_command.configure_parser(parser)
    registered = {entry.option.flag for entry in bake.option_entries()}
    own = set()
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        names = action.option_strings or [action.metavar]
        if not registered.intersection(names):
            own.add(names[0])
    assert set(flag_rows("## Files, objects and how the run goes")) == own


# --- a toy mode and a toy map make the tables out of date


def test_a_toy_mode_makes_the_api_table_out_of_date(toys):
    problems = weathering_problems()
    assert "api.md lacks the weathering input 'grime'" in problems
    # a row that says "all" (every registered mode, the toy too) is wrong for an input the toy lacks
    row = "| `front_width` | soiling, wet, efflorescence |"
    problems = weathering_problems(api_text().replace(row, "| `front_width` | all |", 1))
    assert any(problem.startswith("api.md: 'front_width' is used by") for problem in problems)


def test_a_toy_map_makes_the_cli_table_out_of_date(toys):
    problems = bake_option_problems()
    assert "cli.md lacks the bake option --toy-level (toy: level)" in problems
    # --maps defaults to every map, which now includes the toy
    assert any(problem.startswith("cli.md: --maps defaults to") for problem in problems)


def test_a_row_the_registries_lack_is_found():
    row = "| `time` | soiling, wet, efflorescence | 0 |"
    extra = api_text().replace(row, "| `moss` | soiling | 0 | toy row |\n" + row, 1)
    assert weathering_problems(extra) == ["api.md lists 'moss', which no registered mode has"]
