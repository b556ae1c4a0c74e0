"""Every difference between the Blender lines we support (4.2-4.5 and 5.x) lives here."""

import sys
from typing import NoReturn

import bpy

from ..common import process_end
from ..core import voronoi

BLENDER_5 = bpy.app.version >= (5, 0, 0)

#: How the Voronoi texture hashes its cells (core/voronoi.py): 5.x the cells' integer coordinates
#: (PCG), 4.x the bits of their float ones (lookup3); so the two lines put the lichens' seeds in
#: different places.
VORONOI_HASH = voronoi.PCG if BLENDER_5 else voronoi.LOOKUP3

#: The EEVEE engine id: renamed back to BLENDER_EEVEE in 5.0.
EEVEE_ENGINE = "BLENDER_EEVEE" if BLENDER_5 else "BLENDER_EEVEE_NEXT"

#: Blender 4's report of a render's or a bake's progress, printed line by line on standard output
#: in background mode ("Fra:1 Mem:... | Synchronizing object | ...", and "Time: 00:09.76 (Saving:
#: 00:00.05)" once a picture is written), where a command prints its own lines (the bake's status
#: lines, the main job's progress bar); Blender 5 logs them without printing them.
PROGRESS_NOTES = () if BLENDER_5 else (b"Fra:", b"(Saving: ")


def new_material(name):
    """A new material with a node tree (use_nodes is implied, and deprecated, from 5.0)."""
    material = bpy.data.materials.new(name)
    if not BLENDER_5:
        material.use_nodes = True
    return material


def use_world_nodes(world):
    """Give ``world`` a node tree (use_nodes is implied, and deprecated, from 5.0)."""
    if not BLENDER_5:
        world.use_nodes = True


#: bpy 4.x as a Python module crashes at interpreter exit (segfault, exit 139) while classes,
#: properties or CLI commands are still registered: whatever registers them must unregister
#: before the interpreter exits (``porous_weathering.register`` does it with atexit).
UNREGISTER_BEFORE_EXIT = bpy.app.module and not BLENDER_5


def session_folder() -> str:
    """Blender's folder for this session (``bpy.app.tempdir``): a new one each time Blender reads
    its factory settings."""
    return bpy.app.tempdir


def end_process(code: int) -> NoReturn:
    """End a script using bpy with ``code`` now: bpy 4.5 can hang for ever in a static destructor
    at a normal interpreter exit. Blender's folder for the session, which only its own exit path
    removes, is removed first (``common.process_end``)."""
    sys.stdout.flush()
    sys.stderr.flush()
    process_end.remove_at_end(session_folder)
    process_end.end(code)


def newer_file_version() -> str | None:
    """ "Blender X.Y" of the open .blend when a newer Blender than this one saved it (saving it
    here would write it in an older format, losing what that one stores), else None."""
    made, running = tuple(bpy.data.version), tuple(bpy.app.version_file)
    if made <= running:
        return None
    shown = 3 if made[:2] == running[:2] else 2  # a newer file format of the same release
    return "Blender " + ".".join(map(str, made[:shown]))


def running_version() -> str:
    """ "Blender X.Y.Z" of this Blender."""
    return f"Blender {bpy.app.version_string}"
