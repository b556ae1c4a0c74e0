"""A porous material made from an artist's existing material keeps its texture images."""

import bpy

import pytest

from porous_weathering.blender import compat
from porous_weathering.shading import material


def textured_principled(name="Scan"):
    source = compat.new_material(name)
    tree = source.node_tree
    bsdf = next(node for node in tree.nodes if node.type == "BSDF_PRINCIPLED")
    for socket_name in ("Base Color", "Roughness"):
        texture = tree.nodes.new("ShaderNodeTexImage")
        texture.image = bpy.data.images.new(f"{name} {socket_name}", 4, 4)
        tree.links.new(texture.outputs["Color"], bsdf.inputs[socket_name])
    return source


def image_feeding(socket):
    return socket.links[0].from_node.image if socket.is_linked else None


def test_keeps_base_colour_and_roughness_images():
    source = textured_principled()
    nodes_before = len(source.node_tree.nodes)
    porous = material.make_porous_from_material(source, porosity=0.3)
    group = porous.node_tree.nodes["Porous"]
    assert image_feeding(group.inputs["Base Color"]) is bpy.data.images["Scan Base Color"]
    assert image_feeding(group.inputs["Roughness"]) is bpy.data.images["Scan Roughness"]
    assert group.inputs["Porosity"].default_value == pytest.approx(0.3)  # the other parameters still apply
    assert len(source.node_tree.nodes) == nodes_before and porous.name == "Scan Porous"


def test_material_without_images_uses_the_given_colour():
    source = compat.new_material("Plain")
    porous = material.make_porous_from_material(source, base_color=(0.2, 0.3, 0.4))
    group = porous.node_tree.nodes["Porous"]
    assert not group.inputs["Base Color"].is_linked and not group.inputs["Roughness"].is_linked
    assert tuple(group.inputs["Base Color"].default_value)[:3] == pytest.approx((0.2, 0.3, 0.4))
