"""The panel's operators with the panel's default settings, on each sample scene, and the
artist's path through them in the order an artist clicks them."""

import os
import pathlib

import bpy

import numpy as np
import pytest

from helpers import panel_calls
from porous_weathering import ui
from porous_weathering.blender import render
from porous_weathering.common import imageio
from porous_weathering.contracts import STONE_NODE
from porous_weathering.core import modes as weathering_modes
from porous_weathering.core import stones
from porous_weathering.maps import efflorescence_map, linking
from porous_weathering.maps import registry as maps
from porous_weathering.samples import studio
from porous_weathering.shading import presets
from porous_weathering.ui import settings as ui_settings

SAMPLES = sorted((pathlib.Path(__file__).resolve().parents[1] / "sample_blends").glob("*.blend"))
#: Scan-sized samples (the bust: 200k triangles) skip the per-sample tests below, which bake every
#: map several times (minutes each on 2 cores); tests/test_samples.py bakes and Makes it once.
SCAN_SIZED = {"bust"}


def per_sample(paths):
    """Each sample path as a test parameter; the scan-sized ones skipped, with the reason."""
    skip = pytest.mark.skip(reason="scan-sized sample: weathered end to end once in tests/test_samples.py")
    return [pytest.param(path, id=path.stem, marks=skip if path.stem in SCAN_SIZED else ()) for path in paths]


def first_mesh():
    return next(obj for obj in bpy.context.scene.objects if obj.type == "MESH" and obj.data.polygons)


def open_and_select(sample, name=None):
    """Open ``sample`` and make its object ``name`` (default: its first mesh) the only selected one."""
    bpy.ops.wm.open_mainfile(filepath=str(sample), load_ui=False)
    obj = bpy.data.objects[name] if name else first_mesh()
    for other in bpy.context.scene.objects:
        other.select_set(other is obj)
    bpy.context.view_layer.objects.active = obj
    return obj


@pytest.mark.parametrize("sample", per_sample(SAMPLES))
def test_panel_operators_run_on_sample(sample, registered, tmp_path):
    obj = open_and_select(sample)
    settings = bpy.context.scene.porous_weathering

    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    assert obj.active_material["pw_light_mode"] in ("SUN", "POINT", "AMBIENT")

    soiling_maps = sorted({item.map for item in weathering_modes.inputs_of(("soiling",)) if item.map})
    assert linking.missing_maps(obj, ("soiling",)) == soiling_maps
    result = bpy.ops.porous_weathering.bake_maps(maps=set(maps.names()), target="attribute", samples=4, sun_samples=4)
    assert result == {"FINISHED"} and linking.missing_maps(obj, ("soiling", "wet")) == []

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
@pytest.mark.parametrize("sample", per_sample(SAMPLES))
def test_bake_then_make_connects_every_baked_map(sample, target, registered, tmp_path):
    """The artist's path: Bake Weathering Maps, tick a mode, Make Porous Material: every map the
    mode reads is connected to its input (no constant 0 left behind), for each target."""
    assert MAP_MODES.keys() >= {"soiling", "wet"}
    obj = open_and_select(sample)
    settings = bpy.context.scene.porous_weathering

    made = set(linking.discover_maps(obj))  # nothing baked yet: each mode warns of every map it reads
    for mode in MAP_MODES:
        reads = {item.map for item in weathering_modes.inputs_of((mode,)) if item.map}
        assert linking.missing_maps(obj, (mode,)) == sorted(reads - made)
    # 512: the brick wall's 864 UV islands cannot lie 4 texels apart in fewer (docs/maps.md)
    assert bpy.ops.porous_weathering.bake_maps(
        maps={"rain"}, target=target, resolution=512, samples=2, out_dir=str(tmp_path)
    ) == {"FINISHED"}
    # half baked: the warning stays for the maps soiling reads but the rain
    soiling_maps = {item.map for item in weathering_modes.inputs_of(("soiling",)) if item.map}
    assert linking.missing_maps(obj, ("soiling",)) == sorted(soiling_maps - {"rain"})
    assert bpy.ops.porous_weathering.bake_maps(
        maps=set(maps.names()), target=target, resolution=512, samples=2, sun_samples=2, out_dir=str(tmp_path)
    ) == {"FINISHED"}
    baked = linking.discover_maps(obj)
    for mode, inputs in MAP_MODES.items():
        assert linking.missing_maps(obj, (mode,)) == []
        for name in weathering_modes.names():
            setattr(settings, name, name == mode)
        assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
        group = obj.active_material.node_tree.nodes["Porous"]
        for item in inputs:
            assert_reads(group.inputs[item.socket], baked[item.map], obj)


