"""The node builder's choices of nodes (shader_math.py): the maths stays the same, the nodes a
shaded point evaluates get fewer.  What the groups compute is checked by the render tests."""

import itertools

import bpy

import pytest

from porous_weathering.core import modes
from porous_weathering.core.shader_math import Graph, dot, front, minimum, mix, multiply_add, power, smoothstep
from porous_weathering.shading import nodes


def scratch_graph():
    """(graph, a per-point scalar N.I, constant scalars c and d, a constant colour k)."""
    tree = bpy.data.node_groups.new("Scratch", "ShaderNodeTree")
    for name, socket_type in (("c", "NodeSocketFloat"), ("d", "NodeSocketFloat"), ("k", "NodeSocketColor")):
        tree.interface.new_socket(name, in_out="INPUT", socket_type=socket_type)
    graph = Graph(tree)
    group_in = graph.node("NodeGroupInput", depth=0)
    geometry = graph.node("ShaderNodeNewGeometry", depth=0)
    point = dot(graph.wrap(geometry.outputs["Normal"]), graph.wrap(geometry.outputs["Incoming"]))
    c, d, k = (graph.wrap(group_in.outputs[name]) for name in ("c", "d", "k"))
    return graph, point, c, d, k


def varying_nodes(graph, operation):
    nodes_of = [node for node in graph.tree.nodes if getattr(node, "operation", None) == operation]
    return [node for node in nodes_of if graph.varies(node.outputs[0])]


def test_constant_factors_gather_so_that_cycles_folds_them():
    graph, x, c, d, _ = scratch_graph()
    product = (x * c) * d
    assert not graph.varies(product.product[1])  # c d: one node of constants, which Cycles folds
    assert product.product[0] is x and len(varying_nodes(graph, "MULTIPLY")) == 2  # x c is left unused
    # with a second per-point factor the constants still come last, whatever the order
    y = x * x
    assert ((x * c) * y).product == ((y * x) * c).product == (x * y, c)
    assert x * 1.0 is x


def test_a_colour_scaled_twice_is_scaled_once():
    graph, x, c, _, k = scratch_graph()
    scaled = (k * x) * c
    assert scaled.scaled[0] is k and scaled.scaled[1].product == (x, c)
    assert (k * c) * x is scaled  # the same node whichever factor comes first


def test_constant_terms_join_a_multiply_adds_addend():
    graph, x, c, d, _ = scratch_graph()
    sum_ = multiply_add(x, c, 2.0) + d - 1.0 + 0.0
    assert len(varying_nodes(graph, "MULTIPLY_ADD")) == 3  # one per term; the group drops the first two
    assert sum_.affine[:2] == (x, c) and not graph.varies(sum_.affine[2])  # 2 + d - 1: folded
    assert not varying_nodes(graph, "ADD") and not varying_nodes(graph, "SUBTRACT")
    assert multiply_add(1.0, x, 0.0) is x and multiply_add(0.0, x, c) is c
    # a per-point term is not a constant: it stays a node of its own
    assert (multiply_add(x, c, 2.0) + x).affine is None
    # a constant times a multiply-add, plus a constant, is one multiply-add of the same x
    scaled = multiply_add(c, multiply_add(x, -1.0, 3.7), d)
    assert scaled.affine[0] is x and not graph.varies(scaled.affine[1]) and not graph.varies(scaled.affine[2])


def test_per_point_forms_take_one_node_each():
    """The forms the stone's per-point values take (docs/model.md §8.9): each a node per point."""
    graph, x, c, d, k = scratch_graph()
    operation = lambda expr: expr.socket.node.operation  # noqa: E731
    assert (x * c / 2.0).product[0] is x  # (x c) / 2 is x (c / 2)
    assert operation(1.0 - (c - x)) == "ADD"  # x + (1 - c)
    kept = 1.0 - minimum(c - x, 0.5)  # max(x + (1 - c), 0.5)
    assert operation(kept) == "MAXIMUM" and kept.socket.node.inputs[0].links[0].from_socket.node.operation == "ADD"
    assert operation(c * (1.0 - x)) == "MULTIPLY_ADD"  # c - c x
    normal = graph.wrap(graph.node("ShaderNodeNewGeometry").outputs["Normal"])
    assert operation(1.0 - 0.5 * normal) == "MULTIPLY_ADD"  # a colour's 1 - s v
    swapped = mix(1.0 - x, 0.2, 0.7)  # the Mix by x of 0.7 and 0.2
    assert swapped.socket.node.inputs[0].links[0].from_socket == x.socket
    assert power(x, 1.0) is x
    edge = front(x * d, x * c, 0.0, d).socket.node  # the mask moved by the advance, the edges constant
    assert edge.inputs["Value"].links[0].from_socket.node.operation == "MULTIPLY_ADD"
    edges = [link.from_socket for name in ("From Min", "From Max") for link in edge.inputs[name].links]
    assert edge.inputs["From Min"].default_value == 1.0 and not any(graph.varies(socket) for socket in edges)


