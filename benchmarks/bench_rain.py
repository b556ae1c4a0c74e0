"""Rain bake: error against a high-sample reference vs samples per texel and wall time.

    python benchmarks/bench_rain.py [--resolution 128] [--reference 2048]

A ~100k-triangle terrain (a 224 x 224 quad grid with bumps that shelter each other) under a
roof over one half, baked to a RESOLUTION² image, vertical rain, cone 15°. For each sky (the
sun lamp and the world-texture cone, rain.RainSettings.sky) and sample count: wall time and
the RMSE against a reference baked with the sun lamp at --reference samples. Writes the
table, and what it says about rain.DEFAULT_SAMPLES, to docs/rain_benchmark.md and the plot
(RMSE against wall time, log-log) to docs/img/rain_benchmark.png.
"""

import argparse
import math
import pathlib
import sys
import time

import bpy

import bmesh  # noqa: E402  (importable only once bpy is)
import matplotlib
import matplotlib.ticker
import numpy as np

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
import machine  # noqa: E402  (benchmarks/machine.py)

from porous_weathering.maps import rain
from porous_weathering.samples import studio  # noqa: E402

SAMPLES = (1, 4, 16, 64, 256)
DOCS = pathlib.Path(__file__).resolve().parent.parent / "docs"
OUT = DOCS / "rain_benchmark.md"
PLOT = DOCS / "img" / "rain_benchmark.png"


def terrain(scene, cuts=224):
    mesh = bpy.data.meshes.new("Terrain")
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_grid(bm, x_segments=cuts, y_segments=cuts, size=1.0, calc_uvs=True)
    for vertex in bm.verts:
        vertex.co.z = 0.12 * math.sin(7 * vertex.co.x) * math.cos(5 * vertex.co.y)
    bm.to_mesh(mesh)
    bm.free()
    obj = studio.link(scene, bpy.data.objects.new("Terrain", mesh))
    roof = studio.add_plane(scene, name="Roof", size=2.4)
    roof.location = (1.2, 0.0, 0.6)
    return obj, roof


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--reference", type=int, default=2048)
    args = parser.parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj, roof = terrain(bpy.context.scene)
    bpy.context.view_layer.update()
    obj.data.calc_loop_triangles()
    triangles = len(obj.data.loop_triangles)

    def bake(samples, sky, seed=0):
        settings = rain.RainSettings(cone=15.0, samples=samples, sky=sky, seed=seed)
        started = time.perf_counter()
        image = rain.bake_rain_image(obj, "UVMap", args.resolution, settings, occluders=[roof])
        return image, time.perf_counter() - started

    reference, reference_time = bake(args.reference, "sun", seed=1)
    rows = []
    for sky in ("sun", "world"):
        for samples in SAMPLES:
            image, seconds = bake(samples, sky)
            rmse = float(np.sqrt(np.mean((image - reference) ** 2)))
            rows.append((sky, samples, seconds, rmse))
            print(f"{sky:6} {samples:5d} spp  {seconds:7.2f} s  RMSE {rmse:.4f}", flush=True)

    write_plot(rows)
    OUT.write_text(report(rows, triangles, args, reference_time))
    print(f"wrote {OUT} and {PLOT}")


def write_plot(rows):
    """RMSE against wall time, one line per sky, each point labelled with its sample count."""
    figure, axes = plt.subplots(figsize=(6, 4), dpi=100)
    for sky, label in (("sun", "sun lamp"), ("world", "world-texture cone")):
        points = [(seconds, rmse, samples) for row_sky, samples, seconds, rmse in rows if row_sky == sky]
        seconds, rmse, samples = zip(*points)
        axes.loglog(seconds, rmse, "o-", label=label)
        for x, y, n in points:
            axes.annotate(f"{n}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    axes.axhline(1 / 255, color="grey", linestyle=":", label="1/255 (one 8-bit step)")
    for axis in (axes.xaxis, axes.yaxis):
        axis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axes.set_xlabel("wall time (s)")
    axes.set_ylabel("RMSE against the reference")
    axes.set_title("Rain bake: error against time (labels: samples per texel)")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend()
    figure.tight_layout()
    PLOT.parent.mkdir(exist_ok=True)
    figure.savefig(PLOT)
    plt.close(figure)


def report(rows, triangles, args, reference_time):
    """docs/rain_benchmark.md: the setting, the table, the plot and the default's numbers."""
    measured = {(sky, samples): (seconds, rmse) for sky, samples, seconds, rmse in rows}
    default = rain.DEFAULT_SAMPLES
    lines = [
        "# Rain bake: error against samples per texel and wall time",
        "",
        f"`python benchmarks/bench_rain.py` ({machine.describe(bpy.app.version_string)}).",
        "",
        f"Rain bake on a {triangles}-triangle terrain half under a roof, {args.resolution}² texels, cone 15°, "
        f"vertical rain. Reference: sun lamp, {args.reference} samples ({reference_time:.1f} s).",
        "",
        "| sky | samples per texel | wall time (s) | RMSE vs reference | RMSE × 255 |",
        "|---|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {sky} | {samples} | {seconds:.2f} | {rmse:.4f} | {rmse * 255:.1f} |" for sky, samples, seconds, rmse in rows
    ]
    lines += ["", f"![RMSE against wall time]({PLOT.relative_to(DOCS)})", ""]

    def sun(samples):
        seconds, rmse = measured["sun", samples]
        return f"RMSE {rmse * 255:.1f}/255 in {seconds:.2f} s"

    if ("sun", default) in measured:
        neighbours = [f"; {n} samples: {sun(n)}" for n in (default // 4, default * 4) if ("sun", n) in measured]
        lines += [
            f"Default (`rain.DEFAULT_SAMPLES`): {default} samples per texel with the sun lamp, {sun(default)}"
            + "".join(neighbours)
            + ". Why this default: "
            "[maps.md](maps.md#sun-lamp-or-world-texture-cone-and-the-default-sample-count)."
        ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
