"""The main job's façade baked by the code of several checkouts, interleaved in one run: how a
change to the bakes moves the default bake's cost against the bake of an earlier commit
(docs/benchmarks.md, "The default bake's cost, corners that share a point baked once").

    git worktree add /tmp/before COMMIT --detach
    .venv-5.2/bin/python benchmarks/bake_versions.py [--rounds 3] /tmp/before:rain,edges,runoff . /tmp/before

Each argument is CHECKOUT[:MAPS] (a folder holding the package; the maps comma-separated, the
bake's default when left out). Round after round, each is baked in a child process of its own
on a freshly prepared façade (united and cut as the main job prepares it, ``bench_life.facade``),
target attribute, default samples; one JSON line per bake, then each one's median wall time and
its ratio to the first's. The children run one at a time, so the ratios are of one run.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

CHILD = """
import json, sys, time
root, names = sys.argv[1], tuple(n for n in sys.argv[2].split(",") if n)
sys.path[:0] = [root]
from benchmarks import bench_life
from porous_weathering.maps import bake
_, objects, _ = bench_life.facade()
started = time.monotonic()
bake.bake_maps(objects, bake.BakeOptions(maps=names, target="attribute"))
print("RESULT " + json.dumps(dict(seconds=time.monotonic() - started, corners=len(objects[0].data.loops))))
"""


def bake_once(root, maps):
    run = subprocess.run([sys.executable, "-c", CHILD, root, maps], capture_output=True, text=True, check=True)
    [line] = [line for line in run.stdout.splitlines() if line.startswith("RESULT ")]
    return json.loads(line.removeprefix("RESULT "))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("bakes", nargs="+", help="CHECKOUT[:MAPS], MAPS comma-separated (default: every map)")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    bakes = [(os.path.abspath(root), maps) for root, _, maps in (bake.partition(":") for bake in args.bakes)]
    seconds = {bake: [] for bake in bakes}
    for round_index in range(args.rounds):
        for root, maps in bakes:
            result = bake_once(root, maps)
            seconds[root, maps].append(result["seconds"])
            load = os.getloadavg()[0]
            print(json.dumps(dict(round=round_index, checkout=root, maps=maps or "default", **result, load=load)))
    first = statistics.median(seconds[bakes[0]])
    for bake, times in seconds.items():
        median = statistics.median(times)
        print(f"{bake[0]}:{bake[1] or 'default'}  median {median:.1f} s  ({median / first:.2f} x the first)")
    print(time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()))


if __name__ == "__main__":
    main()
