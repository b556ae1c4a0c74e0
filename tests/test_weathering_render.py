"""Rendered weathered materials against model.py, pixel by pixel (Cycles CPU, fixed seed).

A weathered pixel must equal k_d D + k_s G + k_water W, where D, G and W are renders of a
white Lambert, a white GGX of the stone's roughness and a white GGX of the water's
roughness, and the weights come from model.weathered_coefficients at that pixel's normal
and mask values (read from probe renders).  Each state renders with the API's defaults (the
extensions beyond the paper on: black crust, wet darkening) and with the paper-exact settings
(crust = 0, wet_darkening = 0), which must also render bit for bit as the paper's modes do.
A run-off map (docs/model.md §7) renders as the model says, and runoff = 0, streaks = 0 renders
bit for bit as no run-off map.
"""

import bpy

import numpy as np
import pytest

import porous_weathering as pw
from benchmarks import probes
from helpers import (
    STONE,
    TOLERANCE,
    LitSphere,
    MaskedPlane,
    assert_matches,
    expected_image,
    gradient_image,
    lichen_seed_probe,
    lobes,
    model_weights,
    paper_modes,
    weathered,
)
from porous_weathering.blender import compat
from porous_weathering.core import model, shader_math, voronoi
from porous_weathering.core.backends import NumpyOps
from porous_weathering.core.modes import biological
from porous_weathering.samples import studio
from porous_weathering.shading import nodes, weathering

#: Mask values that leave every fill partial, so each term of each mode shows ("soiling crust":
#: carbon-full pores under a partial crust, on the fringe of the white area).
STATES = {
    "soiling": dict(time=0.45, rain_map=0.35, edge_map=0.75, pollution_color=(0.05, 0.04, 0.03)),
    "soiling crust": dict(time=0.9, rain_map=0.35, edge_map=0.9, crust=0.7, pollution_color=(0.05, 0.04, 0.03)),
    "wet": dict(time=0.6, rain_map=0.55, water_specular=0.9),
    "efflorescence": dict(time=0.5, efflorescence_map=0.62, salt_color=(0.85, 0.8, 0.75)),
    "soiling+wet+efflorescence": dict(time=0.9, rain_map=0.3, edge_map=0.9, efflorescence_map=0.8),
}
#: The settings under which the extensions beyond the paper (docs/model.md §6) vanish.
PAPER_EXACT = dict(crust=0.0, wet_darkening=0.0)


def modes_of(state_name):
    return state_name.split(" ")[0].split("+")


def settings_of(modes, state_name, paper):
    """The state, with the paper-exact settings of ``modes`` if ``paper``."""
    extra = {name: value for name, value in PAPER_EXACT.items() if name in model.inputs_of(modes)} if paper else {}
    return {**STATES[state_name], **extra}


@pytest.mark.parametrize("paper", [False, True], ids=["defaults", "paper-exact"])
@pytest.mark.parametrize("state_name", list(STATES))
def test_key_light_matches_model(fresh_scene, state_name, paper):
    modes = modes_of(state_name)
    state = settings_of(modes, state_name, paper)
    sphere = LitSphere(fresh_scene)
    image = sphere.render(weathered("Weathered", modes, key_light=sphere.sun, **state))
    n_dot_l, n_dot_v = sphere.cosines()
    expected = expected_image(model_weights(modes, n_dot_l, n_dot_v, **state), lobes(sphere.render, STONE["roughness"]))
    assert_matches(image, expected, sphere.covered & (n_dot_l > 0.0))


@pytest.mark.parametrize("paper", [False, True], ids=["defaults", "paper-exact"])
def test_ambient_matches_model(fresh_scene, paper):
    state_name = "soiling+wet+efflorescence"
    modes = modes_of(state_name)
    state = settings_of(modes, state_name, paper)
    sphere = LitSphere(fresh_scene)
    image = sphere.render(weathered("Weathered", modes, **state))
    n_dot_l, n_dot_v = sphere.cosines()
    expected = expected_image(model_weights(modes, None, n_dot_v, **state), lobes(sphere.render, STONE["roughness"]))
    assert_matches(image, expected, sphere.covered & (n_dot_l > 0.0))


