"""A .blend opened as the commands and the main job open it (``open_blend``)."""

import bpy

from ..common import held_output

#: Blender's note on opening a file, which a command that opens each file twice (its check before
#: any work, then its run) would print twice among its own lines, and the main job before its bar.
READ_NOTE = b"Read blend: "


def open_blend(path: str) -> None:
    """Open the .blend at ``path``: never running its code, without its UI, and without Blender's
    note that it was read (RuntimeError as ``wm.open_mainfile``, whose message the command's one
    error line gives: Blender's own report lines are not printed then)."""
    with held_output.held((READ_NOTE,), shown_on_error=False):
        bpy.ops.wm.open_mainfile(filepath=path, load_ui=False, use_scripts=False)  # never run a file's code
