"""Render time against error: the porous material (key light, ambient) and each weathering mode,
side by side with the base Diffuse + Glossy and the Principled BSDF at equal settings
(docs/accuracy.md, "Render time against error").

One scene (a sphere under a sun at 45° and an overcast sky), Cycles and EEVEE, every material
at two sample counts in interleaved rounds; timing.py takes the fixed per-render cost out and
reports the cost of one sample and its ratio to Diffuse + Glossy's (median over rounds, and
the range).  The error of a render is against the reference of what that material means (its
own light mode's weights), so it is the engine's noise and approximation only.

    python benchmarks/speed.py [--size 128] [--rounds 5] [--images docs/img]
"""

import argparse
import pathlib
import statistics
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import porous_weathering as pw  # noqa: E402
from benchmarks import plots, scenes, timing  # noqa: E402
from benchmarks import reference as ref  # noqa: E402
from benchmarks.accuracy import MATERIALS, percent, sun_towards  # noqa: E402
from porous_weathering.blender import compat, render
from porous_weathering.core import model  # noqa: E402

PARAMS = MATERIALS["diffuse"]
SUN = ref.Sun(sun_towards(45.0), 3.0)
SKY = ref.Sky("OVERCAST", 0.5)
SAMPLES = {"CYCLES": (16, 64), "EEVEE": (1, 4)}
BASELINE = "Diffuse+Glossy"
#: The target (docs/benchmarks.md) for the porous material's overhead over Diffuse + Glossy at equal samples.
TARGET = 1.15
#: Masks as constants at t = 0.7 that put every mode mid-way through its weathering: every fill
#: strictly between 0 and 1 (``fills``), where Cycles would fold part of a mode's live nodes away.
#: The fronts are front_width (0.1) wide and the washing threshold another 0.4 above them, so the
#: threshold is set where one rain value falls inside both.
WEATHERING = dict(time=0.7, rain_map=0.35, edge_map=0.35, efflorescence_map=0.32, rain_threshold=0.4)
REFERENCE_SAMPLES = 4096
#: Errors are measured on every 4th pixel of every 4th row: a 4096-sample reference of each
#: pixel would take minutes, and noise per pixel does not depend on the resolution.
ERROR_STRIDE = 4


def fills():
    """The weathering fractions that WEATHERING gives, by the model: each must be in (0, 1)."""
    s = model.weathering_state(model.MODES, WEATHERING)

    def front(mask, level):
        return float(model.pore_fill(s[mask], s["time"], s[level], s["front_width"]))

    # soiling's sheltered fraction rises linearly from 0 at the rain threshold over the front width
    return {
        "sheltered": (s["rain_threshold"] - s["rain_map"]) / s["front_width"],
        "carbon front": front("edge_map", "soiling_level"),
        "water": front("rain_map", "wet_level"),
        "salt": front("efflorescence_map", "efflorescence_level"),
    }


def check_fills(parser):
    """Refuse to run, through ``parser``, when WEATHERING puts a fill at a bound."""
    outside = {name: value for name, value in fills().items() if not 0.0 < value < 1.0}
    if outside:
        parser.error(f"WEATHERING puts {outside} at a bound, where Cycles folds nodes away")


def stone(porous=True):
    base = dict(base_color=PARAMS["kd"], ks=PARAMS["ks"], roughness=PARAMS["m"])
    return {**base, "porosity": PARAMS["alpha"], "pore_depth_ratio": PARAMS["sp"]} if porous else base


def principled():
    material = compat.new_material("Principled")
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*PARAMS["kd"], 1.0)
    bsdf.inputs["Roughness"].default_value = PARAMS["m"]
    return material


def weathered(modes, sun):
    state = {name: value for name, value in WEATHERING.items() if name in model.inputs_of(modes)}
    return pw.make_weathered_material("+".join(modes), modes=modes, key_light=sun, **stone(), **state)


def materials(sun):
    """name -> (material, the reference material it should render, or None)."""
    return {
        BASELINE: (pw.make_base_material("Base", **stone(False)), ref.Porous(**{**PARAMS, "alpha": 0.0})),
        "Principled BSDF": (principled(), None),
        "porous key light": (
            pw.make_porous_material("Key", **stone(), key_light=sun),
            ref.Porous(**PARAMS, light_mode=SUN.towards),
        ),
        "porous ambient": (pw.make_porous_material("Ambient", **stone()), ref.Porous(**PARAMS, light_mode=ref.AMBIENT)),
        **{mode: (weathered((mode,), sun), None) for mode in model.MODES},
        "all three modes": (weathered(model.MODES, sun), None),
    }


