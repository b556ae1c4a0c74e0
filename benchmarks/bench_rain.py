"""Rain bake: error against a high-sample reference vs samples per texel and wall time.

    python benchmarks/bench_rain.py [--resolution 128] [--reference 2048]

A ~100k-triangle terrain (a 224 x 224 quad grid with bumps that shelter each other) under a
roof over one half, baked to a RESOLUTION² image, vertical rain, cone 15°. For each sky (the
sun lamp and the world-texture cone, rain.RainSettings.sky) and sample count: wall time and
the RMSE against a reference baked with the sun lamp at --reference samples. Writes the
table to docs/rain_benchmark.md (matplotlib is not a dependency: no plot).
"""

import argparse
import math
import pathlib
import sys
import time

import bpy
import bmesh  # noqa: E402  (importable only once bpy is)
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
from porous_weathering import rain, studio  # noqa: E402

SAMPLES = (1, 4, 16, 64, 256)
OUT = pathlib.Path(__file__).resolve().parent.parent / "docs" / "rain_benchmark.md"


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

    lines = [f"Rain bake on a {triangles}-triangle terrain, {args.resolution}² texels, cone 15°, "
             f"{bpy.app.version_string}, 2 CPU cores. Reference: sun lamp, {args.reference} samples "
             f"({reference_time:.1f} s).", "",
             "| sky | samples per texel | wall time (s) | RMSE vs reference |", "|---|---:|---:|---:|"]
    lines += [f"| {sky} | {samples} | {seconds:.2f} | {rmse:.4f} |" for sky, samples, seconds, rmse in rows]
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
