"""presets.from_colorimetry (docs/presets.md, "From measured colours"): CIEDE2000 held to Sharma,
Wu & Dalal's test pairs; the round trip measured colours -> inputs -> the model (and a Cycles
render of a face-on plane in a white sky) back to the measured colours within ΔE00 2; colours no
setting gives refused with a clear message."""

import bpy

import numpy as np
import pytest

import porous_weathering as pw
from porous_weathering import presets
from porous_weathering.blender import compat, render
from porous_weathering.core import colorimetry
from porous_weathering.samples import studio

#: Sharma, Wu & Dalal (Color Res. Appl. 30(1), 2005), Table 1: (L*a*b* 1, L*a*b* 2, ΔE00).
SHARMA_PAIRS = [
    ((50.0, 2.6772, -79.7751), (50.0, 0.0, -82.7485), 2.0425),
    ((50.0, 3.1571, -77.2803), (50.0, 0.0, -82.7485), 2.8615),
    ((50.0, 2.8361, -74.0200), (50.0, 0.0, -82.7485), 3.4412),
    ((50.0, -1.3802, -84.2814), (50.0, 0.0, -82.7485), 1.0000),
    ((50.0, -1.1848, -84.8006), (50.0, 0.0, -82.7485), 1.0000),
    ((50.0, -0.9009, -85.5211), (50.0, 0.0, -82.7485), 1.0000),
    ((50.0, 0.0, 0.0), (50.0, -1.0, 2.0), 2.3669),
    ((50.0, -1.0, 2.0), (50.0, 0.0, 0.0), 2.3669),
    ((50.0, 2.4900, -0.0010), (50.0, -2.4900, 0.0009), 7.1792),
    ((50.0, 2.4900, -0.0010), (50.0, -2.4900, 0.0010), 7.1792),
    ((50.0, 2.4900, -0.0010), (50.0, -2.4900, 0.0011), 7.2195),
    ((50.0, 2.4900, -0.0010), (50.0, -2.4900, 0.0012), 7.2195),
    ((50.0, -0.0010, 2.4900), (50.0, 0.0009, -2.4900), 4.8045),
    ((50.0, -0.0010, 2.4900), (50.0, 0.0010, -2.4900), 4.8045),
    ((50.0, -0.0010, 2.4900), (50.0, 0.0011, -2.4900), 4.7461),
    ((50.0, 2.5, 0.0), (50.0, 0.0, -2.5), 4.3065),
    ((50.0, 2.5, 0.0), (73.0, 25.0, -18.0), 27.1492),
    ((50.0, 2.5, 0.0), (61.0, -5.0, 29.0), 22.8977),
    ((50.0, 2.5, 0.0), (56.0, -27.0, -3.0), 31.9030),
    ((50.0, 2.5, 0.0), (58.0, 24.0, 15.0), 19.4535),
    ((50.0, 2.5, 0.0), (50.0, 3.1736, 0.5854), 1.0000),
    ((50.0, 2.5, 0.0), (50.0, 3.2972, 0.0), 1.0000),
    ((50.0, 2.5, 0.0), (50.0, 1.8634, 0.5757), 1.0000),
    ((50.0, 2.5, 0.0), (50.0, 3.2592, 0.3350), 1.0000),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
    ((63.0109, -31.0961, -5.8663), (62.8187, -29.7946, -4.0864), 1.2630),
    ((61.2901, 3.7196, -5.3901), (61.4292, 2.2480, -4.9620), 1.8731),
    ((35.0831, -44.1164, 3.7933), (35.0232, -40.0716, 1.5901), 1.8645),
    ((22.7233, 20.0904, -46.6940), (23.0331, 14.9730, -42.5619), 2.0373),
    ((36.4612, 47.8580, 18.3852), (36.2715, 50.5065, 21.2231), 1.4146),
    ((90.8027, -2.0831, 1.4410), (91.1528, -1.6435, 0.0447), 1.4441),
    ((90.9257, -0.5406, -0.9208), (88.6381, -0.8985, -0.7239), 1.5381),
    ((6.7747, -0.2908, -2.4247), (5.8714, -0.0985, -2.2286), 0.6377),
    ((2.0776, 0.0795, -1.1350), (0.9033, -0.0636, -0.5514), 0.9082),
]

