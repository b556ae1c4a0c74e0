"""Batch baking on a Dask cluster: ``bake ... --workers N`` or ``--scheduler ADDRESS`` (docs/batch.md).

A task runs the ``bake`` command itself on whole files (``bake FILE ... --maps ...``), so its
outcomes, messages and exit code are those of the serial run by construction. It runs in the
worker's *bake process*: one long-lived Python process per worker that imports bpy once and runs
the command (``entry.main``) for every task it is given, so a task costs a file open, not a Blender
start. A process of its own, not the worker, because bpy holds one scene per process and is not
thread-safe, and so that a crashing bake takes down that process, not the worker: the task starts
a new bake process and runs once more.

Files interact only through image maps of the same path (mesh objects of the same name, one
``--out``), which the serial run settles in file order. So a run of several files first lists
the mesh objects of each file (in parallel: a file open each, no bake), and files that share a
name are baked together, in their order, by one task: the serial run on those files.

A worker that dies mid-task is replaced, and the scheduler runs its task elsewhere (up to
``distributed.scheduler.allowed-failures`` times). Each attempt logs an event, from which the
client prints a ``retried`` line; the bake processes also report their progress bar through
events. Interrupted (SIGINT, SIGTERM), the client cancels its tasks; a task that learns it was
cancelled, or whose worker closes, stops its bake process (SIGTERM: the bake command discards
the map in flight and does not save).

This module imports nothing that imports bpy: the workers run its tasks without bpy, and only
the bake processes (``serve``) import it.
"""

import argparse
import contextlib
import ctypes
import io
import json
import logging
import os
import re
import select
import signal
import subprocess
import sys
import tempfile
import threading
import uuid
import warnings
from dataclasses import dataclass

from ..common.progress import ProgressBar
from ..contracts import EXIT_FAILED, EXIT_OK, EXIT_REFUSED, EXIT_SIGINT, EXIT_USAGE, EXTENSION_ROOT

#: Where ``porous_weathering`` is found by the bake processes of a worker.
CONNECT_TIMEOUT = "10s"
#: Exit codes of the bake command (docs/cli.md) that a run on Dask combines as the serial run does.
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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``bake`` that hand the work to Dask (the default is the serial run)."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=_positive_int,
        metavar="N",
        help="bake on a local Dask cluster of N worker processes, one file per task (docs/batch.md)",
    )
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="bake on the workers of a running Dask scheduler, e.g. tcp://host:8786; "
        "files and --out must be reachable by every worker at the same path",
    )


def _positive_int(text):
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a number of workers of 1 or more, got {text!r}")
    return int(text)


# --- tasks, run on the workers ---------------------------------------------------------------


@dataclass(frozen=True)
class Result:
    """What a request printed and returned in a bake process (one task)."""

    files: tuple
    code: int
    stdout: tuple = ()  # its lines: for "bake", the outcome lines ("written OBJECT.MAP -> WHERE") and "saved ..."
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
    return Result(tuple(files), 1, stderr=(f"error: {', '.join(files)}: {died}",))


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
            [sys.executable, "-c", f"from porous_weathering.cli.distributed import serve; serve({reply_end})"],
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
    """The bake process. Each line of stdin is a request, a JSON list of words: ``["bake", ...]``
    runs the bake command with those words; ``["meshes", FILE]`` opens FILE and prints the names
    of its mesh objects (a JSON list). What it prints goes out on ``reply_fd`` as it comes, then
    its exit code, one JSON message a line: {"out": line}, {"err": line}, {"frame": progress
    bar frame}, {"code": int}."""
    from . import entry

    replies = os.fdopen(reply_fd, "w", buffering=1)

    def send(**message):
        try:
            replies.write(json.dumps(message) + "\n")
        except BrokenPipeError:  # the worker is gone (killed): no one wants this bake any more
            os._exit(1)

    for line in sys.stdin:
        command, *words = json.loads(line)
        with (
            contextlib.redirect_stdout(_forwarding_stream(send, "out")),
            contextlib.redirect_stderr(_forwarding_stream(send, "err")),
        ):
            try:
                code = entry.main([command, *words]) if command == "bake" else _print_mesh_objects(*words)
            except SystemExit as error:  # argparse: the client checked the words, so unexpected
                code = error.code if isinstance(error.code, int) else 2
            except Exception as error:  # what the serial run would end with as a traceback
                print(f"error: {type(error).__name__}: {error}", file=sys.stderr)
                code = 1
        send(code=code)
    replies.close()
    os._exit(0)  # skip bpy's exit-time cleanup, as entry.exit_with does


