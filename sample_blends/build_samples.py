"""Build the sample scenes in sample_blends/ from Blender's primitives and modifiers: never edit them by hand.

    python sample_blends/build_samples.py [--out DIR] [NAME ...]   (the bpy module; commit with
                                                                    the 4.5 line, which every line reads)

limestone_facade.blend  a limestone façade: plinth, pilasters with capitals, recessed windows
                        with sills, a string course and an overhanging cornice
brick_wall.blend        a fired-clay brick wall in running bond with recessed lime-mortar joints
sculpted_stone.blend    a limestone block with deep hollows and salient ridges, on a plinth
bust.blend              a scan-like limestone bust (scan_generator.py): 200k triangles, no UV
                        map, in millimetres, with a hat whose brim shelters the face, deep eye
                        sockets and ears; the size of a real scan is its point (about 4.5 MB)

Modifiers are applied, so each mesh is what renders and bakes see. The façade's flat faces are
cut into a grid of cells (``refine``), so that per-corner maps (colour-attribute bakes of rain
and edges) resolve the shelter of a cornice or a sill. The bricks and their mortar have a UV map
projected from the front whose texture space lines up with the bond (``WALL_UV``), the layout that
efflorescence_map.brick_joint_map draws; each brick is a block of its own (its loose part, in the
face attribute presets.mark_blocks writes), the mortar the lime mortar preset. Every object has
a porous preset material lit by the scene's key sun (key-light mode). Sizes are in metres, but
for the bust: millimetres (the scene's unit scale says so), as scans come.
"""

import argparse
import math
import pathlib
import sys

import bpy

import bmesh  # importable only once bpy is
import numpy as np
from mathutils import Matrix, Vector

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import scan_generator  # noqa: E402  (sample_blends/scan_generator.py)

from porous_weathering.blender import compat
from porous_weathering.samples import studio  # noqa: E402
from porous_weathering.samples.demo import refine  # noqa: E402
from porous_weathering.shading.material import make_preset_material  # noqa: E402
from porous_weathering.shading.presets import mark_blocks  # noqa: E402

# --- building blocks -------------------------------------------------------------------


def mesh_object(scene, name, build):
    """A new object whose mesh ``build(bm)`` writes into a fresh bmesh."""
    bm = bmesh.new()
    build(bm)
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    return studio.link(scene, bpy.data.objects.new(name, mesh))


def box(scene, name, size, center):
    """An axis-aligned box of ``size`` (x, y, z) centred at ``center``."""

    def build(bm):
        bmesh.ops.create_cube(bm, size=1.0, calc_uvs=True)
        bmesh.ops.scale(bm, vec=size, verts=bm.verts)
        bmesh.ops.translate(bm, vec=center, verts=bm.verts)

    return mesh_object(scene, name, build)


def rod(scene, name, radius, length, center, segments=16):
    """A cylinder along X: the round moulding of a cornice or string course."""

    def build(bm):
        bmesh.ops.create_cone(
            bm,
            cap_ends=True,
            segments=segments,
            radius1=radius,
            radius2=radius,
            depth=length,
            calc_uvs=True,
            matrix=_matrix(center, rotation_y=math.pi / 2),
        )

    obj = mesh_object(scene, name, build)
    obj.data.shade_smooth()
    return obj


def _matrix(center, rotation_y=0.0):
    return Matrix.Translation(center) @ Matrix.Rotation(rotation_y, 4, "Y")


def bevel(obj, width, segments=2):
    modifier = obj.modifiers.new("Bevel", "BEVEL")
    modifier.width, modifier.segments = width, segments
    modifier.limit_method = "ANGLE"
    return modifier


def array(obj, count, offset):
    modifier = obj.modifiers.new("Array", "ARRAY")
    modifier.count = count
    modifier.use_relative_offset, modifier.use_constant_offset = False, True
    modifier.constant_offset_displace = offset
    return modifier


def carve(obj, cutters):
    """Boolean-subtract each cutter object from ``obj`` (the cutters are removed on apply)."""
    for cutter in cutters:
        modifier = obj.modifiers.new(f"Carve {cutter.name}", "BOOLEAN")
        modifier.operation, modifier.object = "DIFFERENCE", cutter
        cutter.hide_render = True


def apply_modifiers(obj):
    """Replace the object's mesh with its evaluated mesh; delete the boolean cutters."""
    cutters = [m.object for m in obj.modifiers if m.type == "BOOLEAN"]
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = bpy.data.meshes.new_from_object(evaluated)
    old, obj.data = obj.data, mesh
    obj.modifiers.clear()
    bpy.data.meshes.remove(old)
    mesh.name = obj.name
    for cutter in cutters:
        bpy.data.meshes.remove(cutter.data)


def give(material, *objects):
    for obj in objects:
        studio.assign(obj, material)


def camera(scene, location, target, lens=35.0):
    data = bpy.data.cameras.new("Camera")
    data.lens = lens
    obj = studio.link(scene, bpy.data.objects.new("Camera", data))
    obj.location = location
    obj.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    scene.camera = obj
    return obj


