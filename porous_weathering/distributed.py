"""Batch baking on a Dask cluster: ``bake ... --workers N`` or ``--scheduler ADDRESS`` (docs/batch.md).

Every task runs the ``bake`` command itself in a fresh process on a worker:
``python -m porous_weathering bake FILE --objects=OBJECT --maps MAP ...``. A fresh process because
bpy holds one scene per process, and so that a crashing bake takes down one process, not the
worker. The command writes its map atomically and skips it when the stored input hash matches,
so a task is idempotent: a retried or re-run task writes its map whole or finds it "unchanged".

The run has up to three phases, each a set of Dask tasks:

1. plan: a dry run per file lists its (object, map) pairs and which are already up to date;
2. bake: one task per (file, object, map) that is not up to date;
3. save (``--save``): per file, once all its maps are baked, the command with ``--save`` links
   them into the .blend (its maps are then "unchanged") - one process per .blend, never two.

A worker that dies mid-task is replaced, and the scheduler runs the task elsewhere (up to
``distributed.scheduler.allowed-failures`` times); a bake process killed by a signal (a crash,
the OOM killer) is retried through ``retries=``. Each attempt logs an event on the scheduler,
from which the CLI reports retries.

Workers import this module to run its tasks without bpy: it imports nothing that imports bpy.
"""

import argparse
import contextlib
import ctypes
import logging
import os
import signal
import subprocess
import sys
import time
from collections import Counter, defaultdict
from dataclasses import dataclass, replace

from .progress import ProgressBar

#: Where ``python -m porous_weathering`` is found by the bake processes of a worker.
PACKAGE_PARENT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: Scheduler event topic of task attempts: {"key", "worker"}.
ATTEMPTS_TOPIC = "porous-weathering-attempt"
#: Extra attempts of a task whose bake process was killed by a signal.
RETRIES = 1
CONNECT_TIMEOUT = "10s"
#: Loaded before any fork: a forked child of a threaded worker must not dlopen.
_LIBC = ctypes.CDLL(None) if sys.platform.startswith("linux") else None
_PR_SET_PDEATHSIG = 1


