"""The stone's own structure (docs/model.md §8): the maths in numpy, and the stone group's
renders against it pixel by pixel (Cycles CPU, fixed seed, tiny images).

- numpy: the per-point parameters keep the material's means, rise together with the porosity
  field, are clamped; the receptivity is 1 at the mean and none (None) is r = 1 bit for bit.
- render: the per-point k_d, alpha, s_p, m (and r, z_p, z_c) are read back from probe renders of
  the material's own stone node; they are the numpy maths of the read fields, and the rendered
  pixels are the model's (porous and weathered) at those parameters.
- the grains' plane (§8.1): its mirror lays every face's cells nearly flat (numpy).
- ``variation = 0`` and ``stone = None`` render bit for bit the same, with no stone node.
- the same plane in millimetres (unit scale 0.001) and in metres has the same fields.
- run-off in rivulets (docs/model.md §8.8): the weighted run-off keeps R's mean across the fall
  line (numpy, and on a render's fields), level faces have none, an inclined plane renders as the
  model per pixel, and in millimetres as in metres.
"""

import math
import warnings

import bpy

import numpy as np
import pytest

import porous_weathering as pw
from benchmarks import probes
from helpers import (
    MaskedPlane,
    assert_matches,
    lichen_seed_probe,
    presets_row,
    stone_glossy_lobe,
    stone_parameters,
    stone_probe,
    stone_shifted,
    stone_weights,
)
from porous_weathering.blender import render
from porous_weathering.contracts import GROUP_NODE, STONE_NODE
from porous_weathering.core import model, porous, stones
from porous_weathering.core.backends import NumpyOps
from porous_weathering.core.modes import base, biological, soiling
from porous_weathering.samples import studio
from porous_weathering.shading import nodes
from porous_weathering.shading.presets import PATCH_OCTAVES, PRESETS

XP = NumpyOps(colour=True)
SCALAR = NumpyOps(colour=False)
STRUCTURED = [key for key, preset in PRESETS.items() if preset.structure is not None]
#: A stone of the test's own values (porous enough to show the structure), with limestone's structure.
STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.08, roughness=0.6, porosity=0.3, pore_depth_ratio=2.5)
KD = np.array(STONE["base_color"])


def parameters(stone, z_p, z_c, variation=1.0, kd=KD):
    s = STONE
    return stones.point_parameters(
        XP, stone, kd, s["porosity"], s["pore_depth_ratio"], s["roughness"], z_p, z_c, variation
    )


# --- the maths, in numpy ---------------------------------------------------------------------


def test_every_preset_has_its_stone():
    assert "GRANITE" in PRESETS
    assert STRUCTURED == list(PRESETS)


@pytest.mark.parametrize("key", STRUCTURED)
def test_means_are_kept(key):
    """Over a field symmetric about 0 the mean of each parameter is the material's value."""
    stone = PRESETS[key].structure
    z = np.linspace(-1.0, 1.0, 201)
    kd, alpha, sp, m = parameters(stone, z, z[::-1])
    s = STONE
    assert alpha.mean() == pytest.approx(s["porosity"], rel=1e-12)
    assert sp.mean() == pytest.approx(s["pore_depth_ratio"], rel=1e-12)
    assert m.mean() == pytest.approx(s["roughness"], rel=1e-12)
    assert kd.mean(axis=0) == pytest.approx(KD, rel=1e-12)


@pytest.mark.parametrize("key", STRUCTURED)
def test_porous_points_are_rougher_and_deeper(key):
    stone = PRESETS[key].structure
    z = np.linspace(-1.0, 1.0, 21)
    _, alpha, sp, m = parameters(stone, z, np.zeros_like(z))
    for values in (alpha, sp, m):
        assert np.all(np.diff(values) > 0.0)
    r = stones.receptivity(XP, stone, z, 1.0)
    assert np.all(np.diff(r) > 0.0) and r[10] == 1.0


@pytest.mark.parametrize("key", STRUCTURED)
def test_variation_zero_is_the_material(key):
    stone = PRESETS[key].structure
    z = np.linspace(-1.0, 1.0, 11)
    kd, alpha, sp, m = parameters(stone, z, z, variation=0.0)
    s = STONE
    assert np.all(alpha == s["porosity"]) and np.all(sp == s["pore_depth_ratio"]) and np.all(m == s["roughness"])
    assert np.all(kd == KD)
    assert np.all(stones.receptivity(XP, stone, z, 0.0) == 1.0)


@pytest.mark.parametrize("key", STRUCTURED)
def test_preset_stones_stay_in_range(key):
    """No clamp acts on a preset's own values (so its means are kept) and k_d + k_s <= 1."""
    preset = PRESETS[key]
    kd0 = np.array(preset.linear_base_color()[:3])
    z = np.array([-1.0, 1.0])
    kd, alpha, sp, m = stones.point_parameters(
        XP, preset.structure, kd0, preset.porosity, preset.pore_depth_ratio, preset.roughness, z, z, 1.0
    )
    assert np.all((alpha > 0) & (alpha < 1)) and np.all(sp > 0) and np.all((m > 0) & (m < 1.5))
    assert np.all(kd > 0) and np.all(kd.max(axis=-1) + preset.ks <= 1.0)