def sky(scene, color=(0.42, 0.5, 0.62), strength=0.6):
    world = bpy.data.worlds.new("Sky")
    compat.use_world_nodes(world)
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*color, 1.0)
    background.inputs["Strength"].default_value = strength
    scene.world = world


def quick_cycles(scene, width, height):
    """Cycles settings for quick, deterministic renders of the sample on 2 CPU cores."""
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 32
    scene.cycles.preview_samples = 8
    scene.cycles.seed = 0
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 4
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100


def ground(scene, size=30.0):
    obj = studio.add_plane(scene, "Ground", size)
    give(make_preset_material("CONCRETE", name="Ground Concrete"), obj)
    return obj


# --- the scenes --------------------------------------------------------------------------


#: The façade's map resolution: wind-driven rain under the 0.65 m cornice leaves a band about a
#: metre high dry, which cells of 0.2 m resolve (~23k triangles in all).
FACADE_CELL = 0.2


def limestone_facade(scene):
    """A two-bay façade, 8 m wide and 6 m high, facing -Y."""
    # Low enough that the cornice's shadow leaves most of the band it shelters from rain in light.
    sun = studio.add_sun(scene, towards=(0.6, -0.65, 0.42), strength=2.5)
    stone = make_preset_material("LIMESTONE", key_light=sun)

    wall = box(scene, "Wall", (8.0, 0.5, 5.4), (0.0, 0.25, 3.5))
    windows = [box(scene, f"Window Opening {i}", (1.2, 0.6, 2.0), (x, 0.0, 3.2)) for i, x in enumerate((-1.75, 1.75))]
    carve(wall, windows)
    plinth = box(scene, "Plinth", (8.2, 0.7, 0.8), (0.0, 0.15, 0.4))
    pilasters = box(scene, "Pilasters", (0.5, 0.15, 4.4), (-3.5, -0.075, 3.0))
    capitals = box(scene, "Capitals", (0.7, 0.3, 0.25), (-3.5, -0.1, 5.3))
    for obj in (pilasters, capitals):
        array(obj, 3, (3.5, 0.0, 0.0))
    sills = box(scene, "Window Sills", (1.5, 0.25, 0.08), (-1.75, -0.05, 2.16))
    array(sills, 2, (3.5, 0.0, 0.0))
    string_course = box(scene, "String Course", (8.0, 0.12, 0.15), (0.0, -0.06, 1.65))
    string_roll = rod(scene, "String Course Roll", 0.07, 8.0, (0.0, -0.1, 1.52))
    fascia = box(scene, "Cornice Fascia", (8.2, 0.3, 0.25), (0.0, 0.0, 5.55))
    ovolo = rod(scene, "Cornice Ovolo", 0.11, 8.3, (0.0, -0.17, 5.75))
    corona = box(scene, "Cornice Corona", (8.6, 0.9, 0.25), (0.0, -0.2, 5.95))
    cap = box(scene, "Cornice Cap", (8.7, 0.95, 0.08), (0.0, -0.2, 6.11))
    blocks = (wall, plinth, pilasters, capitals, sills, string_course, fascia, corona, cap)
    for obj in blocks:
        bevel(obj, 0.015)
    for obj in (*blocks, string_roll, ovolo):
        apply_modifiers(obj)
        refine(obj, FACADE_CELL)
    give(stone, *blocks, string_roll, ovolo)
    ground(scene)
    camera(scene, (3.2, -9.0, 2.0), (0.0, 0.0, 3.4))
    sky(scene)
    quick_cycles(scene, 640, 480)


BRICK = Vector((0.215, 0.1025, 0.065))  # a standard fired-clay brick
JOINT = 0.01
COURSES, BRICKS_PER_COURSE = 16, 9
#: The bricks' UV map: texture space is the wall seen from the front, a course per 1/COURSES of
#: v and a brick per 1/BRICKS_PER_COURSE of u, the joints' centres on the grid lines.
WALL_UV = "Wall"


def project_wall_uvs(obj, pitch, course):
    """Planar UVs from the front (x, z), joint centres at the grid lines of a running bond whose
    bottom course starts with a whole brick (brick_joint_map's layout)."""
    mesh = obj.data
    layer = mesh.uv_layers.new(name=WALL_UV)
    positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", positions)
    corners = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    x, z = positions.reshape(-1, 3)[corners, 0], positions.reshape(-1, 3)[corners, 2]
    uvs = np.stack([(x + JOINT / 2) / (BRICKS_PER_COURSE * pitch), (z - JOINT / 2) / (COURSES * course)], axis=1)
    layer.data.foreach_set("uv", uvs.astype(np.float32).ravel())