#: Survey-like (clean, soiled, crust) L*a*b* triples, and the stone each is measured on.
SURVEYS = [
    (((80.0, 1.5, 9.0), (62.0, 1.0, 6.0), (35.0, 0.5, 2.0)), "LIMESTONE"),  # a pale oolitic limestone
    (((84.0, 0.5, 6.0), (70.0, 0.8, 5.0), (28.0, 0.3, 1.5)), "LIMESTONE"),  # a thick crust: more coverage
    (((72.0, 5.0, 18.0), (55.0, 3.0, 10.0), (32.0, 1.0, 3.0)), "SANDSTONE"),  # a buff sandstone
    (((90.0, 0.0, 2.0), (82.0, 0.2, 3.0), (40.0, 0.5, 2.5)), "MARBLE"),  # white marble (holds little deposit)
    (((48.0, 24.0, 22.0), (38.0, 10.0, 10.0), (24.0, 2.0, 2.0)), "BRICK"),  # red brick
]


def test_ciede2000_reproduces_sharmas_test_pairs():
    first, second, expected = (np.array(column) for column in zip(*SHARMA_PAIRS))
    np.testing.assert_allclose(colorimetry.delta_e_2000(first, second), expected, atol=1e-4)
    np.testing.assert_allclose(colorimetry.delta_e_2000(second, first), expected, atol=1e-4)  # symmetric


def test_lab_and_srgb_conversions():
    np.testing.assert_allclose(colorimetry.linear_to_lab(np.ones(3)), (100.0, 0.0, 0.0), atol=1e-9)
    np.testing.assert_allclose(colorimetry.linear_to_lab(np.zeros(3)), (0.0, 0.0, 0.0), atol=1e-9)
    for lab in ((80.0, 1.5, 9.0), (35.0, -4.0, 2.0), (5.0, 0.5, -1.0)):
        np.testing.assert_allclose(colorimetry.linear_to_lab(colorimetry.lab_to_linear(lab)), lab, atol=1e-9)
    # 18% grey is L* 49.5; sRGB 0.5 is linear 0.2140
    assert colorimetry.linear_to_lab(np.full(3, 0.18))[0] == pytest.approx(49.496, abs=1e-3)
    assert colorimetry.srgb_to_linear(0.5) == pytest.approx(0.21404, abs=1e-5)
    np.testing.assert_allclose(
        colorimetry.linear_to_srgb(colorimetry.srgb_to_linear([0.1, 0.5, 0.9])), [0.1, 0.5, 0.9], atol=1e-6
    )


def model_colours(found, preset):
    """The model's (clean, soiled, crust) linear colours at t = 1 with ``found`` (from_colorimetry)."""
    stone = presets.PRESETS[preset]
    params = dict(kd=np.array(found["base_color"][:3]), ks=stone.ks, m=stone.roughness)
    params.update(alpha=stone.porosity, sp=stone.pore_depth_ratio)
    inputs = {name: found[name] for name in ("deposit_color", "pollution_color", "crust")}
    return [colorimetry.appearance(params, point, **inputs) for point in ("clean", "soiled", "crust")]


@pytest.mark.parametrize("survey, preset", SURVEYS)
def test_round_trip_through_the_model(survey, preset):
    found = presets.from_colorimetry(*survey, preset=preset)
    got = colorimetry.linear_to_lab(np.array(model_colours(found, preset)))
    assert colorimetry.delta_e_2000(got, np.array(survey)).max() < 1e-6
    assert 0.0 <= found["crust"] <= 1.0 and all(
        0.0 <= c <= 1.0 for c in found["deposit_color"] + found["pollution_color"]
    )
    kwargs = presets.PRESETS[preset].material_params()
    assert {key: found[key] for key in kwargs if key != "base_color"} == {
        k: v for k, v in kwargs.items() if k != "base_color"
    }


