"""Batch runs on a Dask cluster, the client: ``bake ...`` or ``survey ...`` with ``--workers N``
or ``--scheduler ADDRESS`` (docs/batch.md): their options, the tasks it schedules and the exit
code it combines from their results. What a task runs on a worker is ``dask_worker``.

A task runs the command itself on whole files (``bake FILE ... --maps ...``, ``survey FILE ...
--years ...``) in a bake process of its worker (``dask_worker.in_bake_process``), so its
outcomes, messages and exit code are those of the serial run by construction.

Files interact only through outputs of the same path, which the serial run settles in file
order: image maps of mesh objects of the same name (one ``--out``), whose names a bake of
several files first lists (in parallel: a file open each, no bake); surveys named after .blend
files of the same name. Files that share a name run together, in their order, in one task: the
serial run on those files.

A worker that dies mid-task is replaced, and the scheduler runs its task elsewhere (up to
``distributed.scheduler.allowed-failures`` times); a task whose bake process dies runs once more
(``dask_worker.RETRIES``). Each attempt logs an event, from which the client prints a
``retried`` line; the bake processes also report their progress bar through events.
Interrupted (SIGINT, SIGTERM), the client cancels its tasks, which stop their bake processes.

This module imports nothing that imports bpy (nor does ``dask_worker``).
"""

import argparse
import contextlib
import json
import logging
import multiprocessing
import os
import signal
import sys
import tempfile
import threading
import uuid
import warnings
from collections.abc import Callable

from ..common import process_end
from ..common.progress import ProgressBar
from ..contracts import EXIT_FAILED, EXIT_OK, EXIT_USAGE, batch_exit_code
from .dask_worker import Result, in_bake_process

#: How long the client waits for the scheduler of --scheduler to answer.
CONNECT_TIMEOUT = "10s"


def add_arguments(parser: argparse.ArgumentParser, command: str) -> None:
    """The options of ``command`` (bake, survey) that hand its files to Dask (the default is the
    serial run)."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=_positive_int,
        metavar="N",
        help=f"{command} on a local Dask cluster of N worker processes, one file per task (docs/batch.md)",
    )
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help=f"{command} on the workers of a running Dask scheduler, e.g. tcp://host:8786; "
        "files and --out must be reachable by every worker at the same path",
    )


def _positive_int(text):
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a number of workers of 1 or more, got {text!r}")
    return int(text)


# --- the command line, in the client process -------------------------------------------------


#: The names of what each of the files writes that another file could write too (``clash_groups``).
Outputs = Callable[["_Run", list[str]], list[list[str]]]


def run(args: argparse.Namespace, command: str, words: list[str], outputs: Outputs | None, interrupted: str) -> int:
    """``command`` (``dask_worker.COMMANDS``) on Dask over ``args.files``; returns the exit code,
    that of the serial run on the same inputs.

    ``words`` are the command-line words of the options every task of this run gets (its
    objects, ``BakeOptions.to_argv``, ``SurveyOptions.to_argv``, switches); ``outputs`` names
    what each file writes (None: nothing two files could both write); ``interrupted`` says
    what an interrupt leaves."""
    files = [os.path.abspath(path) for path in args.files]
    try:
        with _interrupts_raised(), _connect(args) as client:
            return _Run(client, command).run(files, words, outputs)
    except SchedulerUnreachable as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except Interrupted as interrupt:
        print(f"\ninterrupted: the tasks were cancelled; {interrupted}", file=sys.stderr)
        return interrupt.code


class SchedulerUnreachable(Exception):
    pass


class Interrupted(Exception):
    """SIGINT or SIGTERM reached the client: ``code`` is 128 + the signal number (EXIT_SIGINT,
    EXIT_SIGTERM)."""

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
    # Their scratch space in a folder of this run's, removed with it (else Dask leaves its own).
    with tempfile.TemporaryDirectory(prefix="pw_dask_", ignore_cleanup_errors=True) as scratch:
        client_handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            with (
                dask.config.set(
                    {"distributed.worker.multiprocessing-method": "forkserver", "temporary-directory": scratch}
                ),
                warnings.catch_warnings(),
            ):
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
        process_end.remove_at_end(_multiprocessing_folder)
        with cluster, Client(cluster) as client:
            yield client


def _multiprocessing_folder():
    """multiprocessing's folder for this process (where the forkserver's socket is), which only
    its exit-time finalizer removes, or None. Read where ``multiprocessing.util.get_temp_dir``
    keeps it (Python 3.11 and 3.13 alike): no public call returns it without making one."""
    return multiprocessing.process.current_process()._config.get("tempdir")


class _Run:
    """One run of a command on a cluster. Its tasks report their attempts and progress as events
    of a topic of this run, which arrive on the client's event-loop thread."""

    def __init__(self, client, command):
        self.client, self.command = client, command
        self.topic = f"porous-weathering-{uuid.uuid4().hex}"
        self.attempts = {}  # task key -> the workers of its attempts
        self.running = {}  # task key -> the fraction of its bake done, for the tasks of this phase
        self.lock = threading.Lock()  # the progress bar and the output, drawn from both threads
        self.bar, self.done, self.total = None, 0, 0
        client.subscribe_topic(self.topic, self._on_event)

    def run(self, files, words, outputs):
        """The command on ``files`` with ``words``; the exit code."""
        named = outputs(self, files) if outputs and len(files) > 1 else [[] for _ in files]
        requests = [([self.command, *group, *words], group) for group in clash_groups(files, named)]
        results = self._gather(self.command, requests, show=True)
        for r in results:
            if len(r.workers) > 1:
                print(
                    f"retried   {', '.join(map(os.path.basename, r.files))} ran on {', '.join(r.workers)} "
                    "(a worker was lost or its bake process died)",
                    flush=True,
                )
        return batch_exit_code(r.code for r in results)

    def mesh_names(self, files):
        """The names of the mesh objects of each file (none for a file that cannot be opened)."""
        listed = self._gather("list", [(["meshes", path], [path]) for path in files], show=False)
        return [json.loads(r.stdout[-1]) if r.code == EXIT_OK else [] for r in listed]

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
        if error is None:  # no result and no error: the client lost the scheduler that held it
            reason = f"its Dask task ended '{future.status}' with neither a result nor an error: the scheduler was lost"
        elif type(error).__name__ == "KilledWorker":
            reason = f"the Dask workers running it died {len(workers)} times"
        else:
            reason = f"{type(error).__name__}: {error}"
        return Result(
            tuple(files), EXIT_FAILED, stderr=tuple(f"error: {path}: {reason}" for path in files), workers=workers
        )

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


def clash_groups(files: list[str], outputs: list[list[str]]) -> list[list[str]]:
    """The files in groups that must run together, in their order, in one serial run: files
    that write outputs of the same name (``outputs``, each file's: the mesh objects whose image
    maps a bake names after them, ``bake.image_path``; a survey's name), and a file given twice
    (one writer per .blend). Grouping more files than needed costs only parallelism; the
    outcome is the serial run's either way."""
    group_of = list(range(len(files)))  # union-find over the files

    def root(index):
        while group_of[index] != index:
            index = group_of[index]
        return index

    first_with = {}
    for index, (path, names) in enumerate(zip(files, outputs, strict=True)):
        # casefolded: on a case-insensitive file system, "Wall" and "wall" write one file
        for key in [("file", os.path.realpath(path))] + [("output", name.casefold()) for name in names]:
            group_of[root(index)] = root(first_with.setdefault(key, index))
    groups = {}
    for index, path in enumerate(files):
        groups.setdefault(root(index), []).append(path)
    return list(groups.values())