def _print_mesh_objects(path):
    import bpy

    bpy.ops.wm.open_mainfile(filepath=path, load_ui=False, use_scripts=False)  # never run a file's code
    print(json.dumps(sorted(o.name for o in bpy.data.objects if o.type == "MESH")))
    return 0


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


# --- the command line, in the client process -------------------------------------------------


def run(args: argparse.Namespace, target: str, map_names: tuple, shared: list[str]) -> int:
    """``bake`` on Dask; returns the exit code, that of the serial run on the same inputs.

    ``shared`` are the command-line words of the bake options every task of this run gets
    (``BakeOptions.to_argv``); the files, the objects chosen and ``--force``, ``--save`` and
    ``--dry-run`` come from ``args``."""
    selection = (
        [f"--collection={args.collection}"] if args.collection else ["--objects", *args.objects] if args.objects else []
    )
    words = [*selection, "--maps", ",".join(map_names), *shared] + ["--force"] * args.force
    files = [os.path.abspath(path) for path in args.files]
    try:
        with _interrupts_raised(), _connect(args) as client:
            return _Run(client, words).bake(files, target, ["--dry-run"] * args.dry_run + ["--save"] * args.save)
    except SchedulerUnreachable as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except Interrupted as interrupt:
        print(
            "\ninterrupted: the tasks were cancelled; maps finished so far are complete, "
            "no .blend file was saved after the interrupt",
            file=sys.stderr,
        )
        return interrupt.code


class SchedulerUnreachable(Exception):
    pass


class Interrupted(Exception):
    """SIGINT or SIGTERM reached the client: ``code`` is 128 + the signal number (130, 143)."""

    def __init__(self, signum):
        super().__init__(signal.Signals(signum).name)
        self.code = 128 + signum