def add_arguments(parser):
    """The options of ``bake`` that hand the work to Dask (the default is the serial run)."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=_positive_int,
        metavar="N",
        help="bake on a local Dask cluster of N worker processes, one (file, object, map) per task (docs/batch.md)",
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
    """What one task did: ``status`` is an Outcome status, "failed" or "saved"."""

    file: str
    object: str
    map: str
    status: str
    where: str = ""
    error: str = ""
    seconds: float = 0.0
    workers: tuple = ()  # of each attempt, in order: set by the client from the attempt events


def plan_file(path, selection, options):
    """Task: the Results of a dry run of ``path`` ("planned" or "unchanged"), or one "failed"."""
    started = time.monotonic()
    process = _run_bake_command([path, *selection, *options, "--dry-run"])
    if process.returncode != 0:
        return [Result(path, "", "", "failed", error=_error_message(process.stderr))]
    seconds = time.monotonic() - started
    return [
        Result(path, obj, map_name, status, where, seconds=seconds)
        for status, obj, map_name, where in parse_outcomes(process.stdout)
    ]


def bake_map(path, object_name, map_name, options):
    """Task: bake one map of one object of ``path``; its Result."""
    started = time.monotonic()
    process = _run_bake_command([path, f"--objects={object_name}", "--maps", map_name, *options])
    seconds = time.monotonic() - started
    outcomes = parse_outcomes(process.stdout)
    if process.returncode != 0 or len(outcomes) != 1:
        return Result(path, object_name, map_name, "failed", error=_error_message(process.stderr), seconds=seconds)
    status, _, _, where = outcomes[0]
    return Result(path, object_name, map_name, status, where, seconds=seconds)


def save_file(path, object_names, options):
    """Task: link the baked maps of ``object_names`` into ``path`` and save it."""
    started = time.monotonic()
    process = _run_bake_command([path, "--objects", *object_names, *options, "--save"])
    status, error = ("saved", "") if process.returncode == 0 else ("failed", _error_message(process.stderr))
    return Result(path, "", "", status, path, error, time.monotonic() - started)


def parse_outcomes(stdout):
    """(status, object, map, where) of the outcome lines the bake command prints:
    ``STATUS OBJECT.MAP -> WHERE``."""
    outcomes = []
    for line in stdout.splitlines():
        status, _, rest = line.partition(" ")
        if status in ("written", "unchanged", "planned") and " -> " in rest:
            name, where = rest.strip().split(" -> ", 1)
            obj, map_name = name.rsplit(".", 1)
            outcomes.append((status, obj, map_name, where))
    return outcomes


def _run_bake_command(argv):
    _log_attempt()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, (PACKAGE_PARENT, os.environ.get("PYTHONPATH")))))
    process = subprocess.run(
        [sys.executable, "-m", "porous_weathering", "bake", *argv],
        capture_output=True,
        text=True,
        env=env,
        preexec_fn=_die_with_parent,
    )
    if process.returncode < 0:  # a crash or the OOM killer, not a bad input: worth another attempt
        raise ChildProcessError(
            f"bake process killed by signal {-process.returncode}: {_error_message(process.stderr)}"
        )
    return process


def _die_with_parent():
    """In the bake process before exec: die with the worker, so no orphan bakes on after it."""
    if _LIBC is not None:
        _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)


def _log_attempt():
    from distributed import get_worker

    worker = get_worker()
    worker.log_event(ATTEMPTS_TOPIC, {"key": worker.get_current_task(), "worker": worker.address})


def _error_message(stderr):
    """The last line the command printed: its ``error: ...`` or the exception of a traceback."""
    lines = [line.strip() for line in stderr.replace("\r", "\n").splitlines() if line.strip()]
    return lines[-1] if lines else "the bake command failed without a message"


# --- the command line, in the client process -------------------------------------------------


def run(args, target, map_names, shared):
    """``bake`` on Dask; returns the exit code (0: every requested map was written or is up to date).

    ``shared`` are the command-line words of the bake options every bake process of this run
    gets (``BakeOptions.to_argv``); files, objects and maps come per task."""
    if target == "attribute":
        print(
            "error: attribute maps live in the .blend, which one process must write: use --target image "
            "with --workers/--scheduler, or bake attributes without them",
            file=sys.stderr,
        )
        return 2
    try:
        with _connect(args) as client:
            return _run_on(client, args, map_names, shared)
    except SchedulerUnreachable as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


class SchedulerUnreachable(Exception):
    pass


@contextlib.contextmanager
def _connect(args):
    from distributed import Client, LocalCluster

    if args.scheduler:
        try:
            client = Client(args.scheduler, timeout=CONNECT_TIMEOUT)
        except OSError as error:  # includes the connection timeout
            raise SchedulerUnreachable(f"cannot reach the Dask scheduler {args.scheduler}: {error}") from error
        with client:
            yield client
        return
    # One thread per worker: a bake process already uses every core of the machine.
    with (
        LocalCluster(
            n_workers=args.workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client


@dataclass(frozen=True)
class _Task:
    function: object
    arguments: tuple
    lost: Result  # what to report when the task failed for good (e.g. its workers kept dying)


def _run_on(client, args, map_names, shared):
    files = [os.path.abspath(path) for path in args.files]
    selection = (
        [f"--collection={args.collection}"] if args.collection else ["--objects", *args.objects] if args.objects else []
    )

    plans = _gather(
        client,
        ProgressBar("plan"),
        [
            _Task(
                plan_file, (path, [*selection, "--maps", ",".join(map_names)], shared), [Result(path, "", "", "failed")]
            )
            for path in files
        ],
    )
    planned = _refuse_clashes([result for plan in plans for result in plan])
    if args.dry_run:
        return _report(planned)
    baked = _gather(
        client,
        ProgressBar("bake"),
        [
            _Task(bake_map, (r.file, r.object, r.map, shared), replace(r, status="failed"))
            for r in planned
            if r.status == "planned"
        ],
    )
    results = [r for r in planned if r.status != "planned"] + baked
    if args.save:
        failed_files = {r.file for r in results if r.status == "failed"}
        objects = {path: sorted({r.object for r in results if r.file == path}) for path in files}
        results += _gather(
            client,
            ProgressBar("save"),
            [
                _Task(save_file, (path, objects[path], shared), Result(path, "", "", "failed"))
                for path in files
                if path not in failed_files
            ],
        )
    return _report(results)


def _gather(client, bar, tasks):
    """Run the tasks on the cluster, with a progress bar; their results in order, each Result
    carrying the workers its task ran on (from the attempt events)."""
    from distributed import as_completed

    futures = {client.submit(t.function, *t.arguments, pure=False, retries=RETRIES): t for t in tasks}
    keys = [future.key for future in futures]
    results = {}
    for done, future in enumerate(as_completed(list(futures)), 1):
        task = futures.pop(future)
        if future.status == "finished":
            results[future.key] = future.result()
        else:
            error = future.exception()
            results[future.key] = _with(task.lost, error=f"{type(error).__name__}: {error}")
        future.release()  # else the scheduler recomputes a fetched result whose worker dies later
        bar(done / len(keys), f"{done}/{len(keys)} {os.path.basename(task.arguments[0])}")
    if keys:
        bar.finish()
    workers = defaultdict(tuple)
    for _, event in client.get_events(ATTEMPTS_TOPIC):
        workers[event["key"]] += (event["worker"],)
    return [_with(results[key], workers=workers[key]) for key in keys]


def _with(result, **changes):
    """``result`` (a Result or a plan's list of them) with ``changes``."""
    if isinstance(result, list):
        return [replace(r, **changes) for r in result]
    return replace(result, **changes)


def _refuse_clashes(planned):
    """Fail the maps of a file when an earlier file writes the same image (as the serial run does)."""
    claimed, checked = {}, []
    for result in planned:
        owner = claimed.setdefault(result.where, result.file) if result.where else result.file
        if owner != result.file:
            result = replace(
                result,
                status="failed",
                error=f"{os.path.basename(owner)} also writes {result.where}: bake it into another --out",
            )
        checked.append(result)
    return checked


def _report(results):
    """Print the summary table (stdout), retries and errors; the exit code."""
    print(f"{'status':9} {'tries':>5} {'seconds':>7}  file / map")
    for r in results:
        name = f"{os.path.basename(r.file)}" + (f": {r.object}.{r.map}" if r.object else "")
        print(f"{r.status:9} {len(r.workers):>5} {r.seconds:>7.1f}  {name}" + (f" -> {r.where}" if r.where else ""))
    for r in results:
        if len(r.workers) > 1:
            print(
                f"retried   {os.path.basename(r.file)}: {r.object}.{r.map} ran on {', '.join(r.workers)} "
                f"(a worker was lost or its bake process was killed)"
            )
    failed = [r for r in results if r.status == "failed"]
    for r in failed:
        print(f"error: {r.file}" + (f": {r.object}.{r.map}" if r.object else "") + f": {r.error}", file=sys.stderr)
    counts = Counter(r.status for r in results)
    print(", ".join(f"{n} {status}" for status, n in sorted(counts.items())))
    return 1 if failed else 0
