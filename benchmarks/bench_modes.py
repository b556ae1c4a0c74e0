"""Shader cost per weathering mode against the porous-only material (the paper's table 2:
83 / 138 / 120 / 101 pixel-shader instructions for porosity / soiling / wet / efflorescence).

Cost proxies: the nodes of each material's group (all of them, and the maths nodes alone),
EEVEE's first render of each material (its shader compile + render) and its best later
render, and Cycles' render time, on one sphere under a key sun.  EEVEE's own engine shaders
are compiled first on a plain material.  Renders are interleaved across materials so that
load on the machine hits all of them alike.

    python benchmarks/bench_modes.py [--size 64] [--samples 4] [--repeats 3]
"""

import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import porous_weathering as pw  # noqa: E402
from porous_weathering import model, nodes, render, studio  # noqa: E402

STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.1, roughness=0.5, porosity=0.3, pore_depth_ratio=2.0)
STATE = dict(time=0.6, rain_map=0.4, edge_map=0.7, efflorescence_map=0.6)
#: label -> modes; the paper's instruction count for comparison
MODE_SETS = {"porosity": ((), 83), "soiling": ((model.SOILING,), 138), "wet": ((model.WET,), 120),
             "efflorescence": ((model.EFFLORESCENCE,), 101), "all three": (model.MODES, None)}
MATHS = {"MATH", "VECT_MATH", "GAMMA"}


def node_counts(modes, light_mode):
    group = nodes.weathered_group(modes, light_mode)
    return len(group.nodes), sum(node.type in MATHS for node in group.nodes)


def material(label, modes, sun):
    used = set(model.inputs_of(modes)) if modes else set()
    return pw.make_weathered_material(label, modes=modes, key_light=sun, **STONE,
                                      **{name: value for name, value in STATE.items() if name in used})


def timed(scene):
    start = time.perf_counter()
    render.render_array(scene)
    return time.perf_counter() - start


def measure(size, samples, repeats):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    sphere = studio.add_sphere(scene)
    sun = studio.add_sun(scene, (0.5, 0.3, 0.8))
    studio.add_ortho_camera(scene)
    materials = {label: material(label, modes, sun) for label, (modes, _) in MODE_SETS.items()}
    render.use_eevee(scene, size=size, samples=samples)
    studio.assign(sphere, pw.make_base_material("Warm-up"))
    timed(scene)  # compiles EEVEE's engine shaders
    first, eevee, cycles = {}, {label: [] for label in materials}, {label: [] for label in materials}
    for label, mat in materials.items():
        studio.assign(sphere, mat)
        first[label] = timed(scene)
    for _ in range(repeats):
        for label, mat in materials.items():
            studio.assign(sphere, mat)
            eevee[label].append(timed(scene))
    render.use_cycles(scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
    for _ in range(repeats):
        for label, mat in materials.items():
            studio.assign(sphere, mat)
            cycles[label].append(timed(scene))
    rows = []
    for label, (modes, paper) in MODE_SETS.items():
        total, maths = node_counts(modes, nodes.SUN)
        ambient_total, _ = node_counts(modes, nodes.AMBIENT)
        steady = min(eevee[label])
        rows.append([label, paper or "—", total, ambient_total, maths, f"{first[label]:.2f}",
                     f"{steady:.2f}", f"{min(cycles[label]):.3f}"])
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--samples", type=int, default=4)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    rows = measure(args.size, args.samples, args.repeats)
    header = ["material", "paper instr.", "nodes (sun)", "nodes (ambient)", "maths nodes (sun)",
              "EEVEE first render s", "EEVEE best render s", "Cycles render s"]
    print(f"### Shader cost per mode, Blender {bpy.app.version_string} ({args.size} px, {args.samples} samples, "
          f"best of {args.repeats})\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for row in rows:
        print("| " + " | ".join(str(cell) for cell in row) + " |")


if __name__ == "__main__":
    main()