def test_parameters_are_clamped():
    stone = PRESETS["LIMESTONE"].structure
    kd, alpha, sp, m = stones.point_parameters(XP, stone, KD, 0.95, 2.0, 1.45, np.array([1.0]), np.array([1.0]), 5.0)
    assert alpha[0] == 1.0 and m[0] == 1.5  # variation clamped to 1, alpha to 1, m to 1.5


def test_the_least_roughness_keeps_k_above_its_floor():
    """m >= LEAST_ROUGHNESS gives k = 2 m^2 / pi >= K_FLOOR, in single precision too, so the receptive
    group needs no floor of k per point (docs/model.md §8.2); the stone's m clamps to it."""
    least = np.float32(stones.LEAST_ROUGHNESS)
    assert least * least * np.float32(2.0 / np.pi) >= porous.K_FLOOR
    assert 2.0 * stones.LEAST_ROUGHNESS**2 / np.pi >= porous.K_FLOOR
    stone, z = PRESETS["LIMESTONE"].structure, np.ones(1)
    _, _, _, m = stones.point_parameters(XP, stone, KD, 0.2, 2.0, 0.0, z, z, 1.0)
    assert m[0] == stones.LEAST_ROUGHNESS


def test_fields_are_zero_mean_and_bounded():
    stone = PRESETS["SANDSTONE"].structure
    rng = np.random.default_rng(0)
    # a texture's value lies in [0, 1]; a clipped layer's is taken beyond, where its clip acts
    values = [rng.uniform(*((0.0, 1.0) if stones.unclipped(t) else (-0.5, 1.5)), 1000) for t in stone.textures]
    mirrored = [1.0 - v for v in values]  # a texture's values mirrored about 1/2
    z_p, z_c = stones.fields(XP, stone, values)
    z_p2, z_c2 = stones.fields(XP, stone, mirrored)
    assert np.abs(z_p).max() <= 1.0 and np.abs(z_c).max() <= 1.0
    assert np.allclose(z_p + z_p2, 0.0) and np.allclose(z_c + z_c2, 0.0)


def test_a_layer_clipped_before_its_gain_is_clipped_after():
    """texture_value takes the noise's value clipped to where its z lies in [-1, 1], then the gain:
    clip(gain (v - 1/2), -1, 1) (docs/model.md §8.1), for every kind."""
    values = np.linspace(-0.5, 1.5, 2001)
    layers = {(t.kind, t.gain): t for preset in PRESETS.values() for t in preset.structure.textures}
    assert {kind for kind, _ in layers} == {stones.NOISE, stones.WAVE, stones.CELLS, stones.BEDS}
    for texture in layers.values():
        gain = texture.gain
        expected = gain * (values - 0.5) if stones.unclipped(texture) else np.clip(gain * (values - 0.5), -1.0, 1.0)
        np.testing.assert_allclose(stones.texture_value(XP, values, texture), expected, atol=1e-15)


def test_a_noise_spreads_as_wide_whatever_its_octaves():
    """A noise's gain scales with how narrow its normalised octaves leave it (docs/model.md §8.1):
    Blender's fBm of independent octaves, sampled here as sums of independent uniform draws of
    equal spread (a fractional detail mixing, by its fraction, the normalised sums without and with
    one octave more, as Blender's fBm does), spreads gain (v - 1/2) alike for the presets' octaves,
    a fractional detail's and the calibration's."""
    rng = np.random.default_rng(1)

    def spread(texture):
        whole, fraction = int(texture.detail), texture.detail % 1.0
        amplitudes = texture.roughness ** np.arange(whole + 2)
        draws = rng.uniform(-0.5, 0.5, (200_000, whole + 2)) * amplitudes
        without = draws[:, :-1].sum(axis=1) / amplitudes[:-1].sum()
        with_next = draws.sum(axis=1) / amplitudes.sum()
        return texture.gain * ((1.0 - fraction) * without + fraction * with_next).std()

    detail, roughness = stones.NOISE_GAIN_OCTAVES
    calibration = stones.Texture(stones.NOISE, 0.1, 1.0, 0.0, detail=detail, roughness=roughness)
    assert calibration.gain == stones.GAIN[stones.NOISE]
    patches = stones.Texture(stones.NOISE, 0.1, 1.0, 0.0, **PATCH_OCTAVES)
    half_octave = stones.Texture(stones.NOISE, 0.1, 1.0, 0.0, detail=0.5, roughness=1.0)
    assert patches.gain > calibration.gain
    for texture in (patches, half_octave):
        assert spread(texture) == pytest.approx(spread(calibration), rel=0.01)


