"""The node groups are the same maths, node for node, as the baseline snapshot.

tests/data/node_groups.json was captured from the code before the node-builder refactor
(identical on Blender 4.5 and 5.2), with tests/snapshots.py. A difference in a group's
interface, its properties or any node (type, setting, constant, link) fails that group's
test with a diff that names the first nodes that differ. If the maths is meant to change,
regenerate the baseline (see the end of tests/snapshots.py) in the same commit.
"""

import json
import pathlib

import bpy

import pytest

from snapshots import all_group_snapshots

BASELINE_PATH = pathlib.Path(__file__).resolve().parent / "data" / "node_groups.json"
BASELINE = json.loads(BASELINE_PATH.read_text())


@pytest.fixture(scope="module")
def current():
    bpy.ops.wm.read_factory_settings(use_empty=True)  # groups of earlier tests are not reused
    return all_group_snapshots()


# --- a readable diff ----------------------------------------------------------------------


def _show(value):
    return json.dumps(value, sort_keys=True)


def _reaches(source, ids):
    return any(upstream[0] in ids for upstream in ([source] if isinstance(source[0], str) else source))


def _outputs_fed(nodes, node_id):
    """The group outputs whose value depends on ``node_id``."""
    downstream = {}
    for key, node in nodes.items():
        for source in node["inputs"].values():
            for upstream in [source] if isinstance(source[0], str) else source:
                downstream.setdefault(upstream[0], set()).add(key)
    reached, todo = {node_id}, [node_id]
    while todo:
        for key in downstream.get(todo.pop(), ()):
            if key not in reached:
                reached.add(key)
                todo.append(key)
    return sorted(
        name
        for key in reached
        if nodes[key]["type"] == "NodeGroupOutput"
        for name, source in nodes[key]["inputs"].items()
        if _reaches(source, reached)
    )


def _upstream_ids(node):
    return {
        upstream[0]
        for source in node["inputs"].values()
        for upstream in ([source] if isinstance(source[0], str) else source)
    }


def _first_differences(only_here, here, there):
    """Nodes of ``only_here`` whose upstream nodes all exist in ``there``: where a change starts
    (every node downstream of a changed node has a new id too)."""
    return sorted(key for key in only_here if _upstream_ids(here[key]) <= set(there))


def _field_diff(old, new):
    lines = []
    for field in ("type", "properties", "constants", "inputs"):
        if field == "type":
            if old["type"] != new["type"]:
                lines.append(f"      type: {old['type']} -> {new['type']}")
            continue
        for key in sorted(set(old[field]) | set(new[field])):
            a, b = old[field].get(key, "<absent>"), new[field].get(key, "<absent>")
            if a != b:
                lines.append(f"      {field}[{key}]: {_show(a)} -> {_show(b)}")
    return lines


def node_differences(expected, actual):
    """Readable lines for the node differences between two snapshots' ``nodes``."""
    only_expected = set(expected) - set(actual)
    only_actual = set(actual) - set(expected)
    lines = [
        f"  nodes: {len(only_expected)} of {len(expected)} baseline node ids are gone, "
        f"{len(only_actual)} of {len(actual)} current node ids are new "
        "(a change also renews the id of every node downstream of it)"
    ]
    removed = _first_differences(only_expected, expected, actual)
    added = _first_differences(only_actual, actual, expected)
    for new_id in list(added):
        new = actual[new_id]
        # the baseline node it most likely replaces: same type and same upstream nodes
        candidates = [
            old_id
            for old_id in removed
            if expected[old_id]["type"] == new["type"] and expected[old_id]["inputs"] == new["inputs"]
        ]
        candidates = candidates or [
            old_id
            for old_id in removed
            if expected[old_id]["type"] == new["type"] and _upstream_ids(expected[old_id]) == _upstream_ids(new)
        ]
        if len(candidates) == 1:
            old_id = candidates[0]
            removed.remove(old_id)
            added.remove(new_id)
            lines.append(f"    changed {old_id} -> {new_id} (feeds {', '.join(_outputs_fed(actual, new_id))}):")
            lines += _field_diff(expected[old_id], new)
    for old_id in removed:
        lines.append(
            f"    baseline only: {old_id} (fed {', '.join(_outputs_fed(expected, old_id))}) "
            f"{_show({k: v for k, v in expected[old_id].items() if k != 'count'})}"
        )
    for new_id in added:
        lines.append(
            f"    current only: {new_id} (feeds {', '.join(_outputs_fed(actual, new_id))}) "
            f"{_show({k: v for k, v in actual[new_id].items() if k != 'count'})}"
        )
    for key in sorted(set(expected) & set(actual)):
        if expected[key]["count"] != actual[key]["count"]:
            lines.append(
                f"    {key}: {expected[key]['count']} identical node(s) in the baseline, {actual[key]['count']} now"
            )
    return lines


def group_differences(expected, actual):
    """Readable lines for every difference between two group snapshots ([] when equal)."""
    lines = []
    old_items, new_items = expected["interface"], actual["interface"]
    for index in range(max(len(old_items), len(new_items))):
        old = old_items[index] if index < len(old_items) else "<absent>"
        new = new_items[index] if index < len(new_items) else "<absent>"
        if old != new:
            lines.append(f"  interface item {index}: {_show(old)}\n                     now: {_show(new)}")
    if expected["properties"] != actual["properties"]:
        lines.append(f"  tree properties: {_show(expected['properties'])} -> {_show(actual['properties'])}")
    if expected["nodes"] != actual["nodes"]:
        lines += node_differences(expected["nodes"], actual["nodes"])
    return lines


# --- the tests ----------------------------------------------------------------------------


def test_the_same_groups_are_built(current):
    assert sorted(current) == sorted(BASELINE)


@pytest.mark.parametrize("name", sorted(BASELINE))
def test_group_matches_the_baseline(current, name):
    if name not in current:
        pytest.fail(f"{name}: not built any more (built: {sorted(current)})")
    lines = group_differences(BASELINE[name], current[name])
    if lines:
        pytest.fail(f"{name} differs from {BASELINE_PATH.name}:\n" + "\n".join(lines), pytrace=False)
