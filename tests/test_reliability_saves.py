"""Saves and maps that lose nothing (docs/reliability.md, "Saves, panel maps and up-front
checks"): the panel's efflorescence map follows the bake's provenance rule and never edits a
user's image; ``bake --save`` never rewrites a newer Blender's file in an older format; what
can be checked before a bake is (faces after modifiers, samples, file-name length, ``--out``,
API types); and every command exits 0 on bpy 4.5, whose interpreter crashes at exit while
anything is registered."""

import hashlib
import pathlib
import subprocess

import bpy

import numpy as np
import pytest

from bad_meshes import cube
from helpers import ROOT, run_cli
from porous_weathering.cli import selection
from porous_weathering.common import imageio
from porous_weathering.contracts import map_image_property
from porous_weathering.maps import bake, efflorescence_map, rain, sky_bake
from porous_weathering.samples import studio

FAST = ["--resolution", "16", "--samples", "4", "--sun-samples", "4"]
VENVS = {line: ROOT / f".venv-{line}" / "bin" / "python" for line in ("4.5", "5.2")}
#: Names longer than 63 bytes are cut by Blender before 5.0.
LONG_NAMES = bpy.app.version >= (5, 0, 0)


def digest(path):
    return hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()


def error_lines(result):
    return [line for line in result.stderr.replace("\r", "\n").splitlines() if line.startswith("error: ")]


def written(result):
    """The ``written`` lines of a bake's output (Blender says "File written by newer ..." too)."""
    return [line for line in result.stdout.splitlines() if line.startswith("written")]


def venv_python(line):
    """The python of the project's venv of Blender ``line``; the test is skipped without it."""
    if not VENVS[line].exists():
        pytest.skip(f"no .venv-{line} to run Blender {line} in")
    return str(VENVS[line])


# --- the panel's efflorescence map ------------------------------------------------------------


@pytest.fixture
def plane_in(registered, fresh_scene, tmp_path):
    """``plane_in(name)``: the scene, with an active UV-mapped plane, saved as tmp_path/name."""
    plane = studio.add_plane(fresh_scene)
    bpy.context.view_layer.objects.active = plane

    def save_as(name):
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / name))
        return bpy.data.objects["Plane"]

    return save_as


def make_map(**options):
    return bpy.ops.porous_weathering.make_efflorescence_map(source="BRICK_JOINTS", resolution=16, **options)


def test_an_efflorescence_map_of_another_blend_is_refused_unless_replace(plane_in, tmp_path):
    plane = plane_in("first.blend")
    assert make_map() == {"FINISHED"}
    path = efflorescence_map.default_path(plane.name)
    assert make_map(rows=4) == {"FINISHED"}, "the map made from this .blend and object is replaced"
    made = digest(path)
    plane = plane_in("second.blend")  # another .blend beside it, with an object of that name
    with pytest.raises(RuntimeError) as refused:
        make_map()
    message = str(refused.value)
    assert "first.blend (object 'Plane')" in message and "second.blend (object 'Plane')" in message
    assert "Replace" in message and digest(path) == made
    assert make_map(replace=True) == {"FINISHED"}
    assert imageio.read_metadata(path)[imageio.SOURCE_KEY] == str(tmp_path / "second.blend")


def test_a_hand_made_efflorescence_map_is_refused_unless_replace(plane_in):
    plane = plane_in("wall.blend")
    path = efflorescence_map.default_path(plane.name)
    imageio.write_image(path, np.full((8, 8), 0.5, dtype=np.float32))  # painted by hand: no pw:map
    painted = digest(path)
    with pytest.raises(RuntimeError, match="Porous Weathering did not write"):
        make_map()
    assert digest(path) == painted and map_image_property("efflorescence") not in plane
    assert make_map(replace=True) == {"FINISHED"} and digest(path) != painted


def test_a_users_image_of_the_maps_name_is_never_edited(plane_in):
    plane = plane_in("wall.blend")
    name = pathlib.Path(efflorescence_map.default_path(plane.name)).name
    users = bpy.data.images.new(name, 4, 4)
    users.pixels.foreach_set(np.linspace(0.0, 1.0, 64, dtype=np.float32))
    users.pack()
    users.filepath = "//my paintings/salt.png"
    users.colorspace_settings.name = "sRGB"
    plane[map_image_property("efflorescence")] = users.name  # even when the object points at it
    pixels = np.empty(64, dtype=np.float32)
    users.pixels.foreach_get(pixels)

    assert make_map() == {"FINISHED"}
    assert (users.name, users.filepath, users.colorspace_settings.name) == (name, "//my paintings/salt.png", "sRGB")
    assert users.packed_file is not None
    kept = np.empty(64, dtype=np.float32)
    users.pixels.foreach_get(kept)
    assert np.array_equal(kept, pixels)
    made = bpy.data.images[plane[map_image_property("efflorescence")]]
    assert made != users and made.colorspace_settings.name == "Non-Color"
    assert bpy.path.abspath(made.filepath) == efflorescence_map.default_path(plane.name)
    assert make_map(rows=4) == {"FINISHED"} and bpy.data.images[plane[map_image_property("efflorescence")]] == made