def blender_reflect(a, b):
    """Blender's Vector Math Reflect: a mirrored in the plane of normal b (normalised)."""
    unit = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return a - 2.0 * np.sum(a * unit, axis=-1, keepdims=True) * unit


def test_grains_mirror_lays_every_face_nearly_flat():
    """docs/model.md §8.1: the grains' mirror is never zero, takes the axes' faces onto the (x, y)
    plane exactly ((x, y), (±z, y), (x, ±z)), and stretches no face's cells more than 1.57 times
    (1 / |z| of the mirrored normal), a vertical wall no more than 2 / √3 = 1.155 times."""
    xp = NumpyOps(colour=False)
    normals = np.random.default_rng(7).normal(size=(400_000, 3))
    angles = np.radians(np.arange(360.0))
    walls = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=-1)
    normals = np.concatenate([normals / np.linalg.norm(normals, axis=-1, keepdims=True), walls])
    mirror = stones.grains_mirror(xp, normals)
    assert np.linalg.norm(mirror, axis=-1).min() >= 1.0
    stretch = 1.0 / np.abs(blender_reflect(normals, mirror)[:, 2])
    assert stretch.max() <= 1.57
    assert stretch[-len(walls) :].max() <= 2.0 / math.sqrt(3.0) + 1e-9
    place = np.array([0.3, -0.7, 1.9])
    for normal, plane in (((0, 0, 1), (0.3, -0.7)), ((1, 0, 0), (-1.9, -0.7)), ((0, -1, 0), (0.3, -1.9))):
        for side in (1.0, -1.0):
            mirrored = blender_reflect(place, stones.grains_mirror(xp, side * np.array(normal, float)))
            np.testing.assert_allclose(np.abs(mirrored[:2]), np.abs(plane), atol=1e-12)


def test_a_stone_whose_weights_exceed_one_is_refused():
    texture = stones.Texture(stones.NOISE, 0.1, 0.7, 0.0)
    with pytest.raises(ValueError, match="porosity weights"):
        stones.Stone((texture, texture), 0.2, 0.1, 0.1, (0.0, 0.0, 0.0), "too much")


def test_no_receptivity_is_r_one_bit_for_bit():
    """No stone (None) is r = 1 at the field's mean, and a stone at variation 0, bit for bit."""
    modes = model.MODES
    state = dict(time=0.6, rain_map=0.3, edge_map=0.7, efflorescence_map=0.65, runoff_map=0.3)
    s = STONE
    args = (s["base_color"], s["ks"], s["roughness"], s["porosity"], s["pore_depth_ratio"], 0.8, 0.9, modes)
    plain = model.weathered_coefficients(*args, **state)
    with_one = model.weathered_coefficients(*args, receptivity=1.0, **state)
    at_zero = model.weathered_coefficients(
        *args, receptivity=1.0, field=np.array([-1.0, 0.3, 1.0]), variation=0.0, **state
    )
    for a, b, c in zip(plain, with_one, at_zero):
        assert np.array_equal(a, b) and np.array_equal(np.broadcast_to(a, c.shape), c)


def test_local_share_keeps_the_mean_and_the_ends():
    """docs/model.md §8.7: share + s min(share, 1 - share) stays in [0, 1], is 0 at 0 and 1 at 1 at
    every point, and its mean over a field symmetric about 0 is the share, for any variation."""
    z = np.linspace(-1.0, 1.0, 401)
    share = np.linspace(0.0, 1.0, 51)[:, None]
    for variation in (0.3, 1.0):
        local = base.local_share(XP, share, base.uptake_spread(XP, z, variation))
        assert local.min() >= 0.0 and local.max() <= 1.0
        assert np.all(local[0] == 0.0) and np.all(local[-1] == 1.0)
        assert np.abs(local.mean(axis=1) - share[:, 0]).max() < 1e-12
    spread = base.uptake_spread(XP, z, 1.0)
    assert np.all(np.diff(base.local_share(XP, 0.3, spread)) >= 0.0)  # the receptive part first
    assert np.abs(spread).max() == 1.0 and spread[200] == 0.0
    assert base.local_share(XP, share, None) is share


def test_the_wash_front_breaks_up_along_the_stone():
    """docs/model.md §8.7: the share is taken of the sheltered fill, so at the wash's edge (half
    sheltered, a saturated crust front) the receptive part keeps a full crust and the resistant part
    none, of mean the half crust of the model without a stone (which keeps its own product)."""
    crust, width = 0.8, 0.1
    plain = soiling.crust_coverage(XP, 0.5, 1.0, 1.0, 1.0, width, crust)
    spread = base.uptake_spread(XP, np.linspace(-1.0, 1.0, 401), 1.0)
    local = soiling.crust_coverage(XP, 0.5, 1.0, 1.0, 1.0, width, crust, spread)
    assert plain == pytest.approx(0.5 * crust, abs=1e-12)
    assert local[0] == 0.0 and local[-1] == pytest.approx(crust, abs=1e-12)
    assert local.mean() == pytest.approx(plain, abs=1e-12)