def test_extensions_show_at_their_defaults(fresh_scene):
    """The states above do exercise the crust and the wet darkening: at the API's defaults the
    model's pixels differ from the paper-exact ones by far more than the render tolerance."""
    sphere = LitSphere(fresh_scene, size=16)
    n_dot_l, n_dot_v = sphere.cosines()
    lit = sphere.covered & (n_dot_l > 0.0)
    for state_name in ("soiling crust", "wet", "soiling+wet+efflorescence"):
        modes = modes_of(state_name)
        defaults, paper = (model_weights(modes, n_dot_l, n_dot_v, **settings_of(modes, state_name, p)) for p in (0, 1))
        assert np.abs(defaults[0] - paper[0])[lit].min() > 0.01, state_name


@pytest.mark.parametrize("light", ["key", "ambient"])
def test_paper_exact_settings_render_the_paper_bit_for_bit(fresh_scene, light):
    """crust = 0 and wet_darkening = 0 render exactly what the modes without the layers beyond
    the paper render (the groups built from their records as the paper writes them)."""
    sphere = LitSphere(fresh_scene, size=32)
    key_light = sphere.sun if light == "key" else None
    state = {**STATES["soiling+wet+efflorescence"], **PAPER_EXACT}
    with paper_modes(model.MODES) as paper:
        as_paper = sphere.render(weathered("Paper", paper, key_light=key_light, **state))
    extended = sphere.render(weathered("Extended", model.MODES, key_light=key_light, **state))
    assert np.array_equal(extended, as_paper)
    with_defaults = sphere.render(
        weathered("Defaults", model.MODES, key_light=key_light, **STATES["soiling+wet+efflorescence"])
    )
    assert np.abs(with_defaults - as_paper).max() > 0.01  # the comparison can tell them apart


@pytest.mark.parametrize("light", ["key", "ambient"])
def test_time_zero_renders_the_clean_material_exactly(fresh_scene, light):
    sphere = LitSphere(fresh_scene)
    key_light = sphere.sun if light == "key" else None
    clean = sphere.render(pw.make_porous_material("Clean", key_light=key_light, **STONE))
    state = {**STATES["soiling+wet+efflorescence"], "time": 0.0}
    aged = sphere.render(weathered("New", model.MODES, key_light=key_light, **state))
    assert np.array_equal(aged, clean)


def test_image_and_attribute_masks_match_model(fresh_scene):
    """Rain and edge maps from images, the efflorescence map from a colour attribute."""
    plane = MaskedPlane(fresh_scene)
    ramp = np.linspace(0.0, 1.0, 16)
    rain = gradient_image("Rain", np.tile(ramp, (16, 1)))
    edge = gradient_image("Edge", np.tile(ramp[:, None], (1, 16)))
    salt = plane.plane.data.color_attributes.new("salt", "FLOAT_COLOR", "POINT")
    for corner, value in zip(salt.data, (0.0, 0.3, 1.0, 0.6)):
        corner.color = (value, value, value, 1.0)
    state = dict(time=0.55, front_width=0.3)
    image = plane.render(
        weathered(
            "Masked", model.MODES, key_light=plane.sun, rain_map=rain, edge_map=edge, efflorescence_map="salt", **state
        )
    )
    masks = dict(rain_map=plane.probe(rain), edge_map=plane.probe(edge), efflorescence_map=plane.probe("salt"))
    covered = image[..., 3] > 0.999
    n_dot_l = np.dot(np.array(plane.sun.matrix_world.to_3x3().col[2]), (0.0, 0.0, 1.0))
    expected = expected_image(
        model_weights(model.MODES, n_dot_l, 1.0, **state, **masks), lobes(plane.render, STONE["roughness"])
    )
    assert np.ptp(masks["rain_map"][covered]) > 0.8 and np.ptp(masks["efflorescence_map"][covered]) > 0.8
    assert_matches(image, expected, covered)


def runoff_plane(scene):
    """A MaskedPlane whose rain map rises across it and whose run-off map rises down it: every
    part of the soiling and wet modes that run-off moves shows (washed, sheltered, streaked, wet)."""
    plane = MaskedPlane(scene)
    ramp = np.linspace(0.0, 1.0, 16)
    rain = gradient_image("Rain", np.tile(ramp * 0.5, (16, 1)))
    runoff = gradient_image("Runoff", np.tile(ramp[:, None], (1, 16)))
    return plane, rain, runoff