# --- the key light, the efflorescence map and the weathering values of the panel ------------------


def add_light(scene, name, kind, energy):
    light = studio.link(scene, bpy.data.objects.new(name, bpy.data.lights.new(name, kind)))
    light.data.energy = energy
    return light


def test_key_light_defaults_to_the_scenes_strongest_sun(registered, fresh_scene):
    """An empty Key Light is the strongest sun that renders (first by name among equals); no sun:
    ambient. Make wires what the rule picks."""
    settings = fresh_scene.porous_weathering
    assert settings.key_light is None and ui_settings.key_light(fresh_scene, settings) is None
    lamp = add_light(fresh_scene, "Lamp", "POINT", 1000.0)
    assert ui_settings.key_light(fresh_scene, settings) is None, "a point light is never picked for the artist"
    low = add_light(fresh_scene, "Low Sun", "SUN", 1.0)
    assert ui_settings.key_light(fresh_scene, settings) is low, "the only sun"
    strong = add_light(fresh_scene, "Strong Sun", "SUN", 4.0)
    add_light(fresh_scene, "Strong Sun 2", "SUN", 4.0)
    add_light(fresh_scene, "Hidden Sun", "SUN", 9.0).hide_render = True
    assert ui_settings.key_light(fresh_scene, settings) is strong
    settings.key_light = lamp
    assert ui_settings.key_light(fresh_scene, settings) is lamp, "a light the artist picks wins"
    settings.key_light = None

    plane = studio.add_plane(fresh_scene)
    bpy.context.view_layer.objects.active = plane
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    assert plane.active_material["pw_light_mode"] == "SUN"
    assert plane.active_material.node_tree["pw_key_light"] == strong.name


def test_panel_weathering_values_come_from_the_registry_and_the_stone(registered, fresh_scene):
    """Every input the registry marks for the panel is a slider with its tooltip and range;
    picking a stone sets the preset's values; Make passes them to the modes that use them."""
    settings = fresh_scene.porous_weathering
    shown = [item for item in weathering_modes.inputs().values() if item.panel]
    assert {item.name for item in shown} == {
        "crust",
        "wet_darkening",
        "runoff",
        "streaks",
        "biological_level",
        "lichen_density",
    }
    for item in shown:
        prop = settings.bl_rna.properties[item.name]
        assert prop.description == item.tooltip and (prop.hard_min, prop.hard_max) == (item.low, item.high)
        assert getattr(settings, item.name) == pytest.approx(  # the stone's, then the default site's
            presets.weathering_values(ui_settings.DEFAULT_SOURCE, presets.DEFAULT_ENVIRONMENT)[item.name]
        )
    settings.source = "BRICK"
    assert settings.crust == pytest.approx(presets.PRESETS["BRICK"].weathering["crust"])
    settings.crust, settings.wet_darkening = 0.3, 0.45
    settings.soiling = settings.wet = True
    plane = studio.add_plane(fresh_scene)
    bpy.context.view_layer.objects.active = plane
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    group = plane.active_material.node_tree.nodes["Porous"]
    assert group.inputs["Crust"].default_value == pytest.approx(0.3)
    assert group.inputs["Wet Darkening"].default_value == pytest.approx(0.45)
    settings.source = ui_settings.FROM_MATERIAL  # no preset: the API defaults
    assert settings.crust == pytest.approx(weathering_modes.inputs()["crust"].default)


