"""Files written whole or not at all: a temporary file beside the target (``temporary_file``),
renamed over it when whole (``move_into_place``), and blocks that an interrupt must not cut in
two (``uncut``: renaming a finished file into place, saving a .blend). ``interrupts`` waits
for an uncut block and removes the temporary files of the writes in progress
(``remove_temporary_files``) before it ends the process. Files replaced together
(``move_into_place_together``) are all replaced or none, and temporary folders
(``temporary_folder``) are removed as the temporary files are; one left by a killed process is
removed by the next (``remove_stale_folders``).
"""

import contextlib
import os
import shutil
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence

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


@contextlib.contextmanager
def folders_undone_on_error(folder: str | None) -> Iterator[None]:
    """For a block that may create ``folder`` (None: none) and its missing parents: those it
    created are removed again, if still empty, when the block raises, so that a refusal leaves
    no folder behind."""
    missing = []
    path = None if folder is None else os.path.abspath(folder)
    while path is not None and not os.path.exists(path):  # the root exists: the walk ends
        missing.append(path)  # deepest first
        path = os.path.dirname(path)
    try:
        yield
    except BaseException:
        for made in missing:
            with contextlib.suppress(OSError):
                os.rmdir(made)
        raise


def move_into_place(temporary: str, path: str) -> None:
    """Rename the ``temporary_file`` over ``path`` (atomic), uncut by an interrupt."""
    with _uncut:
        os.replace(temporary, path)
        _temporary_files.discard(temporary)


def move_into_place_together(moves: Sequence[tuple[str, str]]) -> None:
    """Rename each ``temporary_file`` over its path ((temporary, path) pairs), uncut: all are
    replaced, or, when one rename fails, the paths are given back what they held before (the
    error is raised). The old files are set aside under temporary names meanwhile."""
    with _uncut, contextlib.ExitStack() as stack:
        done = []  # (path, where its old file is set aside, or None)
        try:
            for temporary, path in moves:
                aside = None
                if os.path.lexists(path):
                    aside = stack.enter_context(temporary_file(os.path.dirname(path), ".old"))
                    os.replace(path, aside)
                done.append((path, aside))
                os.replace(temporary, path)
                _temporary_files.discard(temporary)
        except OSError:
            for path, aside in reversed(done):
                if aside is None:
                    with contextlib.suppress(FileNotFoundError):
                        os.remove(path)
                else:
                    move_into_place(aside, path)
            raise


@contextlib.contextmanager
def temporary_folder(prefix: str) -> Iterator[str]:
    """A new folder in the system's temporary folder for the block, named ``<prefix><pid>_...``
    (its owner, for ``remove_stale_folders``), removed with everything in it when the block
    ends, fails or is interrupted."""
    with _uncut:
        path = tempfile.mkdtemp(prefix=f"{prefix}{os.getpid()}_")
        _temporary_files.add(path)
    try:
        yield path
    finally:
        with _uncut:
            _temporary_files.discard(path)
            shutil.rmtree(path, ignore_errors=True)


def remove_stale_folders(prefix: str) -> list[str]:
    """Remove the ``temporary_folder``s of ``prefix`` that a killed process left: older than
    now and owned by a process that no longer runs. Returns the folders removed."""
    started, removed = time.time(), []
    root = tempfile.gettempdir()
    with contextlib.suppress(OSError):
        for entry in os.scandir(root):
            owner, _, rest = entry.name.removeprefix(prefix).partition("_")
            if not (entry.name.startswith(prefix) and owner.isdigit() and rest and entry.is_dir(follow_symlinks=False)):
                continue
            with contextlib.suppress(OSError):
                if entry.stat(follow_symlinks=False).st_mtime < started and not _runs(int(owner)):
                    shutil.rmtree(entry.path)
                    removed.append(entry.path)
    return removed


def _runs(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def _umask() -> int:
    mask = os.umask(0o077)  # the only portable way to read it is to set it; set back at once
    os.umask(mask)
    return mask


def stop_writes() -> None:
    """Wait for an uncut block in progress, then let none start again (the process is ending),
    and remove the temporary files and folders of the writes in progress."""
    _uncut.acquire()  # never released
    for path in list(_temporary_files):
        with contextlib.suppress(OSError):
            if os.path.isdir(path) and not os.path.islink(path):
                shutil.rmtree(path)
            else:
                os.remove(path)
