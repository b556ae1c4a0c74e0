"""Environments (docs/presets.md, "Environments") and time in years (docs/weathering.md, "Time in
years"): the records hold the values docs/presets.md's table gives, each site's deposit makes the
limestone's grey area lose the 30% of t = 1, make_weathered_material takes the default environment
and explicit inputs win, the soiling law holds to the paper's numbers, and the panel's Environment,
Years and Keyframe Years work."""

import inspect
import math
import pathlib
import re

import bpy

import numpy as np
import pytest

import porous_weathering as pw
from porous_weathering import presets, weathering
from porous_weathering.contracts import GROUP_NODE
from porous_weathering.core import aging, colorimetry, environments, model
from porous_weathering.core import modes as weathering_modes
from porous_weathering.samples import studio

PRESETS_DOC = pathlib.Path(__file__).resolve().parent.parent / "docs" / "presets.md"
COLUMNS = (
    "label",
    "key",
    "elemental_carbon",
    "deposit_color",
    "crust_factor",
    "streaks",
    "efflorescence_level",
    "biological_level",
    "lichen_density",
)


def documented_environments():
    """{key: {column: value}} of docs/presets.md's table of environments."""
    text = PRESETS_DOC.read_text(encoding="utf-8")
    table = text[text.index("| Environment | key |") :].split("\n\n")[0].splitlines()[2:]
    rows = {}
    for line in table:
        cells = dict(zip(COLUMNS, (cell.strip() for cell in line.strip("|").split("|"))))
        key = cells.pop("key").strip("`")
        rows[key] = {
            "label": cells.pop("label"),
            "deposit_color": tuple(float(x) for x in re.findall(r"[\d.]+", cells.pop("deposit_color"))),
            **{column: float(value) for column, value in cells.items()},
        }
    return rows


def test_the_docs_table_is_the_registry():
    documented = documented_environments()
    assert set(documented) == set(environments.ENVIRONMENTS) >= {"URBAN", "SUBURBAN", "RURAL", "COASTAL"}
    for key, row in documented.items():
        site = environments.ENVIRONMENTS[key]
        assert {
            column: site.values[column] if column in site.values else getattr(site, column) for column in row
        } == row, key


def test_the_default_environment_is_urban_and_documented():
    assert environments.DEFAULT_ENVIRONMENT == presets.DEFAULT_ENVIRONMENT == "URBAN"
    signature = inspect.signature(weathering.make_weathered_material)
    assert signature.parameters["environment"].default == "URBAN"
    assert "**The default environment is `URBAN`**" in PRESETS_DOC.read_text(encoding="utf-8")


def limestone():
    stone = presets.PRESETS["LIMESTONE"]
    return dict(
        kd=np.array(stone.linear_base_color()[:3]),
        ks=stone.ks,
        m=stone.roughness,
        alpha=stone.porosity,
        sp=stone.pore_depth_ratio,
    )


def luminance(rgb):
    return float(colorimetry.RGB_TO_XYZ[1] @ rgb)


@pytest.mark.parametrize("key", list(environments.ENVIRONMENTS))
def test_every_sites_grey_area_loses_thirty_percent_at_full_age(key):
    """t = 1 is a 30% reflectance loss of sheltered stone (aging.LOSS_AT_FULL_AGE): each site's
    deposit gives it to the limestone preset's grey area (no carbon), face on, ambient light."""
    site = environments.ENVIRONMENTS[key]
    clean = luminance(colorimetry.appearance(limestone(), "clean"))
    grey = luminance(colorimetry.appearance(limestone(), "soiled", deposit_color=site.values["deposit_color"]))
    assert grey / clean == pytest.approx(1.0 - aging.LOSS_AT_FULL_AGE, abs=0.01)
    half = luminance(
        colorimetry.appearance(limestone(), "soiled", deposit_color=site.values["deposit_color"], time=0.5)
    )
    assert half / clean == pytest.approx(1.0 - aging.LOSS_AT_FULL_AGE / 2, abs=0.01)  # linear in t


def test_the_environments_inputs_are_those_the_modes_use():
    urban = environments.weathering_inputs("URBAN", ("soiling",))
    assert urban == dict(
        pollution_color=(0.03, 0.03, 0.03), deposit_color=(0.257, 0.249, 0.231), crust=0.8, streaks=0.5
    )
    assert environments.weathering_inputs("COASTAL", ("efflorescence",)) == dict(efflorescence_level=1.0)
    assert environments.weathering_inputs("RURAL", ("wet",)) == {}
    assert environments.weathering_inputs(None, ("soiling",)) == {}
    assert environments.ENVIRONMENTS["RURAL"].weathering(crust=0.6)["crust"] == pytest.approx(0.15)
    assert set(environments.ENVIRONMENTS["URBAN"].weathering()) <= set(model.WEATHERING_INPUTS)
    with pytest.raises(ValueError, match="unknown environment 'CITY'"):
        environments.weathering_inputs("CITY", ("soiling",))


