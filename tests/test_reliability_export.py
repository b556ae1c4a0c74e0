"""Reliability of the export (docs/reliability.md, "The export"): the .glb and its paradata
replaced together or not at all, no temporary file or folder left by an error or a signal at
any stage (and a killed run's folder cleaned by the next), no silent overwrite of a pair made
from something else, bad input refused up front in one line, and messages and names that say
the truth (JSON paradata, variant and material names)."""

import json
import os
import pathlib
import signal
import subprocess
import sys

import bpy

import numpy as np
import pytest
from test_export import make_wall, read_glb, save, variant_materials

from helpers import ROOT, cli_command, run_cli, temporary_env
from porous_weathering.common import atomic
from porous_weathering.publish import export

SIZE = 16


def files(folder):
    """{name: bytes} of the files in ``folder`` (hidden temporary files included)."""
    return {path.name: path.read_bytes() for path in pathlib.Path(folder).iterdir()}


def litter(folder):
    """The export's temporary folders in ``folder`` (a TMPDIR)."""
    return [name for name in os.listdir(folder) if name.startswith(export.FOLDER_PREFIX)]


def one_error_line(done):
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    return errors[0]


# --- one transaction ------------------------------------------------------------------------


def test_a_failed_rename_gives_back_the_previous_pair(tmp_path, monkeypatch):
    """The paradata cannot be renamed into place (after the .glb was): the .glb is rolled back,
    the old pair is byte-identical, and no temporary file is left beside it."""
    wall = make_wall()
    save(tmp_path)
    out = tmp_path / "out"
    first = export.export_variants([wall], (1.0,), size=SIZE, out_dir=out)
    before = files(out)
    replace = os.replace

    def failing(source, target):
        if str(target) == first.paradata and str(source).endswith(".json"):  # the new paradata, not the old
            raise PermissionError(13, "Permission denied", target)
        replace(source, target)

    monkeypatch.setattr(atomic.os, "replace", failing)
    with pytest.raises(PermissionError):
        export.export_variants([wall], (0.5, 1.0), size=SIZE, out_dir=out)
    monkeypatch.undo()
    assert files(out) == before  # the old .glb back, no hidden .pw_* left


def test_move_into_place_together_rolls_back_a_new_pair(tmp_path):
    """Where nothing was before, a failed second rename removes the first file again."""
    (tmp_path / "b.json").mkdir()  # a folder cannot be replaced by a file
    (tmp_path / "b.json" / "keep").write_text("x")
    with atomic.temporary_file(str(tmp_path), ".glb") as glb, atomic.temporary_file(str(tmp_path), ".json") as side:
        with pytest.raises(OSError):
            atomic.move_into_place_together([(glb, str(tmp_path / "a.glb")), (side, str(tmp_path / "b.json"))])
    assert sorted(os.listdir(tmp_path)) == ["b.json"] and os.listdir(tmp_path / "b.json") == ["keep"]


#: The export, stopped at one stage to be sent a signal: the stage's function is wrapped so that
#: once it has run (the copy made, a texture written, the .glb written to its temporary file) the
#: child says so and waits.
CHILD_AT_STAGE = r"""
import sys, time
from porous_weathering.cli import entry
from porous_weathering.blender import scratch_scene
from porous_weathering.publish import export, gltf, textures
stage = sys.argv.pop(1)
owner, name = {
    "lightmap": (export._Scratch, "copy"),
    "bake": (scratch_scene, "emit_bake"),
    "textures": (textures, "_write_png"),
    "write": (gltf, "export_gltf"),
}[stage]
original = getattr(owner, name)
def stalled(*args, **kwargs):
    result = original(*args, **kwargs)
    print("AT " + stage, flush=True)
    time.sleep(120)
    return result
setattr(owner, name, stalled)
entry.exit_with(sys.argv[1:])
"""


@pytest.fixture
def exported_once(tmp_path):
    """A wall exported once to OUT (the pair a later export replaces) and a TMPDIR of its own."""
    wall = make_wall()
    blend = save(tmp_path)
    out = tmp_path / "out"
    export.export_variants([wall], (1.0,), size=SIZE, out_dir=out)
    temporary = tmp_path / "tmp"
    return blend, out, temporary


def start_at(stage, blend, out, temporary, *words):
    return subprocess.Popen(
        [sys.executable, "-c", CHILD_AT_STAGE, stage, "export", blend, "--ages", "0.5,1", "--size", str(SIZE)]
        + ["--out", str(out), *words],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=temporary_env(temporary),
    )


