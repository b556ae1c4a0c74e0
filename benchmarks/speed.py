"""Render time against error: the porous material, the base Diffuse + Glossy, the Principled BSDF.

One scene (a sphere under a sun and an overcast sky), equal settings for every material, and
renders interleaved (material by material, repeated) so that load on the machine hits all of
them alike; each time is the fastest of ``--repeats``.  The error of a render is against the
reference of what that material means (its own light mode's weights), so it is the engine's
noise and approximation only.  Overhead = time / time of Diffuse + Glossy at the same samples.

    python benchmarks/speed.py [--size 64] [--repeats 2]
"""

import argparse
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import porous_weathering as pw  # noqa: E402
from benchmarks import scenes  # noqa: E402
from benchmarks.accuracy import MATERIALS, percent, sun_towards  # noqa: E402
from porous_weathering import compat, render  # noqa: E402
from porous_weathering import reference as ref  # noqa: E402

PARAMS = MATERIALS["diffuse"]
SUN = ref.Sun(sun_towards(45.0), 3.0)
SKY = ref.Sky("OVERCAST", 0.5)
CYCLES_SAMPLES = (4, 16, 64)
EEVEE_SAMPLES = (1, 16)


def materials():
    """name -> (material, the reference material it should render, or None)."""
    base = dict(base_color=PARAMS["kd"], ks=PARAMS["ks"], roughness=PARAMS["m"])
    porous = dict(base, porosity=PARAMS["alpha"], pore_depth_ratio=PARAMS["sp"])
    principled = bpy.data.materials.new("Principled")
    if not compat.BLENDER_5:
        principled.use_nodes = True
    bsdf = principled.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*PARAMS["kd"], 1.0)
    bsdf.inputs["Roughness"].default_value = PARAMS["m"]
    return {
        "Diffuse+Glossy": (pw.make_base_material("Base", **base), ref.Porous(**{**PARAMS, "alpha": 0.0})),
        "porous key light": (pw.make_porous_material("Key", **porous, key_light="Sun"),
                             ref.Porous(**PARAMS, light_mode=SUN.towards)),
        "porous ambient": (pw.make_porous_material("Ambient", **porous), ref.Porous(**PARAMS, light_mode=ref.AMBIENT)),
        "Principled BSDF": (principled, None),
    }


def timed_render(scene):
    start = time.perf_counter()
    image = render.render_array(scene)
    return time.perf_counter() - start, image


def measure(engine, samples_list, size, repeats):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = scenes.build(scene, "SPHERE", (SUN,), SKY)
    candidates = materials()
    surface = scenes.reference_surface("SPHERE", size)
    expected = {name: ref.render(surface, reference, (SUN,), SKY, samples=4096)
                for name, (_, reference) in candidates.items() if reference is not None}
    rows = []
    for samples in samples_list:
        if engine == "CYCLES":
            render.use_cycles(scene, size=size, samples=samples)
        else:
            render.use_eevee(scene, size=size, samples=samples)
        times, errors = {name: [] for name in candidates}, {}
        for repeat in range(repeats + 1):  # the first round warms up (EEVEE compiles shaders)
            for name, (material, _) in candidates.items():
                obj.data.materials.clear()
                obj.data.materials.append(material)
                seconds, image = timed_render(scene)
                if repeat:
                    times[name].append(seconds)
                if name in expected:
                    mask = expected[name].covered & (image[..., 3] > 0.999)
                    errors[name] = ref.errors(image, expected[name].rgb, mask)[0]
        base = min(times["Diffuse+Glossy"])
        for name in candidates:
            best = min(times[name])
            rows.append([engine.title(), samples, name, f"{best:.3f}", f"{best / base:.3f}",
                         percent(errors[name]) if name in errors else "—"])
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    rows = measure("CYCLES", CYCLES_SAMPLES, args.size, args.repeats)
    rows += measure("EEVEE", EEVEE_SAMPLES, args.size, args.repeats)
    print(f"### Render time against error ({args.size} px sphere, sun 45° + overcast sky; fastest of "
          f"{args.repeats} interleaved runs)\n")
    print(scenes.markdown_table(["engine", "samples", "material", "seconds", "× Diffuse+Glossy", "RMSE"], rows))


if __name__ == "__main__":
    main()