def test_a_thick_crust_takes_more_coverage_than_the_stones():
    thin = presets.from_colorimetry(*SURVEYS[0][0])
    thick = presets.from_colorimetry(*SURVEYS[1][0])
    assert thin["crust"] == pytest.approx(presets.PRESETS["LIMESTONE"].panel_weathering()["crust"])
    assert thick["crust"] > thin["crust"]


def test_srgb_and_hex_input_mean_the_same_colours():
    as_hex = presets.from_colorimetry("#D6CDB8", "#9C958A", "#4A4744")
    as_floats = presets.from_colorimetry(
        *[[int(code[i : i + 2], 16) / 255 for i in (1, 3, 5)] for code in ("#D6CDB8", "#9C958A", "#4A4744")],
        space="srgb",
    )
    assert as_hex == pytest.approx(as_floats)
    # the clean stone is the limestone preset's own swatch: its k_d is not far from the preset's
    assert np.abs(np.array(as_hex["base_color"]) - presets.PRESETS["LIMESTONE"].linear_base_color()).max() < 0.1


@pytest.mark.parametrize(
    "colours, kwargs, message",
    [
        (((80, 1, 9), (62, 1, 6), (70, 1, 4)), {}, "must darken"),  # crust lighter than the soiled stone
        (((60, 1, 9), (70, 1, 6), (35, 1, 4)), {}, "must darken"),  # soiled lighter than the clean stone
        (((80, 1, 9), (45, 1, 6), (30, 1, 4)), {}, "soiled stone"),  # darker than a deposit makes it
        (((15, 0, 0), (10, 0, 0), (5, 0, 0)), {}, "clean stone"),  # darker than the stone's glossy lobe alone
        (((80, 90, 9), (62, 1, 6), (35, 1, 4)), {}, "gamut"),
        (((80, 1, 9), (62, 1, 6), (35, 1)), {}, "three finite numbers"),
        (((80, 1, 9), (62, 1, 6), (35, 1, 4)), dict(space="xyz"), "space"),
        (((0.8, 0.7, 0.6), (0.5, 0.5, 255), (0.2, 0.2, 0.2)), dict(space="srgb"), "0-255"),
        (((80, 1, 9), (62, 1, 6), (35, 1, 4)), dict(preset="BASALT"), "unknown preset"),
        (("#D6CDB", "#9C958A", "#4A4744"), {}, "#RRGGBB"),
    ],
)
def test_colours_no_setting_gives_are_refused(colours, kwargs, message):
    with pytest.raises(ValueError, match=message):
        presets.from_colorimetry(*colours, **kwargs)


def white_sky_plane(scene):
    """A plane seen face on under a uniform white sky (radiance 1), nothing else: a white Lambert
    surface renders 1, so a pixel is the colour a colorimeter reads (diffuse plus specular)."""
    plane = studio.add_plane(scene)
    studio.add_ortho_camera(scene, scale=1.0)
    scene.world = bpy.data.worlds.new("White Sky")
    compat.use_world_nodes(scene.world)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = 1.0
    render.use_cycles(scene, size=32, samples=16)
    return plane


def test_round_trip_through_a_cycles_render(fresh_scene):
    """The measured colours come back from a Cycles render of the material at t = 1, face on, in
    ambient light, within ΔE00 2 (the glossy lobe reflects a little less than the colorimeter's
    specular-included reading: the whole difference)."""
    plane = white_sky_plane(fresh_scene)
    survey, preset = SURVEYS[0]
    found = presets.from_colorimetry(*survey, preset=preset)
    for point, lab in zip(colorimetry.SURVEY_POINTS, survey):
        material = pw.make_weathered_material(point, time=1.0, **colorimetry.SURVEY_POINTS[point], **found)
        studio.assign(plane, material)
        pixels = render.render_array(fresh_scene)
        assert (pixels[..., 3] > 0.999).all()  # the plane fills the picture
        rendered = colorimetry.linear_to_lab(pixels[..., :3].reshape(-1, 3).mean(axis=0))
        difference = colorimetry.delta_e_2000(rendered, np.array(lab))
        print(f"{point}: rendered L*a*b* {np.round(rendered, 2)}, measured {lab}, ΔE00 {difference:.2f}")
        assert difference <= 2.0, (point, rendered, lab)
