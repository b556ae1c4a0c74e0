"""Edge/cavity mask timings (docs/maps.md, "Edge/cavity mask").

    python benchmarks/bench_edges.py [--max-vertices N] [--repeats N]

1. The curvature mask (``edges.write_curvature_attribute``: evaluate, curvature, smooth,
   map, write the ``pw_edges`` attribute) on UV spheres of 5k to 1M vertices: it must grow
   linearly, so the table prints the time per vertex and its ratio to the smallest mesh's.
2. The Sobel mask (``edges.edge_mask_image``: two Cycles EMIT bakes plus the numpy filter)
   of a 20k-vertex sphere at 256 to 2048 texels square.

Each row is the best of ``--repeats`` runs (one run above 300k vertices).
"""

import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402
import bmesh  # noqa: E402  (after bpy)

from porous_weathering import edges  # noqa: E402

SEGMENTS = (100, 200, 400, 800, 1414)  # a UV sphere of s segments and s/2 rings has ~s^2/2 vertices
RESOLUTIONS = (256, 512, 1024, 2048)


def uv_sphere(segments):
    mesh = bpy.data.meshes.new("Sphere")
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=segments // 2, radius=1.0, calc_uvs=True)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new("Sphere", mesh)
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
    print(f"Blender {bpy.app.version_string}; radius 0.1 on a unit sphere; best of {args.repeats}\n")

    print("| vertices | curvature mask (s) | us / vertex | per-vertex ratio to the first row |")
    print("|---:|---:|---:|---:|")
    first = None
    for segments in SEGMENTS:
        obj = uv_sphere(segments)
        vertices = len(obj.data.vertices)
        if vertices > args.max_vertices:
            break
        seconds = best_time(lambda: edges.write_curvature_attribute(obj, 0.1),
                            args.repeats if vertices < 300_000 else 1)
        per_vertex = seconds / vertices * 1e6
        first = first or per_vertex
        print(f"| {vertices:,} | {seconds:.3f} | {per_vertex:.2f} | {per_vertex / first:.2f} |", flush=True)
        bpy.data.meshes.remove(obj.data)

    obj = uv_sphere(200)
    print(f"\n| texels (Sobel, {len(obj.data.vertices):,} vertices) | edge mask image (s) | ns / texel |")
    print("|---:|---:|---:|")
    for resolution in RESOLUTIONS:
        seconds = best_time(lambda: edges.edge_mask_image(obj, "UVMap", resolution), args.repeats)
        print(f"| {resolution}^2 | {seconds:.3f} | {seconds / resolution**2 * 1e9:.0f} |", flush=True)


if __name__ == "__main__":
    main()
