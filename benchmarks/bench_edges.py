"""Edge/cavity mask timings (docs/maps.md, "Edge/cavity mask").

    python benchmarks/bench_edges.py [--max-vertices N] [--repeats N]

1. The curvature mask (``edges.write_curvature_attribute``: evaluate, curvature, smooth,
   map, write the ``pw_edges`` attribute) on tori of 5k to 1M vertices: it must grow
   linearly, so the table prints the time per vertex and its ratio to the smallest mesh's.
2. The Sobel mask (``edges.edge_mask_image``: two Cycles EMIT bakes plus the numpy filter)
   of a 20k-vertex torus at 256 to 2048 texels square.

Each row is the best of ``--repeats`` runs (one run above 300k vertices).
"""

import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from porous_weathering import edges  # noqa: E402

SEGMENTS = (100, 200, 400, 800, 1414)  # a torus of s x s/2 quads has s^2/2 vertices
RESOLUTIONS = (256, 512, 1024, 2048)


def torus(segments):
    """A torus of major radius 1 and minor radius 0.4, segments x segments / 2 quads, with UVs,
    made straight from numpy arrays (bmesh's primitives take quadratic time at 1M vertices)."""
    around, across = segments, segments // 2
    u, v = np.meshgrid(np.arange(around), np.arange(across), indexing="ij")
    a, b = 2 * np.pi * u.ravel() / around, 2 * np.pi * v.ravel() / across
    points = np.stack([(1 + 0.4 * np.cos(b)) * np.cos(a), (1 + 0.4 * np.cos(b)) * np.sin(a), 0.4 * np.sin(b)], 1)
    corner_u = np.stack([u, u + 1, u + 1, u], -1).reshape(-1, 4)
    corner_v = np.stack([v, v, v + 1, v + 1], -1).reshape(-1, 4)
    mesh = bpy.data.meshes.new("Torus")
    mesh.vertices.add(len(points))
    mesh.vertices.foreach_set("co", points.astype(np.float32).ravel())
    mesh.loops.add(corner_u.size)
    mesh.loops.foreach_set("vertex_index", ((corner_u % around) * across + corner_v % across).ravel())
    mesh.polygons.add(len(corner_u))
    mesh.polygons.foreach_set("loop_start", np.arange(0, corner_u.size, 4))
    mesh.update(calc_edges=True)
    uv = np.stack([corner_u / around, corner_v / across], -1) * 0.98 + 0.01  # off the image border
    mesh.uv_layers.new(name="UVMap").data.foreach_set("uv", uv.astype(np.float32).ravel())
    obj = bpy.data.objects.new("Torus", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def best_time(run, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-vertices", type=int, default=1_100_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    print(f"Blender {bpy.app.version_string}; smoothing radius 0.1 on a torus of radii 1 and 0.4; best of {args.repeats}\n")

    print("| vertices | curvature mask (s) | us / vertex | per-vertex ratio to the first row |")
    print("|---:|---:|---:|---:|")
    first = None
    for segments in SEGMENTS:
        obj = torus(segments)
        vertices = len(obj.data.vertices)
        if vertices > args.max_vertices:
            break
        seconds = best_time(lambda: edges.write_curvature_attribute(obj, 0.1),
                            args.repeats if vertices < 300_000 else 1)
        per_vertex = seconds / vertices * 1e6
        first = first or per_vertex
        print(f"| {vertices:,} | {seconds:.3f} | {per_vertex:.2f} | {per_vertex / first:.2f} |", flush=True)
        bpy.data.meshes.remove(obj.data)

    obj = torus(200)
    print(f"\n| texels (Sobel, {len(obj.data.vertices):,} vertices) | edge mask image (s) | ns / texel |")
    print("|---:|---:|---:|")
    for resolution in RESOLUTIONS:
        seconds = best_time(lambda: edges.edge_mask_image(obj, "UVMap", resolution), args.repeats)
        print(f"| {resolution}^2 | {seconds:.3f} | {seconds / resolution**2 * 1e9:.0f} |", flush=True)


if __name__ == "__main__":
    main()
