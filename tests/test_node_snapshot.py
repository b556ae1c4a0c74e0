"""The node groups are the same maths, node for node, as their snapshot.

Every group the package builds is one case: the porous group in each light mode, the
weathered group of every non-empty set of registered weathering modes in each light mode (with
and without the receptivity of a stone's structure, and with its rivulets), the group of every preset's stone, its
masonry group and its group of the mesh's blocks, read from the registries (``modes.names()``,
``nodes.LIGHT_MODES``, ``presets.PRESETS``), so a new mode or light mode is covered by
construction. ``group_data`` turns a group into plain data (its interface, its
properties and its nodes: type, settings, constants and links) that syrupy compares with
tests/__snapshots__/test_node_snapshot.ambr; one snapshot serves Blender 4.5 and 5.2. If a group
is meant to change, regenerate it in the same commit:
``python -m pytest tests/test_node_snapshot.py --snapshot-update``.
"""

import hashlib
import json
import math

import bpy

import pytest

from helpers import weathered_mode_sets
from porous_weathering.core import stones
from porous_weathering.core.modes import names as modes_names
from porous_weathering.shading import nodes
from porous_weathering.shading.presets import PRESETS

# --- a node group as plain data -------------------------------------------------------------


def _rounded(value, digits):
    """Floats to ``digits`` significant digits (-0.0 as 0.0), the rest as they are."""
    if isinstance(value, bool) or not isinstance(value, float):
        return value
    return float(f"{value:.{digits - 1}e}") + 0.0 if math.isfinite(value) else repr(value)


def _plain(value):
    """An RNA value as plain data: floats rounded, arrays as lists, enum flags sorted, IDs by name."""
    if isinstance(value, (bool, int, str, float)) or value is None:
        return _rounded(value, 6)
    if isinstance(value, (set, frozenset)):
        return sorted(value)
    if hasattr(value, "name") and hasattr(value, "bl_rna"):
        return value.name
    try:
        return [_plain(item) for item in value]
    except TypeError:
        return repr(value)


def _interface(tree):
    """The interface items in order: sockets (name, direction, type, description, default, range,
    panel) and panels."""
    items = []
    for item in tree.interface.items_tree:
        if item.item_type == "PANEL":
            items.append({"panel": item.name, "description": item.description})
            continue
        entry = {"name": item.name, "in_out": item.in_out, "socket_type": item.socket_type}
        entry["description"] = item.description
        for key, attribute in (("default", "default_value"), ("min", "min_value"), ("max", "max_value")):
            if hasattr(item, attribute):
                entry[key] = _plain(getattr(item, attribute))
        if getattr(item, "parent", None) is not None and item.parent.name:  # the root panel has no name
            entry["panel"] = item.parent.name
        items.append(entry)
    return items


#: Properties every node has (layout and UI state), but label and mute, kept when set.
BASE_PROPERTIES = {p.identifier for cls in (bpy.types.Node, bpy.types.ShaderNode) for p in cls.bl_rna.properties}
KEPT_BASE_PROPERTIES = {"label": "", "mute": False}


def _settings(node):
    """A node's own settings (operation, data_type, use_clamp, a group's tree ...)."""
    settings = {}
    for prop in node.bl_rna.properties:
        key = prop.identifier
        if key in BASE_PROPERTIES or prop.type == "COLLECTION":
            continue
        if prop.type == "POINTER" and not hasattr(getattr(node, key), "users"):
            continue  # structs such as texture_mapping: not used by these groups; IDs by name
        settings[key] = _plain(getattr(node, key))
    settings.update(
        {key: getattr(node, key) for key, unset in KEPT_BASE_PROPERTIES.items() if getattr(node, key) != unset}
    )
    return settings


def _socket_key(socket):
    """A socket's identifier ('Value_001'), but the name on group input/output nodes (whose
    identifiers count interface items in creation order)."""
    return socket.name if socket.node.bl_idname in ("NodeGroupInput", "NodeGroupOutput") else socket.identifier


