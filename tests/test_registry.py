"""One module is enough: the toy mode and toy map of tests/toys/ (modes/grime.py, maps/toy.py),
each one module holding one record, put where a mode's and a map's module go by the ``toys``
fixture, appear in the registries (after the shipped ones, in their order), the model, the node
group (its Cycles render matches its numpy backend), the node-group snapshot's cases, the panel,
the bake operator's properties, BakeOptions, ``bake --help``, the input hash (a changed setting
re-bakes) and the export, and a group of an older build without the toy's input is built again;
the docs tables' check sees them too (tests/test_docs_tables.py)."""

import ast
import contextlib
import importlib.util
import io
import json
import pathlib
import sys

import bpy

import numpy as np
import pytest

import porous_weathering
from helpers import (
    STONE,
    TOYS,
    LitSphere,
    assert_matches,
    expected_image,
    lobes,
    model_weights,
    weathered,
    weathered_mode_sets,
)
from porous_weathering.cli import entry
from porous_weathering.core import model
from porous_weathering.core import modes as weathering_modes
from porous_weathering.maps import bake
from porous_weathering.maps import registry as maps
from porous_weathering.publish import export
from porous_weathering.shading import nodes
from porous_weathering.ui import panel as ui


def test_a_module_is_all_a_mode_and_a_map_need(toys):
    """The registries find the toys' modules, nothing else names them, and they go once their
    modules are no longer on the packages' paths."""
    assert weathering_modes.names() == ("soiling", "wet", "efflorescence", "biological", "grime")
    assert maps.names() == ("rain", "edges", "runoff", "sun", "damp", "toy")
    assert weathering_modes.get("grime") is sys.modules["porous_weathering.core.modes.grime"].MODE
    assert maps.get("toy") is sys.modules["porous_weathering.maps.toy"].MAP
    assert importlib.util.find_spec("porous_weathering.toy"), "public, as porous_weathering.rain is"
    for toy in (TOYS / "modes" / "grime.py", TOYS / "maps" / "toy.py"):
        names = [name.id for name in ast.walk(ast.parse(toy.read_text())) if isinstance(name, ast.Name)]
        assert "register" not in names, f"{toy.name}: a module needs no register call"


def test_the_toys_go_with_their_modules():
    assert "grime" not in weathering_modes.names() and "toy" not in maps.names()
    assert importlib.util.find_spec("porous_weathering.toy") is None


def test_a_group_of_an_older_build_without_the_toy_input_is_built_again(toys, fresh_scene):
    """No build number to bump for a new input: a group whose sockets are not those of the
    records (here one without Grime Strength, as a file saved before the input came) is set aside
    as "(old)" and built again; one that is, is reused."""
    group = nodes.weathered_group(("grime",), nodes.SUN)
    assert nodes.weathered_group(("grime",), nodes.SUN) is group
    group.interface.remove(group.interface.items_tree["Grime Strength"])
    rebuilt = nodes.weathered_group(("grime",), nodes.SUN)
    assert rebuilt is not group and group.name.endswith(" (old)")
    assert "Grime Strength" in rebuilt.interface.items_tree


def test_toy_mode_is_in_the_model(toys):
    assert "grime" in model.MODES and "grime_strength" in model.WEATHERING_INPUTS
    kd, ks, water = model.weathered_coefficients(
        (0.6, 0.5, 0.4), 0.1, 0.4, 0.3, 2.0, 0.8, 0.9, ("grime",), time=1.0, grime=0.8, grime_strength=0.5
    )
    clean, clean_ks = model.porous_coefficients((0.6, 0.5, 0.4), 0.1, 0.4, 0.3, 2.0, 0.8, 0.9)
    np.testing.assert_allclose(kd, clean * (1.0 - 0.4))
    assert ks == pytest.approx(clean_ks) and not water.any()
    assert maps.get("toy").feeds == ["grime"] and maps.feeding("grime") is maps.get("toy")


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
    options = bake.BakeOptions(toy_settings=maps.get("toy").settings(level=0.25))
    assert options.maps == (*maps.names()[:-1], "toy") and options.toy_settings.level == 0.25
    assert ["--toy-level", "0.25"] == options.to_argv()[-2:]
    with pytest.raises(ValueError, match="toy level"):
        bake.BakeOptions(toy_settings=maps.get("toy").settings(level=2.0))
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


def test_toy_mode_is_in_the_node_group_snapshot_cases(toys):
    assert [mode_set for mode_set in weathered_mode_sets() if "grime" in mode_set][0] == ("grime",)
    assert ("soiling", "wet", "efflorescence", "grime") in weathered_mode_sets()


def test_toy_map_rebakes_when_its_setting_changes(toys, fresh_scene, tmp_path):
    """Every setting of a map is in its input hash by default: the record lists none by hand."""
    bpy.ops.mesh.primitive_plane_add()
    plane = bpy.context.active_object
    options = bake.BakeOptions(maps=("toy",), target="attribute", toy_settings=maps.get("toy").settings(level=0.25))
    assert [o.status for o in bake.bake_maps([plane], options)] == ["written"]
    assert [o.status for o in bake.bake_maps([plane], options)] == ["unchanged"]
    changed = bake.BakeOptions(maps=("toy",), target="attribute", toy_settings=maps.get("toy").settings(level=0.5))
    assert [o.status for o in bake.bake_maps([plane], changed)] == ["written"]
    values = np.zeros(len(plane.data.loops) * 4, np.float32)
    plane.data.color_attributes[maps.get("toy").attribute].data.foreach_get("color", values)
    assert np.allclose(values.reshape(-1, 4)[:, 0], 0.5)


def test_toy_mode_is_exported(toys, fresh_scene, tmp_path):
    """The export bakes whatever a material's modes are: a variant per age, and the paradata
    names the toy mode and its inputs."""
    bpy.ops.mesh.primitive_plane_add()
    plane = bpy.context.active_object
    plane.data.materials.append(weathered("Grimy", ("grime",), grime=1.0, grime_strength=1.0))
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "toy.blend"))
    result = export.export_variants([plane], (0.0, 1.0), size=16, out_dir=str(tmp_path / "out"))
    assert list(result.variants) == ["clean", "t=1"]
    paradata = json.loads(pathlib.Path(result.paradata).read_text())
    (material,) = [m for obj in paradata["objects"] for m in obj["materials"]]
    assert material["modes"] == ["grime"] and material["inputs"]["Grime Strength"] == 1.0
