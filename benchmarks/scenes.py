"""The reference's analytic scenes (benchmarks/reference.py) built in Blender, one to one.

A scene is described once, as reference objects (a surface kind, lights, a sky), and this
module makes its Blender twin, so a render and the reference always show the same thing.
``through_gltf`` sends an object through Blender's glTF add-on as a user's file arrives (the
edge benchmark's scan and the tests' split meshes).
"""

import math
import pathlib

import bpy

import porous_weathering as pw
from benchmarks import probes, reference
from porous_weathering.samples import studio

#: Tessellation of the rendered sphere: fine enough that the smooth-shaded mesh's normals
#: differ from the true sphere's by less than the errors measured (0.03% RMSE, Lambert).
SPHERE_SEGMENTS, SPHERE_RINGS = 256, 128


def build(scene, surface, lights=(), sky=None):
    """Add ``surface`` ("SPHERE", "PLANE" or ("V_GROOVE", slope)), the lights, the sky and the
    studio camera to ``scene``; return the surface object."""
    if surface == "SPHERE":
        obj = studio.add_sphere(scene, segments=SPHERE_SEGMENTS, rings=SPHERE_RINGS)
        # Poles to the sides: at the pole facing the camera, Cycles' shadow rays from the fan of
        # thin triangles found the mesh itself and left one pixel black (even for a plain Diffuse).
        obj.rotation_euler = (math.pi / 2, 0.0, 0.0)
    elif surface == "PLANE":
        obj = studio.add_plane(scene)
    else:
        obj = add_v_groove(scene, surface[1])
    for light in lights:
        add_light(scene, light)
    set_sky(scene, sky)
    studio.add_ortho_camera(scene, scale=reference.ORTHO_SCALE)
    return obj


def reference_surface(surface, size):
    if surface == "SPHERE":
        return reference.sphere(size)
    if surface == "PLANE":
        return reference.plane(size)
    return reference.v_groove(size, surface[1])


def porous_material(params, key_light=None, name="Porous"):
    """The porous material of the reference's parameters ``params`` (kd, ks, m, alpha, sp)."""
    return pw.make_porous_material(
        name,
        base_color=params["kd"],
        ks=params["ks"],
        roughness=params["m"],
        porosity=params["alpha"],
        pore_depth_ratio=params["sp"],
        key_light=key_light,
    )


def add_v_groove(scene, slope_degrees, name="VGroove"):
    """The reference's V-groove: two flat faces meeting along the Y axis."""
    vertices, faces = [], []
    for origin, edge_u, edge_v in reference.v_groove_faces(slope_degrees):
        corners = [origin, origin + edge_u, origin + edge_u + edge_v, origin + edge_v]
        faces.append([len(vertices) + i for i in range(4)])
        vertices.extend(tuple(map(float, corner)) for corner in corners)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    mesh.update()
    return studio.link(scene, bpy.data.objects.new(name, mesh))


def add_light(scene, light):
    if isinstance(light, reference.Sun):
        return studio.add_sun(scene, light.towards, strength=light.strength)
    lamp = probes.add_point_light(
        scene, light.location, power=light.power, kind="AREA" if isinstance(light, reference.AreaLight) else "POINT"
    )
    if isinstance(light, reference.AreaLight):
        lamp.data.shape = "SQUARE"
        lamp.data.size = light.size
    return lamp


def set_sky(scene, sky):
    """A world of the reference sky's radiance (black when ``sky`` is None)."""
    world = bpy.data.worlds.new("Sky")
    if world.node_tree is None:  # 4.x; from 5.0 a world has nodes and use_nodes is deprecated
        world.use_nodes = True
    tree = world.node_tree
    background = next(node for node in tree.nodes if node.type == "BACKGROUND")
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = 0.0 if sky is None else sky.strength
    if sky is not None and sky.kind == "OVERCAST":
        # (1 + 2 z) / 3 above the horizon, 0 below: z is the world direction's Z.
        coordinates = tree.nodes.new("ShaderNodeTexCoord")
        separate = tree.nodes.new("ShaderNodeSeparateXYZ")
        gradient = tree.nodes.new("ShaderNodeMath")
        gradient.operation = "MULTIPLY_ADD"
        gradient.inputs[1].default_value, gradient.inputs[2].default_value = 2.0 / 3.0, 1.0 / 3.0
        above = tree.nodes.new("ShaderNodeMath")
        above.operation = "GREATER_THAN"
        above.inputs[1].default_value = 0.0
        radiance = tree.nodes.new("ShaderNodeMath")
        radiance.operation = "MULTIPLY"
        tree.links.new(coordinates.outputs["Generated"], separate.inputs[0])
        tree.links.new(separate.outputs["Z"], gradient.inputs[0])
        tree.links.new(separate.outputs["Z"], above.inputs[0])
        tree.links.new(gradient.outputs[0], radiance.inputs[0])
        tree.links.new(above.outputs[0], radiance.inputs[1])
        tree.links.new(radiance.outputs[0], background.inputs["Color"])
    scene.world = world
    return world


def write_error_image(path, image, expected, mask, gain=10.0):
    """|image - expected| times ``gain``, relative to the expected RMS, as a PNG (white = 1/gain)."""
    import numpy as np
    import OpenImageIO as oiio

    scale = np.sqrt(np.mean(expected[mask] ** 2))
    error = np.where(mask[..., None], np.abs(image[..., :3] - expected) / scale * gain, 0.0)
    pixels = np.ascontiguousarray(np.clip(error, 0.0, 1.0).astype(np.float32))
    output = oiio.ImageBuf(pixels)
    if not output.write(str(path), oiio.UINT8):
        raise OSError(f"cannot write {path}: {output.geterror()}")


def print_or_write(markdown, path=None):
    """The report to ``path`` (a --out option), or to the terminal when there is none."""
    if path:
        path.write_text(markdown + "\n")
    else:
        print(markdown)


def markdown_table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def through_gltf(obj, folder, keep=False):
    """``obj`` unwrapped by Smart UV Project, exported with Blender's glTF add-on into ``folder``
    and imported again, split at its UV seams and hard edges as the importer leaves a user's
    file: the imported mesh object. The scene is emptied before the import unless ``keep``."""
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project()
    bpy.ops.object.mode_set(mode="OBJECT")
    path = str(pathlib.Path(folder) / f"{obj.name}.glb")
    bpy.ops.export_scene.gltf(filepath=path, use_selection=True)
    if not keep:
        bpy.ops.wm.read_factory_settings(use_empty=True)
    before = set(bpy.context.scene.objects)
    bpy.ops.import_scene.gltf(filepath=path)
    (imported,) = [found for found in bpy.context.scene.objects if found.type == "MESH" and found not in before]
    return imported
