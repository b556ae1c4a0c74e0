"""The process's own output held for a block (``held``): file descriptors 1 and 2, where
Blender's C code and its add-ons print past Python's ``sys.stdout``, and Python's streams, which
Blender's operator reports go through, kept in temporary files and written out after the block
through the streams, less the lines a user did not ask for (a bake's "saved to internal image"
note in the middle of the command line's progress bar) and the empty lines, or not at all when the
block failed and its error says it in one line. A command ended by a signal in the middle of a
block gives them back first (``give_back``), so that its last line is seen."""

import contextlib
import os
import sys
import tempfile
import threading
from collections.abc import Iterator, Sequence
from typing import BinaryIO, TextIO

_lock = threading.Lock()


#: The Python stream of each descriptor held.
_STREAMS = {1: "stdout", 2: "stderr"}


class _Hold:
    """One block's held descriptors: each one's duplicate of what it was, its store, and the
    Python stream that wrote to it (which Blender's operator reports go through: in a Dask bake
    process a stream that forwards each line, not the descriptor)."""

    def __init__(self, dropped: Sequence[bytes]):
        self.dropped = tuple(dropped)
        self.kept: dict[int, tuple[int, BinaryIO, TextIO | None]] = {}

    def hold(self, fd: int, store: BinaryIO) -> None:
        """``fd`` and its Python stream written to ``store`` until ``give_back`` (OSError, nothing
        held, for a descriptor the process does not have)."""
        self.kept[fd] = (os.dup(fd), store, getattr(sys, _STREAMS[fd]))
        os.dup2(store.fileno(), fd)
        setattr(sys, _STREAMS[fd], open(fd, "w", encoding="utf-8", errors="replace", closefd=False, buffering=1))

    def give_back(self, shown: bool) -> None:
        """Each descriptor and stream back as it was, then what they held, less the dropped lines
        and the empty ones (Blender's spacing between its notes), if ``shown``, through the stream."""
        _flush()
        for fd, (saved, store, stream) in self.kept.items():
            # the block's stream is left open (closefd=False): a logger that took it during the
            # block (the glTF add-on's, when its export fails) writes to the descriptor given back
            setattr(sys, _STREAMS[fd], stream)
            os.dup2(saved, fd)
            os.close(saved)
            if not shown:
                continue
            store.seek(0)
            kept = [line for line in store if line.strip() and not any(note in line for note in self.dropped)]
            if stream is None:  # no Python stream (a program started without a console)
                os.write(fd, b"".join(kept))
            else:
                stream.write(b"".join(kept).decode("utf-8", "replace"))
                stream.flush()


#: The blocks holding the descriptors now, the innermost last.
_holds: list[_Hold] = []


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # a stream closed or replaced by the host
            stream.flush()


@contextlib.contextmanager
def held(dropped: Sequence[bytes] = (), *, shown_on_error: bool = True) -> Iterator[None]:
    """Hold file descriptors 1 and 2 and Python's streams on them (``sys.stdout``, ``sys.stderr``)
    for the block, then write out through the streams what was printed, less the lines that hold
    one of ``dropped`` (Blender 5 puts a time and a log's name before some) and the empty lines;
    with ``shown_on_error`` False, nothing when the block raised."""
    _flush()
    hold = _Hold(dropped)
    with contextlib.ExitStack() as stack:
        for fd in _STREAMS:
            store = stack.enter_context(tempfile.TemporaryFile())
            with contextlib.suppress(OSError):  # no such descriptor (a program started without a console)
                hold.hold(fd, store)
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