def configure(engine, size):
    def set_up(scene, samples):
        if engine == "CYCLES":
            render.use_cycles(scene, size=size, samples=samples)
        else:
            render.use_eevee(scene, size=size, samples=samples)

    return set_up


def measure(engine, size, rounds):
    """name -> (timing.costs() entry, [relative RMSE at each sample count, or None],
    [median render seconds at each sample count])."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = scenes.build(scene, "SPHERE", (SUN,), SKY)
    sun = next(o for o in scene.objects if o.type == "LIGHT")
    candidates = materials(sun)
    full = scenes.reference_surface("SPHERE", size)
    every = (slice(None, None, ERROR_STRIDE),) * 2
    surface = ref.Surface(full.position[every], full.normal[every], full.covered[every])
    expected = {
        name: ref.render(surface, reference, (SUN,), SKY, samples=REFERENCE_SAMPLES)
        for name, (_, reference) in candidates.items()
        if reference is not None
    }
    samples = SAMPLES[engine]
    times, images = timing.interleaved_rounds(
        scene, obj, {name: m for name, (m, _) in candidates.items()}, configure(engine, size), samples, rounds
    )
    results = {}
    for name, cost in timing.costs(times, candidates, samples, BASELINE).items():
        errors = [None] * len(samples)
        if name in expected:
            for i, count in enumerate(samples):
                image = images[name, count][every]
                mask = expected[name].covered & (image[..., 3] > 0.999)
                errors[i] = ref.errors(image, expected[name].rgb, mask)[0]
        results[name] = (cost, errors, [statistics.median(times[name, count]) for count in samples])
    return results


def table_rows(engine, results):
    return [
        [
            engine.title(),
            name,
            f"{cost['fixed s']:.2f}",
            f"{cost['ms/sample']:.2f}",
            timing.ratio_cell(cost),
            *(percent(e) if e is not None else "—" for e in errors),
        ]
        for name, (cost, errors, _) in results.items()
    ]


def verdict(engine, results):
    """One line per porous material: its per-sample overhead against the target."""
    lines = []
    for name, (cost, _, _) in results.items():
        if name not in (BASELINE, "Principled BSDF"):
            met = (
                "met"
                if cost["ratio range"][1] <= TARGET
                else "met by the median only"
                if cost["ratio"] <= TARGET
                else "not met"
            )
            lines.append(
                f"- {engine.title()}, {name}: {cost['ratio']:.2f}× Diffuse+Glossy per sample "
                f"(target ≤ {TARGET}×: {met})"
            )
    return "\n".join(lines)


def plot_time_against_error(path, results):
    """Cycles: RMSE against the median wall time of a render, at each sample count."""
    series = {
        name: (seconds, [100 * e for e in errors])
        for name, (_, errors, seconds) in results.items()
        if errors[0] is not None
    }
    plots.line_plot(
        path,
        series,
        "render time (s, median, fixed cost included)",
        "RMSE (%)",
        f"Cycles, {SAMPLES['CYCLES']} samples: time against error",
        log="xy",
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--images", type=pathlib.Path, default=pathlib.Path("docs/img"))
    args = parser.parse_args()
    check_fills(parser)
    sections = []
    for engine, (low, high) in SAMPLES.items():
        results = measure(engine, args.size, args.rounds)
        header = [
            "engine",
            "material",
            "fixed s / render",
            "ms / sample",
            "× Diffuse+Glossy per sample (range)",
            f"RMSE at {low} spp",
            f"RMSE at {high} spp",
        ]
        sections.append(scenes.markdown_table(header, table_rows(engine, results)) + "\n\n" + verdict(engine, results))
        if engine == "CYCLES":
            plot_time_against_error(args.images / "speed_time_vs_error.png", results)
    sections.append("![Cycles time against error](img/speed_time_vs_error.png)")
    print(
        f"### Render time against error ({args.size} px sphere, sun 45° + overcast sky)\n\n"
        f"Cost of one sample = slope between {SAMPLES['CYCLES']} samples (Cycles) or {SAMPLES['EEVEE']} (EEVEE); "
        f"fixed = the rest of a render. Median of {args.rounds} interleaved rounds; the range is that of the "
        f"per-round ratios (the 2-core machine is shared with other jobs). RMSE against the reference of the "
        f"material's own light mode ({REFERENCE_SAMPLES} sky samples, on every {ERROR_STRIDE}th pixel and row).\n\n"
        + "\n\n".join(sections)
    )


if __name__ == "__main__":
    main()
