"""Small analytic scenes for the demo's pictures, the checks and the benchmarks: a sphere or a
plane under one light, seen by an orthographic camera looking down -Z. The probes that read
shading quantities out as pixels are the checks' kit, outside the package
(``benchmarks/probes.py``)."""

import bpy

from ..blender.scratch_scene import aim_sun  # noqa: F401  (part of the kit: the demo aims its sun)


def link(scene, obj):
    scene.collection.objects.link(obj)
    return obj


def add_sphere(scene, name="Sphere", radius=1.0, segments=96, rings=48):
    """A smooth-shaded UV sphere at the origin."""
    import bmesh

    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=rings, radius=radius, calc_uvs=True)
    bm.to_mesh(mesh)
    bm.free()
    mesh.shade_smooth()
    return link(scene, bpy.data.objects.new(name, mesh))


def add_plane(scene, name="Plane", size=2.0):
    """A square facing +Z at the origin."""
    half = size / 2
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)], [], [(0, 1, 2, 3)])
    mesh.uv_layers.new(name="UVMap")
    for loop, uv in zip(mesh.uv_layers[0].data, [(0, 0), (1, 0), (1, 1), (0, 1)]):
        loop.uv = uv
    return link(scene, bpy.data.objects.new(name, mesh))


def add_sun(scene, towards=(0.0, 0.0, 1.0), strength=3.0, name="Sun"):
    """A sun of zero angle (sharp, deterministic) shining from direction ``towards``."""
    light = bpy.data.lights.new(name, "SUN")
    light.energy = strength
    light.angle = 0.0
    sun = link(scene, bpy.data.objects.new(name, light))
    aim_sun(sun, towards)
    return sun


def add_ortho_camera(scene, scale=2.2, height=5.0):
    data = bpy.data.cameras.new("Camera")
    data.type = "ORTHO"
    data.ortho_scale = scale
    camera = link(scene, bpy.data.objects.new("Camera", data))
    camera.location = (0.0, 0.0, height)
    scene.camera = camera
    return camera


def assign(obj, material):
    obj.data.materials.clear()
    obj.data.materials.append(material)
