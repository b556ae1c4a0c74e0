"""The panel's operators with the panel's default settings, on each sample scene."""

import pathlib

import bpy

import pytest

import porous_weathering
from porous_weathering import maps, ui
from porous_weathering import modes as weathering_modes

SAMPLES = sorted((pathlib.Path(__file__).resolve().parents[1] / "sample_blends").glob("*.blend"))


@pytest.fixture
def registered():
    porous_weathering.register()
    yield
    porous_weathering.unregister()


def first_mesh():
    return next(obj for obj in bpy.context.scene.objects if obj.type == "MESH" and obj.data.polygons)


@pytest.mark.parametrize("sample", SAMPLES, ids=[path.stem for path in SAMPLES])
def test_panel_operators_run_on_sample(sample, registered, tmp_path):
    bpy.ops.wm.open_mainfile(filepath=str(sample), load_ui=False)
    obj = first_mesh()
    for other in bpy.context.scene.objects:
        other.select_set(other is obj)
    bpy.context.view_layer.objects.active = obj
    settings = bpy.context.scene.porous_weathering

    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    assert obj.active_material["pw_light_mode"] in ("SUN", "POINT", "AMBIENT")

    assert ui.missing_maps(obj, ("soiling",)) == ["edges", "rain"]
    result = bpy.ops.porous_weathering.bake_maps(maps={"rain", "edges"}, target="attribute", samples=4)
    assert result == {"FINISHED"} and ui.missing_maps(obj, ("soiling", "wet")) == []

    settings.soiling = settings.wet = True
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    weathered = obj.active_material
    assert weathered["pw_modes"] == "soiling,wet"
    assert bpy.ops.porous_weathering.keyframe_aging.poll()
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 24
    assert bpy.ops.porous_weathering.keyframe_aging() == {"FINISHED"}
    time = weathered.node_tree.nodes["Porous"].inputs["Time"]
    for frame, age in ((24, 1.0), (1, 0.0), (12, None)):
        bpy.context.scene.frame_set(frame)
        if age is None:
            assert 0.0 < time.default_value < 1.0
        else:
            assert time.default_value == pytest.approx(age)


def test_every_panel_class_has_a_description():
    for cls in ui.CLASSES:
        assert (cls.__doc__ or "").strip(), cls.__name__


def test_every_control_has_a_tooltip(registered):
    """Every operator option and every panel setting says what it does."""
    operators = [getattr(bpy.ops.porous_weathering, name) for name in dir(bpy.ops.porous_weathering)]
    assert len(operators) >= 4
    properties = [(op.idname(), prop) for op in operators for prop in op.get_rna_type().properties]
    properties += [
        ("settings", prop)
        for prop in bpy.context.scene.porous_weathering.bl_rna.properties
        if prop.identifier != "name"
    ]
    untold = [
        f"{owner}.{prop.identifier}"
        for owner, prop in properties
        if prop.identifier != "rna_type" and not prop.description.strip()
    ]
    assert not untold


#: Every mode that reads a baked map, and the inputs those maps feed.
MAP_MODES = {
    mode: [item for item in weathering_modes.inputs_of(mode) if item.map in maps.names()]
    for mode in weathering_modes.names()
}
MAP_MODES = {mode: inputs for mode, inputs in MAP_MODES.items() if inputs}


def assert_reads(socket, source, obj):
    """``socket`` is fed by the node that reads ``source`` (a baked map of ``obj``)."""
    assert socket.is_linked, f"{socket.name} is not connected to its baked map"
    node = socket.links[0].from_node
    if isinstance(source, str):
        assert node.type == "ATTRIBUTE" and node.attribute_name == source
    else:
        assert node.type == "TEX_IMAGE" and node.image == source


@pytest.mark.parametrize("target", ["image", "attribute"])
@pytest.mark.parametrize("sample", SAMPLES, ids=[path.stem for path in SAMPLES])
def test_bake_then_make_connects_every_baked_map(sample, target, registered, tmp_path):
    """The artist's path: Bake Weathering Maps, tick a mode, Make Porous Material: every map the
    mode reads is connected to its input (no constant 0 left behind), for each target."""
    assert MAP_MODES.keys() >= {"soiling", "wet"}
    bpy.ops.wm.open_mainfile(filepath=str(sample), load_ui=False)
    obj = first_mesh()
    for other in bpy.context.scene.objects:
        other.select_set(other is obj)
    bpy.context.view_layer.objects.active = obj
    settings = bpy.context.scene.porous_weathering

    for mode, inputs in MAP_MODES.items():  # nothing baked yet: each mode warns
        assert ui.missing_maps(obj, (mode,)) == sorted({item.map for item in inputs})
    assert bpy.ops.porous_weathering.bake_maps(
        maps={"rain"}, target=target, resolution=64, samples=2, out_dir=str(tmp_path)
    ) == {"FINISHED"}
    assert ui.missing_maps(obj, ("soiling",)) == ["edges"]  # half baked: the warning stays
    assert bpy.ops.porous_weathering.bake_maps(
        maps=set(maps.names()), target=target, resolution=64, samples=2, out_dir=str(tmp_path)
    ) == {"FINISHED"}
    baked = ui.baked_maps(obj)
    for mode, inputs in MAP_MODES.items():
        assert ui.missing_maps(obj, (mode,)) == []
        for name in weathering_modes.names():
            setattr(settings, name, name == mode)
        assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
        group = obj.active_material.node_tree.nodes["Porous"]
        for item in inputs:
            assert_reads(group.inputs[item.socket], baked[item.map], obj)
