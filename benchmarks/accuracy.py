"""Accuracy of the rendered porous material against the exact reference (docs/accuracy.md).

Prints markdown: per light mode (key light, ambient) the relative RMSE and max error of Cycles
(and a few EEVEE) renders against benchmarks/reference.py, as a sun moves from the zenith
to 89 degrees, and in three environments (uniform sky, overcast, sun + sky).  Error images go
to ``--images``.  Errors are relative to the reference's RMS over the covered pixels.

    python benchmarks/accuracy.py [--images docs/img]
"""

import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import bpy  # noqa: E402

import numpy as np  # noqa: E402

import porous_weathering as pw  # noqa: E402
from benchmarks import plots, scenes  # noqa: E402
from benchmarks import reference as ref  # noqa: E402
from porous_weathering.blender import render
from porous_weathering.samples import studio  # noqa: E402

MATERIALS = {
    "diffuse": dict(kd=(0.62, 0.55, 0.45), ks=0.05, m=0.6, alpha=0.35, sp=2.5),
    "glossy": dict(kd=(0.25, 0.22, 0.2), ks=0.6, m=0.25, alpha=0.3, sp=1.5),
}
ZENITH_ANGLES = (0, 30, 60, 75, 85, 89)
EEVEE_ANGLES = (30, 75)
#: Ambient mode is called broken down where its RMSE exceeds this.
BREAKDOWN = 0.05
SIZE, SKY_SIZE, SKY_SAMPLES, REFERENCE_SAMPLES = 48, 32, 1024, 4096


def sun_towards(zenith_degrees, azimuth_degrees=30.0):
    zenith, azimuth = np.radians(zenith_degrees), np.radians(azimuth_degrees)
    return (float(np.sin(zenith) * np.cos(azimuth)), float(np.sin(zenith) * np.sin(azimuth)), float(np.cos(zenith)))


def environments():
    sun = ref.Sun(sun_towards(45.0), 3.0)
    return {
        "uniform sky": ((), ref.Sky("UNIFORM", 1.0)),
        "overcast": ((), ref.Sky("OVERCAST", 1.0)),
        "sun 45° + overcast": ((sun,), ref.Sky("OVERCAST", 0.5)),
    }


def porous_material(params, key_light):
    if params["alpha"] == 0.0:  # the base Diffuse + Glossy material, which the reference gives at alpha = 0
        return pw.make_base_material("Base", base_color=params["kd"], ks=params["ks"], roughness=params["m"])
    return scenes.porous_material(params, key_light)


def rendered(surface, lights, sky, params, mode, engine="CYCLES", size=SIZE, samples=1):
    """A render of the porous material in ``mode`` ("key" on the first light, or "ambient")."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = scenes.build(scene, surface, lights, sky)
    if engine == "CYCLES":
        render.use_cycles(scene, size=size, samples=samples)
    else:
        render.use_eevee(scene, size=size, samples=samples)
    key = next(o for o in scene.objects if o.type == "LIGHT") if mode == "key" else None
    studio.assign(obj, porous_material(params, key))
    return render.render_array(scene)


def exact(surface, lights, sky, params, size, light_mode=ref.EXACT):
    return ref.render(
        scenes.reference_surface(surface, size),
        ref.Porous(**params, light_mode=light_mode),
        lights,
        sky,
        samples=REFERENCE_SAMPLES,
    )


def compared(image, expected):
    mask = expected.covered & (image[..., 3] > 0.999)
    return ref.errors(image, expected.rgb, mask), mask


def percent(value):
    return f"{100 * value:.3g}%"


def sun_sweep(images):
    rows, breakdown, curves = [], {}, {}
    for name, params in MATERIALS.items():
        for zenith in ZENITH_ANGLES:
            lights = (ref.Sun(sun_towards(zenith)),)
            expected = exact("SPHERE", lights, None, params, SIZE)
            row = [name, f"{zenith}°"]
            for mode in ("key", "ambient"):
                image = rendered("SPHERE", lights, None, params, mode)
                (rmse, worst), mask = compared(image, expected)
                row += [percent(rmse), percent(worst)]
                curves.setdefault(f"{name}, {mode}", ([], []))[0].append(zenith)
                curves[f"{name}, {mode}"][1].append(100 * rmse)
                if mode == "ambient" and rmse > BREAKDOWN:
                    breakdown.setdefault(name, (zenith, rmse))
                if zenith == 60 and name == "diffuse":
                    scenes.write_error_image(images / f"error_sun60_{mode}.png", image, expected.rgb, mask)
            rows.append(row)
    table = scenes.markdown_table(
        ["material", "sun zenith", "key RMSE", "key max", "ambient RMSE", "ambient max"], rows
    )
    plots.line_plot(
        images / "accuracy_sun_sweep.png",
        curves,
        "sun zenith angle (°)",
        "RMSE (% of reference RMS)",
        "Porous sphere under one sun, Cycles vs exact reference",
        log="y",
    )
    notes = [
        f"- {name}: ambient RMSE first exceeds {percent(BREAKDOWN)} at a sun {z}° from the zenith ({percent(e)})"
        for name, (z, e) in breakdown.items()
    ]
    notes = notes or [f"- the ambient RMSE stays under {percent(BREAKDOWN)} at every angle"]
    return (
        "### One sun, Cycles (deterministic: a zero-angle sun needs one sample)\n\n"
        + table
        + "\n\n"
        + "\n".join(notes)
        + "\n\n![RMSE against sun angle](img/accuracy_sun_sweep.png)\n\n"
        + "A large key-light max with a small RMSE comes from terminator pixels, "
        "where the smooth-shaded mesh shadows itself and the analytic sphere does not (geometry, not BRDF)."
    )


def eevee_rows():
    """EEVEE's porous material, and its base Diffuse + Glossy material (alpha = 0, no
    porous nodes at all), against the reference: what EEVEE's own lobes contribute."""
    rows = []
    for name, params in MATERIALS.items():
        for zenith in EEVEE_ANGLES:
            lights = (ref.Sun(sun_towards(zenith)),)
            row = [name, f"{zenith}°"]
            for variant in (params, dict(params, alpha=0.0)):
                expected = exact("SPHERE", lights, None, variant, 32)
                image = rendered("SPHERE", lights, None, variant, "key", engine="EEVEE", size=32, samples=16)
                (rmse, worst), _ = compared(image, expected)
                row += [percent(rmse), percent(worst)]
            rows.append(row)
    return (
        "### One sun, EEVEE (key light, 16 samples, 32 px)\n\n"
        + scenes.markdown_table(
            ["material", "sun zenith", "porous RMSE", "porous max", "base Diffuse+Glossy RMSE", "base max"], rows
        )
        + "\n\nThe base material has no porous nodes: where its error matches the porous one, the "
        "difference is EEVEE's own diffuse and glossy lobes against Cycles' GGX, not the porous maths."
    )


