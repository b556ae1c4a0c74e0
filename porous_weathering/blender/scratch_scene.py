"""Copies of the user's objects in temporary scenes, where the bakes work: the user's
scene, meshes, materials and selection are never touched; the probe materials and light
aiming those scenes use; and exact texel bakes (EMIT, one sample a texel) of what a probe
emits on an object's UV map."""

import bpy

import numpy as np
from mathutils import Vector

from ..core.shader_math import Graph
from . import compat, mesh_arrays

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


def bake_point_values(obj, uv_map_name, resolution, values, *, margin=0):
    """(image, islands): ``values`` (one per vertex of ``obj``'s mesh) drawn into a float32
    (H, W) image of ``uv_map_name``, each texel interpolating its triangle's corners, and the
    (H, W) bool map of the texels on a UV island or its ``margin``. Top row first.

    ``margin`` texels around every island are filled from the island's edge (Blender's bake
    margin, EXTEND)."""
    name = "PW Point Values"

    def prepare(mesh):
        mesh.color_attributes.new(name, "FLOAT_COLOR", "POINT").data.foreach_set("color", mesh_arrays.grey_rgba(values))

    (baked,) = emit_bakes(
        obj,
        uv_map_name,
        resolution,
        [lambda graph, geometry: graph.node("ShaderNodeAttribute", attribute_name=name).outputs["Color"]],
        prepare=prepare,
        margin=margin,
    )
    return baked[..., 0].copy(), baked[..., 3] > 0


def emit_bakes(obj, uv_map_name, resolution, emitted, prepare=None, margin=0):
    """One float RGBA (H, W, 4) array, top row first, per ``emitted(graph, geometry)``: exact
    Cycles EMIT bakes (one sample, the texel centre) of probe materials emitting it, on a copy
    of the object (its mesh first given to ``prepare``) in a temporary scene: the user's
    scene, mesh, materials and selection are untouched. Texels off every UV island and its
    ``margin`` (filled by EXTEND) have alpha 0."""
    image = bpy.data.images.new("PW Texel Bake", resolution, resolution, alpha=True, float_buffer=True)
    probes = [emission_probe(f"PW Texel Probe {index}", build) for index, build in enumerate(emitted)]
    scene = bpy.data.scenes.new("PW Texel Bake")
    copy = None
    try:
        copy = placed_copy(obj, scene, probes[0], own_mesh=True)
        if prepare is not None:
            prepare(copy.data)
        scene.render.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.cycles.samples = 1  # deterministic: the texel centre
        context = only_selected(copy)
        pixels = np.empty((len(probes), resolution, resolution, 4), dtype=np.float32)
        for index, probe in enumerate(probes):
            texture = probe.node_tree.nodes.new("ShaderNodeTexImage")
            texture.image = image
            probe.node_tree.nodes.active = texture
            for slot in copy.material_slots:
                slot.material = probe
            image.pixels.foreach_set(np.zeros(resolution * resolution * 4, dtype=np.float32))
            with bpy.context.temp_override(**context):
                bpy.ops.object.bake(
                    type="EMIT",
                    target="IMAGE_TEXTURES",
                    uv_layer=uv_map_name,
                    margin=margin,
                    margin_type="EXTEND",
                    use_clear=False,
                    use_selected_to_active=False,
                )
            image.pixels.foreach_get(pixels[index].ravel())
        return list(pixels[:, ::-1])  # Blender stores the bottom row first
    finally:
        if copy is not None:
            mesh = copy.data
            bpy.data.objects.remove(copy)
            bpy.data.meshes.remove(mesh)
        bpy.data.scenes.remove(scene)
        for probe in probes:
            bpy.data.materials.remove(probe)
        bpy.data.images.remove(image)