def test_the_variation_slider_gives_the_stone_its_structure_or_none(registered, fresh_scene):
    """Make gives a preset's material its stone's structure at the panel's Variation (1 by
    default: as the stone shows it); at 0 the material is uniform, with no stone node."""
    settings = fresh_scene.porous_weathering
    assert settings.variation == stones.DEFAULT_VARIATION == 1.0
    plane = studio.add_plane(fresh_scene)
    bpy.context.view_layer.objects.active = plane
    settings.variation = 0.4
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    stone = plane.active_material.node_tree.nodes[STONE_NODE]
    assert stone.inputs["Variation"].default_value == pytest.approx(0.4)
    settings.variation = 0.0
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    assert STONE_NODE not in plane.active_material.node_tree.nodes


def test_the_made_materials_stone_varies_live_from_the_panel(registered, fresh_scene):
    """After Make, the panel shows the active material's own Variation (its stone node's input),
    so the structure is dialled without Make: at 0 the material renders as the uniform one Make
    gives at 0; a uniform material shows no such slider."""
    settings = fresh_scene.porous_weathering
    plane = studio.add_plane(fresh_scene)
    studio.add_sun(fresh_scene, (0.5, 0.3, 0.8))
    studio.add_ortho_camera(fresh_scene)
    render.use_cycles(fresh_scene, size=16, samples=1)
    bpy.context.view_layer.objects.active = plane
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    structured = plane.active_material
    socket = ui_settings.variation_socket(structured)
    assert ("prop", (socket, "default_value")) in panel_calls()
    varied = render.render_array(fresh_scene)
    socket.default_value = 0.0
    dialled_down = render.render_array(fresh_scene)
    settings.variation = 0.0
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    uniform = render.render_array(fresh_scene)
    assert ui_settings.variation_socket(plane.active_material) is None
    assert not any(call[0] == "prop" and call[1][0] == socket for call in panel_calls())
    assert np.abs(varied - uniform).max() > 0.01
    assert np.abs(dialled_down - uniform).max() < 1e-5


def test_make_gives_every_selected_object_its_own_material(registered, fresh_scene):
    """Make, as Bake and Export, takes the selected objects (the active one first): each gets a
    material of its own, on its own maps; one it cannot make for gives none of them anything."""
    settings = fresh_scene.porous_weathering
    planes = [studio.add_plane(fresh_scene, name) for name in ("First", "Second", "Third")]
    for plane, x in zip(planes, (0.0, 3.0, 6.0)):
        plane.location.x = x
        plane.select_set(plane.name != "Third")
    bpy.context.view_layer.objects.active = planes[1]
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    first, second, third = (plane.active_material for plane in planes)
    assert third is None and first is not second
    assert first.name.startswith("First") and second.name.startswith("Second")
    assert STONE_NODE in first.node_tree.nodes and STONE_NODE in second.node_tree.nodes

    materials = len(bpy.data.materials)
    settings.masonry = "FACE_SETS"  # the active one has face sets, the other selected one none
    planes[1].data.attributes.new(presets.FACE_SET_ATTRIBUTE, "INT", "FACE")
    with pytest.raises(RuntimeError, match="'First' has no face sets"):
        bpy.ops.porous_weathering.make_material()
    assert [plane.active_material for plane in planes] == [first, second, None]
    assert len(bpy.data.materials) == materials  # the active one's, made first, removed
    assert stones.MeshBlocks().attribute not in planes[1].data.attributes


def test_keyframe_aging_ages_every_selected_objects_material(registered, fresh_scene):
    """Years and Keyframe Aging age the materials one Make gave the selected objects, each once."""
    settings = fresh_scene.porous_weathering
    settings.soiling = True
    planes = [studio.add_plane(fresh_scene, name) for name in ("First", "Second")]
    for plane in planes:
        plane.select_set(True)
    bpy.context.view_layer.objects.active = planes[0]
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    settings.years = 12.0
    times = [ui_settings.time_socket(plane.active_material).default_value for plane in planes]
    assert 0.0 < times[0] < 1.0 and times[1] == times[0]
    fresh_scene.frame_start, fresh_scene.frame_end = 1, 11
    assert bpy.ops.porous_weathering.keyframe_aging() == {"FINISHED"}
    fresh_scene.frame_set(6)
    times = [ui_settings.time_socket(plane.active_material).default_value for plane in planes]
    assert times == pytest.approx([0.5, 0.5])
    assert planes[0].active_material is not planes[1].active_material