def test_the_deposit_darkens_red_brick():
    """docs/model.md §8.6: without a stone a grey deposit lightens red brick's green and blue; with
    the brick's stone it filters the brick's own colour, darker in every channel; on the reference
    limestone it is the same deposit at any variation (the environments' calibration holds)."""
    deposit = np.array([0.257, 0.249, 0.231])  # the urban site's
    grey = dict(time=1.0, rain_map=0.0, edge_map=0.0, deposit_color=deposit, crust=0.0, runoff_map=0.0)
    preset = PRESETS["BRICK"]
    brick = np.array(preset.linear_base_color()[:3])
    args = (brick, preset.ks, preset.roughness, preset.porosity, preset.pore_depth_ratio, None, 1.0, ("soiling",))
    clean = model.weathered_coefficients(*args, time=0.0)[0]
    today = model.weathered_coefficients(*args, **grey)[0]
    stone = model.weathered_coefficients(*args, receptivity=1.0, field=0.0, variation=1.0, **grey)[0]
    assert today[1] > clean[1] and today[2] > clean[2]
    assert np.all(stone < clean)
    limestone = PRESETS["LIMESTONE"]
    assert np.array_equal(np.array(limestone.linear_base_color()[:3]), soiling.DEPOSIT_REFERENCE_STONE)
    reference = (
        soiling.DEPOSIT_REFERENCE_STONE,
        limestone.ks,
        limestone.roughness,
        limestone.porosity,
        limestone.pore_depth_ratio,
        None,
        1.0,
    )
    plain = model.weathered_coefficients(*reference, ("soiling",), **grey)[0]
    for variation in (0.4, 1.0):
        mixed = model.weathered_coefficients(*reference, ("soiling",), variation=variation, **grey)[0]
        assert mixed == pytest.approx(plain, abs=1e-12)


def test_receptive_points_weather_first():
    """A point of higher r is further along every front at the same t."""
    s = STONE
    r = np.array([0.8, 1.0, 1.25])
    kd_w, _, _ = model.weathered_coefficients(
        s["base_color"], s["ks"], s["roughness"], s["porosity"], s["pore_depth_ratio"], None, 1.0,
        ("soiling",), receptivity=r, time=0.5, rain_map=0.0, edge_map=0.5, crust=0.0,
    )  # fmt: skip
    assert np.all(np.diff(kd_w.sum(axis=-1)) < 0.0)  # darker where more receptive


#: Soiling by run-off alone (no rain, no carbon): washed rivulets with dirty margins between them.
RIVULET_STATE = dict(time=0.6, rain_map=0.0, edge_map=0.0, runoff_map=0.3, streaks=1.0, crust=0.0)


def runoff_entering(normal, x, y, field, variation=1.0, spacing=0.04, runoff_map=0.3, rain_map=0.0):
    """The run-off map as it enters the modes (the soiling point's state) at points of a face of
    ``normal`` placed at (x, y) metres (docs/model.md §8.8)."""
    place = np.stack(np.broadcast_arrays(x, y, 0.0), axis=-1)
    across, horizontal = base.fall_line(SCALAR, place, np.asarray(normal))
    state = {**RIVULET_STATE, "runoff_map": runoff_map, "rain_map": rain_map}
    point = model.weathered_point(
        KD, STONE["ks"], STONE["roughness"], STONE["porosity"], STONE["pore_depth_ratio"], 0.8, 0.9, ("soiling",),
        field=field, variation=variation, rivulets=(across, horizontal, spacing), **state,
    )  # fmt: skip
    return point.state["runoff_map"]


def test_rivulets_keep_the_water_across_the_fall_line():
    """Along a horizontal line of an inclined or vertical face the run-off in rivulets keeps the map's
    mean over every cell of one spacing (each cell its own rivulet: docs/model.md §8.8), so over the
    line; the cells differ in their rivulets' width and strength, and half the water runs in less
    than a fifth of the width; level faces and variation 0 keep R bit for bit."""
    spacing, field, cells, per_cell = 0.04, 0.4, 100, 2000
    place = (np.arange(cells * per_cell) + 0.5) / per_cell - cells / 2  # in spacings, whole cells
    across = (place - base.RIVULET_WANDER * field) * spacing
    for slope in (30.0, 90.0):
        normal = (0.0, -math.sin(math.radians(slope)), math.cos(math.radians(slope)))
        x = -across  # u = -x on these faces
        held = runoff_entering(normal, x, 0.3, field, runoff_map=0.2).reshape(cells, per_cell)
        assert np.abs(held.mean(axis=1) - 0.2).max() < 1e-9
        assert held.max() <= 1.0 and held.min() >= 0.0 and held.max() > 0.8
        peaks = held.max(axis=1)
        assert peaks.std() > 0.1  # rivulets of their own strength and width
        wettest = np.cumsum(np.sort(held.ravel())[::-1]) / held.sum()
        assert (wettest < 0.5).mean() < 0.2  # (an even film: a half)
        heavy = runoff_entering(normal, x, 0.3, field, runoff_map=0.8).reshape(cells, per_cell)
        assert np.abs(heavy.mean(axis=1) - 0.8).max() < 1e-9 and heavy.max() <= 1.0
        wandering = np.random.default_rng(5).uniform(-0.5, 0.5, x.size)
        assert abs(runoff_entering(normal, x, 0.3, wandering).mean() - 0.3) < 0.01
    x = -across
    for normal in ((0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.0, math.sin(0.05), math.cos(0.05))):
        assert np.array_equal(runoff_entering(normal, x, 0.3, field), np.full(x.size, 0.3))  # finite: w = 1
    assert np.array_equal(runoff_entering((0.0, -1.0, 0.0), x, 0.3, field, variation=0.0), np.full(x.size, 0.3))


