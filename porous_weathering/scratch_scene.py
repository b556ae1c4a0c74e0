"""Copies of the user's objects in temporary scenes, where the bakes work: the user's
scene, meshes, materials and selection are never touched; and the probe materials and
light aiming those scenes use."""

import bpy  # noqa: F401  (mathutils is importable only once bpy is)

from mathutils import Vector

from . import compat
from .shader_math import Graph

#: Object types that have surfaces, materials and therefore something to bake or shade.
GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


def placed_copy(obj, scene, material, *, own_mesh=False):
    """A copy of ``obj`` linked into ``scene``, standing where ``obj`` stands (unparented, no
    animation or constraints, renderable), every slot showing ``material``.

    With ``own_mesh`` the copy gets its own copy of the mesh (to write bake results into);
    otherwise it shares ``obj``'s, whose materials stay untouched (object-linked slots).
    """
    copy = obj.copy()
    if own_mesh:
        copy.data = obj.data.copy()
        copy.data.materials.clear()
        copy.data.materials.append(material)
    copy.animation_data_clear()
    copy.constraints.clear()
    copy.parent = None
    copy.matrix_world = obj.matrix_world.copy()
    copy.hide_render = False
    for slot in copy.material_slots:
        slot.link = "OBJECT"
        slot.material = material
    scene.collection.objects.link(copy)
    return copy


def only_selected(obj):
    """Make ``obj`` the selected, active object of its (temporary) scene; returns the context
    override under which ``bpy.ops.object.bake`` works on it alone."""
    scene = obj.users_scene[0]
    view_layer = scene.view_layers[0]
    obj.select_set(True, view_layer=view_layer)
    view_layer.objects.active = obj
    return dict(
        scene=scene,
        view_layer=view_layer,
        object=obj,
        active_object=obj,
        selected_objects=[obj],
        selected_editable_objects=[obj],
    )


def aim_sun(sun, towards):
    """Rotate a sun so that the unit vector towards it is ``towards`` (its local +Z)."""
    towards = Vector(towards)
    if not towards.length > 0.0:
        raise ValueError(f"cannot aim the sun '{sun.name}' along a zero-length (or NaN) direction")
    sun.rotation_mode = "XYZ"
    sun.rotation_euler = towards.normalized().to_track_quat("Z", "Y").to_euler("XYZ")


def emission_probe(name, build):
    """A material that emits ``build(graph, geometry)`` (a colour Expr or socket) exactly.

    Cycles renders an Emission closure of strength 1 as its colour, so the pixels of a
    probe render are the shading quantity itself at each pixel's centre.
    """
    material = compat.new_material(name)
    tree = material.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    geometry = graph.node("ShaderNodeNewGeometry", depth=0)
    colour = build(graph, geometry)
    emission = graph.node("ShaderNodeEmission", {"Color": colour, "Strength": 1.0})
    graph.node("ShaderNodeOutputMaterial", {"Surface": emission.outputs[0]})
    return material


def normal_probe():
    """Emits the world-space shading normal, encoded as N / 2 + 1/2."""
    return emission_probe("Normal Probe", lambda graph, geometry: graph.wrap(geometry.outputs["Normal"]) * 0.5 + 0.5)
