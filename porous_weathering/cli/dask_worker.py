"""What runs on a Dask worker for ``bake ...`` or ``survey ...`` with ``--workers N`` /
``--scheduler ADDRESS`` (the client is ``distributed``; docs/batch.md).

A task (``in_bake_process``) runs in the worker's *bake process*: one long-lived Python process
per worker that imports bpy once and runs the command (``entry.main``: one of ``COMMANDS``) for
every task it is given, so a task costs a file open, not a Blender start. A process of its own, not the worker,
because bpy holds one scene per process and is not thread-safe, and so that a crashing bake
takes down that process, not the worker: the task starts a new bake process and runs once more.
Each attempt logs an event (the client prints a ``retried`` line from them); the bake process
also reports its progress bar through events. A task that learns it was cancelled, or whose
worker closes, stops its bake process (SIGTERM: the bake command discards the map in flight and
does not save).

This module imports no bpy: the workers run its tasks without bpy, and only the bake processes
(``serve``, started as ``python -c "from porous_weathering.cli.dask_worker import serve; ..."``)
import it.
"""

import contextlib
import ctypes
import functools
import io
import json
import os
import re
import select
import signal
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass

from ..contracts import EXIT_FAILED, EXIT_OK, EXIT_SIGINT, EXIT_USAGE, EXTENSION_ROOT

#: The commands a bake process runs for a task, each as the command line does (``entry.main``).
COMMANDS = ("bake", "survey")
#: Extra attempts of a task whose bake process died.
RETRIES = 1
#: How often a running task checks whether it was cancelled (seconds).
CANCEL_POLL = 0.2
#: How long a stopped bake process gets to discard its map in flight before it is killed.
STOP_GRACE = 10.0
#: Loaded before any fork: a forked child of a threaded worker must not dlopen.
_LIBC = ctypes.CDLL(None) if sys.platform.startswith("linux") else None
_PR_SET_PDEATHSIG = 1
#: A frame of the progress bar of the bake command (progress.ProgressBar): its percentage and message.
_BAR_FRAME = re.compile(r"\] +(\d+)% (.*)$")
#: The bake process: Python running ``serve`` (its argument, the file descriptor of the replies, appended).
SERVE = "from porous_weathering.cli.dask_worker import serve; serve({reply_fd})"


@dataclass(frozen=True)
class Result:
    """What a request printed and returned in a bake process (one task)."""

    files: tuple
    code: int
    stdout: tuple = ()  # its lines: the outcome lines ("written OBJECT.MAP -> WHERE", "saved ...", "written PATH")
    stderr: tuple = ()  # its message lines ("error: FILE: ..."), progress bar frames left out
    workers: tuple = ()  # of each attempt, in order (set by the client from the attempt events)


def in_bake_process(request: list[str], files: list[str], topic: str) -> Result:
    """Task: ``request`` (see ``serve``) about ``files`` in this worker's bake process.

    A bake process that dies (a crash, the OOM killer) is replaced and the request runs once
    more; cancelled (the client was interrupted), the task stops its bake process."""
    from distributed import get_worker

    worker = get_worker()
    key = worker.get_current_task()

    def cancelled():  # by the client, or the worker is closing (its cluster too, maybe)
        task = worker.state.tasks.get(key)
        running = task is not None and task.state in ("executing", "long-running")
        return not (running and worker.status.name in ("running", "paused"))

    def report(**event):
        worker.log_event(topic, {"key": key, **event})

    with _BAKE_PROCESS_LOCK:  # one request at a time per worker, whatever its number of threads
        for _ in range(1 + RETRIES):
            report(attempt=worker.address)
            try:
                return _bake_process().run(request, files, cancelled, report)
            except _BakeProcessDied as error:
                died = error
    return Result(tuple(files), EXIT_FAILED, stderr=(f"error: {', '.join(files)}: {died}",))


class _BakeProcessDied(Exception):
    pass


_BAKE_PROCESS_LOCK = threading.Lock()
_bake_process_of_worker = None


def _bake_process():
    """This worker's bake process, started anew if it is not running."""
    global _bake_process_of_worker
    if _bake_process_of_worker is None or _bake_process_of_worker.process.poll() is not None:
        _bake_process_of_worker = _BakeProcess()
    return _bake_process_of_worker


