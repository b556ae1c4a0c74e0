"""Normalised snapshots of the node groups the package builds (a test helper, not a test module).

``group_snapshot(tree)`` describes a shader node tree independently of node names, node
locations and the order in which nodes were created, so that two builds of the same maths
compare equal and any change to the maths (a node, a property, a constant, a link) does not.
``all_group_snapshots()`` builds every group the package can build and snapshots each one.

Canonical node ids: a node's id is a hash of everything it computes: its type, its
properties, the constants on its unlinked inputs, and, for each linked input, the id of the
upstream node and which of its outputs feeds it. Ids are computed recursively from the
source nodes (Group Input, Geometry ...), so equal sub-graphs get equal ids whatever their
creation order or names, and a change anywhere changes the id of that node and of every node
downstream of it. Two nodes that compute exactly the same thing share an id: the snapshot
keeps one entry with ``count`` 2.

tests/data/node_groups.json holds the snapshots of the code before the node refactor;
tests/test_node_snapshot.py compares the current code against it.
"""

import hashlib
import itertools
import json
import math

#: Light modes and weathering modes, spelled out here so that the snapshot does not depend on
#: the package's own constants (porous_weathering.nodes.LIGHT_MODES, model.MODES).
LIGHT_MODES = ("SUN", "POINT", "AMBIENT")
WEATHERING_MODES = ("soiling", "wet", "efflorescence")

#: Node properties always recorded when set away from their default, although Node itself
#: defines them (every other property of the Node base class is layout or UI state).
_BASE_PROPERTIES_KEPT = {"label": "", "mute": False}


def _decimals(value, places=6):
    """``value`` rounded to ``places`` decimals, -0.0 as 0.0 (interface defaults and ranges)."""
    if isinstance(value, bool) or not isinstance(value, float):
        return value
    if not math.isfinite(value):
        return repr(value)
    return round(value, places) + 0.0


def _significant(value, digits=6):
    """``value`` rounded to ``digits`` significant digits, -0.0 as 0.0 (node constants: small
    constants such as an epsilon of 1e-6 keep their precision)."""
    if isinstance(value, bool) or not isinstance(value, float):
        return value
    if not math.isfinite(value):
        return repr(value)
    return float(f"{value:.{digits - 1}e}") + 0.0


def _plain(value, rounding):
    """A JSON-able form of an RNA value: floats rounded, arrays as lists, IDs by name."""
    if isinstance(value, (bool, int, str)) or value is None:
        return value
    if isinstance(value, float):
        return rounding(value)
    if isinstance(value, (set, frozenset)):  # enum flags
        return sorted(value)
    if hasattr(value, "name") and hasattr(value, "bl_rna"):  # an ID (image, node tree ...)
        return value.name
    try:
        return [_plain(item, rounding) for item in value]
    except TypeError:
        return repr(value)


# --- the interface ------------------------------------------------------------------------


def interface_snapshot(tree):
    """The tree's interface items in order: sockets (name, in/out, type, default, range,
    description) and panels."""
    items = []
    for item in tree.interface.items_tree:
        if item.item_type == "PANEL":
            items.append({"panel": item.name, "description": item.description})
            continue
        entry = {
            "name": item.name,
            "in_out": item.in_out,
            "socket_type": item.socket_type,
            "description": item.description,
        }
        for key, attribute in (("default", "default_value"), ("min", "min_value"), ("max", "max_value")):
            if hasattr(item, attribute):
                entry[key] = _plain(getattr(item, attribute), _decimals)
        parent = getattr(item, "parent", None)
        if parent is not None and parent.name:  # inside a panel (the root panel has no name)
            entry["panel"] = parent.name
        items.append(entry)
    return items


# --- the nodes ----------------------------------------------------------------------------


def _base_property_names():
    import bpy

    return {prop.identifier for prop in bpy.types.ShaderNode.bl_rna.properties} | {
        prop.identifier for prop in bpy.types.Node.bl_rna.properties
    }


def node_properties(node, base=None):
    """The node's own settings (operation, distribution, data_type, use_clamp ...): every RNA
    property its class adds to Node, plus label and mute when set."""
    base = _base_property_names() if base is None else base
    properties = {}
    for prop in node.bl_rna.properties:
        key = prop.identifier
        if key in base or key == "rna_type" or prop.type == "COLLECTION":
            continue
        if prop.type == "POINTER":
            value = getattr(node, key)
            # IDs (a group's node tree, an image) by name; structs such as texture_mapping
            # are UI/mapping state not used by the groups this package builds.
            if value is None or not hasattr(value, "users"):
                continue
        properties[key] = _plain(getattr(node, key), _significant)
    for key, default in _BASE_PROPERTIES_KEPT.items():
        value = getattr(node, key)
        if value != default:
            properties[key] = value
    return properties


