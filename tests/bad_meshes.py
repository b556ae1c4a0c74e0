"""Broken and awkward scene objects, as heritage scans and old files bring them, and a
snapshot of what an operation may leave behind (shared by the reliability tests).

Every builder takes the scene (and, for linked data, a temporary folder), links what it
makes into the scene and returns the object an operation is run on.
"""

import os
import subprocess
import sys

import bpy

import bmesh
import numpy as np

from porous_weathering.samples import studio

#: The datablock collections an operation could leave a half-made thing in.
DATA_KINDS = (
    "objects",
    "meshes",
    "materials",
    "images",
    "node_groups",
    "scenes",
    "lights",
    "worlds",
    "curves",
    "textures",
    "libraries",
)


def mesh_object(scene, name, vertices, edges=(), faces=(), location=(0.0, 0.0, 0.0)):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in vertices], list(edges), [tuple(f) for f in faces])
    mesh.update()
    obj = studio.link(scene, bpy.data.objects.new(name, mesh))
    obj.location = location
    return obj


def cube(scene, name="Cube", size=1.0, location=(0.0, 0.0, 0.0)):
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=size)
    bm.to_mesh(mesh)
    bm.free()
    obj = studio.link(scene, bpy.data.objects.new(name, mesh))
    obj.location = location
    return obj


def no_faces(scene, _tmp):
    """Vertices and edges only (a scan's point cloud or a wire outline)."""
    return mesh_object(scene, "Wire", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 1)], edges=[(0, 1), (1, 2), (2, 3)])


def zero_area_faces(scene, _tmp):
    """A quad, a sliver whose three corners lie on a line, and a triangle collapsed to a point."""
    vertices = [
        (0, 0, 0),
        (1, 0, 0),
        (1, 1, 0),
        (0, 1, 0),  # a good quad
        (2, 0, 0),
        (3, 0, 0),
        (4, 0, 0),  # collinear
        (5, 5, 5),
        (5, 5, 5),
        (5, 5, 5),
    ]  # coincident
    return mesh_object(scene, "Slivers", vertices, faces=[(0, 1, 2, 3), (4, 5, 6), (7, 8, 9)])


def only_zero_area_face(scene, _tmp):
    """One triangle whose corners lie on a line: faces, but no surface."""
    return mesh_object(scene, "Sliver", [(0, 0, 0), (1, 0, 0), (2, 0, 0)], faces=[(0, 1, 2)])


def non_manifold_edges(scene, _tmp):
    """Three quads sharing one edge (a fin), plus an open boundary everywhere else."""
    vertices = [(0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0), (-1, 0, 0), (-1, 1, 0), (0, 0, 1), (0, 1, 1)]
    return mesh_object(scene, "Fin", vertices, faces=[(0, 2, 3, 1), (1, 5, 4, 0), (0, 6, 7, 1)])


def loose_vertices(scene, _tmp):
    """A cube with stray vertices and a loose edge around it (unclean photogrammetry)."""
    obj = cube(scene, "Stray")
    mesh = obj.data
    first = len(mesh.vertices)
    mesh.vertices.add(3)
    mesh.vertices.foreach_set(
        "co", np.concatenate([np.array([v.co for v in mesh.vertices][:first]).ravel(), [3, 0, 0, 0, 3, 0, 0, 0, 3]])
    )
    mesh.edges.add(1)
    mesh.edges[-1].vertices = (first + 1, first + 2)
    mesh.update()
    return obj


def noisy_grid(scene, name="Noisy", quads=99):
    """A unit square of ``quads``² quads, its heights random (a rough scan's patch): 19,602
    triangles, which xatlas charts for about 20 s on 2 cores."""
    rng = np.random.default_rng(1)
    x, y = (axis.ravel() for axis in np.meshgrid(np.linspace(0, 1, quads + 1), np.linspace(0, 1, quads + 1)))
    corner = np.arange((quads + 1) ** 2).reshape(quads + 1, quads + 1)[:-1, :-1].ravel()
    faces = np.stack([corner, corner + 1, corner + quads + 2, corner + quads + 1], axis=1)
    return mesh_object(scene, name, np.stack([x, y, 0.02 * rng.standard_normal(x.size)], axis=1), faces=faces)


def ngons(scene, _tmp):
    """An octagonal prism: two 8-sided caps and quads."""
    angles = np.linspace(0, 2 * np.pi, 9)[:-1]
    ring = [(np.cos(a), np.sin(a)) for a in angles]
    vertices = [(x, y, 0.0) for x, y in ring] + [(x, y, 1.0) for x, y in ring]
    faces = [tuple(reversed(range(8))), tuple(range(8, 16))]
    faces += [(i, (i + 1) % 8, 8 + (i + 1) % 8, 8 + i) for i in range(8)]
    return mesh_object(scene, "Octagon", vertices, faces=faces)


