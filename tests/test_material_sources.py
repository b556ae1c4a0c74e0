"""A porous material made from an artist's existing material keeps its texture images, or a
scan's vertex colours; the condition survey reads them as the render does."""

import bpy

import numpy as np
import pytest

from porous_weathering import survey
from porous_weathering.blender import compat, render
from porous_weathering.contracts import map_attribute
from porous_weathering.maps import linking
from porous_weathering.samples import studio
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


def dressed_plane(scene, source):
    """A plane whose own material is ``source``, as Make finds an artist's object or a scan."""
    plane = studio.add_plane(scene, "Dressed")
    plane.data.materials.append(source)
    return plane


def test_keeps_base_colour_and_roughness_images(fresh_scene):
    source = textured_principled()
    nodes_before = len(source.node_tree.nodes)
    plane = dressed_plane(fresh_scene, source)
    porous = linking.weathered_material_for(plane, (), preset=None, stone={"porosity": 0.3})
    group = porous.node_tree.nodes["Porous"]
    assert image_feeding(group.inputs["Base Color"]) is bpy.data.images["Scan Base Color"]
    assert image_feeding(group.inputs["Roughness"]) is bpy.data.images["Scan Roughness"]
    assert group.inputs["Porosity"].default_value == pytest.approx(0.3)  # the other parameters still apply
    assert len(source.node_tree.nodes) == nodes_before and porous.name == "Scan Porous"


def test_material_without_images_uses_the_given_colour(fresh_scene):
    plane = dressed_plane(fresh_scene, compat.new_material("Plain"))
    porous = linking.weathered_material_for(plane, (), preset=None, stone={"base_color": (0.2, 0.3, 0.4)})
    group = porous.node_tree.nodes["Porous"]
    assert not group.inputs["Base Color"].is_linked and not group.inputs["Roughness"].is_linked
    assert tuple(group.inputs["Base Color"].default_value)[:3] == pytest.approx((0.2, 0.3, 0.4))


def coloured_plane(scene, colours):
    """A plane whose corners hold ``colours`` (4, 3; linear) in the byte colour attribute "Col",
    as a PLY scan's import makes it, and a baked map's attribute beside it."""
    plane = studio.add_plane(scene, "Scan")
    col = plane.data.color_attributes.new("Col", "BYTE_COLOR", "CORNER")
    col.data.foreach_set("color", np.column_stack([colours, np.ones(4)]).astype(np.float32).ravel())
    plane.data.color_attributes.new(map_attribute("rain"), "FLOAT_COLOR", "CORNER")
    plane.data.color_attributes.active_color = plane.data.color_attributes[map_attribute("rain")]
    return plane


def attribute_feeding(material_made):
    """The colour attribute the base colour of ``material_made``'s Porous group reads, if any."""
    socket = material_made.node_tree.nodes["Porous"].inputs["Base Color"]
    node = socket.links[0].from_node if socket.is_linked else None
    return node.attribute_name if node is not None and node.type == "ATTRIBUTE" else None


@pytest.mark.parametrize("reader", ["ShaderNodeVertexColor", "ShaderNodeAttribute"])
def test_keeps_the_vertex_colours_a_material_reads(fresh_scene, reader):
    source = compat.new_material("Scan")
    tree = source.node_tree
    bsdf = next(node for node in tree.nodes if node.type == "BSDF_PRINCIPLED")
    node = tree.nodes.new(reader)
    setattr(node, "layer_name" if reader == "ShaderNodeVertexColor" else "attribute_name", "Col")
    tree.links.new(node.outputs["Color"], bsdf.inputs["Base Color"])
    assert material.principled_textures(source) == {"Base Color": material.ColorAttribute("Col")}
    assert (
        attribute_feeding(linking.weathered_material_for(dressed_plane(fresh_scene, source), (), preset=None)) == "Col"
    )


def test_make_on_a_scan_with_vertex_colours_and_no_material_reads_them(fresh_scene):
    # a PLY scan: its colours in a colour attribute, no material; the object's own material is them,
    # not a baked map's attribute (even an active one)
    plane = coloured_plane(fresh_scene, np.full((4, 3), 0.5))
    assert linking.scan_colours(plane) == material.ColorAttribute("Col")
    made = linking.weathered_material_for(plane, ("soiling",), preset=None)
    assert attribute_feeding(made) == "Col"
    plain = studio.add_plane(fresh_scene, "Plain")
    assert linking.scan_colours(plain) is None
    assert attribute_feeding(linking.weathered_material_for(plain, (), preset=None)) is None


def test_the_survey_reads_the_vertex_colours_as_the_render_does(fresh_scene):
    colours = np.array([[0.6, 0.2, 0.1], [0.2, 0.6, 0.1], [0.1, 0.2, 0.6], [0.4, 0.4, 0.4]])
    plane = coloured_plane(fresh_scene, colours)
    plane.data.materials.append(linking.weathered_material_for(plane, ("soiling",), preset=None))
    found = survey.points.surface(plane)
    kd = survey.points.material_of(plane, 0, found).readers["kd"]
    stored = np.array([tuple(c.color)[:3] for c in plane.data.color_attributes["Col"].data])  # bytes: rounded
    np.testing.assert_allclose(stored, colours, atol=0.01)
    corners = np.eye(3)  # each triangle's corners, as barycentric weights
    read = kd(np.arange(len(found.loops)), corners)  # (triangles, 3 corners, RGB)
    np.testing.assert_allclose(read, stored[found.loops], atol=1e-6)


def test_a_colour_attribute_renders_as_the_colour_it_holds(fresh_scene):
    # the Attribute node feeds k_d: vertex colours c render as base_color=c, pixel for pixel
    colour = (0.55, 0.42, 0.3)
    plane = studio.add_plane(fresh_scene, "Scan")
    col = plane.data.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
    col.data.foreach_set("color", np.tile([*colour, 1.0], 4).astype(np.float32))
    sun = studio.add_sun(fresh_scene, towards=(0.3, -0.2, 1.0))
    studio.add_ortho_camera(fresh_scene)
    render.use_cycles(fresh_scene)
    renders = []
    for base_color in (material.ColorAttribute("Col"), colour):
        plane.data.materials.clear()
        plane.data.materials.append(material.make_porous_material("Stone", base_color=base_color, key_light=sun))
        renders.append(render.render_array(fresh_scene))
    assert renders[1][..., :3].max() > 0.1  # the plane is in the picture, lit
    np.testing.assert_allclose(renders[0], renders[1], atol=1e-5)  # float32: the constant is folded otherwise