class _BakeProcess:
    """A Python process with bpy that runs ``serve``: the bake command once per request."""

    def __init__(self):
        replies, reply_end = os.pipe()
        # Its fd 2 (Blender's own messages, a crash's last words) goes to a file read when it dies;
        # append mode, so that truncating it between requests works.
        self.messages = tempfile.TemporaryFile("a+")
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, (EXTENSION_ROOT, os.environ.get("PYTHONPATH")))))
        self.process = subprocess.Popen(
            [sys.executable, "-c", SERVE.format(reply_fd=reply_end)],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,  # Blender's "Read blend" and "Info: Baking map saved" notes
            stderr=self.messages,
            pass_fds=(reply_end,),
            env=env,
            start_new_session=True,  # a Ctrl-C on the terminal reaches the client, which cancels
            preexec_fn=_die_with_parent,
        )
        os.close(reply_end)
        self.replies = replies

    def run(self, request, files, cancelled, report):
        """The Result of ``request``; _BakeProcessDied when the process dies before it answers."""
        self.messages.truncate(0)
        stdout, stderr, percent = [], [], None
        try:
            self.process.stdin.write((json.dumps(request) + "\n").encode())
            self.process.stdin.flush()
        except BrokenPipeError:
            raise self._died() from None
        pending = b""
        while True:
            ready = select.select([self.replies], [], [], CANCEL_POLL)[0]
            if cancelled():
                self.stop()
                return Result(tuple(files), EXIT_SIGINT)  # for no one: the client cancelled the task
            if not ready:
                continue
            chunk = os.read(self.replies, 65536)
            if not chunk:
                raise self._died()
            *lines, pending = (pending + chunk).split(b"\n")
            for line in lines:
                message = json.loads(line)
                if "code" in message:
                    return Result(tuple(files), message["code"], tuple(stdout), tuple(stderr))
                if "out" in message:
                    stdout.append(message["out"])
                elif "err" in message:
                    stderr.append(message["err"])
                elif (frame := _BAR_FRAME.search(message["frame"])) and frame[1] != percent:
                    percent = frame[1]
                    report(progress=int(percent) / 100, message=frame[2].strip())

    def _died(self):
        code = self.process.wait()
        self.messages.seek(0)
        last_words = [line.strip() for line in self.messages if line.strip()]
        self._close()
        how = f"killed by signal {-code}" if code < 0 else f"ended with exit code {code}"
        return _BakeProcessDied(f"the bake process was {how}" + (f": {last_words[-1]}" if last_words else ""))

    def stop(self):
        """SIGTERM: the bake command discards its map in flight and does not save; then KILL."""
        self.process.terminate()
        try:
            self.process.wait(STOP_GRACE)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self._close()

    def _close(self):
        with contextlib.suppress(BrokenPipeError):  # a request it never read
            self.process.stdin.close()
        os.close(self.replies)
        self.messages.close()


def _die_with_parent():
    """In the bake process before exec: SIGTERM when the worker thread that started it ends, so
    no bake carries on (or saves) after its worker is gone."""
    if _LIBC is not None:
        _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def serve(reply_fd: int) -> None:
    """The bake process. Each line of stdin is a request, a JSON list of words: ``[COMMAND, ...]``
    runs that command (``COMMANDS``: ``bake``, ``survey``) with those words; ``["meshes", FILE]``
    opens FILE and prints the names of its mesh objects (a JSON list). What it prints goes out
    on ``reply_fd`` as it comes, then its exit code, one JSON message a line: {"out": line},
    {"err": line}, {"frame": progress bar frame}, {"code": int}."""
    from ..blender import compat

    # stopped between requests (the worker closes): the bake command takes the signals while it runs
    signal.signal(signal.SIGTERM, lambda number, frame: compat.end_process(128 + number))
    requests = {"meshes": _print_mesh_objects}
    requests.update({name: functools.partial(_run_command, name) for name in COMMANDS})
    replies = os.fdopen(reply_fd, "w", buffering=1)

    def send(**message):
        try:
            replies.write(json.dumps(message) + "\n")
        except BrokenPipeError:  # the worker is gone (killed): no one wants this bake any more
            compat.end_process(EXIT_FAILED)

    for line in sys.stdin:
        command, *words = json.loads(line)
        with (
            contextlib.redirect_stdout(_forwarding_stream(send, "out")),
            contextlib.redirect_stderr(_forwarding_stream(send, "err")),
        ):
            try:
                code = requests[command](*words)
            except SystemExit as error:  # argparse: the client checked the words, so unexpected
                code = error.code if isinstance(error.code, int) else EXIT_USAGE
            except Exception as error:  # what the serial run would end with as a traceback
                print(f"error: {type(error).__name__}: {error}", file=sys.stderr)
                code = EXIT_FAILED
        send(code=code)
    replies.close()
    compat.end_process(EXIT_OK)


def _run_command(name, *words):
    from . import entry

    return entry.main([name, *words])


def _print_mesh_objects(path):
    import bpy

    from ..blender import blend_file

    blend_file.open_blend(path)
    print(json.dumps(sorted(o.name for o in bpy.data.objects if o.type == "MESH")))
    return EXIT_OK


def _forwarding_stream(send, kind):
    """A text stream that sends each line written to it as {kind: line}, and each frame of a
    progress bar (text after a carriage return) as {"frame": text}."""
    return io.TextIOWrapper(_LineForwarder(send, kind), encoding="utf-8", errors="replace", write_through=True)


class _LineForwarder(io.RawIOBase):
    def __init__(self, send, kind):
        self.send, self.kind, self.pending, self.in_frame = send, kind, "", False

    def writable(self):
        return True

    def write(self, data):
        *pieces, self.pending = re.split(r"([\r\n])", self.pending + bytes(data).decode("utf-8", "replace"))
        for text, end in zip(pieces[0::2], pieces[1::2], strict=True):
            if text.strip() and not self.in_frame:
                self.send(**{self.kind: text})
            self.in_frame = end == "\r"
        if self.in_frame and self.pending.strip():  # ProgressBar writes each frame whole, in one call
            self.send(frame=self.pending)
            self.pending = ""
        return len(data)
