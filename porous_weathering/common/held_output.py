"""The process's own output held for a block (``held``): file descriptors 1 and 2, where
Blender's C code and its add-ons print past Python's ``sys.stdout``, kept in temporary files and
written out after the block, less the lines a user did not ask for (a bake's "saved to internal
image" note in the middle of the command line's progress bar), or not at all when the block
failed and its error says it in one line."""

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator, Sequence


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # a stream closed or replaced by the host
            stream.flush()


@contextlib.contextmanager
def held(dropped: Sequence[bytes] = (), *, shown_on_error: bool = True) -> Iterator[None]:
    """Hold file descriptors 1 and 2 for the block, then write out what was printed, less the
    lines that start with one of ``dropped``; with ``shown_on_error`` False, nothing when the
    block raised."""
    _flush()
    with contextlib.ExitStack() as stack:
        kept = {}
        for fd in (1, 2):
            store = stack.enter_context(tempfile.TemporaryFile())
            try:
                kept[fd] = (os.dup(fd), store)
            except OSError:  # no such descriptor (a program started without a console): nothing to hold
                continue
            os.dup2(store.fileno(), fd)
        failed = True
        try:
            yield
            failed = False
        finally:
            _flush()
            for fd, (saved, store) in kept.items():
                os.dup2(saved, fd)
                os.close(saved)
                if failed and not shown_on_error:
                    continue
                store.seek(0)
                with open(fd, "wb", closefd=False) as output:
                    output.writelines(line for line in store if not line.startswith(tuple(dropped)))