# --- saving never downgrades ------------------------------------------------------------------

SAVE_A_CUBE = """
import sys, bpy, bmesh
bpy.ops.wm.read_factory_settings(use_empty=True)
mesh = bpy.data.meshes.new("Cube")
bm = bmesh.new()
bmesh.ops.create_cube(bm, size=1.0)
bm.to_mesh(mesh)
bpy.context.scene.collection.objects.link(bpy.data.objects.new("Cube", mesh))
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
"""


def test_bake_save_refuses_a_newer_blenders_file_unless_allowed(tmp_path):
    newer, older = venv_python("5.2"), venv_python("4.5")
    blend = tmp_path / "cube.blend"
    subprocess.run([newer, "-c", SAVE_A_CUBE, str(blend)], check=True, capture_output=True, timeout=120)
    saved = digest(blend)
    bake_words = [older, "-m", "porous_weathering", "bake", str(blend), "--maps", "edges", "--target", "attribute"]
    for extra in ([], ["--dry-run"]):
        refused = subprocess.run([*bake_words, "--save", *extra], cwd=ROOT, capture_output=True, text=True, timeout=120)
        assert refused.returncode == 2, refused.stderr
        [line] = error_lines(refused)
        assert "saved by Blender 5.2, newer than this Blender 4.5" in line and "--allow-downgrade" in line
        assert not written(refused) and digest(blend) == saved
    allowed = subprocess.run(
        [*bake_words, "--save", "--allow-downgrade"], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert allowed.returncode == 0, allowed.stderr
    assert f"saved     {blend}" in allowed.stdout and digest(blend) != saved


def test_bake_save_of_this_blenders_file_is_not_refused(tmp_path):
    cube(bpy.context.scene)
    blend = tmp_path / "cube.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    result = run_cli("bake", blend, "--maps", "edges", "--target", "attribute", "--save")
    assert result.returncode == 0 and f"saved     {blend}" in result.stdout, result.stderr


# --- checked before any bake ------------------------------------------------------------------


def masked_cube(scene):
    """A cube whose Mask modifier (an empty vertex group) removes every face."""
    obj = cube(scene)
    obj.vertex_groups.new(name="Keep")
    mask = obj.modifiers.new("Mask", "MASK")
    mask.vertex_group = "Keep"
    return obj


def test_a_mesh_whose_modifiers_remove_every_face_is_refused_before_any_map(fresh_scene, tmp_path):
    obj = masked_cube(fresh_scene)
    assert obj.data.polygons and not bake.has_faces(obj)
    options = bake.BakeOptions(maps=("rain", "edges"), resolution=16, out_dir=str(tmp_path / "maps"))
    with pytest.raises(ValueError, match=r"^object 'Cube': its modifiers \(Mask\) leave no face"):
        bake.bake_maps([obj], options)
    assert not (tmp_path / "maps").exists() or not list((tmp_path / "maps").iterdir())
    assert [layer.name for layer in obj.data.uv_layers] == []


def test_a_mesh_whose_modifiers_drop_its_uv_maps_is_refused_before_any_image_map(fresh_scene, tmp_path):
    obj = cube(fresh_scene)
    obj.modifiers.new("Remesh", "REMESH")
    options = bake.BakeOptions(maps=("rain",), resolution=16, out_dir=str(tmp_path / "maps"))
    with pytest.raises(ValueError) as refused:  # was Blender's "No UV map found in ... "Cube.001"", after the unwrap
        bake.bake_maps([obj], options)
    assert str(refused.value) == (
        "object 'Cube': its modifiers (Remesh) drop its UV maps, so image maps cannot be baked through one; "
        "apply them, or bake to attributes (--target attribute)"
    )
    assert not obj.data.uv_layers and not (tmp_path / "maps").exists()


def test_the_command_skips_an_unnamed_faceless_mesh_and_refuses_a_named_one(fresh_scene, tmp_path):
    masked_cube(fresh_scene)
    studio.add_plane(fresh_scene)
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    words = ["--maps", "edges", "--target", "attribute", "--save"]
    skipped = run_cli("bake", blend, *words)
    assert skipped.returncode == 0, skipped.stderr
    assert "warning: object 'Cube' is left out: its mesh has no faces (after its modifiers)" in skipped.stderr
    assert [line.split()[1] for line in written(skipped)] == ["Plane.edges"]
    named = run_cli("bake", blend, *words, "--objects", "Cube", "Plane")
    assert named.returncode == 2
    [line] = error_lines(named)
    assert "object 'Cube': its modifiers (Mask) leave no face" in line and "Cube." not in line
    assert not written(named)


def test_the_command_refuses_a_point_cloud_in_one_line(fresh_scene, tmp_path):
    """A raw scan comes as a point cloud (vertices, no faces): one line says it must be meshed."""
    mesh = bpy.data.meshes.new("Scan")
    mesh.from_pydata([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)], [], [])
    fresh_scene.collection.objects.link(bpy.data.objects.new("Scan", mesh))
    blend = tmp_path / "cloud.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    refused = run_cli("bake", blend, "--out", tmp_path / "maps")
    assert refused.returncode == 2
    [line] = error_lines(refused)
    assert line.endswith("no mesh object with faces: 'Scan' has none (a scan's point cloud must be meshed first)")
    assert not (tmp_path / "maps").exists()


