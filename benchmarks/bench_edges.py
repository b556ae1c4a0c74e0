"""Edge/cavity mask timings (docs/maps.md, "Edge/cavity mask").

    python benchmarks/bench_edges.py [--max-vertices N] [--rounds N] [--no-sobel]

1. The curvature mask (``edges.write_curvature_attribute``: evaluate, curvature, smooth,
   map, write the ``pw_edges`` attribute) on tori of 10k to 1M vertices: it must grow
   linearly, so the table gives the time per vertex and its ratio to the smallest mesh's.
   The sizes are timed in interleaved rounds (each round times every size once), so load
   from other jobs on the machine hits all sizes alike; each size keeps its best round. CPU
   time of this process is given beside wall time, as it is less sensitive to that load.
   The plot goes to docs/img/edges_benchmark_<Blender line>.png.
2. The Sobel mask (``edges.edge_mask_image``: two Cycles EMIT bakes plus the numpy filter)
   of a 20k-vertex torus at 256 to 2048 texels square.
"""

import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import matplotlib  # noqa: E402
import numpy as np  # noqa: E402

matplotlib.use("Agg")  # files only, no display
import machine  # noqa: E402  (benchmarks/machine.py)
import matplotlib.pyplot as plt  # noqa: E402
import timing  # noqa: E402  (benchmarks/timing.py)

from porous_weathering import edges  # noqa: E402

IMAGES = pathlib.Path(__file__).resolve().parents[1] / "docs" / "img"
SEGMENTS = (142, 200, 283, 400, 566, 800, 1132, 1414)  # a torus of s x s/2 quads has s^2/2 vertices
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


def curvature_timings(tori, rounds):
    """{vertices: (best wall seconds, best CPU seconds)} of the curvature mask, in interleaved rounds."""
    best = {len(obj.data.vertices): (np.inf, np.inf) for obj in tori}
    for _ in range(rounds):
        for obj in tori:
            wall, cpu = timing.wall_and_cpu_seconds(lambda obj=obj: edges.write_curvature_attribute(obj, 0.1))
            vertices = len(obj.data.vertices)
            best[vertices] = (min(best[vertices][0], wall), min(best[vertices][1], cpu))
    return best


def write_plot(best, path):
    """Time against vertex count (log-log, with the linear slope through the first point) and
    time per vertex against vertex count."""
    vertices = np.array(sorted(best))
    wall, cpu = (np.array([best[n][k] for n in vertices]) for k in (0, 1))
    figure, (total, per_vertex) = plt.subplots(1, 2, figsize=(10, 4), dpi=100)
    total.loglog(vertices, wall, "o-", label="wall time")
    total.loglog(vertices, cpu, "s-", label="CPU time")
    total.loglog(vertices, wall[0] * vertices / vertices[0], "k:", label="linear (slope 1)")
    total.set_ylabel("curvature mask (s)")
    for label, seconds, marker in (("wall", wall, "o-"), ("CPU", cpu, "s-")):
        per_vertex.semilogx(vertices, seconds / vertices * 1e6, marker, label=f"{label} time")
    per_vertex.set_ylim(bottom=0)
    per_vertex.set_ylabel("µs per vertex")
    for axes in (total, per_vertex):
        axes.set_xlabel("vertices")
        axes.grid(True, which="both", alpha=0.3)
        axes.legend()
    figure.suptitle(f"Curvature edge mask (write_curvature_attribute), Blender {bpy.app.version_string}")
    figure.tight_layout()
    path.parent.mkdir(exist_ok=True)
    figure.savefig(path)
    plt.close(figure)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-vertices", type=int, default=1_100_000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-sobel", action="store_true", help="time the curvature mask only")
    args = parser.parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    tori = [torus(segments) for segments in SEGMENTS if segments**2 // 2 <= args.max_vertices]
    best = curvature_timings(tori, args.rounds)
    print(f"{machine.describe(bpy.app.version_string)}")
    print(f"smoothing radius 0.1 on a torus of radii 1 and 0.4; best of {args.rounds} interleaved rounds\n")
    print("| vertices | wall (s) | µs / vertex | ratio to first | CPU (s) | CPU µs / vertex | ratio to first |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    first = None
    for vertices, (wall, cpu) in sorted(best.items()):
        per_vertex = np.array([wall, cpu]) / vertices * 1e6
        first = per_vertex if first is None else first
        print(
            f"| {vertices:,} | {wall:.3f} | {per_vertex[0]:.2f} | {per_vertex[0] / first[0]:.2f} "
            f"| {cpu:.3f} | {per_vertex[1]:.2f} | {per_vertex[1] / first[1]:.2f} |",
            flush=True,
        )
    plot = IMAGES / f"edges_benchmark_{bpy.app.version[0]}.{bpy.app.version[1]}.png"
    write_plot(best, plot)
    print(f"\nwrote {plot}")
    for obj in tori:
        bpy.data.meshes.remove(obj.data)
    if not args.no_sobel:
        sobel_timings(args.rounds)


def sobel_timings(repeats):
    obj = torus(200)
    print(f"\n| texels (Sobel, {len(obj.data.vertices):,} vertices) | edge mask image (s) | ns / texel |")
    print("|---:|---:|---:|")
    for resolution in RESOLUTIONS:
        seconds = best_time(lambda resolution=resolution: edges.edge_mask_image(obj, "UVMap", resolution), repeats)
        print(f"| {resolution}^2 | {seconds:.3f} | {seconds / resolution**2 * 1e9:.0f} |", flush=True)


if __name__ == "__main__":
    main()