def test_every_run_off_runs_in_rivulets():
    """The run-off runs in rivulets whatever rain falls where it runs (docs/model.md §8.8): an open
    wall's own run-off as a sill's, the same rivulets under no rain and under E = 0.42 (the rain
    that lands a drop at a time is W's even part, not the map's)."""
    normal, field = (0.0, -1.0, 0.0), 0.1
    x = -np.linspace(0.0, 2.0, 4001)  # 2 m across a wall, u = -x
    sheltered = runoff_entering(normal, x, 0.3, field, runoff_map=0.2, rain_map=0.0)
    open_wall = runoff_entering(normal, x, 0.3, field, runoff_map=0.2, rain_map=0.42)
    assert np.array_equal(open_wall, sheltered)
    assert open_wall.max() > 0.6 and open_wall.min() < 0.02  # rivulets, not the even film of 0.2


@pytest.mark.parametrize(
    ("size", "scale", "advice"),
    [
        (300.0, 1.0, "0.001 if it is modelled in millimetres"),
        (0.002, 1.0, "1000 if it is modelled in kilometres"),
        (2.0, 0.001, "1 if it is modelled in metres"),
        (0.3, 1.0, None),
        (30.0, 1.0, None),
    ],
)
def test_implausible_sizes_name_the_unit_scale(size, scale, advice):
    message = stones.plausible_size(size, scale)
    if advice is None:
        assert message is None
    else:
        assert "Unit Scale" in message and advice in message


# --- renders ---------------------------------------------------------------------------------


def probe(plane, material, outputs):
    return stone_probe(plane.render, material, outputs)


def glossy_lobe(plane, material):
    return stone_glossy_lobe(plane.render, material)


def read_back(plane, material):
    """The per-pixel values the stone node gives: {kd, alpha, sp, m, r, z_p, z_c}."""
    got = stone_parameters(plane.render, material, extra=("Porosity Field", "Colour Field"))
    return dict(got, z_p=got.pop("Porosity Field"), z_c=got.pop("Colour Field"))


def cosines(plane):
    towards = np.array(plane.sun.matrix_world.to_3x3().col[2])
    return float(towards[2]), 1.0  # the plane faces +Z, the camera looks down -Z


def test_stone_group_is_the_maths_per_pixel(fresh_scene):
    """The fields read back give, through the numpy maths, the parameters read back; the fields
    have mean near 0 over a 2 m plane (a bed face: horizontal, so its bedding is one band), and
    the parameters vary."""
    plane = MaskedPlane(fresh_scene, size=24)
    material = pw.make_porous_material("Stone", **STONE, stone="LIMESTONE")
    got = read_back(plane, material)
    covered = plane.render(material)[..., 3] > 0.999
    stone = PRESETS["LIMESTONE"].structure
    kd, alpha, sp, m = parameters(stone, got["z_p"], got["z_c"])
    for name, value in (("alpha", alpha), ("sp", sp), ("m", m), ("kd", kd)):
        assert np.abs(got[name] - value)[covered].max() < 1e-5 * max(1.0, float(np.abs(value).max())), name
    assert np.abs(got["r"] - stones.receptivity(XP, stone, got["z_p"], 1.0))[covered].max() < 1e-5
    assert np.abs(got["z_p"][covered]).max() <= 1.0 and got["z_p"][covered].std() > 0.1
    assert abs(got["z_p"][covered].mean()) < 0.15 and abs(got["z_c"][covered].mean()) < 0.15


def test_porous_render_matches_the_model_per_pixel(fresh_scene):
    plane = MaskedPlane(fresh_scene, size=24)
    material = pw.make_porous_material("Stone", **STONE, stone="LIMESTONE", key_light=plane.sun)
    got = read_back(plane, material)
    image = plane.render(material)
    diffuse = plane.render(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0))[..., :3]
    glossy = glossy_lobe(plane, material)
    n_dot_l, n_dot_v = cosines(plane)
    kd_poro, ks_poro = model.porous_coefficients(
        got["kd"], STONE["ks"], got["m"], got["alpha"], got["sp"], n_dot_l, n_dot_v
    )
    expected = kd_poro * diffuse + ks_poro[..., None] * glossy
    assert_matches(image, expected, image[..., 3] > 0.999)