#: Soiling and wet where run-off reaches: streaks on, the carbon front part way down the edge mask.
RUNOFF_STATE = dict(time=0.8, front_width=0.3, edge_map=0.6, streaks=1.0, pollution_color=(0.05, 0.04, 0.03))


def test_runoff_map_matches_model(fresh_scene):
    """A run-off map from an image, with the rain map, on soiling and wet: the model's pixels."""
    plane, rain, runoff = runoff_plane(fresh_scene)
    modes = (model.SOILING, model.WET)
    image = plane.render(
        weathered("Runoff", modes, key_light=plane.sun, rain_map=rain, runoff_map=runoff, **RUNOFF_STATE)
    )
    masks = dict(rain_map=plane.probe(rain), runoff_map=plane.probe(runoff))
    covered = image[..., 3] > 0.999
    n_dot_l = np.dot(np.array(plane.sun.matrix_world.to_3x3().col[2]), (0.0, 0.0, 1.0))
    weights = model_weights(modes, n_dot_l, 1.0, **RUNOFF_STATE, **masks)
    assert np.ptp(masks["runoff_map"][covered]) > 0.8 and np.ptp(masks["rain_map"][covered]) > 0.4
    no_runoff = model_weights(modes, n_dot_l, 1.0, **RUNOFF_STATE, rain_map=masks["rain_map"])
    assert np.abs(weights[0] - no_runoff[0])[covered].max() > 0.05  # the run-off shows
    assert_matches(image, expected_image(weights, lobes(plane.render, STONE["roughness"])), covered)


def test_no_runoff_renders_as_no_runoff_map_bit_for_bit(fresh_scene):
    """runoff = 0 and streaks = 0 with a run-off map connected render exactly what the same
    material renders without it."""
    plane, rain, runoff = runoff_plane(fresh_scene)
    modes = (model.SOILING, model.WET)
    state = dict(RUNOFF_STATE, runoff=0.0, streaks=0.0)
    connected = plane.render(
        weathered("Connected", modes, key_light=plane.sun, rain_map=rain, runoff_map=runoff, **state)
    )
    without = plane.render(weathered("Without", modes, key_light=plane.sun, rain_map=rain, **state))
    assert np.array_equal(connected, without)
    with_runoff = plane.render(
        weathered("With", modes, key_light=plane.sun, rain_map=rain, runoff_map=runoff, **RUNOFF_STATE)
    )
    assert np.abs(with_runoff - without).max() > 0.01  # the comparison can tell them apart


def test_missing_image_renders_as_the_default_constant(fresh_scene, tmp_path):
    sphere = LitSphere(fresh_scene, size=32)
    with pytest.warns(model.PorousInputWarning, match="not found"):
        missing = weathered("Missing", model.EFFLORESCENCE, efflorescence_map=str(tmp_path / "gone.png"), time=0.8)
    constant = weathered("Constant", model.EFFLORESCENCE, time=0.8)
    lost = bpy.data.images.new("Lost", 4, 4)
    lost.source, lost.filepath = "FILE", str(tmp_path / "lost.exr")
    with pytest.warns(model.PorousInputWarning, match="no pixels"):
        unloadable = weathered("Unloadable", model.EFFLORESCENCE, efflorescence_map=lost, time=0.8)
    reference = sphere.render(constant)
    for material in (missing, unloadable):
        assert not any(node.type == "TEX_IMAGE" for node in material.node_tree.nodes)
        assert np.array_equal(sphere.render(material), reference)


def test_out_of_range_values_render_clamped(fresh_scene):
    sphere = LitSphere(fresh_scene, size=32)
    bright = gradient_image("Bright", np.full((4, 4), 1.6))
    with pytest.warns(model.PorousInputWarning, match="outside"):
        over = weathered("Over", model.MODES, time=1.4, rain_map=bright, edge_map=-0.5, efflorescence_map=7.0)
    inside = weathered("Inside", model.MODES, time=1.0, rain_map=1.0, edge_map=0.0, efflorescence_map=1.0)
    image = sphere.render(over)
    assert np.isfinite(image).all()
    assert np.abs(image - sphere.render(inside)).max() <= TOLERANCE


