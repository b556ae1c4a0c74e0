"""Rising damp (docs/model.md §9.2; docs/maps.md, "Rising damp"): the steady height of sharp-front
theory, √ thickness; a wall on the ground baked to a colour attribute and to an image as the
numpy model says at its points; millimetres and metres alike; a sheltered plinth damp all the same;
the wet mode and the efflorescence reading D as the model does, and D = 0 exactly as without it;
bad flags refused before any work."""

import dataclasses
import os

import bpy

import numpy as np
import pytest

from helpers import (
    STONE,
    MaskedPlane,
    assert_matches,
    expected_image,
    gradient_image,
    lobes,
    mode_variants,
    model_weights,
    run_cli,
    weathered,
)
from meshes import add_to_scene, box, merge, quad
from porous_weathering.core import model, rising_damp
from porous_weathering.core.backends import NumpyOps
from porous_weathering.core.modes import base as mode_base
from porous_weathering.core.modes import efflorescence, wet
from porous_weathering.maps import bake, damp, edges, rain
from porous_weathering.maps import registry as maps
from porous_weathering.samples import demo
from porous_weathering.shading import presets

SETTINGS = damp.DampSettings()
#: A wall 2 m long, 0.5 m thick, 1.6 m high, standing on the ground at z = 0.
WALL = ((0.0, 0.0, 0.0), (2.0, 0.5, 1.6))


def corner_values(obj, attribute):
    values = np.empty(len(obj.data.loops) * 4, np.float32)
    obj.data.color_attributes[attribute].data.foreach_get("color", values)
    return values.reshape(-1, 4)[:, 0]


