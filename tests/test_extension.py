"""The extension as Blender sees it: registration, saved files, untrusted files."""

import bpy

import numpy as np
import pytest

import porous_weathering
from helpers import LitSphere
from porous_weathering import ui
from porous_weathering.blender import render
from porous_weathering.samples import studio

PARAMS = dict(base_color=(0.6, 0.5, 0.4), ks=0.1, roughness=0.5, porosity=0.35, pore_depth_ratio=2.0)


def registered_classes():
    return {cls.__name__ for cls in ui.CLASSES if cls.is_registered}


def test_register_unregister_twice_leaves_nothing(fresh_scene):
    before_handlers = {
        name: len(getattr(bpy.app.handlers, name))
        for name in dir(bpy.app.handlers)
        if isinstance(getattr(bpy.app.handlers, name), list)
    }
    for _ in range(2):
        porous_weathering.register()
        try:
            assert registered_classes() == {cls.__name__ for cls in ui.CLASSES}
            assert hasattr(bpy.ops.porous_weathering, "add_porous_material")
        finally:
            porous_weathering.unregister()
        assert registered_classes() == set()
    after_handlers = {name: len(getattr(bpy.app.handlers, name)) for name in before_handlers}
    assert after_handlers == before_handlers


def test_every_registered_class_has_a_description():
    for cls in ui.CLASSES:
        assert (cls.__doc__ or "").strip(), cls.__name__


def test_operator_adds_a_porous_material(fresh_scene):
    porous_weathering.register()
    try:
        sphere = studio.add_sphere(fresh_scene, segments=16, rings=8)
        bpy.context.view_layer.objects.active = sphere
        assert bpy.ops.porous_weathering.add_porous_material() == {"FINISHED"}
        assert sphere.active_material["pw_light_mode"] == "AMBIENT"
        materials = len(bpy.data.materials)
        with pytest.raises(RuntimeError, match="key light 'Nothing': no object of that name"):
            bpy.ops.porous_weathering.add_porous_material(key_light="Nothing")
        assert len(sphere.material_slots) == 1 and len(bpy.data.materials) == materials  # nothing left behind
    finally:
        porous_weathering.unregister()


def test_key_light_drivers_need_no_python(fresh_scene):
    sun = studio.add_sun(fresh_scene, (0.3, 0.2, 0.9))
    material = porous_weathering.make_porous_material("P", key_light=sun, **PARAMS)
    drivers = material.node_tree.animation_data.drivers
    assert len(drivers) == 3
    for fcurve in drivers:
        assert fcurve.driver.type == "SUM" and fcurve.driver.is_valid
        assert [v.type for v in fcurve.driver.variables] == ["TRANSFORMS"]


def test_saved_file_reopens_and_renders_the_same_with_auto_run_off(fresh_scene, tmp_path):
    sphere = LitSphere(fresh_scene, towards=(0.4, -0.2, 0.9))
    material = porous_weathering.make_porous_material("P", key_light=sphere.sun, **PARAMS)
    before = sphere.render(material)
    path = tmp_path / "saved porous é.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))

    bpy.context.preferences.filepaths.use_scripts_auto_execute = False
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False, use_scripts=False)
    scene = bpy.context.scene
    after = render.render_array(scene)
    assert np.array_equal(before, after)

    studio.aim_sun(bpy.data.objects["Sun"], (-0.6, 0.3, 0.74))  # drivers still follow the light
    moved = render.render_array(scene)
    assert not np.allclose(moved, after, atol=1e-3)
