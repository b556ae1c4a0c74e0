"""Cycles render time of the porous material against the same Diffuse + Glossy without
porosity, at equal samples, measured in one run (interleaved repeats, best of each).

    .venv-5.2/bin/python benchmarks/porous_overhead.py [--size 128] [--samples 32] [--repeats 3]
"""

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import bpy  # noqa: E402

import porous_weathering as pw  # noqa: E402
from porous_weathering import render, studio  # noqa: E402

STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.2, roughness=0.4)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--samples", type=int, default=32)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    sphere = studio.add_sphere(scene)
    sun = studio.add_sun(scene, (0.5, 0.3, 0.8))
    studio.add_ortho_camera(scene)
    render.use_cycles(scene, size=args.size, samples=args.samples, bounces=4, pixel_filter=1.5)
    materials = {
        "Diffuse + Glossy": pw.make_base_material("Base", **STONE),
        "porous, key light": pw.make_porous_material("Key", **STONE, porosity=0.3, key_light=sun),
        "porous, ambient": pw.make_porous_material("Ambient", **STONE, porosity=0.3),
    }
    best = {name: float("inf") for name in materials}
    for _ in range(args.repeats + 1):  # the first round warms up kernels and caches
        for name, material in materials.items():
            studio.assign(sphere, material)
            started = time.perf_counter()
            render.render_array(scene)
            best[name] = min(best[name], time.perf_counter() - started)
    base = best["Diffuse + Glossy"]
    print(f"Blender {bpy.app.version_string}, Cycles CPU, {args.size}x{args.size} px, "
          f"{args.samples} samples, best of {args.repeats}")
    print(f"| material | time (s) | ratio to Diffuse + Glossy |\n|---|---|---|")
    for name, seconds in best.items():
        print(f"| {name} | {seconds:.3f} | {seconds / base:.3f} |")


if __name__ == "__main__":
    main()