def v_groove_rows():
    rows = []
    lights = (ref.Sun(sun_towards(60.0, 0.0)),)
    for name, params in MATERIALS.items():
        expected = exact(("V_GROOVE", 45.0), lights, None, params, SIZE)
        image = rendered(("V_GROOVE", 45.0), lights, None, params, "key")
        (rmse, worst), _ = compared(image, expected)
        rows.append([name, percent(rmse), percent(worst)])
    return (
        "### V-groove (45° faces, sun 60° across it: the far face shadows the lit one), Cycles key light\n\n"
        + scenes.markdown_table(["material", "RMSE", "max"], rows)
    )


def environment_rows():
    """Ambient (and, with a sun, key-light) mode in each environment.

    'model' compares the reference with the mode's weights to the exact reference, with the
    same Monte Carlo samples: the approximation's own error, free of noise.  'Cycles'
    compares a render to the exact reference, and so adds Cycles' noise at its samples.
    """
    rows = []
    for name, params in MATERIALS.items():
        for environment, (lights, sky) in environments().items():
            expected = exact("SPHERE", lights, sky, params, SKY_SIZE)
            modes = ["ambient"] + (["key"] if lights else [])
            for mode in modes:
                weights = ref.AMBIENT if mode == "ambient" else lights[0].towards
                model_only = exact("SPHERE", lights, sky, params, SKY_SIZE, light_mode=weights)
                (model_rmse, model_max), _ = compared(np.dstack([model_only.rgb, model_only.covered]), expected)
                image = rendered("SPHERE", lights, sky, params, mode, size=SKY_SIZE, samples=SKY_SAMPLES)
                (rmse, worst), _ = compared(image, expected)
                bound = np.sqrt(np.mean(expected.bound[expected.covered] ** 2 / 9.0))
                scale = np.sqrt(np.mean(expected.rgb[expected.covered] ** 2))
                rows.append(
                    [
                        name,
                        environment,
                        mode,
                        percent(model_rmse),
                        percent(model_max),
                        percent(rmse),
                        percent(worst),
                        percent(bound / scale),
                    ]
                )
    return (
        f"### Environments (sphere {SKY_SIZE} px; Cycles {SKY_SAMPLES} samples; reference "
        f"{REFERENCE_SAMPLES} samples)\n\n"
        + environment_rows.__doc__.split("\n\n")[1].strip().replace("\n    ", " ")
        + " 'ref σ' is the reference's own Monte Carlo standard error (RMS over pixels).\n\n"
        + scenes.markdown_table(
            ["material", "environment", "mode", "model RMSE", "model max", "Cycles RMSE", "Cycles max", "ref σ"], rows
        )
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", type=pathlib.Path, default=pathlib.Path("docs/img"))
    args = parser.parse_args()
    args.images.mkdir(parents=True, exist_ok=True)
    sections = [sun_sweep(args.images), v_groove_rows(), environment_rows(), eevee_rows()]
    print("\n\n".join(sections))


if __name__ == "__main__":
    main()
