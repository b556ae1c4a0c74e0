"""A command line that stops at once on SIGINT/SIGTERM, leaving no half-written file (``atomic``).

Blender does not let a KeyboardInterrupt through a bake: Cycles bakes in C, and the exception,
raised in Cycles' Python callback once the bake returns, is printed and swallowed (seen with
bpy 4.5 and 5.2; the bake then carries on). The bake releases the GIL, though, so
``exit_on_signals`` takes SIGINT and SIGTERM in a thread woken through
``signal.set_wakeup_fd``, which ends the process while the bake runs: it removes the temporary
files of the writes in progress (``atomic.temporary_file``), gives back the output a block holds
(``held_output``), prints one line and ends the process (``process_end``),
so nothing is written or saved after it. What must not be cut in two (renaming a finished file
into place, saving a .blend) runs under ``atomic.uncut()``, which the thread waits for.
"""

import contextlib
import signal
import socket
import sys
import threading
from collections.abc import Callable, Iterator

from . import atomic, held_output, process_end

SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def exit_on_signals(last_words: Callable[[str], str]) -> Iterator[None]:
    """For the block (called from the main thread): SIGINT or SIGTERM ends the process at once
    with exit code 128 + the signal (130, 143), after any ``atomic.uncut`` block in progress, with the
    temporary files removed and ``last_words(signal name)`` as one line on stderr."""
    wake, woken = socket.socketpair()  # a socket: set_wakeup_fd takes no pipe on Windows
    wake.setblocking(False)
    previous = {number: signal.signal(number, _noted_by_the_watcher) for number in SIGNALS}
    previous_wakeup = signal.set_wakeup_fd(wake.fileno(), warn_on_full_buffer=False)
    watcher = threading.Thread(target=_watch, args=(woken, last_words), name="pw-signals", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        for number, handler in previous.items():  # None: set outside Python (the blender binary's)
            signal.signal(number, signal.SIG_DFL if handler is None else handler)
        signal.set_wakeup_fd(previous_wakeup)
        wake.close()  # the watcher reads the end of the stream and returns
        watcher.join()
        woken.close()


def _noted_by_the_watcher(number, frame):
    """Python's handler must not raise: Blender would print the exception and carry on."""


def _watch(woken, last_words):
    while data := woken.recv(1):
        if data[0] in SIGNALS:
            _exit(signal.Signals(data[0]), last_words)


def _exit(number, last_words):
    try:
        atomic.stop_writes()  # waits for a write or save in progress; nothing starts after
        held_output.give_back()  # a bake holding the output: the last line must be seen
        with contextlib.suppress(Exception):
            sys.stdout.flush()
        sys.stderr.write(f"\n{last_words(number.name)}\n")
        sys.stderr.flush()
    finally:
        process_end.end(128 + number)