def test_a_constant_times_a_smoothstep_is_its_map_range_to_that_constant():
    """c smoothstep(e0, e1, x) is the smoothstep's Map Range to [0, c] (0 + f (c - 0): f c to the
    bit), no Multiply node per point; a per-point factor stays a product."""
    graph, x, c, _, _ = scratch_graph()
    ramp = smoothstep(0.1, 0.3, x)
    scaled = c * ramp
    node = scaled.socket.node
    assert node.bl_idname == "ShaderNodeMapRange" and node.inputs["To Max"].links[0].from_socket == c.socket
    assert node.inputs["Value"].links[0].from_socket == x.socket and scaled.ramp is None  # not folded twice
    assert (ramp * 0.5).socket.node.inputs["To Max"].default_value == 0.5 and (ramp * 0.5).bounds == (0.0, 0.5)
    assert ramp * 1.0 is ramp and not varying_nodes(graph, "MULTIPLY")
    assert (scaled * x).socket.node.operation == "MULTIPLY"


def test_a_mask_input_varies_from_point_to_point():
    tree = bpy.data.node_groups.new("Masks", "ShaderNodeTree")
    for name in ("mask", "level"):
        tree.interface.new_socket(name, in_out="INPUT", socket_type="NodeSocketFloat")
    graph = Graph(tree)
    group_in = graph.node("NodeGroupInput", depth=0)
    mask, level = graph.wrap_varying(group_in.outputs["mask"]), graph.wrap(group_in.outputs["level"])
    assert graph.varies(mask) and not graph.varies(level)
    assert (mask * level * 2.0).product == (mask, level * 2.0)  # the constants gather behind the mask


def test_the_points_own_data_is_one_node_and_what_is_built_from_it_is_built_once():
    """The shading geometry and the object's data are one node each in a tree, so that what two
    parts build from them is built once: the rivulets and the lichens both take the point's place
    in metres (docs/model.md §8.8, §9.3), one Subtract and one Scale on a stone with both."""
    graph, _, c, _, _ = scratch_graph()
    assert graph.node("ShaderNodeNewGeometry", depth=0) is graph.node("ShaderNodeNewGeometry", depth=0)
    assert nodes.point_in_metres(graph, {"Metres Per Unit": c}) is nodes.point_in_metres(graph, {"Metres Per Unit": c})
    group = nodes.weathered_group(modes.names(), nodes.SUN, receptive=True, rivulets=True)
    kinds = [node.bl_idname for node in group.nodes]
    assert kinds.count("ShaderNodeNewGeometry") == kinds.count("ShaderNodeObjectInfo") == 1
    from_origin = [
        node
        for node in group.nodes
        if any(link.from_node.bl_idname == "ShaderNodeObjectInfo" for socket in node.inputs for link in socket.links)
    ]
    assert len(from_origin) == 1  # the point less the object's location, in one Subtract


@pytest.mark.parametrize("light_mode", nodes.LIGHT_MODES)
def test_every_node_of_a_group_feeds_an_output(light_mode):
    for count in range(len(modes.names()) + 1):
        for mode_set in itertools.combinations(modes.names(), count):
            group = nodes.weathered_group(mode_set, light_mode)
            used = {node.name for node in group.nodes if node.bl_idname in ("NodeGroupInput", "NodeGroupOutput")}
            changed = True
            while changed:
                sources = {link.from_node.name for link in group.links if link.to_node.name in used}
                changed = not sources <= used
                used |= sources
            assert used == {node.name for node in group.nodes}, group.name