def test_materials_hold_only_their_modes_nodes():
    groups = {
        modes: nodes.weathered_group(modes, nodes.SUN)
        for modes in [(), ("soiling",), ("wet",), ("efflorescence",), model.MODES]
    }
    assert groups[()] is nodes.porous_group(nodes.SUN)
    inputs = {
        modes: {item.name for item in group.interface.items_tree if item.in_out == "INPUT"}
        for modes, group in groups.items()
    }
    assert "Time" not in inputs[()]
    assert {"Edge Map", "Pollution Color"} <= inputs[("soiling",)] and "Salt Color" not in inputs[("soiling",)]
    assert "Rain Map" in inputs[("wet",)] and "Edge Map" not in inputs[("wet",)]
    assert "Rain Map" not in inputs[("efflorescence",)]
    assert "Crust" in inputs[("soiling",)] and "Wet Darkening" in inputs[("wet",)]  # users' files name them
    assert "Crust" not in inputs[("wet",)] and "Wet Darkening" not in inputs[("soiling",)]
    assert {"Runoff Map", "Runoff"} <= inputs[("soiling",)] & inputs[("wet",)] and "Streaks" in inputs[("soiling",)]
    assert "Streaks" not in inputs[("wet",)] and "Runoff" not in inputs[("efflorescence",)]
    for modes, group in groups.items():
        glossy = [node for node in group.nodes if node.type == "BSDF_GLOSSY"]
        assert len(glossy) == (2 if "wet" in modes else 1)
        # one set of porous nodes: theta_i and theta_r are each computed once, whatever the modes
        arccos = [node for node in group.nodes if node.type == "MATH" and node.operation == "ARCCOSINE"]
        assert len(arccos) == 2
        assert len(group.nodes) > len(groups[()].nodes) or modes == ()
    again = pw.make_weathered_material("Again", modes=("wet",), key_light=None)
    assert again.node_tree.nodes["Porous"].node_tree is nodes.weathered_group(("wet",), nodes.AMBIENT)


def test_time_is_one_keyframe_pair(fresh_scene):
    material = weathered("Aging", model.SOILING)
    studio.assign(studio.add_plane(fresh_scene), material)  # only materials in use are evaluated
    weathering.animate_weathering(material, 1, 101)
    weathering.animate_weathering(material, 1, 101, input_name="soiling_level", start=0.2, end=0.9)
    socket = material.node_tree.nodes["Porous"].inputs["Time"]
    fresh_scene.frame_set(51)
    assert socket.default_value == pytest.approx(0.5, abs=0.05)
    fresh_scene.frame_set(101)
    assert socket.default_value == pytest.approx(1.0)
    assert material.node_tree.nodes["Porous"].inputs["Soiling Level"].default_value == pytest.approx(0.9)


#: Life on the plane (docs/model.md §9.3): a sun map across it, lichens large enough to span pixels
#: (4 seeds per m², 20 mm a year across: thalli 0.37 m across on the 2 m plane), algae part way.
BIOLOGICAL_STATE = dict(
    biological_years=20.0, lichen_density=4.0, lichen_growth=20.0, damp_map=0.3, rain_map=0.2, runoff_map=0.0
)


def test_the_numpy_lichen_seeds_are_the_renders(fresh_scene):
    """The seeds the survey draws in numpy (biological.lichen_seeds_at, docs/model.md §10.1) are the
    Voronoi texture's F1 and F2 at each pixel's place on the plane, with this Blender's hash: the
    distances within 1e-5 cells, the seeds' values and size draws bit for bit."""
    plane = MaskedPlane(fresh_scene)
    seeds = lichen_seed_probe(plane, BIOLOGICAL_STATE["lichen_density"])
    place = plane.render(probes.emission_probe("Place Probe", lambda graph, geometry: geometry.outputs["Position"]))
    covered = place[..., 3] > 0.999
    metres = place[..., :3][covered]
    normals = np.broadcast_to((0.0, 0.0, 1.0), metres.shape)
    drawn = biological.lichen_seeds_at(metres, normals, BIOLOGICAL_STATE, compat.VORONOI_HASH)
    for nearest in (0, 3):  # F1, then F2
        distance, value, size = drawn[nearest : nearest + 3]
        assert np.abs(distance - seeds[nearest][covered]).max() < 1e-5
        assert np.array_equal(value.astype(np.float32), seeds[nearest + 1][covered])
        assert np.array_equal(size.astype(np.float32), seeds[nearest + 2][covered])
        assert len(np.unique(value)) > 4 and len(np.unique(size)) > 4  # several seeds on the plane
    assert np.all(drawn[3] >= drawn[0]) and not np.array_equal(drawn[1], drawn[4])