@contextlib.contextmanager
def _interrupts_raised():
    """SIGINT and SIGTERM raise Interrupted in the main thread while in this block."""

    def handler(signum, frame):
        raise Interrupted(signum)

    previous = {number: signal.signal(number, handler) for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for number, action in previous.items():
            signal.signal(number, action)


@contextlib.contextmanager
def _connect(args):
    import dask
    from distributed import Client, LocalCluster

    if args.scheduler:
        try:
            client = Client(args.scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, ValueError) as error:  # a malformed address, or no answer in time
            raise SchedulerUnreachable(f"cannot reach the Dask scheduler {args.scheduler}: {error}") from None
        with client:
            yield client
        return
    # One thread per worker: a worker runs one bake at a time, which already uses every core.
    # Workers forked from a fresh forkserver start in half the time of spawned ones, and inherit
    # its ignored SIGINT: a Ctrl-C on the terminal reaches them too, but is the client's to handle.
    client_handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}), warnings.catch_warnings():
            # the scheduler's HTTP server (no dashboard) moves off a port in use, no matter
            warnings.filterwarnings("ignore", "Port .* is already in use")
            cluster = LocalCluster(
                n_workers=args.workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
    finally:
        signal.signal(signal.SIGINT, client_handler)
    with cluster, Client(cluster) as client:
        yield client


class _Run:
    """One ``bake`` on a cluster. Its tasks report their attempts and progress as events of a
    topic of this run, which arrive on the client's event-loop thread."""

    def __init__(self, client, words):
        self.client, self.words = client, words
        self.topic = f"porous-weathering-{uuid.uuid4().hex}"
        self.attempts = {}  # task key -> the workers of its attempts
        self.running = {}  # task key -> the fraction of its bake done, for the tasks of this phase
        self.lock = threading.Lock()  # the progress bar and the output, drawn from both threads
        self.bar, self.done, self.total = None, 0, 0
        client.subscribe_topic(self.topic, self._on_event)

    def bake(self, files, target, flags):
        """Bake ``files`` (with ``flags``: --save, --dry-run); the exit code."""
        meshes = [[] for _ in files]
        if target == "image" and len(files) > 1:  # only then can two files write the same map
            listed = self._gather("list", [(["meshes", path], [path]) for path in files], show=False)
            meshes = [json.loads(r.stdout[-1]) if r.code == 0 else [] for r in listed]
        groups = clash_groups(files, meshes)
        results = self._gather("bake", [(["bake", *group, *self.words, *flags], group) for group in groups], show=True)
        for r in results:
            if len(r.workers) > 1:
                print(
                    f"retried   {', '.join(map(os.path.basename, r.files))} ran on {', '.join(r.workers)} "
                    "(a worker was lost or its bake process died)",
                    flush=True,
                )
        return _exit_code(results)

    def _gather(self, label, requests, show):
        """Run a task per (request, files); their Results, in order, each printed as it comes
        when ``show``."""
        from distributed import as_completed

        futures = {
            self.client.submit(in_bake_process, request, files, self.topic, pure=False): files
            for request, files in requests
        }
        with self.lock:
            self.bar, self.done, self.total = ProgressBar(label), 0, len(futures)
            self.running = {future.key: 0.0 for future in futures}
        results = {}
        try:
            for future in as_completed(list(futures)):
                results[future.key] = self._result(future, futures[future])
                future.release()  # else the scheduler recomputes a fetched result whose worker dies later
                with self.lock:
                    del self.running[future.key]
                    self.done += 1
                    self._draw(os.path.basename(futures[future][-1]))
                    if show:
                        self._show(results[future.key])
        except Interrupted:
            self.client.cancel(list(futures), force=True)
            raise
        finally:
            with self.lock:
                self.bar.finish()
                self.bar = None
        return [results[future.key] for future in futures]

    def _result(self, future, files):
        """The task's Result with the workers of its attempts; one that failed for good (its
        workers kept dying: KilledWorker) as a failure of its files."""
        workers = tuple(self.attempts.get(future.key, ()))
        if future.status == "finished":
            result = future.result()
            return Result(result.files, result.code, result.stdout, result.stderr, workers)
        error = future.exception()
        reason = (
            f"the Dask workers running it died {len(workers)} times"
            if type(error).__name__ == "KilledWorker"
            else f"{type(error).__name__}: {error}"
        )
        return Result(tuple(files), 1, stderr=tuple(f"error: {path}: {reason}" for path in files), workers=workers)

    def _on_event(self, event):
        message = event[1]
        with self.lock:
            if "attempt" in message:
                self.attempts.setdefault(message["key"], []).append(message["attempt"])
            elif message["key"] in self.running:
                self.running[message["key"]] = message["progress"]
                self._draw(message["message"])

    def _draw(self, message):
        self.bar((self.done + sum(self.running.values())) / self.total, f"{self.done}/{self.total} {message}")

    def _show(self, result):
        """Print what the bake command printed, the progress bar then going on from a new line."""
        lines = [(sys.stdout, line) for line in result.stdout] + [(sys.stderr, line) for line in result.stderr]
        if lines and self.bar is not None:
            self.bar.finish()
        for stream, line in lines:
            print(line, file=stream, flush=True)


def clash_groups(files: list[str], meshes: list[list[str]]) -> list[list[str]]:
    """The files in groups that must be baked together, in their order, by one serial run:
    files that hold mesh objects of the same name (only they can have image maps of the same
    path: ``bake.image_path`` keeps distinct names apart), and a file given twice (one writer
    per .blend). ``meshes`` are the names of each file's mesh objects. Grouping more files than
    needed costs only parallelism; the outcome is the serial run's either way."""
    group_of = list(range(len(files)))  # union-find over the files

    def root(index):
        while group_of[index] != index:
            index = group_of[index]
        return index

    first_with = {}
    for index, (path, names) in enumerate(zip(files, meshes, strict=True)):
        # casefolded: on a case-insensitive file system, "Wall" and "wall" write one file
        for key in [("file", os.path.realpath(path))] + [("mesh", name.casefold()) for name in names]:
            group_of[root(index)] = root(first_with.setdefault(key, index))
    groups = {}
    for index, path in enumerate(files):
        groups.setdefault(root(index), []).append(path)
    return list(groups.values())


def _exit_code(results):
    """The serial run's exit code over all files (docs/cli.md): 1 when a file failed, else 3
    when one was refused (it would replace maps made from another .blend), else 0."""
    codes = {r.code for r in results} - {0}
    return EXIT_FAILED if codes - {EXIT_REFUSED} else EXIT_REFUSED if codes else EXIT_OK
