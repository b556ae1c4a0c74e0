"""Edge/cavity mask: timings, and the measurements behind its defaults (docs/maps.md, "Edge/cavity mask").

    python benchmarks/bench_edges.py [--max-vertices N] [--rounds N] [--no-image] [--crumbs] [--gltf] [--study]

1. The attribute mask (``edges.write_curvature_attribute`` with the default settings:
   evaluate, sample, smooth, map, write ``pw_edges``) on the scan-like bust
   (sample_blends/scan_generator.py) of 10k to 1M vertices: it must grow linearly, so the
   table gives the time per vertex and its ratio to the smallest mesh's. The sizes are timed
   in interleaved rounds (each round times every size once), so load from other jobs on the
   machine hits all sizes alike; each size keeps its best round. CPU time of this process is
   given beside wall time, as it is less sensitive to that load, and per sample of the surface
   (coarse busts add samples along long edges and across large faces). The plot goes to
   docs/img/edges_benchmark_<Blender line>.png.
2. The image mask (``edges.edge_mask_image``: two Cycles EMIT bakes of the texels' positions
   and normals, then the same smoothing at every texel) of a 20k-vertex torus at 256 to 2048
   texels square.
3. With ``--crumbs``: the 400k-triangle bust with 0 to 30 000 loose crumbs about its surface
   (a photogrammetry scan's floaters: 1 mm octahedra within 3 mm of it), each crumb a loose
   part, so the mask reads where parts meet (``contacts``): the time against the crumbs'.
4. With ``--gltf``: the bust of 100k and 1M triangles (metres, Smart UV Project) through
   Blender's glTF exporter and importer, which leave it split at its UV seams: its islands, its
   mask's mean and largest difference from the welded bust's at the same places, the mask's
   time welded and through glTF (best of the rounds), and the scan checks' time.
5. With ``--study``: how the defaults were chosen. (a) The bust with and without its scan
   noise at edge scales 0.25% to 4% of its size: how far the noise moves the mask, and how
   much of the surface the mask lights. (b) The bundled samples at the same scales, with the
   cavity and edge weights (1, 1) and (1, 0.5). (c) The same bust in millimetres, metres and
   0.1 units across (attribute), and the same torus in each (image): the largest difference.
"""

import argparse
import pathlib
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "sample_blends"))

import bpy  # noqa: E402

import matplotlib  # noqa: E402
import numpy as np  # noqa: E402

matplotlib.use("Agg")  # files only, no display
import machine  # noqa: E402  (benchmarks/machine.py)
import matplotlib.pyplot as plt  # noqa: E402
import scan_generator  # noqa: E402  (sample_blends/scan_generator.py)
import timing  # noqa: E402  (benchmarks/timing.py)

from benchmarks.scenes import through_gltf  # noqa: E402
from porous_weathering.blender import mesh_arrays  # noqa: E402
from porous_weathering.maps import edges, scan_checks  # noqa: E402

IMAGES = ROOT / "docs" / "img"
TRIANGLES = (20_000, 40_000, 80_000, 200_000, 400_000, 1_000_000, 2_000_000)  # about half as many vertices
RESOLUTIONS = (256, 512, 1024, 2048)
SCALES = (0.0025, 0.005, 0.01, 0.02, 0.04)
WEIGHTS = ((1.0, 1.0), (edges.DEFAULT_CAVITY_WEIGHT, edges.DEFAULT_EDGE_WEIGHT))
SAMPLES = ("limestone_facade", "brick_wall", "sculpted_stone")
#: Scale factors from millimetres: metres, and a bust 0.1 units across.
UNITS = {"mm": 1.0, "m": 0.001, "tenth": 0.1 / scan_generator.NOMINAL_DIAGONAL_MM}


def bust(name, triangles, factor=1.0, scan_noise=True):
    """The bust, scaled by ``factor`` from millimetres, with or without its scan noise (the
    1.2-4 mm field; the same random draws either way, so only the noise differs)."""
    generator_noise = scan_generator._fourier_noise

    def noise(points, rng, terms, shortest, longest, rms):
        values = generator_noise(points, rng, terms, shortest, longest, rms)
        return values if scan_noise or shortest > 10.0 else np.zeros_like(values)

    scan_generator._fourier_noise = noise
    try:
        vertices, faces = scan_generator.bust_mesh(triangles, seed=0)
    finally:
        scan_generator._fourier_noise = generator_noise
    return scan_generator.add_to_scene(name, vertices * factor, faces)