def brick_wall(scene):
    """A 2 m x 1.2 m wall fragment in running bond, facing -Y, joints recessed by 5 mm."""
    sun = studio.add_sun(scene, towards=(0.45, -0.7, 0.55), strength=4.0)
    pitch, course = BRICK.x + JOINT, BRICK.z + JOINT
    courses, per_course = COURSES, BRICKS_PER_COURSE

    def two_courses(bm):  # one brick and the brick half a pitch over it, in the next course
        for x, z in ((0.0, 0.0), (pitch / 2, course)):
            geometry = bmesh.ops.create_cube(bm, size=1.0, calc_uvs=True)
            bmesh.ops.scale(bm, vec=BRICK, verts=geometry["verts"])
            bmesh.ops.translate(
                bm, vec=(x + BRICK.x / 2, BRICK.y / 2, z + BRICK.z / 2 + JOINT), verts=geometry["verts"]
            )

    bricks = mesh_object(scene, "Bricks", two_courses)
    bevel(bricks, 0.004)
    array(bricks, per_course, (pitch, 0.0, 0.0))
    array(bricks, courses // 2, (0.0, 0.0, 2 * course))
    apply_modifiers(bricks)
    project_wall_uvs(bricks, pitch, course)
    mark_blocks(bricks, "ISLANDS")  # each brick its own block: a draw of the brick (docs/model.md §8.5)
    length, height = per_course * pitch + pitch / 2, courses * course + JOINT
    mortar = box(scene, "Mortar", (length, BRICK.y - 0.01, height), (length / 2, BRICK.y / 2 + 0.005, height / 2))
    refine(mortar, course)  # its per-corner maps (the damp's tide) vary course by course
    project_wall_uvs(mortar, pitch, course)  # the joints' salt map lines up on the mortar too
    give(make_preset_material("BRICK", key_light=sun), bricks)
    give(make_preset_material("LIME_MORTAR", key_light=sun), mortar)
    ground(scene)
    camera(scene, (1.6, -2.4, 0.9), (1.05, 0.0, 0.6))
    sky(scene)
    quick_cycles(scene, 640, 480)


def sculpted_stone(scene):
    """A weathered limestone block, 0.9 m across: cellular relief with ridges, and three deep hollows."""
    sun = studio.add_sun(scene, towards=(0.8, -0.35, 0.5), strength=4.0)  # raking light shows relief

    def rock(bm):
        bmesh.ops.create_icosphere(bm, subdivisions=5, radius=0.45, calc_uvs=True)
        bmesh.ops.scale(bm, vec=(1.0, 0.8, 1.1), verts=bm.verts)

    stone = mesh_object(scene, "Sculpted Stone", rock)
    stone.location = (0.0, 0.0, 0.75)
    # Voronoi F1 is low at cell centres and high between them: dished hollows and sharp ridges.
    texture = bpy.data.textures.new("Weathered Relief", "VORONOI")
    texture.noise_scale = 0.15
    displace = stone.modifiers.new("Relief", "DISPLACE")
    displace.texture, displace.strength, displace.texture_coords = texture, 0.4, "OBJECT"
    hollows = []
    for i, (center, radius) in enumerate(
        (((-0.22, -0.3, 0.95), 0.2), ((0.22, -0.25, 0.62), 0.17), ((-0.05, -0.32, 0.42), 0.13))
    ):
        hollow = mesh_object(
            scene,
            f"Hollow {i}",
            lambda bm, r=radius: bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=8, radius=r),
        )
        hollow.location = center
        hollows.append(hollow)
    carve(stone, hollows)
    apply_modifiers(stone)
    bpy.data.textures.remove(texture)
    stone.data.shade_smooth()
    plinth = box(scene, "Plinth", (1.2, 1.0, 0.3), (0.0, 0.0, 0.15))
    bevel(plinth, 0.02)
    apply_modifiers(plinth)
    give(make_preset_material("LIMESTONE", key_light=sun), stone, plinth)
    ground(scene)
    camera(scene, (0.95, -2.2, 1.25), (0.0, 0.0, 0.72), lens=45.0)
    sky(scene)
    quick_cycles(scene, 480, 480)


#: The bust's least size: as many triangles as a scan of a bust (at least 200k).
BUST_TRIANGLES = 200_000
#: What scan_generator is asked for (its count comes within 0.2% of the request): 200,280.
BUST_REQUEST = 200_500


def bust(scene):
    """A scan-like limestone bust, 0.5 m tall, in millimetres, no UV map: scan_generator's scene."""
    scan_generator.build_scene(scene, triangles=BUST_REQUEST, unit="mm", seed=0, material="limestone")


SAMPLES = {
    "limestone_facade": limestone_facade,
    "brick_wall": brick_wall,
    "sculpted_stone": sculpted_stone,
    "bust": bust,
}


def build(name, out_dir=HERE):
    """Build one sample scene into ``out_dir``/NAME.blend and return its path."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 backups beside the samples
    scene = bpy.context.scene
    scene.name = name
    SAMPLES[name](scene)
    path = pathlib.Path(out_dir) / f"{name}.blend"
    path.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True, relative_remap=False)
    return path


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "names", nargs="*", metavar="NAME", help=f"scenes to build (default: all of {', '.join(SAMPLES)})"
    )
    parser.add_argument("--out", type=pathlib.Path, default=HERE, help="output folder (default: sample_blends/)")
    arguments = parser.parse_args()
    if unknown := set(arguments.names) - set(SAMPLES):
        parser.error(f"unknown scene {', '.join(sorted(unknown))}")
    for sample in arguments.names or SAMPLES:
        print(f"wrote {build(sample, arguments.out)}")
