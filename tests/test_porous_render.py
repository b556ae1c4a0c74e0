"""Rendered porous materials against model.py, pixel by pixel (Cycles CPU, fixed seed)."""

import numpy as np
import pytest

import porous_weathering as pw
from benchmarks.scenes import porous_material
from helpers import LitSphere, assert_matches

DIFFUSE = dict(kd=(0.62, 0.55, 0.45), ks=0.05, m=0.6, alpha=0.35, sp=2.5)
GLOSSY = dict(kd=(0.25, 0.22, 0.2), ks=0.6, m=0.25, alpha=0.3, sp=1.5)


@pytest.mark.parametrize("params", [DIFFUSE, GLOSSY], ids=["diffuse", "glossy"])
def test_key_light_matches_model(fresh_scene, params):
    sphere = LitSphere(fresh_scene)
    image = sphere.render(porous_material(params, key_light=sphere.sun))
    expected, mask = sphere.expected(**params)
    assert_matches(image, expected, mask)


@pytest.mark.parametrize("params", [DIFFUSE, GLOSSY], ids=["diffuse", "glossy"])
def test_ambient_matches_model(fresh_scene, params):
    sphere = LitSphere(fresh_scene)
    image = sphere.render(porous_material(params))
    expected, mask = sphere.expected(**params, ambient=True)
    assert_matches(image, expected, mask)


def test_porous_over_base_ratio_is_the_models(fresh_scene):
    """The per-pixel ratio porous/base (what the paper's Fig. 11 shows) is the model's ratio."""
    sphere = LitSphere(fresh_scene)
    p = DIFFUSE
    image = sphere.render(porous_material(p, key_light=sphere.sun))
    base = sphere.render(pw.make_base_material("Base", base_color=p["kd"], ks=p["ks"], roughness=p["m"]))
    expected, mask = sphere.expected(**p)
    base_model, _ = sphere.expected(**{**p, "alpha": 0.0})
    mask &= base[..., :3].min(axis=-1) > 1e-3
    ratio = image[..., :3][mask] / base[..., :3][mask]
    assert np.allclose(ratio, expected[mask] / base_model[mask], rtol=1e-3)
    assert ratio.max() < 1.0  # porosity darkens this diffuse stone everywhere it is lit


def test_rotating_the_key_light_changes_the_shading(fresh_scene):
    sphere = LitSphere(fresh_scene, towards=(0.0, 0.0, 1.0))
    material = porous_material(DIFFUSE, key_light=sphere.sun)
    before = sphere.render(material)
    studio_towards = (0.8, 0.0, 0.6)
    from porous_weathering.samples import studio

    studio.aim_sun(sphere.sun, studio_towards)
    after = sphere.render(material)
    expected, mask = sphere.expected(**DIFFUSE)
    assert not np.allclose(before, after, atol=1e-3)
    assert_matches(after, expected, mask)


def test_a_picture_is_written_without_blenders_note(fresh_scene, tmp_path, capfd):
    """The main job's progress bar carries its steps only: Blender's "Saved: '...'" note on each
    picture it writes is left out (render.SAVED_NOTE), and on Blender 4 its lines on the render's
    progress ("Fra:1 Mem:...", "Time: ... (Saving: ...)", compat.PROGRESS_NOTES) and the empty
    lines after them; the picture written all the same."""
    from porous_weathering.blender import render

    sphere = LitSphere(fresh_scene)
    sphere.render(porous_material(DIFFUSE, key_light=sphere.sun))  # its set-up: lights, camera, size
    capfd.readouterr()
    render.render_picture(fresh_scene, tmp_path / "sphere.png")
    assert (tmp_path / "sphere.png").stat().st_size > 0
    printed = capfd.readouterr()
    assert printed.out + printed.err == ""
