"""A benchmark's stage in a fresh child process, so that its memory peak, caches and imports are
its own: the child reports its result as a line of JSON (``report``), the parent reads it and the
child's peak resident memory (``run``: ``ru_maxrss`` from ``os.wait4``)."""

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: What marks the child's result among whatever else it prints (Blender's own lines).
RESULT = "RESULT "


def report(result) -> None:
    """Print ``result`` (JSON-able) as the child's result."""
    print(RESULT + json.dumps(result), flush=True)


@dataclasses.dataclass
class Apart:
    """What a child run gave: its result (None if it failed or reported none), its peak resident
    bytes, and the end of what it wrote to stderr."""

    result: dict | None
    peak_bytes: int
    errors: str


def run(script, arguments) -> Apart:
    """Run ``script`` (a path) with ``arguments`` in a fresh Python from the repository root."""
    with tempfile.TemporaryFile("w+") as errors:  # a file, not a pipe: the child never blocks on it
        command = [sys.executable, os.path.abspath(script), *map(str, arguments)]
        process = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=errors, text=True)
        output = process.stdout.read()
        process.stdout.close()
        _, status, usage = os.wait4(process.pid, 0)
        process.returncode = os.waitstatus_to_exitcode(status)  # reaped here: Popen must not wait again
        errors.seek(0)
        tail = errors.read()[-500:]
    lines = [line.removeprefix(RESULT) for line in output.splitlines() if line.startswith(RESULT)]
    result = json.loads(lines[-1]) if process.returncode == 0 and lines else None
    return Apart(result, usage.ru_maxrss * 1024, tail)  # ru_maxrss is in KiB on Linux


def stages_main(script, description, stages, child, *, resolution, triangles, argv=None):
    """The command of a benchmark of ``stages`` on an image of ``--resolution``² and a mesh of
    ``--triangles``: each stage run apart (``run``), its result printed with the child's peak
    memory; run as ``--child STAGE``, ``child(stage, args)`` measures it and ``report``s."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--stages", nargs="+", choices=stages, default=list(stages))
    parser.add_argument("--resolution", type=int, default=resolution)
    parser.add_argument("--triangles", type=int, default=triangles)
    parser.add_argument("--child", choices=stages, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child(args.child, args)
    print(f"load average at the start: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    for stage in args.stages:
        done = run(script, ["--child", stage, "--resolution", args.resolution, "--triangles", args.triangles])
        result = done.result if done.result is not None else {"failed": done.errors}
        print(f"{stage}: {json.dumps(result)} peak {done.peak_bytes / 1024**2:.0f} MiB")
