"""Every preset builds a valid porous material with its documented values, and sets the
black crust that reproduces the measured crust."""

import pathlib
import warnings

import bpy

import numpy as np
import pytest

import porous_weathering as pw
from porous_weathering.core import model
from porous_weathering.core import modes as weathering_modes
from porous_weathering.core.modes import soiling
from porous_weathering.shading import nodes
from porous_weathering.shading.presets import PRESETS

DOCS = pathlib.Path(__file__).resolve().parent.parent / "docs" / "presets.md"


@pytest.mark.parametrize("key", PRESETS)
def test_preset_values_are_physical(key):
    preset = PRESETS[key]
    low, high = preset.porosity_range
    assert 0.0 <= low <= preset.porosity <= high <= 0.4  # the paper: brick, the most porous, up to 0.4
    assert 0.5 <= preset.pore_depth_ratio <= 4.0
    assert 0.0 < preset.roughness <= 1.0
    kd = preset.linear_base_color()[:3]
    assert all(0.0 < c < 1.0 for c in kd)
    assert max(kd) + preset.ks <= 1.0, "k_s + k_d > 1 would be clamped (docs/model.md §1)"


@pytest.mark.parametrize("key", PRESETS)
def test_preset_builds_a_porous_material(key):
    preset = PRESETS[key]
    with warnings.catch_warnings():
        warnings.simplefilter("error", model.PorousInputWarning)  # no value of ours needs clamping
        material = pw.make_preset_material(key)
    assert material.name == preset.label and material["pw_preset"] == key
    assert material["pw_light_mode"] == nodes.AMBIENT
    group = material.node_tree.nodes["Porous"].inputs
    assert group["Porosity"].default_value == pytest.approx(preset.porosity)
    assert group["Pore Depth Ratio"].default_value == pytest.approx(preset.pore_depth_ratio)
    assert group["Specular"].default_value == pytest.approx(preset.ks)
    assert group["Roughness"].default_value == pytest.approx(preset.roughness)
    assert tuple(group["Base Color"].default_value) == pytest.approx(preset.linear_base_color())


def test_preset_with_key_light_and_name(fresh_scene):
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    fresh_scene.collection.objects.link(sun)
    material = pw.make_preset_material("BRICK", name="Wall", key_light="Sun")
    assert material.name == "Wall" and material["pw_light_mode"] == nodes.SUN


def test_unknown_preset_names_the_choices():
    with pytest.raises(ValueError, match="LIMESTONE"):
        pw.make_preset_material("BASALT")


def test_srgb_hex_decodes_to_linear():
    preset = PRESETS["LIMESTONE"]
    white = type(preset)(**{**preset.__dict__, "base_color": "#FFFFFF"})
    mid = type(preset)(**{**preset.__dict__, "base_color": "#BCBCBC"})  # sRGB 188 is linear ~0.5
    assert white.linear_base_color() == pytest.approx((1.0, 1.0, 1.0, 1.0))
    assert mid.linear_base_color()[0] == pytest.approx(0.5029, abs=1e-3)


@pytest.mark.parametrize("key", PRESETS)
def test_docs_give_each_presets_values(key):
    preset = PRESETS[key]
    row = next((line for line in DOCS.read_text().splitlines() if line.startswith(f"| {preset.label} |")), None)
    assert row is not None, f"docs/presets.md has no table row for {preset.label}"
    cells = [cell.strip() for cell in row.strip("|").split("|")]
    assert f"{preset.porosity:g}" in cells and f"{preset.pore_depth_ratio:g}" in cells
    assert preset.base_color in cells


LUMA = np.array([0.2126, 0.7152, 0.0722])


def black_point_luminance(preset, crust, time=1.0):
    """Luminance of k_d + k_s of the preset's fully developed black point (sheltered, edge mask
    1, level 1) at ``time``, seen face on under ambient light: what a spectrophotometer reads."""
    params = preset.material_params()
    kd_w, ks_w, _ = model.weathered_coefficients(
        params["base_color"][:3],
        params["ks"],
        params["roughness"],
        params["porosity"],
        params["pore_depth_ratio"],
        None,
        1.0,
        (model.SOILING,),
        time=time,
        rain_map=0.0,
        edge_map=1.0,
        crust=crust,
    )
    return float(LUMA @ kd_w + ks_w)


def test_default_crust_reproduces_the_measured_crust_on_limestone():
    limestone = PRESETS["LIMESTONE"]
    ratio = black_point_luminance(limestone, soiling.CRUST_DEFAULT) / black_point_luminance(limestone, 0.0, time=0.0)
    assert ratio == pytest.approx(soiling.CRUST_REFLECTANCE_RATIO, abs=0.01)


@pytest.mark.parametrize("key", PRESETS)
def test_preset_crust_reflects_what_the_measured_crust_reflects(key):
    """The crust is one material whatever it grows on: every preset's fully developed black
    point has the luminance of the crusted limestone of the measurement (docs/presets.md)."""
    crust = PRESETS[key].panel_weathering()["crust"]
    limestone = PRESETS["LIMESTONE"]
    measured = soiling.CRUST_REFLECTANCE_RATIO * black_point_luminance(limestone, 0.0, time=0.0)
    assert black_point_luminance(PRESETS[key], crust) == pytest.approx(measured, abs=0.015)


@pytest.mark.parametrize("key", PRESETS)
def test_preset_weathering_values_are_panel_inputs_in_range(key):
    panel = {item.name: item for item in weathering_modes.inputs().values() if item.panel}
    for name, value in PRESETS[key].weathering.items():
        assert name in panel, f"{key} sets {name!r}, which the panel does not show"
        assert panel[name].low <= value <= panel[name].high


@pytest.mark.parametrize("key", PRESETS)
def test_docs_give_each_presets_weathering_values(key):
    preset = PRESETS[key]
    text = DOCS.read_text().split("## The stone's structure")[0]  # that table: tests/test_stone_structure.py
    rows = [line for line in text.splitlines() if line.startswith(f"| {preset.label} |")]
    assert len(rows) == 2, f"docs/presets.md needs a material row and a weathering row for {preset.label}"
    cells = [cell.strip() for cell in rows[1].strip("|").split("|")]
    values = preset.panel_weathering()
    assert cells[1].split()[0] == f"{values['crust']:g}" and cells[2].split()[0] == f"{values['wet_darkening']:g}"
