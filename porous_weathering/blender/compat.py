"""Every difference between the Blender lines we support (4.2-4.5 and 5.x) lives here."""

import bpy

BLENDER_5 = bpy.app.version >= (5, 0, 0)

#: The EEVEE engine id: renamed back to BLENDER_EEVEE in 5.0.
EEVEE_ENGINE = "BLENDER_EEVEE" if BLENDER_5 else "BLENDER_EEVEE_NEXT"


def new_material(name):
    """A new material with a node tree (use_nodes is implied, and deprecated, from 5.0)."""
    material = bpy.data.materials.new(name)
    if not BLENDER_5:
        material.use_nodes = True
    return material


def compositor_tree(scene):
    """The scene's compositor node tree (scene.node_tree before 5.0), or None."""
    if BLENDER_5:
        return scene.compositing_node_group
    return scene.node_tree if scene.use_nodes else None


def use_world_nodes(world):
    """Give ``world`` a node tree (use_nodes is implied, and deprecated, from 5.0)."""
    if not BLENDER_5:
        world.use_nodes = True