def with_crumbs(vertices, faces, count, seed=0):
    """The mesh with ``count`` loose octahedra 1 mm across whose centres lie within 3 mm of
    its vertices, off the surface or in it (a scan's floaters)."""
    rng = np.random.default_rng(seed)
    octahedron = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float32) * 0.5
    eight = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    centres = vertices[rng.integers(len(vertices), size=count)] + rng.uniform(-3.0, 3.0, size=(count, 3))
    crumbs = (centres[:, None, :] + octahedron).reshape(-1, 3)
    crumb_faces = (eight[None] + len(vertices) + 6 * np.arange(count)[:, None, None]).reshape(-1, 3)
    return np.concatenate([vertices, crumbs]), np.concatenate([faces, crumb_faces])


def crumb_timings(rounds, triangles=400_000, counts=(0, 300, 3_000, 30_000)):
    """The attribute mask of the bust with loose crumbs, best of ``rounds`` for each count."""
    vertices, faces = scan_generator.bust_mesh(triangles, seed=0)
    print(f"{machine.describe(bpy.app.version_string)}")
    print(f"\n| loose crumbs ({triangles:,}-triangle bust) | wall (s) | CPU (s) | × without crumbs |")
    print("|---:|---:|---:|---:|")
    first = None
    for count in counts:
        obj = scan_generator.add_to_scene(f"Bust with {count} crumbs", *with_crumbs(vertices, faces, count))
        wall, cpu = min(
            timing.wall_and_cpu_seconds(lambda obj=obj: edges.write_curvature_attribute(obj)) for _ in range(rounds)
        )
        first = first or wall
        print(f"| {count:,} | {wall:.2f} | {cpu:.2f} | {wall / first:.2f} |", flush=True)
        bpy.data.meshes.remove(obj.data)