def test_the_masonry_choice_lays_the_stone_in_blocks(registered, fresh_scene):
    """Make lays the stone in the panel's Masonry (docs/model.md §8.5): coursed ashlar at the
    panel's lengths (metres), or the blocks of the mesh's loose parts, which Make writes into its
    face attribute; a mesh without the face sets asked for is refused in one line, nothing written
    or made; without a preset no masonry is laid."""
    settings = fresh_scene.porous_weathering
    assert settings.masonry == ui_settings.NO_MASONRY
    plane = studio.add_plane(fresh_scene)
    bpy.context.view_layer.objects.active = plane
    settings.masonry, settings.course_height = ui_settings.ASHLAR, 0.4
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    stone = plane.active_material.node_tree.nodes[STONE_NODE]
    assert stone.node_tree.name.endswith(" Ashlar")
    assert stone.inputs["Course Height"].default_value == pytest.approx(0.4)
    assert stone.inputs["Block Length"].default_value == pytest.approx(stones.Ashlar.block_length)

    made = plane.active_material
    settings.masonry = "FACE_SETS"  # the plane has none
    with pytest.raises(RuntimeError, match="no face sets"):
        bpy.ops.porous_weathering.make_material()
    assert plane.active_material is made and stones.MeshBlocks().attribute not in plane.data.attributes

    settings.masonry = "ISLANDS"
    second = studio.add_plane(fresh_scene, "Second")
    second.location.x = 3.0
    bpy.ops.object.select_all(action="DESELECT")
    plane.select_set(True)
    second.select_set(True)
    bpy.context.view_layer.objects.active = plane
    bpy.ops.object.join()
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    stone = plane.active_material.node_tree.nodes[STONE_NODE]
    assert " Blocks" in stone.node_tree.name
    blocks = np.empty(len(plane.data.polygons), dtype=np.int32)
    plane.data.attributes[stones.MeshBlocks().attribute].data.foreach_get("value", blocks)
    assert len(np.unique(blocks)) == 2

    settings.source = ui_settings.FROM_MATERIAL
    assert settings.masonry_for(plane) == (None, None)


def test_a_make_that_fails_writes_no_blocks(registered, fresh_scene, monkeypatch):
    """Make reads the mesh's blocks first and writes them only once its material is made: a
    material that cannot be made leaves the mesh as it was (no block attribute under CANCELLED)."""
    plane = studio.add_plane(fresh_scene)
    bpy.context.view_layer.objects.active = plane
    fresh_scene.porous_weathering.masonry = "ISLANDS"

    def refuse(*args, **kwargs):
        raise ValueError("refused")

    monkeypatch.setattr(linking, "weathered_material_for", refuse)
    with pytest.raises(RuntimeError, match="refused"):
        bpy.ops.porous_weathering.make_material()
    assert stones.MeshBlocks().attribute not in plane.data.attributes
    monkeypatch.undo()
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    assert stones.MeshBlocks().attribute in plane.data.attributes


