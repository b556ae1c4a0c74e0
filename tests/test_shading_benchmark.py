"""The shading benchmarks' own pieces (benchmarks/shading.py, shading_instructions.py): the
lookup-texture experiment renders what docs/benchmarks.md says it does, the folding check renders
its baseline, the instruction report groups C++ functions by name, and the constant masks keep
every fill inside its front."""

import numpy as np

from benchmarks import shading, shading_instructions, speed
from porous_weathering.blender import render
from porous_weathering.samples import studio

#: docs/benchmarks.md: the 64² lookup texture renders within 0.13% RMSE (0.37% of the brightest
#: pixel at most) of the exact group; a lookup on the wrong axes or channels is far above these.
LOOKUP_RMSE, LOOKUP_MAX = 0.002, 0.005


def render_each(names, samples):
    """Renders of shading.py's materials ``names`` on its scene at 32 px, and the scene's sun."""
    scene, obj, sun, _ = shading.scene_filling_the_frame(32, threads=1)
    scene.cycles.samples = samples
    makers = shading.material_makers(sun)
    renders = []
    for name in names:
        studio.assign(obj, makers[name]())
        renders.append(render.render_array(scene))
    return renders, sun


def test_the_lookup_texture_renders_close_to_the_exact_group_but_not_within_the_render_tests():
    (exact, lookup), sun = render_each(("porous key light", "porous key light, lookup texture"), samples=4)
    covered = exact[..., 3] > 0.5
    difference = (lookup - exact)[..., :3][covered]
    rmse = np.sqrt((difference**2).mean() / (exact[..., :3][covered] ** 2).mean())
    largest = np.abs(difference).max() / exact[..., :3][covered].max()
    assert rmse < LOOKUP_RMSE and largest < LOOKUP_MAX, (rmse, largest)
    # the render tests hold the shipped groups to 1e-4 of the brightest pixel: the lookup is not
    assert largest > 1e-4
    assert "porous key light, lookup texture" not in shading.materials(sun)


def test_instruction_report_groups_functions_by_name():
    assert shading_instructions.short_name("void ccl::svm_eval_nodes<1979u, (ccl::ShaderType)0>(int, float*)") == (
        "ccl::svm_eval_nodes"
    )
    assert shading_instructions.short_name("ccl::(anonymous namespace)::kernel_image_interp(int)") == (
        "ccl::{anonymous}::kernel_image_interp"
    )
    pixels = 4
    slopes = {
        "base": {"void f<1>(int)": 10 * pixels, "g(float)": 5 * pixels},
        "other": {"void f<2>(int)": 30 * pixels, "g(float)": 4 * pixels, "h()": 2 * pixels},
    }
    table = shading_instructions.function_table(slopes, ["base", "other"], pixels, rows=1)
    assert "| `f` | +20 |" in table
    assert "| other | +1 |" in table  # g -1, h +2
    assert "| all | +21 |" in table


def test_the_folding_check_renders_its_baseline():
    """Its chain ends at the baseline's roughness, so only the instructions may differ."""
    (base, folded), sun = render_each((shading.BASELINE, shading.FOLDED), samples=2)
    assert np.abs(base - folded).max() < 1e-6
    assert shading.FOLDED not in shading.materials(sun)


def test_the_constant_masks_put_every_fill_inside_its_front():
    """shading.py and speed.py refuse to run when a fill of their constant masks is 0 or 1 (Cycles
    would fold that mode's nodes away): the masks must stay inside the defaults' fronts."""
    assert all(0.0 < value < 1.0 for value in speed.fills().values()), speed.fills()