@pytest.mark.parametrize("variation", [1.0, 0.5])
def test_weathered_fronts_follow_the_stone(fresh_scene, variation):
    """With the stone's receptivity, uptake and deposit mix (docs/model.md §8.3, §8.6, §8.7) the soiling
    at t is where the model puts it, per pixel (the carbon front, the grey deposit in the stone's
    colour, the crust), and it breaks up along the stone: some points are further along than others."""
    plane = MaskedPlane(fresh_scene, size=24)
    state = dict(time=0.5, rain_map=0.0, edge_map=0.55, crust=0.5)
    material = pw.make_weathered_material(
        "Weathered", modes=("soiling",), **STONE, stone="LIMESTONE", key_light=plane.sun, environment=None,
        variation=variation, **state,
    )  # fmt: skip
    got = read_back(plane, material)
    got["z_p"] = stone_shifted(plane.render, material, "Porosity Field")
    image = plane.render(material)
    diffuse = plane.render(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0))[..., :3]
    glossy = glossy_lobe(plane, material)
    n_dot_l, n_dot_v = cosines(plane)
    kd_w, ks_w, _ = stone_weights(got, STONE["ks"], n_dot_l, n_dot_v, ("soiling",), variation, **state)
    covered = image[..., 3] > 0.999
    assert_matches(image, kd_w * diffuse + ks_w[..., None] * glossy, covered)
    fill = model.pore_fill(0.55, np.minimum(0.5 * got["r"], 1.0), 1.0, 0.1)
    fill = base.local_share(XP, fill, base.uptake_spread(XP, got["z_p"], variation))[covered]
    assert fill.min() < 0.25 and fill.max() > 0.75  # the front runs through the stone's structure


def test_life_follows_the_stone(fresh_scene):
    """The algal film at the stone's pace and capacity and the lichens' establishment at the point's
    share of the stone (docs/model.md §8.3, §8.7, §9.3): per pixel where the model puts them, given the stone's
    values and the lichens' seeds read back; the share of seeds that establish runs through the
    stone's structure about its mean."""
    plane = MaskedPlane(fresh_scene, size=24)
    state = dict(
        biological_years=20.0, lichen_density=4.0, lichen_growth=20.0, damp_map=0.3, rain_map=0.2, runoff_map=0.0,
        sun_map=0.5,
    )  # fmt: skip
    material = pw.make_weathered_material(
        "Life", modes=("biological",), **STONE, stone="LIMESTONE", key_light=plane.sun, environment=None, **state
    )
    got = read_back(plane, material)
    got["z_p"] = stone_shifted(plane.render, material, "Porosity Field")
    seeds = lichen_seed_probe(plane, state["lichen_density"])
    image = plane.render(material)
    diffuse = plane.render(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0))[..., :3]
    n_dot_l, n_dot_v = cosines(plane)
    kd_w, ks_w, _ = stone_weights(
        got, STONE["ks"], n_dot_l, n_dot_v, ("biological",), 1.0, fields={biological.LICHEN_SEEDS: seeds}, **state
    )
    covered = image[..., 3] > 0.999
    assert_matches(image, kd_w * diffuse + ks_w[..., None] * glossy_lobe(plane, material), covered)
    full = model.weathering_state("biological", state)
    spread = base.uptake_spread(SCALAR, got["z_p"], 1.0)[covered]
    light = biological.lichen_light(SCALAR, full)
    suitability = biological.lichen_suitability(SCALAR, full, light)  # 0.72 here
    established = base.local_share(SCALAR, suitability, spread)
    assert established.min() < suitability - 0.2 < suitability + 0.2 < established.max()
    # the thalli's margins follow the stone (their reach, §9.3): pixels in or out by it alone
    near = tuple(seed[covered] for seed in seeds)
    reaching = biological.in_either(SCALAR, *biological.thalli_covers(SCALAR, full, near, established, spread))
    round_thalli = biological.lichen_cover(SCALAR, full, near, established)
    assert 0.0 < np.mean((reaching > 0.5) != (round_thalli > 0.5)) < 0.2