def test_artist_path_makes_and_connects_the_efflorescence_map(registered, tmp_path):
    """Open the brick wall, save it, pick the stone, tick Wet and Efflorescence, Make (the maps
    are missing), Bake Weathering Maps, Make (the salt reads the run-off: the absorbed water),
    Make Efflorescence Map (brick joints, then from a photograph), set Wet Darkening, Make: the
    sun lights it, every map is connected, the location map in the run-off's place, the values
    are the panel's; then From: Absorbed Water, Make: the run-off again."""
    obj = open_and_select(SAMPLES[[path.stem for path in SAMPLES].index("brick_wall")], "Bricks")
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "wall.blend"))  # the maps go beside it
    scene = bpy.context.scene
    settings = scene.porous_weathering

    settings.source = "BRICK"
    settings.wet = settings.efflorescence = True
    assert settings.key_light is None and ui_settings.scene_sun(scene) is not None
    read = sorted({item.map for item in weathering_modes.inputs_of(settings.modes()) if item.map})
    assert linking.missing_maps(obj, settings.modes()) == read
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}  # warns, and still makes it
    assert bpy.ops.porous_weathering.bake_maps(
        maps=set(maps.names()), target="attribute", samples=2, sun_samples=2
    ) == {"FINISHED"}
    # no location map made yet: the salt follows the water the stone absorbs, the run-off map
    assert linking.missing_maps(obj, settings.modes()) == []
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    runoff = linking.discover_maps(obj)["runoff"]
    assert_reads(obj.active_material.node_tree.nodes["Porous"].inputs["Efflorescence Map"], runoff, obj)

    assert bpy.ops.porous_weathering.make_efflorescence_map(source="BRICK_JOINTS", resolution=64) == {"FINISHED"}
    path = efflorescence_map.default_path(obj.name)
    assert os.path.dirname(path) == str(tmp_path)
    joints = efflorescence_map.brick_joint_map(64)
    assert np.array_equal(imageio.read_image(path)[0][..., 0], joints)
    image = linking.discover_maps(obj)["efflorescence"]
    assert linking.missing_maps(obj, settings.modes()) == [] and bpy.path.abspath(image.filepath) == path

    photo = np.full((48, 48, 3), 0.2, dtype=np.float32)
    photo[10:30, 5:40] = 0.9  # a salt patch
    imageio.write_image(tmp_path / "salt.png", photo)
    with pytest.raises(RuntimeError, match="choose the photograph"):
        bpy.ops.porous_weathering.make_efflorescence_map(source="PHOTO", resolution=64)
    with pytest.raises(RuntimeError, match="gone.png"):
        bpy.ops.porous_weathering.make_efflorescence_map(source="PHOTO", photo=str(tmp_path / "gone.png"))
    assert np.array_equal(imageio.read_image(path)[0][..., 0], joints), "a failed attempt loses nothing"
    assert bpy.ops.porous_weathering.make_efflorescence_map(
        source="PHOTO", photo=str(tmp_path / "salt.png"), resolution=64
    ) == {"FINISHED"}
    from_photo = efflorescence_map.photo_map(tmp_path / "salt.png", size=64)
    assert np.array_equal(imageio.read_image(path)[0][..., 0], from_photo)
    assert linking.discover_maps(obj)["efflorescence"] is image, "the same image, reloaded"

    settings.wet_darkening = 0.7
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    made = obj.active_material
    group = made.node_tree.nodes["Porous"]
    assert made["pw_light_mode"] == "SUN" and made.node_tree["pw_key_light"] == ui_settings.scene_sun(scene).name
    assert_reads(group.inputs["Efflorescence Map"], image, obj)
    assert_reads(group.inputs["Rain Map"], linking.discover_maps(obj)["rain"], obj)
    assert group.inputs["Wet Darkening"].default_value == pytest.approx(0.7)
    pixels = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(pixels)
    assert np.allclose(pixels.reshape(64, 64, 4)[::-1, :, 0], from_photo)  # Blender's rows: bottom first

    # back to the absorbed water: Make reads the run-off again, the photograph's map stays on disk
    assert bpy.ops.porous_weathering.make_efflorescence_map(source="ABSORBED_WATER") == {"FINISHED"}
    assert "efflorescence" not in linking.discover_maps(obj) and os.path.exists(path)
    assert bpy.ops.porous_weathering.make_material() == {"FINISHED"}
    assert_reads(obj.active_material.node_tree.nodes["Porous"].inputs["Efflorescence Map"], runoff, obj)


def test_efflorescence_map_needs_a_saved_blend_and_a_uv_map(registered, fresh_scene, tmp_path):
    """One clear line each, and nothing written."""
    scan = studio.add_plane(bpy.context.scene)
    bpy.context.view_layer.objects.active = scan
    with pytest.raises(RuntimeError, match="save the .blend first"):
        bpy.ops.porous_weathering.make_efflorescence_map(resolution=32)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scan.blend"))
    scan.data.uv_layers.remove(scan.data.uv_layers[0])
    with pytest.raises(RuntimeError, match="no UV map"):
        bpy.ops.porous_weathering.make_efflorescence_map(resolution=32)
    with pytest.raises(RuntimeError, match="has no runoff map to take the place of its efflorescence map: bake it"):
        bpy.ops.porous_weathering.make_efflorescence_map(source="ABSORBED_WATER")
    assert "pw_efflorescence_image" not in scan and not list(tmp_path.glob("*.exr"))
