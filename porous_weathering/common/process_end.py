"""The end of a command-line process: ``os._exit`` at once (bpy 4.5 can hang for ever in a static
destructor at a normal interpreter exit), after removing what a normal exit would have removed:
the folders ``remove_at_end`` names. Blender's own folder for the session (``bpy.app.tempdir``,
``blender_XXXXXX`` in the system's temporary folder) is removed only on Blender's exit path, and
multiprocessing's (``pymp-XXXXXXXX``: a local Dask cluster's forkserver socket) only by its
exit-time finalizer; ``os._exit`` skips both: every run would leave them behind."""

import contextlib
import os
import re
import shutil
import threading
from collections.abc import Callable
from typing import NoReturn

#: a folder made for one process, Blender's or multiprocessing's (their mkdtemp patterns): a guard,
#: since a Blender that could not make one works in the temporary folder itself, never removed
_MADE_FOR_THE_PROCESS = re.compile(r"blender_\w{6}|pymp-\w{8}")

_lock = threading.Lock()
_folders: list[Callable[[], str | None]] = []


def remove_at_end(folder: Callable[[], str | None]) -> None:
    """Remove the folder ``folder()`` names (if any) when ``end`` ends the process, if it is one
    Blender or multiprocessing made for the process (by its name). Asked at the end: Blender makes
    a new one each time it reads its factory settings."""
    with _lock:
        if folder not in _folders:
            _folders.append(folder)


def end(code: int) -> NoReturn:
    """End the process with ``code`` now, the folders of ``remove_at_end`` removed first."""
    with _lock:
        for folder in _folders:
            with contextlib.suppress(Exception):  # nothing may keep the process from ending
                path = folder()
                if path and _MADE_FOR_THE_PROCESS.fullmatch(os.path.basename(os.path.normpath(path))):
                    shutil.rmtree(path, ignore_errors=True)
    os._exit(code)