def test_the_numpy_white_noise_is_the_renders(fresh_scene):
    """A cell's draws in numpy (voronoi.white_noise_colour: the rivulets', docs/model.md §8.8) are the
    White Noise texture's Color in 1D at each pixel's whole-numbered W, with this Blender's hash:
    cells of 0.2 m across the 2 m plane, negative and positive."""
    plane = MaskedPlane(fresh_scene)
    cells_per_metre = 5.0

    def build(graph, geometry):
        position = graph.node("ShaderNodeSeparateXYZ", {"Vector": geometry.outputs["Position"]})
        cell = shader_math.floor(graph.wrap(position.outputs["X"]) * cells_per_metre)
        return graph.node("ShaderNodeTexWhiteNoise", {"W": cell}, noise_dimensions="1D").outputs["Color"]

    colour = plane.render(probes.emission_probe("White Noise Probe", build))
    place = plane.render(probes.emission_probe("Place Probe", lambda graph, geometry: geometry.outputs["Position"]))
    covered = place[..., 3] > 0.999
    cells = np.floor(place[..., 0][covered].astype(np.float32) * np.float32(cells_per_metre))
    assert cells.min() < 0.0 < cells.max()
    assert np.array_equal(np.stack(voronoi.white_noise_colour(cells), axis=-1), colour[..., :3][covered])


def test_biological_matches_model(fresh_scene):
    """Algae and lichens on a plane under a sun map: the model's pixels, given the sun map and the
    lichen seeds read back from probe renders; level 0 renders the plain porous material bit for bit."""
    plane = MaskedPlane(fresh_scene)
    sun = gradient_image("Sun", np.tile(np.linspace(0.0, 1.0, 16), (16, 1)))
    image = plane.render(weathered("Life", ("biological",), key_light=plane.sun, sun_map=sun, **BIOLOGICAL_STATE))
    covered = image[..., 3] > 0.999
    sun_map = plane.probe(sun)
    seeds = lichen_seed_probe(plane, BIOLOGICAL_STATE["lichen_density"])
    n_dot_l = np.dot(np.array(plane.sun.matrix_world.to_3x3().col[2]), (0.0, 0.0, 1.0))
    weights = model.weathered_coefficients(
        *(STONE[key] for key in ("base_color", "ks", "roughness", "porosity", "pore_depth_ratio")),
        n_dot_l,
        1.0,
        ("biological",),
        fields={biological.LICHEN_SEEDS: seeds},
        sun_map=sun_map,
        **BIOLOGICAL_STATE,
    )
    state = {**model.weathering_state("biological", BIOLOGICAL_STATE), "sun_map": sun_map}
    xp = NumpyOps(colour=False)
    lichen = biological.lichen_cover(xp, state, seeds)
    at_seed = (np.zeros_like(seeds[0]), seeds[1], seeds[2])
    unreached = biological.lichen_cover(xp, state, at_seed * 2) < 0.5  # seeds too high for L
    nearest, second = biological.thalli_covers(xp, state, seeds)
    past_nearer = second * (1.0 - nearest)  # in the second seed's thallus alone
    assert 0.1 < lichen[covered].mean() < 0.9 and 0.1 < unreached[covered].mean() < 0.9
    assert (past_nearer[covered] > 0.5).mean() > 0.01  # thalli seen past a nearer seed
    assert_matches(image, expected_image(weights, lobes(plane.render, STONE["roughness"])), covered)
    off = plane.render(
        weathered("Off", ("biological",), key_light=plane.sun, sun_map=sun, **BIOLOGICAL_STATE, biological_level=0.0)
    )
    clean = plane.render(pw.make_porous_material("Clean", key_light=plane.sun, **STONE))
    assert np.array_equal(off, clean)