def _nodes(tree):
    """{node id: node} of every node. A node's id is its short type and a hash of what it
    computes (type, settings, constants of its unlinked available inputs, and for linked ones the
    ids and sockets upstream), so node names, locations and creation order do not matter, and
    nodes computing the same thing share an entry (``count``)."""
    links_into = {}
    for link in tree.links:
        links_into.setdefault(link.to_socket.as_pointer(), []).append(link)
    ids, entries = {}, {}

    def visit(node):
        if node.as_pointer() in ids:
            return ids[node.as_pointer()]
        constants, inputs = {}, {}
        for socket in node.inputs:
            incoming = links_into.get(socket.as_pointer(), [])
            if incoming:
                sources = sorted(
                    [visit(link.from_node), _socket_key(link.from_socket)]
                    + ([] if link.is_valid and not link.is_muted else [f"valid={link.is_valid} muted={link.is_muted}"])
                    for link in incoming
                )
                inputs[_socket_key(socket)] = sources[0] if len(sources) == 1 else sources
            elif socket.enabled and not getattr(socket, "is_unavailable", False) and hasattr(socket, "default_value"):
                constants[_socket_key(socket)] = _plain(socket.default_value)
        entry = {"type": node.bl_idname, "properties": _settings(node), "constants": constants, "inputs": inputs}
        operation = entry["properties"].get("operation")
        digest = hashlib.sha256(json.dumps(entry, sort_keys=True).encode()).hexdigest()[:12]
        node_id = f"{node.bl_idname.removeprefix('ShaderNode')}{'.' + operation if operation else ''}:{digest}"
        ids[node.as_pointer()] = node_id
        entries.setdefault(node_id, {**entry, "count": 0})["count"] += 1
        return node_id

    for node in tree.nodes:
        visit(node)
    return entries


def group_data(tree):
    """The shader node group ``tree`` as plain data: interface, custom properties and nodes."""
    return {
        "interface": _interface(tree),
        "properties": {key: _plain(tree[key]) for key in sorted(tree.keys())},
        "nodes": _nodes(tree),
    }


# --- every group the package builds ----------------------------------------------------------


@pytest.mark.parametrize("light_mode", nodes.LIGHT_MODES)
def test_porous_group_matches_its_snapshot(light_mode, snapshot):
    assert group_data(nodes.porous_group(light_mode)) == snapshot


@pytest.mark.parametrize("light_mode", nodes.LIGHT_MODES)
@pytest.mark.parametrize("modes", weathered_mode_sets(), ids="+".join)
def test_weathered_group_matches_its_snapshot(modes, light_mode, snapshot):
    assert group_data(nodes.weathered_group(modes, light_mode)) == snapshot


@pytest.mark.parametrize("light_mode", nodes.LIGHT_MODES)
@pytest.mark.parametrize("modes", weathered_mode_sets(), ids="+".join)
def test_receptive_weathered_group_matches_its_snapshot(modes, light_mode, snapshot):
    """The group of a material with a stone's structure (docs/model.md §8.3)."""
    assert group_data(nodes.weathered_group(modes, light_mode, receptive=True)) == snapshot


@pytest.mark.parametrize("modes", [(name,) for name in modes_names() if nodes.uses_runoff((name,))], ids="+".join)
def test_rivulet_weathered_group_matches_its_snapshot(modes, snapshot):
    """The group of a material with a stone whose run-off gathers into rivulets (docs/model.md §8.8):
    each mode that reads the run-off map, in one light mode (the rivulets' nodes are the same in
    every light mode and set of modes)."""
    assert group_data(nodes.weathered_group(modes, nodes.SUN, receptive=True, rivulets=True)) == snapshot


@pytest.mark.parametrize("key", [key for key, preset in PRESETS.items() if preset.structure is not None])
def test_stone_group_matches_its_snapshot(key, snapshot):
    assert group_data(nodes.stone_group(key, PRESETS[key].structure)) == snapshot


@pytest.mark.parametrize("key", [key for key, preset in PRESETS.items() if preset.structure is not None])
def test_masonry_group_matches_its_snapshot(key, snapshot):
    """The group of a stone laid as coursed ashlar (docs/model.md §8.5)."""
    assert group_data(nodes.masonry_group(key, PRESETS[key].structure)) == snapshot


@pytest.mark.parametrize("key", [key for key, preset in PRESETS.items() if preset.structure is not None])
def test_mesh_blocks_group_matches_its_snapshot(key, snapshot):
    """The group of a stone laid in the blocks the mesh knows (docs/model.md §8.5)."""
    group = nodes.mesh_blocks_group(key, PRESETS[key].structure, stones.MeshBlocks().attribute)
    assert group_data(group) == snapshot
