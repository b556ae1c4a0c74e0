"""Shadow rays through Embree (``embreex``), measured for the sun map's speed (docs/maps.md, "Sun
exposure", the bake's own rays): not a dependency of the extension, so install it first.

    python -m pip install embreex
    python benchmarks/bench_embree.py [--rays 2000000]

A bumpy terrain of SIDE² vertices (2 (SIDE - 1)² triangles) in the unit square; rays from points
just above it, towards random directions of the upper hemisphere flattened towards the horizon
(most of them hitting a bump), then all towards one sun (coherent, most escaping). Occlusion
queries (``scene.run(..., query="OCCLUDED")``) on one thread, twice, then the random rays split
over two threads. Prints the rays a second of each.
"""

import argparse
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

SIDE = 400
SUN = np.array([0.3, -0.5, 0.81])


def heights(x, y):
    return 0.05 * np.sin(20.0 * x) * np.cos(17.0 * y)


def terrain_triangles():
    """(triangles, 3, 3) float32 of the terrain."""
    x, y = np.meshgrid(np.linspace(0.0, 1.0, SIDE), np.linspace(0.0, 1.0, SIDE))
    vertices = np.stack([x, y, heights(x, y)], axis=-1).reshape(-1, 3).astype(np.float32)
    index = np.arange(SIDE * SIDE).reshape(SIDE, SIDE)
    a, b, c, d = (corner.ravel() for corner in (index[:-1, :-1], index[:-1, 1:], index[1:, :-1], index[1:, 1:]))
    return vertices[np.concatenate([np.stack([a, b, d], axis=-1), np.stack([a, d, c], axis=-1)])]


def rays(count, rng):
    """(origins, random directions, the sun's direction for all), float32."""
    place = rng.random((count, 2))
    origins = np.column_stack([place, heights(place[:, 0], place[:, 1]) + 1e-4]).astype(np.float32)
    directions = rng.normal(size=(count, 3))
    directions[:, 2] = 0.5 * np.abs(directions[:, 2])
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    coherent = np.tile(SUN / np.linalg.norm(SUN), (count, 1))
    return origins, directions.astype(np.float32), coherent.astype(np.float32)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rays", type=int, default=2_000_000)
    args = parser.parse_args()
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh
    except ImportError:
        sys.exit("bench_embree.py needs embreex: python -m pip install embreex")
    triangles = terrain_triangles()
    started = time.perf_counter()
    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, triangles)
    print(f"{len(triangles)} triangles, scene built in {time.perf_counter() - started:.2f} s")
    origins, directions, coherent = rays(args.rays, np.random.default_rng(0))

    def occluded(first, last, towards):
        return scene.run(origins[first:last], towards[first:last], query="OCCLUDED")

    def rate(label, run):
        started = time.perf_counter()
        run()
        seconds = time.perf_counter() - started
        print(f"{label}: {args.rays} rays in {seconds:.2f} s, {args.rays / seconds / 1e6:.2f} M rays/s", flush=True)

    for round_ in (1, 2):
        rate(f"random directions, one thread, round {round_}", lambda: occluded(0, args.rays, directions))
    rate("one direction (a sun), one thread", lambda: occluded(0, args.rays, coherent))
    half = args.rays // 2
    with ThreadPoolExecutor(2) as pool:
        parts = ((0, half), (half, args.rays))
        rate("random directions, two threads", lambda: list(pool.map(lambda p: occluded(*p, directions), parts)))


if __name__ == "__main__":
    main()