@pytest.mark.parametrize(
    "stage, sent",
    [
        ("lightmap", signal.SIGINT),
        ("bake", signal.SIGTERM),
        ("textures", signal.SIGINT),
        ("write", signal.SIGTERM),
    ],
)
def test_a_signal_at_any_stage_leaves_the_old_pair_and_no_temporary_files(exported_once, stage, sent):
    blend, out, temporary = exported_once
    before = files(out)
    child = start_at(stage, blend, out, temporary)
    try:
        assert any(line.strip() == f"AT {stage}" for line in iter(child.stdout.readline, "")), child.stderr.read()
        assert litter(temporary)  # the texture folder exists while the export runs
        if stage == "write":
            assert any(name.startswith(".pw_") for name in os.listdir(out))  # the new .glb, not yet in place
        child.send_signal(sent)
        _, stderr = child.communicate(timeout=60)
    finally:
        child.kill()
    assert child.returncode == 128 + sent, stderr
    assert stderr.strip().splitlines()[-1] == f"interrupted by {sent.name}: nothing was written"
    assert files(out) == before
    assert not os.listdir(temporary)  # no texture folder, nor Blender's for the session


def test_a_killed_runs_texture_folder_is_removed_by_the_next_run(exported_once):
    blend, out, temporary = exported_once
    child = start_at("textures", blend, out, temporary)
    try:
        assert any(line.strip() == "AT textures" for line in iter(child.stdout.readline, "")), child.stderr.read()
        child.send_signal(signal.SIGKILL)  # no chance to clean up
        child.communicate(timeout=60)
    finally:
        child.kill()
    [stale] = litter(temporary)
    assert stale.startswith(f"{export.FOLDER_PREFIX}{child.pid}_")
    assert any(path.suffix == ".png" for path in (temporary / stale).rglob("*"))
    alive = temporary / f"{export.FOLDER_PREFIX}{os.getpid()}_running"  # a live process's: kept
    alive.mkdir()
    done = subprocess.run(
        cli_command("export", blend, "--ages", "1", "--size", SIZE, "--out", out),
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env=temporary_env(temporary),
    )
    assert done.returncode == 0, done.stderr
    assert litter(temporary) == [alive.name]


# --- no silent overwrite --------------------------------------------------------------------


def test_a_pair_from_another_blend_is_refused_unless_forced(tmp_path):
    """Two .blend files, one --out and --name: the second is refused with exit 3 naming both
    files, the first's pair byte-identical; --force replaces it."""
    wall = make_wall()
    first_blend = save(tmp_path, "first.blend")
    out = tmp_path / "out"
    export.export_variants([wall], (1.0,), size=SIZE, out_dir=out, name="wall")
    second_blend = save(tmp_path, "second.blend")
    before = files(out)
    common = ["--ages", "1", "--size", SIZE, "--out", out, "--name", "wall"]
    done = run_cli("export", second_blend, *common, timeout=300)
    assert done.returncode == 3, done.stderr
    error = one_error_line(done)
    assert f"made from {first_blend}, not from {second_blend}" in error and "--force" in error
    assert files(out) == before
    done = run_cli("export", second_blend, *common, "--force", timeout=300)
    assert done.returncode == 0, done.stderr
    with open(out / "wall.paradata.json", encoding="utf-8") as stream:
        assert json.load(stream)["source"]["blend_file"] == second_blend


def test_other_objects_a_changed_glb_and_foreign_files_are_refused(tmp_path):
    wall = make_wall()
    other = make_wall("Other")
    save(tmp_path)
    out = tmp_path / "out"
    result = export.export_variants([wall], (1.0,), size=SIZE, out_dir=out)
    with pytest.raises(export.OverwriteRefused, match="holds the objects Wall, not Other, Wall"):
        export.export_variants([wall, other], (1.0,), size=SIZE, out_dir=out)
    with open(result.path, "ab") as stream:  # changed by hand since
        stream.write(b"    ")
    with pytest.raises(export.OverwriteRefused, match="was changed since"):
        export.export_variants([wall], (1.0,), size=SIZE, out_dir=out)
    os.remove(result.paradata)  # a .glb without paradata: not the extension's
    with pytest.raises(export.OverwriteRefused, match="not written by Porous Weathering") as error:
        export.export_variants([wall], (1.0,), size=SIZE, out_dir=out)
    assert result.path in str(error.value)
    assert sorted(os.listdir(out)) == ["wall.glb"]
    forced = export.export_variants([wall, other], (1.0,), size=SIZE, out_dir=out, force=True)
    assert sorted(os.listdir(out)) == ["wall.glb", "wall.paradata.json"]
    assert sorted(node["name"] for node in read_glb(forced.path)[0]["nodes"]) == ["Other", "Wall"]


