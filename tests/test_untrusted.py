"""Untrusted .blend files: what the extension makes needs no Python to render, registering it
adds no handlers, and nothing it does runs code stored in a file (test_extension.py renders a
saved key-light material with auto-run off; these tests build on that)."""

import pathlib
import re
import subprocess
import sys

import bpy

import numpy as np

import porous_weathering
from benchmarks import probes
from porous_weathering.blender import render
from porous_weathering.maps import bake, rain
from porous_weathering.samples import studio
from porous_weathering.shading import material, presets

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "porous_weathering"

#: Ways Python code can run code it did not ship with (a .blend's text blocks, strings).
EXECUTES_STORED_CODE = re.compile(
    # the builtins, not a method of that name (re.compile builds a pattern, it runs no code)
    r"(?<!\.)\b(exec|eval|compile|execfile|__import__)\s*\(|\.as_module\(|\brunpy\b|"
    r"\bpickle\b|\bmarshal\b|bpy\.data\.texts|driver_namespace|use_scripts\s*=\s*True|"
    r"text\.as_string|bpy\.ops\.text\.run_script"
)


def every_material_kind(scene):
    """One material of each kind the extension makes, in the current file."""
    studio.add_sun(scene, (0.3, 0.2, 0.9))
    for kind in ("POINT", "SPOT", "AREA"):
        probes.add_point_light(scene, (1.0, 1.0, 3.0), name=kind.title(), kind=kind)
    made = [porous_weathering.make_porous_material("Ambient"), porous_weathering.make_base_material("Base")]
    made += [porous_weathering.make_porous_material(name, key_light=name) for name in ("Sun", "Point", "Spot", "Area")]
    made += [material.make_preset_material(name, key_light="Sun") for name in presets.PRESETS]
    return made


def drivers_of(id_block):
    animation = getattr(id_block, "animation_data", None)
    return list(animation.drivers) if animation else []


def test_no_material_or_node_group_needs_a_python_driver(fresh_scene):
    every_material_kind(fresh_scene)
    checked = 0
    for block in list(bpy.data.materials) + list(bpy.data.node_groups):
        trees = [block.node_tree] if isinstance(block, bpy.types.Material) else [block]
        for tree in trees:
            for fcurve in drivers_of(tree):
                driver = fcurve.driver
                assert driver.type != "SCRIPTED" or driver.is_simple_expression, (block.name, driver.expression)
                assert driver.is_valid, (block.name, fcurve.data_path)
                # none names a scene: a material appended elsewhere brings none along
                assert all(variable.targets[0].id_type != "SCENE" for variable in driver.variables)
                checked += 1
    stones = sum(preset.structure is not None for preset in presets.PRESETS.values())
    # three per key-light material, one per stone (its unit scale), none elsewhere
    assert checked == 3 * (4 + len(presets.PRESETS)) + stones


def test_registered_extension_adds_no_handlers_and_no_driver_functions():
    def handlers():
        return {
            name: len(getattr(bpy.app.handlers, name))
            for name in dir(bpy.app.handlers)
            if isinstance(getattr(bpy.app.handlers, name), list)
        }

    before, namespace = handlers(), set(bpy.app.driver_namespace)
    porous_weathering.register()
    try:
        assert handlers() == before
        assert set(bpy.app.driver_namespace) == namespace
        assert not bpy.app.timers.is_registered(porous_weathering.register)
    finally:
        porous_weathering.unregister()


def test_package_source_runs_no_stored_code():
    sources = sorted(PACKAGE.rglob("*.py"))
    assert len(sources) > 10
    offending = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in sources
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if EXECUTES_STORED_CODE.search(line)
    ]
    assert offending == []


def test_the_code_scan_would_catch_stored_code_being_run():
    for line in (
        "exec(text)",
        "eval (expr)",
        "bpy.data.texts['x'].as_module()",
        "mod = __import__(name)",
        "code = compile(text, 'x', 'exec')",
        "bpy.ops.wm.open_mainfile(filepath=p, use_scripts=True)",
        "bpy.app.driver_namespace['f'] = f",
    ):
        assert EXECUTES_STORED_CODE.search(line), line


HOSTILE = r"""
import pathlib
pathlib.Path({marker!r}).write_text("a text block ran")
"""


def make_hostile_file(scene, folder):
    """A .blend holding a self-registering text block and a Python driver, each of which
    writes a marker file if it ever runs, and a stone to work on; (path, markers)."""
    markers = [folder / "text block ran", folder / "driver ran"]
    text = bpy.data.texts.new("autorun.py")
    text.write(HOSTILE.format(marker=str(markers[0])))
    text.use_module = True
    stone = studio.add_plane(scene, name="Stone", size=1.0)
    stone["trap"] = 0.0
    driver = stone.driver_add('["trap"]').driver
    driver.type = "SCRIPTED"
    driver.expression = f"__import__('pathlib').Path({str(markers[1])!r}).write_text('x') or 1.0"
    assert not driver.is_simple_expression
    path = folder / "hostile.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    for marker in markers:
        marker.unlink(missing_ok=True)  # in case this session ran them while building
    return path, markers


def test_hostile_file_is_worked_on_without_running_its_code(fresh_scene, tmp_path):
    path, markers = make_hostile_file(fresh_scene, tmp_path)
    bpy.context.preferences.filepaths.use_scripts_auto_execute = False
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False, use_scripts=False)
    scene = bpy.context.scene
    stone = bpy.data.objects["Stone"]
    porous_weathering.register()
    try:
        bpy.context.view_layer.objects.active = stone
        assert bpy.ops.porous_weathering.add_porous_material() == {"FINISHED"}
    finally:
        porous_weathering.unregister()
    bake.bake_maps(
        [stone],
        bake.BakeOptions(maps=("rain", "edges"), target="attribute", rain_settings=rain.RainSettings(samples=1)),
    )
    studio.add_sun(scene, (0.2, 0.1, 0.95))
    studio.add_ortho_camera(scene, scale=1.2)
    render.use_cycles(scene, size=16, samples=1)
    image = render.render_array(scene)
    assert np.isfinite(image).all() and image[..., :3].max() > 0.05  # the porous material renders
    assert [m.exists() for m in markers] == [False, False]


RUN_CLI_TRUSTING_PREFERENCES = r"""
import sys
import bpy
bpy.context.preferences.filepaths.use_scripts_auto_execute = True  # a user who trusts their own files
from porous_weathering.cli import entry
entry.exit_with(["bake", sys.argv[1], "--out", sys.argv[2], "--resolution", "16", "--samples", "1"])
"""


def test_batch_bake_never_runs_code_stored_in_the_files(fresh_scene, tmp_path):
    path, markers = make_hostile_file(fresh_scene, tmp_path)
    result = subprocess.run(
        [sys.executable, "-c", RUN_CLI_TRUSTING_PREFERENCES, str(path), str(tmp_path / "maps")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert [m.exists() for m in markers] == [False, False]
