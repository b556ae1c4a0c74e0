"""Files written whole or not at all: a temporary file beside the target (``temporary_file``),
renamed over it when whole (``move_into_place``), and blocks that an interrupt must not cut in
two (``uncut``: renaming a finished file into place, saving a .blend). ``interrupts`` waits
for an uncut block and removes the temporary files of the writes in progress
(``remove_temporary_files``) before it ends the process.
"""

import contextlib
import os
import tempfile
import threading
from collections.abc import Iterator

from ..contracts import TEMPORARY_PREFIX

_uncut = threading.RLock()
_temporary_files: set[str] = set()


@contextlib.contextmanager
def uncut() -> Iterator[None]:
    """A block an interrupt waits for instead of cutting it."""
    with _uncut:
        yield


@contextlib.contextmanager
def temporary_file(folder: str, suffix: str) -> Iterator[str]:
    """The path of a new empty file in ``folder`` for the block, created with the permissions
    of any new file (0666 less the umask, not tempfile's 0600). It is removed when the block
    ends, fails or is interrupted, unless ``move_into_place`` moved it."""
    with _uncut:  # created and recorded together, so an interrupt cannot miss it
        try:
            handle, path = tempfile.mkstemp(prefix="." + TEMPORARY_PREFIX, suffix=suffix, dir=folder)
        except OSError as error:
            raise OSError(f"cannot create a file in the folder {folder}: {error.strerror}") from error
        _temporary_files.add(path)
    try:
        os.fchmod(handle, 0o666 & ~_umask())
        os.close(handle)
        yield path
    finally:
        with _uncut:
            if path in _temporary_files:
                _temporary_files.discard(path)
                with contextlib.suppress(FileNotFoundError):
                    os.remove(path)


def move_into_place(temporary: str, path: str) -> None:
    """Rename the ``temporary_file`` over ``path`` (atomic), uncut by an interrupt."""
    with _uncut:
        os.replace(temporary, path)
        _temporary_files.discard(temporary)


def _umask() -> int:
    mask = os.umask(0o077)  # the only portable way to read it is to set it; set back at once
    os.umask(mask)
    return mask


def stop_writes() -> None:
    """Wait for an uncut block in progress, then let none start again (the process is ending),
    and remove the temporary files of the writes in progress."""
    _uncut.acquire()  # never released
    for path in list(_temporary_files):
        with contextlib.suppress(OSError):
            os.remove(path)