def test_the_operator_refuses_unless_replace(tmp_path, registered):
    wall = make_wall()
    save(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "panel.glb").write_bytes(b"someone else's model")
    wall.select_set(True)
    operator = bpy.ops.porous_weathering.export_variants
    assert operator.get_rna_type().properties["force"].name == "Replace"
    with pytest.raises(RuntimeError, match="not written by Porous Weathering.*tick Replace"):
        operator(ages="1", size=SIZE, out_dir=str(out), name="panel")
    assert files(out) == {"panel.glb": b"someone else's model"}
    assert operator(ages="1", size=SIZE, out_dir=str(out), name="panel", force=True) == {"FINISHED"}
    assert sorted(os.listdir(out)) == ["panel.glb", "panel.paradata.json"]


# --- checked up front -----------------------------------------------------------------------


def masked(wall):
    """A Mask modifier whose (empty) vertex group removes every face."""
    wall.vertex_groups.new(name="none")
    wall.modifiers.new("Mask", "MASK").vertex_group = "none"


@pytest.mark.parametrize(
    "case, message",
    [
        ("mask", "object 'Wall': its modifiers (Mask) leave no faces: nothing to export"),
        ("remesh", "object 'Wall': its modifiers (Remesh) leave no UV map"),
        ("long object name", "its name is too long"),
        ("name ..", "must not start with '.'"),
        ("hidden name", "must not start with '.'"),
        ("long file name", "is too long"),
        ("size 16.0", "size must be a whole number"),
        ("out_dir 3", "out_dir must be a folder's path"),
        ("ages None", "ages must be a sequence"),
        ("notes set", "notes['seen'] must hold JSON values"),
        ("notes not a mapping", "notes must be a mapping"),
    ],
)
def test_bad_input_is_refused_up_front_in_one_line(tmp_path, case, message, monkeypatch):
    wall = make_wall()
    save(tmp_path)
    id_max = bpy.types.ID.bl_rna.properties["name"].length_max - 1
    arguments = dict(ages=(1.0,), size=SIZE, out_dir=tmp_path / "out")
    if case == "mask":
        masked(wall)
    elif case == "remesh":
        wall.modifiers.new("Remesh", "REMESH")
    elif case == "long object name":
        wall.name = "W" * id_max
    arguments.update(
        {
            "name ..": dict(name=".."),
            "hidden name": dict(name=".wall"),
            "long file name": dict(name="n" * 250),
            "size 16.0": dict(size=16.0),
            "out_dir 3": dict(out_dir=3),
            "ages None": dict(ages=None),
            "notes set": dict(notes={"seen": {1, 2}}),
            "notes not a mapping": dict(notes=["a"]),
        }.get(case, {})
    )
    made = []  # nothing may be baked: the export's first step is a copy of the object
    monkeypatch.setattr(export._Scratch, "copy", lambda *args: made.append(args))
    counts = (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.scenes), len(bpy.data.materials))
    with pytest.raises(ValueError) as error:
        export.export_variants([wall], arguments.pop("ages"), **arguments)
    assert message in str(error.value) and "\n" not in str(error.value)
    assert "Wall.0" not in str(error.value)  # never the name of an internal copy
    assert not made and not os.path.exists(tmp_path / "out")
    assert (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.scenes), len(bpy.data.materials)) == counts
    assert [modifier.name for modifier in wall.modifiers] == {"mask": ["Mask"], "remesh": ["Remesh"]}.get(case, [])


def test_the_types_the_api_takes(tmp_path):
    options = export.ExportOptions(ages=np.array([1.0, 0.5]), size=np.int64(16), out_dir=tmp_path)
    assert options.size == 16 and type(options.size) is int
    assert options.out_dir == str(tmp_path) and options.ages == (0.5, 1.0)
    with pytest.raises(ValueError, match="size"):
        export.ExportOptions(size=True)
    assert export.ExportOptions(name="").name is None  # the operator's empty field: the .blend's name
    with pytest.raises(ValueError, match="must be a file name"):
        export.ExportOptions(name="  ")