def flipped_normals(scene, _tmp):
    """A closed cube whose faces all point inwards."""
    obj = cube(scene, "Inside Out")
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.reverse_faces(bm, faces=bm.faces)
    bm.to_mesh(obj.data)
    bm.free()
    return obj


def negative_scale(scene, _tmp):
    """A mirrored cube (scale -1 on X), as mirroring by scaling leaves it."""
    obj = cube(scene, "Mirrored")
    obj.scale = (-1.0, 1.0, 1.0)
    return obj


def shared_mesh(scene, _tmp):
    """Two objects standing apart that share one mesh (Alt+D duplicates); returns the first."""
    obj = cube(scene, "Twin A")
    twin = studio.link(scene, bpy.data.objects.new("Twin B", obj.data))
    twin.location = (3.0, 0.0, 0.0)
    return obj


def unapplied_modifiers(scene, _tmp):
    """A cube with a Subdivision Surface and a Bevel modifier still on the stack."""
    obj = cube(scene, "Modified")
    obj.modifiers.new("Bevel", "BEVEL").width = 0.1
    obj.modifiers.new("Subdivision", "SUBSURF").levels = 1
    return obj


def curve(scene, _tmp):
    """A bevelled Bezier curve (renders with faces, but is not a mesh)."""
    data = bpy.data.curves.new("Rope", "CURVE")
    data.dimensions = "3D"
    data.bevel_depth = 0.1
    spline = data.splines.new("BEZIER")
    spline.bezier_points.add(1)
    for point, co in zip(spline.bezier_points, [(0, 0, 0), (2, 0, 1)]):
        point.co = co
        point.handle_left_type = point.handle_right_type = "AUTO"
    return studio.link(scene, bpy.data.objects.new("Rope", data))


def text(scene, _tmp):
    """An extruded text object."""
    data = bpy.data.curves.new("Inscription", "FONT")
    data.body = "SPQR"
    data.extrude = 0.05
    return studio.link(scene, bpy.data.objects.new("Inscription", data))


LIBRARY_SCRIPT = """
import bpy, bmesh, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
mesh = bpy.data.meshes.new("Library Cube")
bm = bmesh.new(); bmesh.ops.create_cube(bm, size=1.0); bm.to_mesh(mesh); bm.free()
obj = bpy.data.objects.new("Library Cube", mesh)
bpy.context.scene.collection.objects.link(obj)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
"""


def make_library(folder):
    """A tiny library .blend with one cube object, written by a separate Python (so that the
    test's own session is not switched to another file); its path."""
    path = os.path.join(os.fspath(folder), "library stones.blend")
    if not os.path.isfile(path):
        subprocess.run([sys.executable, "-c", LIBRARY_SCRIPT, path], check=True, capture_output=True, timeout=120)
    return path


def linked_object(scene, tmp):
    """A cube object and its mesh linked (not appended) from a library .blend."""
    path = make_library(tmp)
    with bpy.data.libraries.load(path, link=True) as (data_from, data_to):
        data_to.objects = ["Library Cube"]
    obj = data_to.objects[0]
    scene.collection.objects.link(obj)
    assert obj.library is not None and obj.data.library is not None
    return obj


#: name -> builder(scene, tmp_path): every kind of awkward object of docs/reliability.md, "Bad meshes".
BUILDERS = {
    "no faces": no_faces,
    "zero-area faces": zero_area_faces,
    "only a zero-area face": only_zero_area_face,
    "non-manifold edges": non_manifold_edges,
    "loose vertices": loose_vertices,
    "n-gons": ngons,
    "flipped normals": flipped_normals,
    "negative scale": negative_scale,
    "shared mesh": shared_mesh,
    "unapplied modifiers": unapplied_modifiers,
    "curve": curve,
    "text": text,
    "linked library data": linked_object,
}


def data_counts():
    return {kind: len(getattr(bpy.data, kind)) for kind in DATA_KINDS}


def layers_of(obj):
    """Names of the UV maps, attributes and material slots of an object's data (empty for non-meshes)."""
    data = obj.data
    uv_maps = tuple(layer.name for layer in data.uv_layers) if obj.type == "MESH" else ()
    attributes = tuple(sorted(a.name for a in data.attributes)) if obj.type == "MESH" else ()
    return uv_maps, attributes, tuple(m.name if m else None for m in data.materials)


def snapshot(objects):
    """What an operation that fails must leave exactly as it was: every datablock count, and
    each object's UV maps, attributes and material slots."""
    return data_counts(), {obj.name: layers_of(obj) for obj in objects}
