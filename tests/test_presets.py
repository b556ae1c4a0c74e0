"""Every preset builds a valid porous material with its documented values."""

import pathlib
import warnings

import bpy

import pytest

import porous_weathering as pw
from porous_weathering import model, nodes
from porous_weathering.presets import PRESETS

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
    assert max(kd) + preset.ks <= 1.0, "k_s + k_d > 1 would be clamped (SPEC 1)"


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
        pw.make_preset_material("GRANITE")


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