@pytest.mark.parametrize(
    "words, message",
    [
        (["--samples", "99999999999"], "samples must be a whole number from 1 to 16777216, not 99999999999"),
        (["--out", "/proc"], "cannot create a file in the folder /proc"),
    ],
)
def test_bad_options_exit_2_before_anything(fresh_scene, tmp_path, words, message):
    studio.add_plane(fresh_scene)
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    result = run_cli("bake", blend, "--maps", "rain", *FAST[:2], *words)
    assert result.returncode == 2
    [line] = result.stderr.splitlines()
    assert line.startswith("error: ") and message in line
    assert "Read blend" not in result.stdout, "refused before any file was opened"


def test_map_file_names_too_long_for_the_file_system_are_refused_up_front(fresh_scene, tmp_path, monkeypatch):
    plane = studio.add_plane(fresh_scene, name="A Plane")
    options = bake.BakeOptions(maps=("rain", "runoff"), resolution=16, out_dir=str(tmp_path / "maps"))
    monkeypatch.setattr(imageio, "_name_max", lambda folder: len("A Plane.rain.exr"))
    with pytest.raises(ValueError) as refused:
        bake.bake_maps([plane], options)
    assert str(refused.value) == (
        "object 'A Plane': the file name 'A Plane.runoff.exr' is 18 bytes, more than the 16 its folder's "
        "file system holds: rename the object"
    )
    assert not plane.data.uv_layers[1:] and not (tmp_path / "maps").exists()


@pytest.mark.skipif(not LONG_NAMES, reason="Blender 4.5 cuts object names to 63 bytes")
def test_a_255_byte_object_name_is_refused_by_the_command(fresh_scene, tmp_path):
    name = "é" * 127 + "x"  # 255 bytes in UTF-8
    studio.add_plane(fresh_scene, name=name)
    assert len(bpy.data.objects[0].name.encode()) == 255
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    result = run_cli("bake", blend, "--maps", "rain", "--out", tmp_path / "maps", *FAST)
    assert result.returncode == 2
    [line] = error_lines(result)
    assert f"object '{name}': the file name" in line and "is 264 bytes, more than the 255" in line
    assert not (tmp_path / "maps").exists() or not list((tmp_path / "maps").iterdir())


def test_an_error_line_never_has_an_empty_reason():
    assert selection.one_line(OSError()) == "OSError"
    assert selection.one_line(RuntimeError("Error: cannot\n  open")) == "cannot open"


def test_api_types_are_checked_with_the_arguments_name(fresh_scene, tmp_path):
    assert bake.BakeOptions(out_dir=tmp_path).out_dir == str(tmp_path)
    with pytest.raises(ValueError, match="out_dir must be a path"):
        bake.BakeOptions(out_dir=3)
    assert efflorescence_map.brick_joint_map(np.int64(16)).shape == (16, 16)
    for bad in (16.0, "16", True):
        with pytest.raises(ValueError, match="^size must be a whole number"):
            efflorescence_map.brick_joint_map(bad)
    plane = studio.add_plane(fresh_scene)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "wall.blend"))
    with pytest.raises(ValueError, match="^size must be a whole number"):
        efflorescence_map.make_map(plane, size=16.0)
    assert not pathlib.Path(efflorescence_map.default_path("Plane")).exists()
    assert efflorescence_map.make_map(plane, size=np.int32(16)).size[:] == (16, 16)
    assert rain.RainSettings(samples=sky_bake.MAX_SAMPLES).samples == 1 << 24


# --- exit codes on bpy 4.5 --------------------------------------------------------------------

PYTHONS = [pytest.param(line, id=f"blender-{line}") for line in VENVS]


@pytest.mark.parametrize("line", PYTHONS)
def test_a_script_that_registers_the_extension_exits_0(line):
    python = venv_python(line)
    for script in (
        "import porous_weathering as p; p.register()",
        "import porous_weathering as p; p.register(); p.unregister()",
    ):
        done = subprocess.run([python, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, f"{script}: {done.returncode} {done.stderr[-500:]}"
        # unregister() removes the exit hook: run again at exit it would fail on what is gone
        assert "Traceback" not in done.stderr, done.stderr


@pytest.mark.parametrize("line", PYTHONS)
def test_every_command_exits_0_on_success(line, fresh_scene, tmp_path):
    python = venv_python(line)
    blend = tmp_path / "plane.blend"
    subprocess.run([python, "-c", SAVE_A_CUBE, str(blend)], check=True, capture_output=True, timeout=120)
    runs = [[command, "--help"] for command in ("bake", "demo", "export")]
    runs.append(["bake", str(blend), "--maps", "edges", "--target", "attribute", "--save"])
    for words in runs:
        done = subprocess.run(
            [python, "-m", "porous_weathering", *words], cwd=ROOT, capture_output=True, text=True, timeout=120
        )
        assert done.returncode == 0, f"{words}: {done.returncode} {done.stderr[-500:]}"