@pytest.mark.parametrize("weathered", [False, True], ids=["porous", "weathered"])
def test_variation_zero_is_today_bit_for_bit(fresh_scene, weathered):
    plane = MaskedPlane(fresh_scene, size=16)

    def make(name, **extra):
        if weathered:
            return pw.make_weathered_material(
                name, modes=("soiling", "wet"), **STONE, time=0.6, rain_map=0.4, edge_map=0.8, runoff_map=0.3, **extra
            )
        return pw.make_porous_material(name, **STONE, key_light=plane.sun, **extra)

    today = make("Today")
    zero = make("Zero", stone="LIMESTONE", variation=0.0)
    assert STONE_NODE not in zero.node_tree.nodes
    assert zero.node_tree.nodes[GROUP_NODE].node_tree is today.node_tree.nodes[GROUP_NODE].node_tree
    assert np.array_equal(plane.render(today), plane.render(zero))
    varied = make("Varied", stone="LIMESTONE")
    assert not np.array_equal(plane.render(today), plane.render(varied))
    assert (nodes.RIVULET_SPACING in varied.node_tree.nodes[GROUP_NODE].inputs) == weathered  # docs/model.md §8.8


def to_millimetres(scene, plane):
    """The same scene modelled in millimetres: the unit scale 0.001, the plane and the camera's
    view 1000 times larger."""
    scene.unit_settings.scale_length = 0.001
    plane.plane.data.transform(np.diag([1000.0, 1000.0, 1000.0, 1.0]))
    plane.plane.data.update()
    camera = scene.camera
    camera.data.ortho_scale *= 1000.0
    camera.location.z *= 1000.0
    camera.data.clip_end = camera.location.z * 2.0


def test_millimetres_and_metres_give_the_same_stone(fresh_scene):
    plane = MaskedPlane(fresh_scene, size=16)
    fields = ("Porosity Field", "Colour Field")
    in_metres = probe(plane, pw.make_porous_material("M", **STONE, stone="SANDSTONE"), fields)
    to_millimetres(fresh_scene, plane)
    in_millimetres = probe(plane, pw.make_porous_material("MM", **STONE, stone="SANDSTONE"), fields)
    assert np.abs(in_metres[..., :2]).max() > 0.1
    close = np.abs(in_metres - in_millimetres) < 1e-3
    assert close.mean() > 0.99, f"{(~close).sum()} values differ"  # a point on a grain's edge may flip


def tilted_plane(scene, size, tilt=45.0):
    """A MaskedPlane turned about X by ``tilt`` degrees: its rows of pixels are horizontal lines,
    its fall line runs up the image."""
    plane = MaskedPlane(scene, size=size)
    plane.plane.rotation_euler.x = math.radians(tilt)
    return plane


def rivulet_material(name, plane, spacing=None):
    material = pw.make_weathered_material(
        name, modes=("soiling",), **STONE, stone="LIMESTONE", key_light=plane.sun, environment=None, **RIVULET_STATE
    )
    if spacing is not None:
        material.node_tree.nodes[GROUP_NODE].inputs[nodes.RIVULET_SPACING].default_value = spacing
    return material


def test_rivulets_render_as_the_model_per_pixel(fresh_scene):
    """An inclined plane under run-off renders as the model with the rivulets of its fields read
    back (place, normal, z_p); without them the model is far off (docs/model.md §8.8)."""
    plane, spacing = tilted_plane(fresh_scene, size=48), 0.4  # 5 rivulets across the 2 m plane
    material = rivulet_material("Rivulets", plane, spacing)
    got = read_back(plane, material)
    got["z_p"] = stone_shifted(plane.render, material, "Porosity Field")
    normal = plane.render(probes.normal_probe())[..., :3] * 2.0 - 1.0
    place = probes.emission_probe("Place", lambda graph, geometry: graph.wrap(geometry.outputs["Position"]) + 2.0)
    across, horizontal = base.fall_line(SCALAR, plane.render(place)[..., :3] - 2.0, normal)
    image = plane.render(material)
    diffuse = plane.render(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0))[..., :3]
    glossy = glossy_lobe(plane, material)
    towards = np.array(plane.sun.matrix_world.to_3x3().col[2])
    n_dot_l, n_dot_v = normal @ towards, normal @ np.array(probes.VIEW_DIRECTION)

    def expected(**rivulets):
        kd_w, ks_w, _ = stone_weights(
            got, STONE["ks"], n_dot_l, n_dot_v, ("soiling",), 1.0, **RIVULET_STATE, **rivulets
        )
        return kd_w * diffuse + ks_w[..., None] * glossy

    covered = image[..., 3] > 0.999
    assert_matches(image, expected(rivulets=(across, horizontal, spacing)), covered)
    assert np.abs(image[..., :3] - expected())[covered].max() > 0.05  # the rivulets show


def test_rivulets_in_millimetres_and_metres(fresh_scene):
    """The inclined plane under run-off, at the stone's own rivulet spacing, renders the same picture
    in millimetres (unit scale 0.001) as in metres."""
    plane = tilted_plane(fresh_scene, size=24)
    in_metres = plane.render(rivulet_material("M", plane))
    to_millimetres(fresh_scene, plane)
    in_millimetres = plane.render(rivulet_material("MM", plane))
    covered = in_metres[..., 3] > 0.999
    assert covered.mean() > 0.5 and in_metres[..., :3][covered].std() > 0.02
    close = np.abs(in_metres - in_millimetres)[covered].max(axis=-1) < 1e-3
    assert close.mean() > 0.99, f"{(~close).sum()} pixels differ"