def test_the_command_line_refuses_bad_input_with_exit_2(tmp_path):
    wall = make_wall()
    masked(wall)
    blend = save(tmp_path)
    for words, message in (
        (["--objects", "Wall", "--out", tmp_path / "out"], "object 'Wall': its modifiers (Mask) leave no faces"),
        (["--objects", "Wall", "--name", "..", "--out", tmp_path / "out"], "must not start with '.'"),
    ):
        done = run_cli("export", blend, *words, "--size", SIZE, timeout=300)
        assert done.returncode == 2, done.stderr
        assert message in one_error_line(done)
    assert not os.path.exists(tmp_path / "out")


def test_the_out_folder_is_tried_before_any_work(tmp_path):
    make_wall()
    blend = save(tmp_path)
    done = run_cli("export", blend, "--ages", "1", "--size", SIZE, "--out", "/proc", timeout=300)
    assert done.returncode == 2, done.stderr
    assert "the output folder /proc (--out) cannot take the files: " in one_error_line(done)
    assert "Wall:" not in done.stderr  # no step started


def test_a_faceless_mesh_is_skipped_when_not_asked_for(tmp_path):
    make_wall()
    ghost = make_wall("Ghost")
    masked(ghost)
    blend = save(tmp_path)
    done = run_cli("export", blend, "--ages", "1", "--size", SIZE, "--out", tmp_path / "out", timeout=300)
    assert done.returncode == 0, done.stderr
    assert "warning: object 'Ghost' has no faces (after its modifiers): skipped" in done.stderr
    gltf_json, _ = read_glb(tmp_path / "out" / "wall.glb")
    assert [node["name"] for node in gltf_json["nodes"]] == ["Wall"]


# --- messages and names ---------------------------------------------------------------------


#: The export whose glTF exporter fails for real: its temporary .glb is made a folder.
CHILD_BROKEN_GLTF = r"""
import os, sys
from porous_weathering.cli import entry
from porous_weathering.publish import gltf
write = gltf.export_gltf
def into_a_folder(scene, path, image_format):
    os.remove(path)
    os.mkdir(path)
    try:
        write(scene, path, image_format)
    finally:
        os.rmdir(path)
gltf.export_gltf = into_a_folder
entry.exit_with(sys.argv[1:])
"""


def test_a_gltf_addon_error_is_one_line(tmp_path):
    """Blender's glTF exporter fails: exit 1 and one line saying why, none of the add-on's
    traceback (Blender prints it to stdout itself), nothing left."""
    make_wall()
    blend = save(tmp_path)
    words = ["export", blend, "--ages", "1", "--size", str(SIZE), "--out", str(tmp_path / "out")]
    done = subprocess.run(
        [sys.executable, "-c", CHILD_BROKEN_GLTF, *words], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 1, done.stderr
    error = one_error_line(done)
    assert "Blender's glTF exporter could not write " in error and error.endswith(".glb'")
    assert "Is a directory" in error and "Traceback" not in done.stdout
    assert not os.listdir(tmp_path / "out")


def test_names_notes_and_the_users_materials(tmp_path):
    """Ages that differ in the 7th digit give two variants and two materials; NaN and inf notes
    are null in a paradata that is valid JSON; a user's materials "Wall clean" and "Wall t=1"
    (an earlier export re-imported) keep their names and the .glb's are not suffixed .001."""
    wall = make_wall()
    mine = [bpy.data.materials.new(name) for name in ("Wall clean", "Wall t=0.1234561")]
    save(tmp_path)
    names = sorted(bpy.data.materials.keys())
    notes = {"a": float("nan"), "b": [float("inf"), 1], "c": {"d": -float("inf")}, "e": np.float32(0.5)}
    result = export.export_variants(
        [wall], export.parse_ages("0.1234561,0.1234562"), size=SIZE, out_dir=tmp_path / "out", notes=notes
    )
    assert result.variants == ("clean", "t=0.1234561", "t=0.1234562")
    materials = variant_materials(read_glb(result.path)[0])
    assert {variant: material["name"] for variant, material in materials.items()} == {
        variant: f"Wall {variant}" for variant in result.variants
    }
    assert sorted(bpy.data.materials.keys()) == names and [m.name for m in mine] == ["Wall clean", "Wall t=0.1234561"]
    with open(result.paradata, encoding="utf-8") as stream:
        text = stream.read()
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text)["notes"] == {"a": None, "b": [None, 1], "c": {"d": None}, "e": 0.5}
    assert export.format_ages((0.0, 0.5, 1.0)) == "0,0.5,1"  # the names pinned before stay
