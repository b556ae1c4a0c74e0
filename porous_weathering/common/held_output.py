"""The process's own output held for a block (``held``): file descriptors 1 and 2, where
Blender's C code and its add-ons print past Python's ``sys.stdout``, kept in temporary files and
written out after the block, less the lines a user did not ask for (a bake's "saved to internal
image" note in the middle of the command line's progress bar), or not at all when the block
failed and its error says it in one line. A command ended by a signal in the middle of a block
gives the descriptors back first (``give_back``), so that its last line is seen."""

import contextlib
import os
import sys
import tempfile
import threading
from collections.abc import Iterator, Sequence
from typing import BinaryIO

_lock = threading.Lock()


class _Hold:
    """One block's held descriptors: each one's duplicate of what it was, and its store."""

    def __init__(self, dropped: Sequence[bytes]):
        self.dropped = tuple(dropped)
        self.kept: dict[int, tuple[int, BinaryIO]] = {}

    def give_back(self, shown: bool) -> None:
        """Each descriptor back as it was, then what it held, less the dropped lines, if ``shown``."""
        _flush()
        for fd, (saved, store) in self.kept.items():
            os.dup2(saved, fd)
            os.close(saved)
            if not shown:
                continue
            store.seek(0)
            with open(fd, "wb", closefd=False) as output:
                output.writelines(line for line in store if not any(note in line for note in self.dropped))


#: The blocks holding the descriptors now, the innermost last.
_holds: list[_Hold] = []


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # a stream closed or replaced by the host
            stream.flush()


@contextlib.contextmanager
def held(dropped: Sequence[bytes] = (), *, shown_on_error: bool = True) -> Iterator[None]:
    """Hold file descriptors 1 and 2 for the block, then write out what was printed, less the
    lines that hold one of ``dropped`` (Blender 5 puts a time and a log's name before some);
    with ``shown_on_error`` False, nothing when the block raised."""
    _flush()
    hold = _Hold(dropped)
    with contextlib.ExitStack() as stack:
        for fd in (1, 2):
            store = stack.enter_context(tempfile.TemporaryFile())
            try:
                hold.kept[fd] = (os.dup(fd), store)
            except OSError:  # no such descriptor (a program started without a console): nothing to hold
                continue
            os.dup2(store.fileno(), fd)
        with _lock:
            _holds.append(hold)
        failed = True
        try:
            yield
            failed = False
        finally:
            with _lock:
                if hold in _holds:  # not given back already by a signal's end
                    _holds.remove(hold)
                    hold.give_back(not failed or shown_on_error)


def give_back() -> None:
    """Every held descriptor back as it was, what they held written out: called by a command
    that ends in the middle of a block (``interrupts``), before its last line."""
    with _lock:
        while _holds:
            _holds.pop().give_back(True)