def test_a_unit_set_after_make_rescales_the_stone(fresh_scene, tmp_path):
    """A stone material made in metres follows the scene's unit once it is set to millimetres, also
    in the file saved and reopened with auto-run off: its stone and rivulets render as a material
    made in millimetres (docs/model.md §8.2: the unit's drivers need no Python)."""
    plane = tilted_plane(fresh_scene, size=24)
    made_in_metres = rivulet_material("M", plane)
    in_metres = plane.render(made_in_metres)
    names = plane.plane.name, made_in_metres.name
    made_in_metres.use_fake_user = True  # saved while the plane shows the other
    to_millimetres(fresh_scene, plane)
    in_millimetres = plane.render(rivulet_material("MM", plane))
    path = tmp_path / "unit.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.context.preferences.filepaths.use_scripts_auto_execute = False
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False, use_scripts=False)
    material = bpy.data.materials[names[1]]
    studio.assign(bpy.data.objects[names[0]], material)
    followed = render.render_array(bpy.context.scene)
    covered = in_metres[..., 3] > 0.999
    close = np.abs(followed - in_millimetres)[covered].max(axis=-1) < 1e-3
    assert close.mean() > 0.99, f"{(~close).sum()} pixels differ"
    drivers = material.node_tree.animation_data.drivers
    unit_drivers = [fcurve for fcurve in drivers if fcurve.driver.variables[0].type == "CONTEXT_PROP"]
    assert len(unit_drivers) == 2  # the stone's and the weathered group's
    for fcurve in unit_drivers:  # the unit as made, without its drivers
        fcurve.mute = True
    for node in material.node_tree.nodes:
        if nodes.METRES_PER_UNIT in node.inputs:
            node.inputs[nodes.METRES_PER_UNIT].default_value = 1.0
    stale = render.render_array(bpy.context.scene)
    assert np.abs(stale - in_millimetres)[covered].max() > 0.05


def test_stone_names_are_checked():
    with pytest.raises(ValueError, match="LIMESTONE"):
        pw.make_porous_material("Bad", stone="BASALT")
    with pytest.raises(ValueError, match="variation"):
        pw.make_porous_material("Bad", stone="LIMESTONE", variation="much")
    assert "Bad" not in bpy.data.materials


LAYER_WORDS = {stones.CELLS: "cells", stones.BEDS: "beds", stones.WAVE: "bands", stones.NOISE: "patches"}


def layer_text(texture):
    """A layer as docs/presets.md writes it: 'cells 1 mm', 'bands 12 cm (z)'."""
    size = f"{texture.size * 1000:g} mm" if texture.size < 0.01 else f"{texture.size * 100:g} cm"
    direction = f" ({texture.direction.lower()})" if texture.kind == stones.WAVE else ""
    return f"{LAYER_WORDS[texture.kind]} {size}{direction}"


@pytest.mark.parametrize("key", STRUCTURED)
def test_docs_give_each_stones_structure(key):
    preset = PRESETS[key]
    cells = presets_row("## The stone's structure", preset.label)
    s = preset.structure
    assert cells[1] == ", ".join(layer_text(texture) for texture in s.textures)
    colour = ", ".join(f"{c:g}" for c in s.colour)
    assert cells[2:6] == [f"{s.porosity:g}", f"{s.pore_depth:g}", f"{s.roughness:g}", colour]


def test_preset_materials_have_their_stone(fresh_scene):
    assert STONE_NODE in pw.make_preset_material("BRICK").node_tree.nodes
    assert STONE_NODE not in pw.make_preset_material("BRICK", name="Flat", variation=0.0).node_tree.nodes


@pytest.mark.parametrize(("size", "unit", "warned"), [(300.0, 1.0, True), (300.0, 0.001, False), (2.0, 1.0, False)])
def test_make_and_the_bake_warn_of_an_implausible_unit(fresh_scene, size, unit, warned):
    from porous_weathering.maps import linking, scan_checks

    fresh_scene.unit_settings.scale_length = unit
    obj = studio.add_plane(fresh_scene, size=size)
    bpy.context.view_layer.update()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        new = linking.weathered_material_for(obj, (), preset="LIMESTONE")
    assert STONE_NODE in new.node_tree.nodes  # Make gives the preset's stone
    made = [str(w.message) for w in caught if "Unit Scale" in str(w.message)]
    baked = [message for message in scan_checks.problems(obj, rain=False) if "Unit Scale" in message]
    assert len(made) == len(baked) == int(warned)
    if warned:
        assert "0.001 if it is modelled in millimetres" in made[0] and made[0] == baked[0]
        # as docs/troubleshooting.md quotes it
        assert "is 300 m across at the scene's unit scale 1 m per unit, implausible for stone" in made[0]
        assert "its materials follow the unit" in made[0]