def socket_values(material):
    group = material.node_tree.nodes[GROUP_NODE]
    return {
        item.name: tuple(group.inputs[item.socket].default_value)[:3]
        if item.is_colour
        else group.inputs[item.socket].default_value
        for item in weathering_modes.inputs().values()
        if item.socket in group.inputs and not item.mask
    }


def test_make_weathered_material_takes_the_environment_and_explicit_inputs_win():
    modes = ("soiling", "efflorescence")
    urban = socket_values(pw.make_weathered_material("Urban", modes=modes))
    assert urban["deposit_color"] == pytest.approx((0.257, 0.249, 0.231), abs=1e-6)
    rural = socket_values(pw.make_weathered_material("Rural", modes=modes, environment="RURAL"))
    assert rural["crust"] == pytest.approx(0.8 * 0.25) and rural["streaks"] == pytest.approx(0.25)
    assert rural["efflorescence_level"] == pytest.approx(0.6)
    assert rural["deposit_color"] == pytest.approx((0.274, 0.246, 0.205), abs=1e-6)
    mine = socket_values(
        pw.make_weathered_material("Mine", modes=modes, environment="RURAL", crust=0.5, deposit_color=(0.1, 0.1, 0.1))
    )
    assert mine["crust"] == pytest.approx(0.5) and mine["deposit_color"] == pytest.approx((0.1, 0.1, 0.1), abs=1e-6)
    assert mine["streaks"] == pytest.approx(0.25)  # the rest stays the site's
    plain = socket_values(pw.make_weathered_material("Plain", modes=modes, environment=None))
    for name, value in plain.items():
        assert value == pytest.approx(model.WEATHERING_INPUTS[name][0], abs=1e-6), name
    before = len(bpy.data.materials)
    with pytest.raises(ValueError, match="unknown environment"):
        pw.make_weathered_material("Bad", environment="MOON")
    assert len(bpy.data.materials) == before


# --- time in years ------------------------------------------------------------------------------


def test_the_square_root_law_holds_to_pio_et_al():
    """Pio, Ramos & Duarte 1998: sheltered reflectance falls with the square root of the exposure,
    30% lost in 5.5-8.8 years in Oporto (at the calibration's concentration)."""
    ec = aging.REFERENCE_ELEMENTAL_CARBON
    loss = [aging.reflectance_loss(years * ec / (aging.REFERENCE_YEARS * ec)) for years in (5.5, 8.8)]
    assert loss[0] <= 0.30 <= loss[1]
    assert aging.age_for_years(aging.REFERENCE_YEARS, ec) == pytest.approx(1.0)
    assert aging.age_for_years(5.5, ec) == pytest.approx(math.sqrt(5.5 / math.sqrt(5.5 * 8.8)))  # 0.889
    assert aging.age_for_years(8.8, ec) == 1.0  # capped: the model's fully weathered state
    # the square root of the dose (Beloin & Haynie 1975): four times the dose, twice the loss
    assert aging.age_for_years(4.0, ec) == pytest.approx(2.0 * aging.age_for_years(1.0, ec))
    # the dose is what counts: half the soot, twice the years
    assert aging.age_for_years(6.0, ec / 2) == pytest.approx(aging.age_for_years(3.0, ec))
    assert aging.age_for_years(0.0, ec) == 0.0


def test_the_exponential_law_is_calibrated_at_the_same_point():
    ec = aging.REFERENCE_ELEMENTAL_CARBON
    assert aging.age_for_years(aging.REFERENCE_YEARS, ec, law="exponential") == pytest.approx(1.0)
    half = aging.age_for_years(aging.REFERENCE_YEARS / 2, ec, law="exponential")
    assert half == pytest.approx((1.0 - 0.7**0.5) / 0.3)  # 0.5516: linear in the dose early, not a square root
    assert half < aging.age_for_years(aging.REFERENCE_YEARS / 2, ec)


def test_each_environment_gives_its_years_to_full_age():
    years = {key: aging.years_for_full_age(site.elemental_carbon) for key, site in environments.ENVIRONMENTS.items()}
    assert years["URBAN"] == pytest.approx(17.39, abs=0.01)
    assert years["URBAN"] < years["SUBURBAN"] < years["RURAL"] == years["COASTAL"]
    for site in environments.ENVIRONMENTS.values():
        assert aging.age_for_years(
            aging.years_for_full_age(site.elemental_carbon), site.elemental_carbon
        ) == pytest.approx(1.0)


@pytest.mark.parametrize(
    "args, message",
    [
        ((-1.0, 2.0), "years"),
        ((float("nan"), 2.0), "years"),
        ((5.0, 0.0), "elemental_carbon"),
        ((5.0, 2.0, "linear"), "law"),
    ],
)
def test_bad_years_are_refused(args, message):
    with pytest.raises(ValueError, match=message):
        weathering.age_for_years(*args)


