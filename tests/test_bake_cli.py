"""``python -m porous_weathering bake``, run as users run it: a subprocess on a tiny .blend."""

import hashlib
import os
import tomllib

import bpy

import numpy as np
import pytest

from helpers import ROOT, run_cli
from porous_weathering.common import imageio
from porous_weathering.maps import bake, edges, lightmap
from porous_weathering.maps import registry as maps
from porous_weathering.samples import studio

FAST = ["--resolution", "16", "--samples", "4", "--sun-samples", "4"]


def statuses(result):
    return [line.split()[0] for line in result.stdout.splitlines() if line.startswith(("written", "unchanged"))]


@pytest.fixture
def blend(fresh_scene, tmp_path):
    """A 4 x 4 plane with a unit cube standing on it, and an empty."""
    studio.add_plane(fresh_scene, size=4.0)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
    studio.link(fresh_scene, bpy.data.objects.new("Marker", None))
    path = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return path


def test_maps_are_written_and_a_rerun_skips_them(blend, tmp_path):
    out = tmp_path / "maps"
    first = run_cli("bake", blend, "--out", out, *FAST)
    assert first.returncode == 0, first.stderr
    # no --maps: every map of the registry
    assert sorted(os.listdir(out)) == sorted(f"{obj}.{name}.exr" for obj in ("Cube", "Plane") for name in maps.names())
    assert "100%" in first.stderr  # the progress bar
    # Blender's notes on each image bake, and on opening the file (its check, then its run)
    assert "Baking map saved" not in first.stdout + first.stderr and "Read blend" not in first.stdout
    # nor Blender 4's lines on each bake's progress ("Fra:1 Mem:..."), among the status lines
    assert [line for line in first.stdout.splitlines() if "Fra:" in line or not line.strip()] == []
    plane, metadata = imageio.read_image(out / "Plane.rain.exr")
    assert plane.shape == (16, 16, 1) and metadata["pw:uv_map"] == "UVMap"
    assert plane[0, 0, 0] == pytest.approx(1.0, abs=0.02)  # open corner
    assert plane[8, 8, 0] < 0.05  # under the cube
    stamp = os.stat(out / "Plane.rain.exr").st_mtime_ns
    again = run_cli("bake", blend, "--out", out, *FAST)
    assert again.returncode == 0, again.stderr
    assert statuses(again) == ["unchanged"] * 2 * len(maps.names())
    assert os.stat(out / "Plane.rain.exr").st_mtime_ns == stamp
    changed = run_cli("bake", blend, "--out", out, *FAST, "--rain-cone", "20")
    # only the rain maps depend on it, and the maps that read them
    on_rain = [kind.name for kind in maps.all_kinds() if kind.name == "rain" or "rain" in kind.reads]
    assert sorted(statuses(changed)) == sorted(
        ["written" if name in on_rain else "unchanged" for name in maps.names()] * 2
    )


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("target", ["attribute", "image"])
def test_a_save_run_again_leaves_the_file_and_its_backup(blend, tmp_path, target):
    """Run twice, the second finds every map up to date and linked: the file is not saved again,
    so Blender's backup (FILE.blend1) still holds the file as it was before the first bake."""
    words = ["bake", blend, "--objects", "Cube", "--target", target, "--out", tmp_path / "maps", "--save", *FAST]
    if target == "image":  # no UV map of its own: the bake lays out its lightmap
        bpy.ops.wm.open_mainfile(filepath=str(blend))
        uv_maps = bpy.data.objects["Cube"].data.uv_layers
        while uv_maps:
            uv_maps.remove(uv_maps[0])
        bpy.ops.wm.save_mainfile()
        os.remove(blend.with_name(blend.name + "1"))
    original = digest(blend)
    first = run_cli(*words)
    assert first.returncode == 0 and f"saved     {blend}" in first.stdout, first.stderr
    baked = digest(blend)
    again = run_cli(*words)
    assert again.returncode == 0 and f"unchanged {blend}" in again.stdout, again.stderr
    assert set(statuses(again)) == {"unchanged"} and "saved" not in again.stdout
    assert digest(blend) == baked and digest(blend.with_name(blend.name + "1")) == original
    if target == "image":  # the lightmap laid out again, the maps on it unchanged: saved, or the file lacks it
        bpy.ops.wm.open_mainfile(filepath=str(blend))
        uv_maps = bpy.data.objects["Cube"].data.uv_layers
        uv_maps.remove(uv_maps[lightmap.LIGHTMAP_UV])
        bpy.ops.wm.save_mainfile()
        relaid = run_cli(*words)
        assert relaid.returncode == 0 and f"saved     {blend}" in relaid.stdout, relaid.stderr
        bpy.ops.wm.open_mainfile(filepath=str(blend))
        assert lightmap.LIGHTMAP_UV in bpy.data.objects["Cube"].data.uv_layers