def gltf_comparison(rounds, sizes=(100_000, 1_000_000)):
    """The bust welded against the same bust through glTF (split at its UV seams), per size."""
    print(f"{machine.describe(bpy.app.version_string)}")
    print(
        "\n| triangles | vertices welded / through glTF | islands | mask mean welded / glTF | largest difference "
        "| mask s welded / glTF | scan checks s (glTF) |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for triangles in sizes:
        print(gltf_row(triangles, rounds), flush=True)


def gltf_row(triangles, rounds):
    """gltf_comparison's row for the bust of ``triangles``."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    vertices, faces = scan_generator.bust_mesh(triangles, seed=0)
    welded = scan_generator.add_to_scene("Bust", vertices * 0.001, faces)
    welded_time, welded_mask = best_mask(welded, rounds)
    with tempfile.TemporaryDirectory() as folder:
        split = through_gltf(welded, folder, keep=True)
    split_time, mask = best_mask(split, rounds)
    at = dict(zip(world_places(welded), welded_mask))
    there = np.array([at[key] for key in world_places(split)])  # the welded mask at the split's vertices
    checks = timing.wall_and_cpu_seconds(lambda: scan_checks.problems(split))[0]
    return (
        f"| {triangles:,} | {len(welded.data.vertices):,} / {len(split.data.vertices):,} "
        f"| {mesh_arrays.face_islands(split.data).max() + 1:,} | {there.mean():.3f} / {mask.mean():.3f} "
        f"| {np.abs(mask - there).max():.2e} | {welded_time:.2f} / {split_time:.2f} | {checks:.2f} |"
    )


def best_mask(obj, rounds):
    """(best wall seconds, mask) of ``edges.write_curvature_attribute`` on ``obj`` over ``rounds``,
    the mask read back from the attribute it writes."""
    seconds = min(timing.wall_and_cpu_seconds(lambda: edges.write_curvature_attribute(obj))[0] for _ in range(rounds))
    colours = np.empty(len(obj.data.vertices) * 4, np.float32)
    obj.data.color_attributes[edges.EDGE_ATTRIBUTE].data.foreach_get("color", colours)
    return seconds, colours[0::4]


def world_places(obj):
    """Each vertex's world position as a tuple of float32, a key."""
    matrix = np.array(obj.matrix_world)
    local = mesh_arrays.attribute(obj.data, "position", np.float32, 3)
    return map(tuple, (local @ matrix[:3, :3].T + matrix[:3, 3]).astype(np.float32))


def torus(segments, radius=1.0):
    """A torus of major radius ``radius`` and minor radius 0.4 ``radius``, segments x segments
    / 2 quads, with UVs, made straight from numpy arrays (bmesh's primitives take quadratic
    time at 1M vertices)."""
    around, across = segments, segments // 2
    u, v = np.meshgrid(np.arange(around), np.arange(across), indexing="ij")
    a, b = 2 * np.pi * u.ravel() / around, 2 * np.pi * v.ravel() / across
    points = np.stack([(1 + 0.4 * np.cos(b)) * np.cos(a), (1 + 0.4 * np.cos(b)) * np.sin(a), 0.4 * np.sin(b)], 1)
    corner_u = np.stack([u, u + 1, u + 1, u], -1).reshape(-1, 4)
    corner_v = np.stack([v, v, v + 1, v + 1], -1).reshape(-1, 4)
    mesh = bpy.data.meshes.new("Torus")
    mesh.vertices.add(len(points))
    mesh.vertices.foreach_set("co", (points * radius).astype(np.float32).ravel())
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
    return min(timing.wall_and_cpu_seconds(run)[0] for _ in range(repeats))


def curvature_timings(busts, rounds):
    """{vertices: (best wall seconds, best CPU seconds)} of the attribute mask, in interleaved rounds."""
    best = {len(obj.data.vertices): (np.inf, np.inf) for obj in busts}
    for _ in range(rounds):
        for obj in busts:
            wall, cpu = timing.wall_and_cpu_seconds(lambda obj=obj: edges.write_curvature_attribute(obj))
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
    total.set_ylabel("attribute edge mask (s)")
    for label, seconds, marker in (("wall", wall, "o-"), ("CPU", cpu, "s-")):
        per_vertex.semilogx(vertices, seconds / vertices * 1e6, marker, label=f"{label} time")
    per_vertex.set_ylim(bottom=0)
    per_vertex.set_ylabel("µs per vertex")
    for axes in (total, per_vertex):
        axes.set_xlabel("vertices")
        axes.grid(True, which="both", alpha=0.3)
        axes.legend()
    figure.suptitle(f"Edge mask on the scan-like bust (write_curvature_attribute), Blender {bpy.app.version_string}")
    figure.tight_layout()
    path.parent.mkdir(exist_ok=True)
    figure.savefig(path)
    plt.close(figure)


def timings(args):
    busts = [bust(f"Bust {n}", n) for n in TRIANGLES if n // 2 <= args.max_vertices]
    best = curvature_timings(busts, args.rounds)
    print(f"{machine.describe(bpy.app.version_string)}")
    print(f"default edge settings (radius {edges.DEFAULT_EDGE_SCALE:g} of the bust's size); best of {args.rounds}")
    # Coarse busts (edges longer than half the radius) add samples along their edges and across
    # their faces: the work is linear in the samples, which the last columns show.
    samples = {
        len(obj.data.vertices): len(
            edges.surface(obj, edges.effective_radius(obj, edges.EdgeSettings())).sources.points
        )
        for obj in busts
    }
    print("\n| vertices | wall (s) | µs / vertex | CPU (s) | CPU µs / vertex | samples | CPU µs / sample |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for vertices, (wall, cpu) in sorted(best.items()):
        print(
            f"| {vertices:,} | {wall:.3f} | {wall / vertices * 1e6:.2f} | {cpu:.3f} | {cpu / vertices * 1e6:.2f} "
            f"| {samples[vertices]:,} | {cpu / samples[vertices] * 1e6:.2f} |",
            flush=True,
        )
    plot = IMAGES / f"edges_benchmark_{bpy.app.version[0]}.{bpy.app.version[1]}.png"
    write_plot(best, plot)
    print(f"\nwrote {plot}")
    for obj in busts:
        bpy.data.meshes.remove(obj.data)


def image_timings(repeats):
    obj = torus(200)
    print(f"\n| texels (image mask, {len(obj.data.vertices):,} vertices) | edge mask image (s) | ns / texel |")
    print("|---:|---:|---:|")
    for resolution in RESOLUTIONS:
        seconds = best_time(lambda resolution=resolution: edges.edge_mask_image(obj, "UVMap", resolution), repeats)
        print(f"| {resolution}^2 | {seconds:.3f} | {seconds / resolution**2 * 1e9:.0f} |", flush=True)
    bpy.data.meshes.remove(obj.data)


def study():
    noise_study()
    samples_study()
    units_study()


def noise_study(triangles=200_000):
    noisy, clean = bust("Noisy", triangles), bust("Clean", triangles, scan_noise=False)
    size = edges.object_size(clean)
    print(f"\n(a) the bust, {len(clean.data.polygons):,} triangles, {size:.1f} mm across, with and without scan noise")
    print("| scale | radius (mm) | noise: mean abs(dC) | p99 | max | lit (C >= 0.5) | of it concave | convex |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for scale in SCALES:
        settings = edges.EdgeSettings(scale=scale, cavity_weight=1.0, edge_weight=1.0)
        masks = [edges.write_curvature_attribute(obj, settings=settings) for obj in (noisy, clean)]
        difference = np.abs(masks[0] - masks[1])
        radius = scale * size
        concave = edges.curvature(clean, radius) < 0
        lit = masks[1] >= 0.5
        print(
            f"| {scale:g} | {radius:.2f} | {difference.mean():.4f} | {np.percentile(difference, 99):.3f} "
            f"| {difference.max():.3f} | {lit.mean():.3f} | {(lit & concave).mean():.3f} "
            f"| {(lit & ~concave).mean():.3f} |",
            flush=True,
        )
    for obj in (noisy, clean):
        bpy.data.meshes.remove(obj.data)


def samples_study():
    """Area fractions lit (C >= 0.5) on each sample, read at the area samples of the surface
    (on a coarse mesh the vertices are only its corners)."""
    print("\n(b) the samples: area lit (C >= 0.5), and of it concave / convex, for cavity and edge weights")
    print("| sample | scale | " + " | ".join(f"weights {w[0]:g}, {w[1]:g}" for w in WEIGHTS) + " |")
    print("|---|---:|" + "---:|" * len(WEIGHTS))
    for name in SAMPLES:
        bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / f"{name}.blend"), load_ui=False)
        objects = [obj for obj in bpy.context.scene.objects if obj.type == "MESH" and obj.name != "Ground"]
        for scale in SCALES[1:]:
            sums = np.zeros((len(WEIGHTS), 4))  # area, lit, lit concave, lit convex
            for obj in objects:
                radius = scale * edges.object_size(obj)
                sources = edges.surface(obj, radius).sources
                carrying = sources.area > 0
                curvature = edges.smooth_over_radius(
                    sources, sources.points[carrying], sources.normals[carrying], radius
                )
                area = sources.area[carrying]
                for row, (cavity, edge) in enumerate(WEIGHTS):
                    lit = edges.curvature_mask(curvature, radius, cavity_weight=cavity, edge_weight=edge) >= 0.5
                    sums[row] += [
                        area.sum(),
                        area[lit].sum(),
                        area[lit & (curvature < 0)].sum(),
                        area[lit & (curvature > 0)].sum(),
                    ]
            cells = [
                f"{lit / total:.3f} ({concave / total:.3f} / {convex / total:.3f})"
                for total, lit, concave, convex in sums
            ]
            print(f"| {name} | {scale:g} | " + " | ".join(cells) + " |", flush=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)


def units_study(triangles=100_000, resolution=512):
    attribute = {
        unit: edges.write_curvature_attribute(bust(f"Bust {unit}", triangles, factor)) for unit, factor in UNITS.items()
    }
    image = {
        unit: edges.edge_mask_image(torus(200, scan_generator.NOMINAL_DIAGONAL_MM * factor / 3.0), "UVMap", resolution)
        for unit, factor in UNITS.items()
    }
    print(
        f"\n(c) units: the largest difference from millimetres "
        f"(bust of {triangles:,} triangles; torus at {resolution}^2)"
    )
    print("| unit | attribute mask | image mask |")
    print("|---|---:|---:|")
    for unit in UNITS:
        print(
            f"| {unit} | {np.abs(attribute[unit] - attribute['mm']).max():.2e} "
            f"| {np.abs(image[unit] - image['mm']).max():.2e} |"
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-vertices", type=int, default=1_100_000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-image", action="store_true", help="time the attribute mask only")
    parser.add_argument("--crumbs", action="store_true", help="the bust with loose crumbs, not the timings")
    parser.add_argument("--gltf", action="store_true", help="the bust welded and through glTF, not the timings")
    parser.add_argument("--study", action="store_true", help="the measurements behind the defaults, not the timings")
    args = parser.parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if args.study:
        study()
        return
    if args.crumbs:
        crumb_timings(args.rounds)
        return
    if args.gltf:
        gltf_comparison(args.rounds)
        return
    timings(args)
    if not args.no_image:
        image_timings(args.rounds)


if __name__ == "__main__":
    main()