def test_animate_years_follows_the_law(fresh_scene):
    material = pw.make_weathered_material("Aging", environment=None)
    studio.assign(studio.add_plane(fresh_scene), material)
    weathering.animate_years(material, 1, 41, 20.0, 2.0)
    time = material.node_tree.nodes[GROUP_NODE].inputs["Time"]
    for frame in (1, 11, 21, 41):
        fresh_scene.frame_set(frame)
        assert time.default_value == pytest.approx(aging.age_for_years(20.0 * (frame - 1) / 40, 2.0), abs=1e-6)
    with pytest.raises(ValueError, match="frame range"):
        weathering.animate_years(material, 10, 10, 20.0, 2.0)


# --- the panel ----------------------------------------------------------------------------------


def selected_plane(scene):
    plane = studio.add_plane(scene)
    bpy.context.view_layer.objects.active = plane
    plane.select_set(True)
    return plane


def test_panel_environment_sets_the_sliders_and_make_uses_it(registered, fresh_scene):
    plane = selected_plane(fresh_scene)
    settings = fresh_scene.porous_weathering
    assert settings.environment == "URBAN"
    settings.source = "SANDSTONE"
    settings.environment = "RURAL"
    assert settings.crust == pytest.approx(presets.PRESETS["SANDSTONE"].weathering["crust"] * 0.25)
    assert settings.streaks == pytest.approx(0.25)
    settings.environment = "URBAN"
    assert settings.crust == pytest.approx(0.75) and settings.streaks == pytest.approx(0.5)
    settings.environment = "COASTAL"
    settings.soiling = settings.efflorescence = True
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    made = socket_values(plane.active_material)
    assert made["deposit_color"] == pytest.approx(
        environments.ENVIRONMENTS["COASTAL"].values["deposit_color"], abs=1e-6
    )
    assert made["crust"] == pytest.approx(settings.crust) and made["efflorescence_level"] == pytest.approx(1.0)


def test_panel_years_set_the_time_and_keyframe_years(registered, fresh_scene):
    plane = selected_plane(fresh_scene)
    settings = fresh_scene.porous_weathering
    settings.soiling = True
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    time = plane.active_material.node_tree.nodes[GROUP_NODE].inputs["Time"]
    settings.years = 10.0
    assert time.default_value == pytest.approx(aging.age_for_years(10.0, 2.0), abs=1e-6)  # URBAN: 0.76
    settings.environment = "RURAL"
    settings.years = 40.0
    assert time.default_value == pytest.approx(aging.age_for_years(40.0, 0.3), abs=1e-6)
    fresh_scene.frame_start, fresh_scene.frame_end = 1, 21
    assert bpy.ops.porous_weathering.keyframe_aging(years=40.0) == {"FINISHED"}
    for frame, years in ((1, 0.0), (11, 20.0), (21, 40.0)):
        fresh_scene.frame_set(frame)
        assert time.default_value == pytest.approx(aging.age_for_years(years, 0.3), abs=1e-6)


def test_panel_years_age_a_material_whose_clock_is_years(registered, fresh_scene):
    """A material of the biological mode alone has no Time: the panel's Years set its clock in
    years, Keyframe Aging keyframes it over years, and without years refuses in one line."""
    plane = selected_plane(fresh_scene)
    settings = fresh_scene.porous_weathering
    for mode in weathering_modes.names():
        setattr(settings, mode, mode == "biological")
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    group = plane.active_material.node_tree.nodes[GROUP_NODE]
    assert "Time" not in group.inputs
    clock = group.inputs["Biological Years"]
    settings.years = 12.0
    assert clock.default_value == pytest.approx(12.0)
    assert bpy.ops.porous_weathering.keyframe_aging.poll()
    fresh_scene.frame_start, fresh_scene.frame_end = 1, 21
    assert bpy.ops.porous_weathering.keyframe_aging(years=40.0) == {"FINISHED"}
    fresh_scene.frame_set(11)
    assert clock.default_value == pytest.approx(20.0, abs=1e-4)
    with pytest.raises(RuntimeError, match="ages in years"):
        bpy.ops.porous_weathering.keyframe_aging(years=0.0)


def test_panel_make_from_measured_colours(registered, fresh_scene):
    plane = selected_plane(fresh_scene)
    settings = fresh_scene.porous_weathering
    settings.soiling = True
    settings.measured_clean, settings.measured_soiled, settings.measured_crust = (80, 1.5, 9), (62, 1, 6), (35, 0.5, 2)
    assert bpy.ops.porous_weathering.make_from_colorimetry() == {"FINISHED"}
    expected = presets.from_colorimetry((80, 1.5, 9), (62, 1, 6), (35, 0.5, 2))
    made = socket_values(plane.active_material)
    for name in ("deposit_color", "pollution_color", "crust"):
        assert made[name] == pytest.approx(expected[name], abs=1e-6), name
    group = plane.active_material.node_tree.nodes[GROUP_NODE]
    assert tuple(group.inputs["Base Color"].default_value)[:3] == pytest.approx(expected["base_color"][:3], abs=1e-6)
    settings.measured_crust = (70, 0.5, 2)  # lighter than the soiled stone: refused, nothing made
    before = len(bpy.data.materials)
    with pytest.raises(RuntimeError, match="must darken"):
        bpy.ops.porous_weathering.make_from_colorimetry()
    assert len(bpy.data.materials) == before
