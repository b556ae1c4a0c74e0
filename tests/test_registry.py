"""One declaration is enough: a toy mode and a toy map, defined here only, appear in the model,
the node group (its Cycles render matches its numpy backend), the panel, the bake operator's
properties, BakeOptions and ``bake --help``."""

import contextlib
import io
from dataclasses import dataclass

import bpy

import numpy as np
import pytest

import porous_weathering
from helpers import STONE, LitSphere, assert_matches, expected_image, lobes, model_weights, weathered
from porous_weathering.blender import mesh_arrays
from porous_weathering.cli import entry
from porous_weathering.common.options import option
from porous_weathering.core import model, modes
from porous_weathering.core.modes.base import TIME, Input, Layer, Mode
from porous_weathering.maps import bake
from porous_weathering.maps import registry as maps
from porous_weathering.shading import nodes
from porous_weathering.ui import panel as ui

GRIME = Input("grime", 0.0, 0.0, 1.0, "Toy grime: darkens the diffuse where the toy map is high", mask=True, map="toy")
STRENGTH = Input("grime_strength", 0.5, 0.0, 1.0, "How much the grime darkens at t = 1")


def darken_with_grime(xp, point):
    """Written once: evaluated by numpy in the model, built as nodes in the group."""
    s = point.state
    point.kd_w = point.kd_w * (1.0 - xp.channel(s["grime"] * s["grime_strength"] * s["time"]))


TOY_MODE = Mode(
    "grime",
    "Grime",
    "Toy mode of the registry test",
    (TIME, GRIME, STRENGTH),
    (Layer(50, darken_with_grime),),
    catalog="Grime",
    asset_summary="Toy grime",
)


@dataclass(frozen=True)
class ToySettings:
    level: float = option(
        0.75, label="Toy Level", flag="--toy-level", low=0.0, high=1.0, tooltip="The value the toy map is baked to"
    )


def toy_image(obj, uv_map, options, margin):
    return np.full((options.resolution, options.resolution), options.toy_settings.level, np.float32)


def toy_attribute(obj, options):
    mesh_arrays.write_corner_attribute(obj.data, "pw_toy", np.full(len(obj.data.loops), options.toy_settings.level))


TOY_MAP = maps.MapKind(
    "toy",
    "Toy Map",
    "Toy map of the registry test",
    attribute="pw_toy",
    settings=ToySettings,
    options_field="toy_settings",
    bake_image=toy_image,
    bake_attribute=toy_attribute,
)


@pytest.fixture
def toys():
    modes.register(TOY_MODE)
    maps.register(TOY_MAP)
    try:
        yield
    finally:
        modes.unregister(TOY_MODE.name)
        maps.unregister(TOY_MAP.name)


def test_toy_mode_is_in_the_model(toys):
    assert "grime" in model.MODES and "grime_strength" in model.WEATHERING_INPUTS
    kd, ks, water = model.weathered_coefficients(
        (0.6, 0.5, 0.4), 0.1, 0.4, 0.3, 2.0, 0.8, 0.9, ("grime",), time=1.0, grime=0.8, grime_strength=0.5
    )
    clean, clean_ks = model.porous_coefficients((0.6, 0.5, 0.4), 0.1, 0.4, 0.3, 2.0, 0.8, 0.9)
    np.testing.assert_allclose(kd, clean * (1.0 - 0.4))
    assert ks == pytest.approx(clean_ks) and not water.any()
    assert maps.get("toy").feeds == ["grime"] and maps.feeding("grime") is TOY_MAP


def test_toy_mode_renders_as_its_numpy_backend(toys, fresh_scene):
    group = nodes.weathered_group(("grime",), nodes.SUN)
    assert [s.name for s in group.interface.items_tree if s.in_out == "INPUT"][-3:] == [
        "Time",
        "Grime",
        "Grime Strength",
    ]
    sphere = LitSphere(fresh_scene)
    state = dict(time=0.7, grime=0.9, grime_strength=0.6)
    image = sphere.render(weathered("Grimy", ("grime",), key_light=sphere.sun, **state))
    n_dot_l, n_dot_v = sphere.cosines()
    expected = expected_image(
        model_weights(("grime",), n_dot_l, n_dot_v, **state), lobes(sphere.render, STONE["roughness"])
    )
    clean = expected_image(
        model_weights(("grime",), n_dot_l, n_dot_v, time=0.0), lobes(sphere.render, STONE["roughness"])
    )
    lit = sphere.covered & (n_dot_l > 0.0)
    assert np.abs(expected - clean)[lit].max() > 0.01  # the toy mode does show
    assert_matches(image, expected, lit)


def test_toy_map_is_in_the_options_and_the_command_line(toys):
    options = bake.BakeOptions(toy_settings=ToySettings(level=0.25))
    assert options.maps == ("rain", "edges", "toy") and options.toy_settings.level == 0.25
    assert ["--toy-level", "0.25"] == options.to_argv()[-2:]
    with pytest.raises(ValueError, match="toy level"):
        bake.BakeOptions(toy_settings=ToySettings(level=2.0))
    help_text = io.StringIO()
    with contextlib.redirect_stdout(help_text), pytest.raises(SystemExit):
        entry.main(["bake", "--help"])
    assert "--toy-level" in help_text.getvalue() and "OUT/<object>.toy.exr" in help_text.getvalue()
    parsed = entry.build_parser().parse_args(["bake", "f.blend", "--maps", "toy", "--toy-level", "0.5"])
    assert bake.options_from_values(vars(parsed)).toy_settings.level == 0.5


@pytest.mark.parametrize("target", ["attribute", "image"])
def test_toy_map_through_the_panel(toys, fresh_scene, tmp_path, target):
    """The panel's path: the bake operator bakes the toy map, Make connects it to the toy mode's input."""
    bpy.ops.mesh.primitive_plane_add()
    plane = bpy.context.active_object
    porous_weathering.register()
    try:
        settings = fresh_scene.porous_weathering
        assert "grime" in settings.bl_rna.properties and settings.bl_rna.properties["grime"].description
        operator = bpy.ops.porous_weathering.bake_maps.get_rna_type().properties
        assert "toy_level" in operator and "toy" in {item.identifier for item in operator["maps"].enum_items}
        assert ui.missing_maps(plane, ("grime",)) == ["toy"]
        assert bpy.ops.porous_weathering.bake_maps(
            maps={"toy"}, target=target, resolution=16, toy_level=0.4, out_dir=str(tmp_path)
        ) == {"FINISHED"}
        assert ui.missing_maps(plane, ("grime",)) == []
        settings.grime = True
        assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
        socket = plane.active_material.node_tree.nodes["Porous"].inputs["Grime"]
        assert socket.is_linked
        source = socket.links[0].from_node
        if target == "attribute":
            assert source.attribute_name == "pw_toy"
        else:
            assert source.image.filepath.endswith("Plane.toy.exr")
    finally:
        porous_weathering.unregister()