def test_dry_run_writes_nothing(blend, tmp_path):
    out = tmp_path / "maps"
    result = run_cli("bake", blend, "--out", out, "--objects", "Cube", "--dry-run", *FAST)
    assert result.returncode == 0, result.stderr
    assert "planned" in result.stdout and "Cube.rain.exr" in result.stdout
    assert not out.exists()
    assert sorted(os.listdir(tmp_path)) == ["scene.blend"]


@pytest.mark.parametrize(
    "args, code, message",
    [
        (["missing.blend"], 2, "no such .blend file"),
        (["{folder}"], 2, "is a folder, not a .blend file"),
        ([], 2, "no .blend file given"),
        (["--objects", "{blend}"], 2, "--objects needs at least one object name"),
        (["{blend}", "--resolution", "1"], 2, "resolution"),
        (["{blend}", "--objects", "Marker"], 2, "'Marker' has no mesh"),
        (["{blend}", "--objects", "Nobody"], 2, "no object named Nobody"),
        (["{blend}", "--out", "/proc/forbidden"], 2, "/proc/forbidden"),
        (["{blend}", "--target", "attribute"], 2, "--save"),
        (["{blend}", "--edge-radius", "0"], 2, "edge radius must be a positive number"),
        (["{blend}", "--occluders", "Nowhere", "--dry-run"], 2, "no collection named 'Nowhere'"),
    ],
)
def test_bad_input_fails_with_one_clear_line(blend, args, code, message):
    """Exit 2 for bad input, found before anything is baked: in the words, or in a file (each is
    opened and checked first)."""
    result = run_cli("bake", *[a.format(blend=blend, folder=blend.parent) for a in args])
    assert result.returncode == code, result.stderr
    [line] = result.stderr.splitlines()
    assert line.startswith("error: ") and message in line


@pytest.mark.parametrize("command", ["bake", "survey", "export"])
def test_a_file_blender_cannot_open_is_one_line(blend, tmp_path, command):
    """A file that is not a .blend fails as its own work does (exit 1), in one line of ours and
    none of Blender's reports; in a batch, the good file of the same run is baked all the same."""
    broken = tmp_path / "broken.blend"
    broken.write_text("not a blend file")
    out = tmp_path / "out"
    words = {
        "bake": [blend, "--resolution", "16", "--samples", "4", "--sun-samples", "4", "--maps", "edges"],
        "survey": ["--years", "10"],
        "export": ["--ages", "1", "--size", "16"],
    }
    result = run_cli(command, broken, *words[command], "--out", out, timeout=300)
    assert result.returncode == 1, result.stderr
    [line] = [line for line in result.stderr.replace("\r", "\n").splitlines() if line.strip() and "[" not in line]
    assert line == f'error: {broken}: File format is not supported in file "{broken}"'
    assert "File format" not in result.stdout, result.stdout  # Blender's reports, on its stdout
    assert sorted(os.listdir(out) if out.exists() else []) == (
        ["Cube.edges.exr", "Plane.edges.exr"] if command == "bake" else []
    )


def test_bad_maps_option_is_refused(blend):
    result = run_cli("bake", blend, "--maps", "rain,snow")
    assert result.returncode == 2 and "rain, edges" in result.stderr and len(result.stderr.splitlines()) == 1