def corners_and_normals(obj):
    """World positions and face normals of ``obj``'s corners."""
    mesh = obj.data
    vertex_of = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", vertex_of)
    matrix = np.array(obj.matrix_world)
    points = np.array([v.co for v in mesh.vertices]) @ matrix[:3, :3].T + matrix[:3, 3]
    normals = np.empty(len(mesh.loops) * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", normals)
    return points[vertex_of], normals.reshape(-1, 3)


def expected_damp(points_m, normals, extent_m, ground_m=0.0):
    """D of the model at points (metres) on a box of ``extent_m`` (its size along x, y, z): the
    thickness at a face is the box's extent along the face's normal."""
    thickness = np.asarray(extent_m)[np.argmax(np.abs(normals), axis=1)]
    return rising_damp.damp(points_m[:, 2] - ground_m, SETTINGS.front(thickness))


# --- the maths -------------------------------------------------------------------------------------


def test_the_steady_height_balances_what_rises_and_what_evaporates():
    s, e, theta = rising_damp.sorptivity_si(0.8), rising_damp.evaporation_si(1.0), 0.2
    for b in (0.2, 0.5, 1.0):
        h = rising_damp.steady_height(s, b, e, theta)
        # per metre of wall: b S² / (2 θ_w h) drawn up through the base, e h lost from the faces
        assert b * s**2 / (2 * theta * h) == pytest.approx(e * h, rel=1e-12)
    # Hall & Hoff's British example: about 1.1 m for a 0.5 m wall, ~110 L held per metre of wall
    h = float(SETTINGS.front(0.5))
    assert 1.0 < h < 1.2
    assert theta * 0.5 * h * 1000 == pytest.approx(110, abs=10)


def test_thicker_walls_rise_higher_by_the_square_root():
    assert SETTINGS.front(2.0) / SETTINGS.front(0.5) == pytest.approx(2.0, rel=1e-12)
    assert SETTINGS.front(0.9) / SETTINGS.front(0.1) == pytest.approx(3.0, rel=1e-12)
    # more evaporation, lower; a thirstier stone, higher
    assert damp.DampSettings(evaporation=4.0).front(0.5) == pytest.approx(SETTINGS.front(0.5) / 2)
    assert damp.DampSettings(sorptivity=1.6).front(0.5) == pytest.approx(SETTINGS.front(0.5) * 2)


def test_the_profile_is_one_below_the_front_and_falls_to_zero_over_the_fringe():
    front = 1.2
    heights = np.linspace(0.0, 2.0, 2001)
    values = rising_damp.damp(heights, front)
    assert np.all(values[heights <= front] == 1.0) and np.all(values[heights >= front * 1.1] == 0.0)
    assert np.all(np.diff(values) <= 0.0)
    assert rising_damp.damp(front * 1.05, front) == pytest.approx(0.5)
    tide = rising_damp.tide_mark(NumpyOps(colour=False), values)
    assert tide.max() == pytest.approx(1.0, abs=1e-3) and heights[np.argmax(tide)] == pytest.approx(
        front * 1.05, abs=2e-3
    )
    assert np.all(tide[(heights <= front) | (heights >= front * 1.1)] == 0.0)


def test_no_damp_is_the_water_from_above_and_the_location_map_bit_for_bit():
    xp = NumpyOps(colour=False)
    rng = np.random.default_rng(1)
    rain_map, runoff_map, location = rng.random((3, 1000))
    state = dict(rain_map=rain_map, runoff_map=runoff_map, runoff=0.7, damp_map=np.zeros(1000))
    assert np.array_equal(wet.water_with_damp(xp, state), wet.water_of(xp, state))
    assert np.array_equal(efflorescence.salt_location(xp, location, np.zeros(1000)), location)
    # with damp: 1 - (1 - W)(1 - D), and the tide mark where it is above the location map
    state["damp_map"] = d = rng.random(1000)
    water = wet.water_of(xp, state)
    assert np.allclose(wet.water_with_damp(xp, state), 1 - (1 - water) * (1 - d))
    assert np.array_equal(efflorescence.salt_location(xp, location, d), np.maximum(location, 4 * d * (1 - d)))


def test_a_damp_plinth_of_limestone_or_brick_is_darker_than_085_times_dry():
    """At t = 1, ambient light, seen face on: where D = 1 the diffuse weight is below 0.85 x the
    dry one in every channel; where D = 0 it is the dry one exactly."""
    for key in ("LIMESTONE", "BRICK"):
        params = presets.PRESETS[key].material_params()
        stone = [params[name] for name in ("base_color", "ks", "roughness", "porosity", "pore_depth_ratio")]
        state = dict(time=1.0, rain_map=0.0)
        dry = model.weathered_coefficients(*stone, None, 1.0, ("wet",), **state)[0]
        damp_kd = model.weathered_coefficients(*stone, None, 1.0, ("wet",), damp_map=1.0, **state)[0]
        above = model.weathered_coefficients(*stone, None, 1.0, ("wet",), damp_map=0.0, **state)[0]
        assert np.all(np.asarray(damp_kd)[:3] < 0.85 * np.asarray(dry)[:3]), key
        assert np.array_equal(above, dry)


# --- the bake ----------------------------------------------------------------------------------------


def test_damp_is_a_map_of_the_registry_that_feeds_the_wet_and_efflorescence_modes():
    kind = maps.get("damp")
    assert kind.attribute == "pw_damp" and kind.image_suffix == ".damp.exr" and kind.feeds == ["damp_map"]
    assert [entry.option.flag for entry in bake.option_entries() if entry.owner == "damp"] == [
        "--sorptivity",
        "--evaporation",
        "--wet-water-content",
        "--sheet-thickness",
    ]
    assert "damp_map" in model.inputs_of(("wet",)) and "damp_map" in model.inputs_of(("efflorescence",))
    assert "damp_map" not in model.inputs_of(("soiling",))


def test_a_wall_on_the_ground_is_damp_to_its_front_at_its_corners(fresh_scene):
    wall = add_to_scene("Wall", *box(*WALL, n=16))
    options = bake.BakeOptions(maps=("damp",), target="attribute")
    assert [o.status for o in bake.bake_maps([wall], options)] == ["written"]
    points, normals = corners_and_normals(wall)
    values = corner_values(wall, damp.DAMP_ATTRIBUTE)
    expected = expected_damp(points, normals, (2.0, 0.5, 1.6))
    assert np.abs(values - expected).max() < 0.01
    faces = np.abs(normals[:, 1]) > 0.9  # the wall's faces: wet to 1.07 m, dry from 1.18 m
    assert np.all(values[faces & (points[:, 2] < 1.0)] > 0.99) and np.all(values[faces & (points[:, 2] > 1.2)] < 0.01)
    assert 0.05 < values[faces & np.isclose(points[:, 2], 1.1)].mean() < 0.95  # in the fringe


def test_a_bust_on_the_ground_is_damp_nearly_all_over(fresh_scene):
    """A small body stands below the steady front of its own thickness (docs/scans.md, "Rising damp on
    a scan"): the sample bust, 0.5 m high in millimetres, baked at the defaults, has D = 1 on 83% of
    its corners, the rest (its hat, high and thin) dry."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(demo.SAMPLES_DIR, "bust.blend"), load_ui=False)
    bust = bpy.data.objects["Bust"]
    assert bust.dimensions.z * bpy.context.scene.unit_settings.scale_length == pytest.approx(0.5, rel=1e-3)
    assert [o.status for o in bake.bake_maps([bust], bake.BakeOptions(maps=("damp",), target="attribute"))] == [
        "written"
    ]
    values = corner_values(bust, damp.DAMP_ATTRIBUTE)
    assert (values > 0.999).mean() == pytest.approx(0.83, abs=0.01)
    assert ((values > 0.001) & (values < 0.999)).mean() < 0.01  # nearly all wholly damp or dry


def test_the_same_wall_in_millimetres_is_the_same_map(fresh_scene):
    metres = add_to_scene("Metres", *box(*WALL, n=16))
    options = bake.BakeOptions(maps=("damp",), target="attribute")
    bake.bake_maps([metres], options)
    reference = corner_values(metres, damp.DAMP_ATTRIBUTE)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.unit_settings.scale_length = 0.001
    low, high = WALL
    millimetres = add_to_scene("Millimetres", *box(np.multiply(low, 1000), np.multiply(high, 1000), n=16))
    bake.bake_maps([millimetres], options)
    assert np.abs(corner_values(millimetres, damp.DAMP_ATTRIBUTE) - reference).max() < 1e-4


def test_a_thin_sheet_takes_the_sheet_thickness(fresh_scene):
    sheet = add_to_scene("Sheet", *quad((0, 0, 0), (2, 0, 0), (0, 0, 2), 20, (0, -1, 0)))
    for thickness in (0.5, 1.5):
        bake.bake_maps(
            [sheet],
            bake.BakeOptions(
                maps=("damp",), target="attribute", damp_settings=damp.DampSettings(sheet_thickness=thickness)
            ),
        )
        points, _ = corners_and_normals(sheet)
        front = float(SETTINGS.front(thickness))
        expected = rising_damp.damp(points[:, 2], front)
        assert np.abs(corner_values(sheet, damp.DAMP_ATTRIBUTE) - expected).max() < 0.01


def test_a_sheltered_plinth_is_damp_all_the_same(fresh_scene):
    """A wall under a deep roof of the same object: no rain reaches its base, the damp does."""
    low, high = WALL
    wall, roof = box(low, high, n=16), box((-0.5, -1.5, 1.6), (2.5, 2.0, 1.8), n=4)
    sheltered = add_to_scene("Sheltered", *merge(wall, roof))
    options = bake.BakeOptions(maps=("rain", "damp"), target="attribute", rain_settings=rain.RainSettings(samples=16))
    bake.bake_maps([sheltered], options)
    points, normals = corners_and_normals(sheltered)
    plinth = (np.abs(normals[:, 1]) > 0.9) & (points[:, 2] < 0.5) & (points[:, 0] > 0.01) & (points[:, 0] < 1.99)
    assert plinth.sum() > 50
    assert corner_values(sheltered, rain.RAIN_ATTRIBUTE)[plinth].max() < 0.1
    assert np.all(corner_values(sheltered, damp.DAMP_ATTRIBUTE)[plinth] > 0.99)


@pytest.mark.parametrize("target", ["attribute", "image"])
def test_a_wall_on_its_plinth_draws_its_water_from_the_ground(fresh_scene, tmp_path, target):
    """A wall modelled as its own object on a plinth of 0.8 m, both on a ground plane: the wall's
    height is taken above the ground the plinth stands on, not above its own foot, as if the two
    were one body (before: the wall's foot at 0.8 m was its ground, damp up to 1.9 m); a block
    that stands on nothing keeps its own foot."""
    add_to_scene("Plinth", *box((0.0, 0.0, 0.0), (2.0, 0.5, 0.8), n=8))
    wall = add_to_scene("Wall", *box((0.0, 0.0, 0.8), (2.0, 0.5, 2.4), n=16))
    ground = add_to_scene("Ground", *quad((-2, -2, 0), (4, -2, 0), (-2, 3, 0), 1, (0, 0, 1)))
    lone = add_to_scene("Lone", *box((6.0, 0.0, 3.0), (8.0, 0.5, 4.6), n=16))  # nothing below it
    options = bake.BakeOptions(maps=("damp",), target=target, resolution=64, out_dir=str(tmp_path / "maps"))
    assert [o.status for o in bake.bake_maps([wall, lone], options)] == ["written", "written"]
    for obj, ground_m in ((wall, 0.0), (lone, 3.0)):
        if target == "attribute":
            points, normals = corners_and_normals(obj)
            values = corner_values(obj, damp.DAMP_ATTRIBUTE)
        else:
            from porous_weathering.common import imageio

            pixels = imageio.read_image(tmp_path / "maps" / f"{obj.name}.damp.exr")[0][..., 0]
            positions, texel_normals, islands = edges.bake_texel_geometry(obj, "PW Lightmap", 64)
            inner = islands & (np.max(np.abs(texel_normals), axis=-1) > 0.999)
            points, normals, values = positions[inner].astype(np.float64), texel_normals[inner], pixels[inner]
        expected = expected_damp(points, normals, (2.0, 0.5, 1.6), ground_m)
        assert np.mean(np.abs(values - expected) < 0.02) > 0.97, obj.name
        faces = np.abs(normals[:, 1]) > 0.9
        assert np.all(values[faces & (points[:, 2] < ground_m + 1.0)] > 0.99), obj.name  # damp below its front
        assert np.all(values[faces & (points[:, 2] > ground_m + 1.2)] < 0.01), obj.name  # dry above its front
    ground.location.z = -0.5  # what it stands on moved: the map is baked again
    assert [o.status for o in bake.bake_maps([wall], options)] == ["written"]


def test_the_facades_parts_baked_as_they_are_are_damp_only_near_the_ground(fresh_scene):
    """The bundled façade's parts, each its own object on its ground plane, baked as they come (no
    union): the cornice, the capitals and the sills, 2 m and more up, are dry; the plinth and the
    wall's foot are damp (before: every part was damp from its own foot up)."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(demo.SAMPLES_DIR, "limestone_facade.blend"), load_ui=False)
    parts = [o for o in bpy.data.objects if o.type == "MESH" and o.name != "Ground"]
    bake.bake_maps(parts, bake.BakeOptions(maps=("damp",), target="attribute"))
    means = {o.name: float(corner_values(o, damp.DAMP_ATTRIBUTE).mean()) for o in parts}
    for name in ("Cornice Cap", "Cornice Corona", "Capitals", "Window Sills"):
        assert means[name] == 0.0, name
    assert means["Plinth"] == 1.0 and 0.05 < means["Wall"] < 0.5


def test_the_image_map_is_the_model_at_its_texels(fresh_scene, tmp_path):
    from porous_weathering.common import imageio

    wall = add_to_scene("Wall", *box(*WALL, n=1))
    out = tmp_path / "maps"
    options = bake.BakeOptions(maps=("damp",), resolution=64, out_dir=str(out))
    assert [o.status for o in bake.bake_maps([wall], options)] == ["written"]
    pixels = imageio.read_image(out / "Wall.damp.exr")[0][..., 0]
    positions, normals, islands = edges.bake_texel_geometry(wall, "PW Lightmap", 64)
    # away from the faces' borders, where a texel's centre may lie off its face
    inner = islands & (np.max(np.abs(normals), axis=-1) > 0.999)
    points = positions[inner].astype(np.float64)
    on_box = np.all((points > np.subtract(WALL[0], 1e-3)) & (points < np.add(WALL[1], 1e-3)), axis=1)
    expected = expected_damp(points, normals[inner], (2.0, 0.5, 1.6))
    assert on_box.mean() > 0.95 and np.median(np.abs(pixels[inner] - expected)) < 1e-3
    assert np.mean(np.abs(pixels[inner] - expected) < 0.02) > 0.97
    assert np.ptp(expected) > 0.9  # wet and dry both on the map


def test_bad_damp_flags_exit_2_before_any_work(fresh_scene, tmp_path):
    add_to_scene("Wall", *box(*WALL, n=2))
    blend = tmp_path / "wall.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "maps"
    for flag, value, words in (
        ("--sorptivity", "0", "sorptivity"),
        ("--evaporation", "-1", "evaporation"),
        ("--wet-water-content", "1.5", "wet water content"),
        ("--sheet-thickness", "nan", "sheet thickness"),
    ):
        bad = run_cli("bake", blend, "--out", out, "--maps", "damp", flag, value)
        assert bad.returncode == 2 and words in bad.stderr, bad.stderr
        assert len(bad.stderr.strip().splitlines()) == 1
    assert not out.exists()


# --- the modes ---------------------------------------------------------------------------------------


DAMP_STATE = dict(time=0.6, front_width=0.3, water_specular=0.9, efflorescence_map=0.3, salt_color=(0.85, 0.8, 0.75))


def test_the_wet_mode_and_the_salt_read_the_damp_as_the_model_does(fresh_scene):
    plane = MaskedPlane(fresh_scene)
    ramp = np.linspace(0.0, 1.0, 16)
    rain_image = gradient_image("Rain", np.tile(ramp * 0.5, (16, 1)))
    damp_image = gradient_image("Damp", np.tile(ramp[:, None], (1, 16)))
    modes = (model.WET, model.EFFLORESCENCE)
    image = plane.render(
        weathered("Damp", modes, key_light=plane.sun, rain_map=rain_image, damp_map=damp_image, **DAMP_STATE)
    )
    masks = dict(rain_map=plane.probe(rain_image), damp_map=plane.probe(damp_image))
    covered = image[..., 3] > 0.999
    n_dot_l = np.dot(np.array(plane.sun.matrix_world.to_3x3().col[2]), (0.0, 0.0, 1.0))
    weights = model_weights(modes, n_dot_l, 1.0, **DAMP_STATE, **masks)
    assert np.ptp(masks["damp_map"][covered]) > 0.8
    dry = model_weights(modes, n_dot_l, 1.0, **DAMP_STATE, rain_map=masks["rain_map"])
    assert np.abs(weights[0] - dry[0])[covered].max() > 0.05  # the damp shows
    assert_matches(image, expected_image(weights, lobes(plane.render, STONE["roughness"])), covered)


def _water_from_above(xp, point):
    """The wet front as docs/model.md §7.2 wrote it before rising damp: it sweeps W."""
    s = point.state
    water = mode_base.pore_fill(xp, wet.water_of(xp, s), s["time"], s["wet_level"], s["front_width"])
    ap = mode_base.filled_absorption(xp, point.ka, point.sp, water, point.theta_i, point.theta_r)
    kd_wet, water_lobe = wet.wet_weights(xp, point.kd, xp.channel(s["water_specular"]), point.pore, ap)
    point.kd_w = mode_base.blend(xp, point.kd_w, kd_wet, xp.channel(water))
    point.water_w = xp.channel(water) * water_lobe
    point.notes["water"] = water


def _salt_from_the_location_map(xp, point):
    """Efflorescence as docs/model.md §4.3 wrote it before rising damp: the location map alone."""
    s = point.state
    salt = mode_base.pore_fill(xp, s["efflorescence_map"], s["time"], s["efflorescence_level"], s["front_width"])
    ap = mode_base.filled_absorption(xp, point.ka, point.sp, salt, point.theta_i, point.theta_r)
    salty = efflorescence.efflorescence_diffuse(xp, point.kd, s["salt_color"], point.pore, ap, xp.channel(point.ks_w))
    point.kd_w = mode_base.blend(xp, point.kd_w, salty, xp.channel(salt))


BEFORE_DAMP = {wet.fill_with_water: _water_from_above, efflorescence.fill_with_salt: _salt_from_the_location_map}


def test_no_damp_renders_as_before_bit_for_bit(fresh_scene):
    """No damp map (or one of zeros) renders exactly what the modes rendered before rising damp."""
    plane = MaskedPlane(fresh_scene)
    ramp = np.linspace(0.0, 1.0, 16)
    rain_image = gradient_image("Rain", np.tile(ramp * 0.5, (16, 1)))
    location = gradient_image("Location", np.tile(ramp[:, None], (1, 16)))
    zero = gradient_image("Zero", np.zeros((16, 16)))
    modes = (model.WET, model.EFFLORESCENCE)
    state = dict(DAMP_STATE, rain_map=rain_image, efflorescence_map=location)
    with mode_variants(
        modes,
        "before_damp",
        lambda mode: tuple(
            dataclasses.replace(layer, apply=BEFORE_DAMP.get(layer.apply, layer.apply)) for layer in mode.layers
        ),
    ) as before:
        as_before = plane.render(weathered("Before", before, key_light=plane.sun, **state))
    without = plane.render(weathered("Without", modes, key_light=plane.sun, **state))
    connected = plane.render(weathered("Connected", modes, key_light=plane.sun, damp_map=zero, **state))
    assert np.array_equal(without, as_before) and np.array_equal(connected, as_before)
    damp_image = gradient_image("Damp", np.tile(ramp[None, :], (16, 1)))
    damped = plane.render(weathered("Damped", modes, key_light=plane.sun, damp_map=damp_image, **state))
    assert np.abs(damped - as_before).max() > 0.01  # the comparison can tell them apart