def _socket_key(socket):
    """How a socket is named in a snapshot: its identifier (stable per node type: 'Value',
    'Value_001'), except on group input/output nodes, where the identifier is the interface
    item's creation-order id ('Socket_3') and the name is what matters."""
    if socket.node.bl_idname in ("NodeGroupInput", "NodeGroupOutput"):
        return socket.name
    return socket.identifier


def _available(socket):
    return getattr(socket, "enabled", True) and not getattr(socket, "is_unavailable", False)


def _describe(node, links_into, ids, base):
    """The node's canonical description, upstream ids resolved (``ids`` must hold them)."""
    constants, inputs = {}, {}
    for socket in node.inputs:
        incoming = links_into.get(socket.as_pointer(), [])
        key = _socket_key(socket)
        if incoming:
            sources = sorted(
                [ids[link.from_node.as_pointer()], _socket_key(link.from_socket)]
                + ([] if link.is_valid and not link.is_muted else [f"valid={link.is_valid} muted={link.is_muted}"])
                for link in incoming
            )
            inputs[key] = sources[0] if len(sources) == 1 else sources
        elif _available(socket) and hasattr(socket, "default_value"):
            constants[key] = _plain(socket.default_value, _significant)
    return {"type": node.bl_idname, "properties": node_properties(node, base), "constants": constants, "inputs": inputs}


def _short_type(description):
    name = description["type"].removeprefix("ShaderNode")
    operation = description["properties"].get("operation")
    return f"{name}.{operation}" if operation else name


def _canonical_id(description):
    digest = hashlib.sha256(json.dumps(description, sort_keys=True).encode()).hexdigest()
    return f"{_short_type(description)}:{digest[:12]}"


def node_snapshots(tree):
    """{canonical id: description} of every node in ``tree`` (see the module docstring)."""
    base = _base_property_names()
    links_into = {}
    for link in tree.links:
        links_into.setdefault(link.to_socket.as_pointer(), []).append(link)
    upstream = {
        node.as_pointer(): [
            link.from_node for socket in node.inputs for link in links_into.get(socket.as_pointer(), [])
        ]
        for node in tree.nodes
    }
    ids, descriptions = {}, {}
    visiting = set()

    def visit(node):  # iterative-safe enough: the groups are a few hundred nodes deep at most
        pointer = node.as_pointer()
        if pointer in ids:
            return ids[pointer]
        if pointer in visiting:
            raise ValueError(f"{tree.name}: the node graph has a cycle through {node.name!r}")
        visiting.add(pointer)
        for source in upstream[pointer]:
            visit(source)
        visiting.discard(pointer)
        description = _describe(node, links_into, ids, base)
        node_id = _canonical_id(description)
        ids[pointer] = node_id
        if node_id in descriptions:
            descriptions[node_id]["count"] += 1
        else:
            descriptions[node_id] = {**description, "count": 1}
        return node_id

    import sys

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(tree.nodes) + 1000))
    try:
        for node in tree.nodes:
            visit(node)
    finally:
        sys.setrecursionlimit(limit)
    return descriptions


def group_snapshot(tree):
    """A JSON-able, order- and name-independent description of the shader node ``tree``."""
    return {
        "interface": interface_snapshot(tree),
        "properties": {key: _plain(tree[key], _significant) for key in sorted(tree.keys())},
        "nodes": node_snapshots(tree),
    }


def weathering_mode_sets():
    """Every non-empty subset of the weathering modes, in a fixed order."""
    return [
        modes
        for size in range(1, len(WEATHERING_MODES) + 1)
        for modes in itertools.combinations(WEATHERING_MODES, size)
    ]


def all_group_snapshots():
    """{group name: snapshot} of every group the package builds, built in the current session
    (start from an empty file: a group of the same name and build version already there would
    be reused, not rebuilt)."""
    from porous_weathering.shading import nodes

    groups = [nodes.porous_group(light_mode) for light_mode in LIGHT_MODES]
    groups += [
        nodes.weathered_group(modes, light_mode) for modes in weathering_mode_sets() for light_mode in LIGHT_MODES
    ]
    snapshots = {}
    for group in groups:
        if group.name in snapshots:
            raise ValueError(f"two builds returned the group {group.name!r}")
        snapshots[group.name] = group_snapshot(group)
    return snapshots


def write_snapshots(path):
    """Snapshots of the importable package's groups, built in an empty file, as sorted JSON."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    data = all_group_snapshots()
    with open(path, "w") as file:
        json.dump(data, file, sort_keys=True, indent=1)
        file.write("\n")
    return data


if __name__ == "__main__":
    # Regenerate the baseline from a given checkout of the package, e.g.:
    #   PYTHONPATH=/path/to/checkout .venv-5.2/bin/python tests/snapshots.py tests/data/node_groups.json
    import os
    import sys

    import porous_weathering

    print(f"snapshots of {porous_weathering.__file__}")
    written = write_snapshots(sys.argv[1])
    print(f"{len(written)} groups -> {sys.argv[1]}")
    sys.stdout.flush()
    os._exit(0)  # bpy 4.5 can hang in a static destructor at interpreter exit (tests/conftest.py)