def test_help_documents_every_option():
    result = run_cli("bake", "--help")
    for option in (
        "--objects",
        "--collection",
        "--maps",
        "--target",
        "--resolution",
        "--samples",
        "--rain-cone",
        "--wind-azimuth",
        "--wind-tilt",
        "--edge-radius",
        "--occluders",
        "--out",
        "--save",
        "--dry-run",
        "--force",
        "--workers",
        "--scheduler",
    ):
        assert option in result.stdout


def test_version_names_the_extension_and_the_blender_it_runs_in():
    """``--version`` prints the manifest's version and bpy's as the last line of standard output
    (exit 0; Blender's own log may come before it), with or without a command after it."""
    with open(ROOT / "blender_manifest.toml", "rb") as stream:
        version = tomllib.load(stream)["version"]
    for words in (["--version"], ["--version", "bake"]):
        result = run_cli(*words)
        assert result.returncode == 0, result.stderr
        assert result.stdout.splitlines()[-1] == f"Porous Weathering {version} (Blender {bpy.app.version_string})"


def test_occluders_option_chooses_what_shelters(blend, tmp_path):
    """With only an empty collection as occluders, the cube no longer shelters the plane."""
    bpy.context.scene.collection.children.link(bpy.data.collections.new("Open Sky"))
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    result = run_cli("bake", blend, "--out", tmp_path / "open", "--objects", "Plane", "--occluders", "Open Sky", *FAST)
    assert result.returncode == 0, result.stderr
    plane, _ = imageio.read_image(tmp_path / "open" / "Plane.rain.exr")
    assert plane[8, 8, 0] == pytest.approx(1.0, abs=0.02)  # under the cube, which is not an occluder now


def test_edge_radius_option_sets_the_smoothing_radius(blend):
    result = run_cli(
        "bake", blend, "--objects", "Cube", "--maps", "edges", "--target", "attribute", "--edge-radius", "0.3", "--save"
    )
    assert result.returncode == 0, result.stderr
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    cube = bpy.data.objects["Cube"]
    colours = np.empty(len(cube.data.vertices) * 4, dtype=np.float32)
    cube.data.color_attributes[bake.ATTRIBUTES["edges"]].data.foreach_get("color", colours)
    assert np.allclose(colours[0::4], edges.curvature_mask(edges.curvature(cube, 0.3), 0.3))
    # A cube's 8 corners read alike at any radius: its stored inputs tell 0.3 from the default.
    for given, status in (({"edge_radius": 0.3}, "unchanged"), ({}, "planned")):
        options = bake.BakeOptions(maps=("edges",), target="attribute", **given)
        assert [outcome.status for outcome in bake.bake_maps([cube], options, dry_run=True)] == [status]


def test_save_links_images_and_attributes_into_the_blend(blend, tmp_path):
    out = tmp_path / "maps"
    result = run_cli("bake", blend, "--out", out, "--objects", "Plane", "--save", *FAST)
    assert result.returncode == 0, result.stderr
    result = run_cli("bake", blend, "--objects", "Cube", "--target", "attribute", "--save", "--samples", "4")
    assert result.returncode == 0, result.stderr
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    image = bpy.data.images[bpy.data.objects["Plane"]["pw_rain_image"]]
    assert image.filepath == "//maps/Plane.rain.exr"
    cube = bpy.data.objects["Cube"].data
    colours = np.empty(len(cube.loops) * 4, dtype=np.float32)
    cube.color_attributes["pw_rain"].data.foreach_get("color", colours)
    top = [i for p in cube.polygons if p.normal.z > 0.9 for i in p.loop_indices]
    assert np.allclose(colours[0::4][top], 1.0, atol=0.05)


def test_run_does_not_depend_on_how_it_was_invoked(blend, tmp_path, capsys):
    """The in-process entry point (what ``blender -c porous_weathering bake`` calls)."""
    from porous_weathering.cli import entry

    assert entry.main(["bake", str(blend), "--out", str(tmp_path / "maps"), "--objects", "Cube", *FAST]) == 0
    assert (tmp_path / "maps" / "Cube.rain.exr").is_file()
    assert bake.image_path(str(tmp_path), "Cube", "edges").endswith("Cube.edges.exr")
