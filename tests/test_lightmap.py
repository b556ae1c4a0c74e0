"""Lightmaps that are right or refused, at any unit (docs/maps.md, "The lightmap"; docs/scans.md,
"Lightmaps at scan size").

The check finds each fault it is for; a new lightmap of a scan-like bust passes it in
millimetres, metres and normalised units, with the same quality; the extension's own lightmap
is reused, so a second bake (after saving and reopening, from the command line too) reports
"unchanged"; a lightmap that cannot be made, or no longer fits, is refused and leaves nothing;
the unwrap is a step of its own with progress, and closing the bake during it stops its
process at once."""

import math
import os
import pathlib
import subprocess
import sys

import bpy

import numpy as np
import pytest

from porous_weathering.common import imageio
from porous_weathering.maps import bake, lightmap, lightmap_child, rain, sky_bake
from porous_weathering.maps import registry as maps
from scripts import load_script

ROOT = pathlib.Path(__file__).resolve().parent.parent
SCAN = load_script("sample_blends/scan_generator.py")
#: Above uv.XATLAS_CHARTS: the scans' path (charts by projection on the axes).
TRIANGLES = 30_000
#: The scan generator's units, and a 269k-triangle head scan's size: about 0.1 units across.
SCALES = {unit: factor for unit, factor in SCAN.UNITS.items()} | {"tenth": 0.1 * SCAN.UNITS["normalised"]}
FAST_RAIN = rain.RainSettings(samples=1)


def report_of(obj, name, resolution):
    geometry = lightmap.Geometry.of(obj.data)
    return lightmap.check_uvs(lightmap.corner_uvs(obj.data, name)[geometry.corners], geometry.areas(), resolution)


# --- the check -----------------------------------------------------------------------------------


def square_pair(gap, size=8.0, resolution=64):
    """Two squares of ``size`` texels (two triangles each, one island each), ``gap`` texels apart."""
    square = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=np.float64) * size
    placed = np.concatenate([square + 4, square + [4 + size + gap, 4]])
    return placed / resolution, np.ones(4)


def test_the_check_passes_a_good_map_and_finds_each_fault():
    good = lightmap.check_uvs(*square_pair(gap=6), 64, padding=4)
    assert good.ok and good.islands == 2 and good.covered == 2 * 8 * 8
    assert good.utilisation == pytest.approx(128 / 64**2)

    crowded = lightmap.check_uvs(*square_pair(gap=3), 64, padding=4)
    assert not crowded.ok and crowded.crowded > 0 and crowded.overlapping == 0

    uvs, areas = square_pair(gap=-2)  # the second square over the first's last two columns
    overlapping = lightmap.check_uvs(uvs, areas, 64, padding=4)
    assert overlapping.overlapping == 2 * 8 and "lie on two triangles" in overlapping.problems()[0]

    uvs, areas = square_pair(gap=6)
    uvs[2:] += [0.9, 0]  # the second square past the right edge
    outside = lightmap.check_uvs(uvs, areas, 64, padding=4)
    assert outside.outside == 2 and "leave [0, 1]" in outside.problems()[0]

    uvs, areas = square_pair(gap=6)
    uvs[0] = np.array([[40, 40], [40.1, 40], [40, 40.1]]) / 64  # an island of 1/6400 of its fair share
    starved = lightmap.check_uvs(uvs, areas, 64, padding=4)
    assert starved.starved == 1 and "fair share" in starved.problems()[0]


def test_the_check_does_not_count_shared_edges_as_overlaps():
    uvs, areas = square_pair(gap=6)
    assert lightmap.overlapping_texels(uvs, 64) == 0  # the diagonal of each square runs through texel centres


# --- new lightmaps, at every unit ----------------------------------------------------------------


def test_a_new_lightmap_passes_the_check_at_every_unit_with_the_same_quality(bust):
    reports = {}
    for unit, scale in SCALES.items():
        mesh = bust(TRIANGLES, unit, scale=scale).data
        geometry = lightmap.Geometry.of(mesh)
        reports[unit] = lightmap.check_uvs(lightmap.lightmap_uvs(mesh, 1024)[geometry.corners], geometry.areas(), 1024)
    for unit, report in reports.items():
        assert report.ok, (unit, report.problems())
        assert report.starved == 0 and report.overlapping == 0 and report.crowded == 0 and report.outside == 0
        assert report.utilisation > 0.4, unit  # the scan gets its texels (xatlas once gave a 0.1-unit head 4%)
        assert report.covered == pytest.approx(reports["mm"].covered, rel=0.05), unit


def ramp(turns=1.5, rings=8, steps=240):
    """A ramp winding ``turns`` times round the Z axis (every face looks up): its mesh."""
    angle = np.linspace(0.0, 2 * math.pi * turns, steps + 1)
    radius = np.linspace(1.0, 2.0, rings + 1)
    a, r = np.meshgrid(angle, radius, indexing="ij")
    vertices = np.stack([r * np.cos(a), r * np.sin(a), 0.05 * a], axis=-1).reshape(-1, 3)
    index = np.arange(len(vertices)).reshape(steps + 1, rings + 1)
    corner = index[:-1, :-1].ravel()
    quads = np.stack([corner, corner + rings + 1, corner + rings + 2, corner + 1], axis=1)
    faces = np.concatenate([quads[:, :3], quads[:, [0, 2, 3]]]).astype(np.int32)
    return SCAN.add_to_scene("Ramp", vertices, faces).data


def test_a_fold_of_the_projection_is_found_and_cut_apart(monkeypatch):
    """A ramp winding one and a half times round the Z axis: every face looks up, so projected
    along Z it lies over itself; the lightmap cuts it apart."""
    mesh = ramp()
    monkeypatch.setattr(lightmap_child, "XATLAS_CHARTS", 0)  # the scans' projection on the axes, whatever the size
    geometry = lightmap.Geometry.of(mesh)
    points = lightmap.normalised(geometry.positions, geometry.vertices)
    normals = lightmap.polygon_normals(points, geometry.vertices, geometry.polygons)
    keys, projected = lightmap.cube_charts(points, geometry.vertices, geometry.polygons, normals)
    assert len(np.unique(keys)) == len(mesh.vertices)  # one chart along +Z ...
    chart_uvs, triangles = lightmap_child._chart_points(keys, projected)
    folded = lightmap_child._folds(chart_uvs, triangles, lightmap_child._charts_of(chart_uvs, triangles), 4.0)
    assert folded.mean() > 0.2  # ... that lies over itself for half a turn
    unwrapped = lightmap.lightmap_uvs(mesh, 512)
    assert lightmap.check_uvs(unwrapped[geometry.corners], geometry.areas(), 512).ok


def test_where_the_charts_made_again_fold_too_each_face_goes_alone(monkeypatch):
    """xatlas' own charts can fold on a scan's busy relief (the Nefertiti bust's scan, 100k
    triangles, did at every resolution): here the re-charting folds as the projection did, and
    the lightmap still passes, its folded faces each a chart of its own."""
    mesh = ramp()

    def folding_charts(points, vertices, polygons, normals):
        """One chart per connected piece, each wound three times round: it lies over itself."""
        turned = (points[:, 0] + 1j * points[:, 1]) ** 3 / np.abs(points[:, 0] + 1j * points[:, 1]) ** 2
        return vertices.astype(np.int64), np.stack([turned.real, turned.imag], axis=-1)[vertices]

    monkeypatch.setattr(lightmap_child, "XATLAS_CHARTS", 0)
    monkeypatch.setattr(lightmap_child, "xatlas_charts", folding_charts)
    geometry = lightmap.Geometry.of(mesh)
    unwrapped = lightmap.lightmap_uvs(mesh, 512)
    report = lightmap.check_uvs(unwrapped[geometry.corners], geometry.areas(), 512)
    assert report.ok and report.islands > 20  # the fold's faces went alone


@pytest.mark.parametrize("resolution", [128, 256, 512])
def test_faces_smaller_than_a_texel_get_a_lightmap(resolution):
    """The corpus's draped figure (72k triangles, deep folds) at resolutions where its faces are
    smaller than a texel: the folds are looked for at 16 samples a face, not a texel's one (at 256²
    it was refused before: two texels on two triangles)."""
    vertices, faces = load_script("sample_blends/corpus_generator.py").shape_mesh("draped_figure", "mm")
    padding = lightmap.padding_for(resolution)
    uvs, report = lightmap_child.make_lightmap(vertices, faces, np.arange(len(faces)), resolution, padding)
    assert report.ok and report.overlapping == 0 and np.isfinite(uvs).all()


# --- the bake: reused, unchanged, refused ----------------------------------------------------------


def bake_image(objects, out, resolution=256, maps=("rain",)):
    options = bake.BakeOptions(maps=maps, resolution=resolution, out_dir=str(out), rain_settings=FAST_RAIN)
    return bake.bake_maps(objects, options)


def test_image_bakes_at_every_unit_give_lightmaps_of_equal_quality(bust, tmp_path):
    reports = {}
    for unit, scale in SCAN.UNITS.items():
        bpy.ops.wm.read_factory_settings(use_empty=True)
        obj = bust(TRIANGLES, scale=scale)
        [outcome] = bake_image([obj], tmp_path / unit)
        assert outcome.status == "written"
        pixels, metadata = imageio.read_image(outcome.where)
        assert metadata["pw:uv_map"] == lightmap.LIGHTMAP_UV and np.isfinite(pixels).all()
        reports[unit] = report_of(obj, lightmap.LIGHTMAP_UV, 256)
        assert reports[unit].ok, (unit, reports[unit].problems())
    for unit, report in reports.items():
        assert report.covered == pytest.approx(reports["mm"].covered, rel=0.05), unit
        assert report.utilisation == pytest.approx(reports["mm"].utilisation, rel=0.05), unit


@pytest.mark.parametrize("per", ["vertex", "corner"])
def test_attribute_maps_are_the_same_at_every_unit(bust, per):
    """Within 1e-3, but for the rare grazing rain sample that float rounding of the same scene at
    another size turns from lit to shaded (docs/scans.md: under 0.1% of corners). A smooth scan's
    rain is baked per vertex; with one sharp edge, per corner, where Cycles' fixed ray offsets made
    3% of the corners differ by more, before the bake scene was brought to one size."""
    values = {}
    for unit, scale in SCAN.UNITS.items():
        bpy.ops.wm.read_factory_settings(use_empty=True)
        obj = bust(8_000 if per == "corner" else TRIANGLES, scale=scale)
        if per == "corner":
            obj.data.attributes.new("sharp_edge", "BOOLEAN", "EDGE").data[0].value = True
        assert sky_bake.smooth_at_vertices(obj) == (per == "vertex")
        options = bake.BakeOptions(
            maps=("rain", "edges"), target="attribute", rain_settings=rain.RainSettings(samples=16)
        )
        assert [o.status for o in bake.bake_maps([obj], options)] == ["written", "written"]
        values[unit] = [colour_attribute(obj.data, name) for name in ("pw_rain", "pw_edges")]
    for unit in ("m", "normalised"):
        for value, reference in zip(values[unit], values["mm"]):
            difference = np.abs(value - reference)
            assert difference.mean() < 1e-4 and np.mean(difference > 1e-3) < 1e-3, unit


def colour_attribute(mesh, name):
    attribute = mesh.color_attributes[name]
    colours = np.empty(len(attribute.data) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", colours)
    return colours[0::4]


def test_a_second_bake_of_a_saved_scan_reuses_its_lightmap_and_is_unchanged(bust, tmp_path):
    obj = bust(TRIANGLES)
    saved = tmp_path / "bust.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(saved))  # maps record the .blend they come from
    assert [o.status for o in bake_image([obj], tmp_path / "maps")] == ["written"]
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=str(saved))
    obj = bpy.data.objects["Bust"]
    options = bake.BakeOptions(maps=("rain",), resolution=256, out_dir=str(tmp_path / "maps"), rain_settings=FAST_RAIN)
    steps = list(bake.iter_bake([obj], options))
    assert f"'{lightmap.LIGHTMAP_UV}' (reused" in steps[-3].stage  # the unwrap's last step, before the map's two
    assert [s.outcome.status for s in steps if s.outcome] == ["unchanged"]
    assert [layer.name for layer in obj.data.uv_layers] == [lightmap.LIGHTMAP_UV]


def test_the_command_line_rebakes_a_saved_scan_as_unchanged(bust, tmp_path):
    """The same command again on the --save'd bust reports "unchanged", and has nothing to save: the
    extension's own lightmap is reused (docs/maps.md, "The lightmap")."""
    bust(TRIANGLES)
    path = tmp_path / "bust.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    command = [sys.executable, "-m", "porous_weathering", "bake", str(path), "--save", "--out", str(tmp_path / "maps")]
    command += ["--resolution", "256", "--samples", "1"]
    for expected, file_line in (("written", f"saved     {path}"), ("unchanged", f"unchanged {path}")):
        run = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr
        lines = [line.split()[0] for line in run.stdout.splitlines() if " -> " in line]  # a line per map
        assert lines == [expected] * len(maps.names()) and file_line in run.stdout, run.stdout


def test_the_own_lightmap_that_no_longer_fits_is_refused_with_why(bust, tmp_path):
    obj = bust(TRIANGLES)
    bake_image([obj], tmp_path / "first", resolution=512)
    with pytest.raises(ValueError, match=rf"'{lightmap.LIGHTMAP_UV}' cannot hold a bake at 64²: .*another island"):
        bake_image([obj], tmp_path / "second", resolution=64)
    assert not (tmp_path / "second").exists() or not os.listdir(tmp_path / "second")
    assert [layer.name for layer in obj.data.uv_layers] == [lightmap.LIGHTMAP_UV]


def test_a_lightmap_that_cannot_be_made_is_refused_leaving_nothing(fresh_scene, tmp_path):
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    cube.data.uv_layers.remove(cube.data.uv_layers[0])
    with pytest.raises(ValueError, match=r"'Cube': cannot make a lightmap: .* at 8²"):  # 6 islands, 2 texels apart
        bake_image([cube], tmp_path / "maps", resolution=8)
    assert not cube.data.uv_layers
    assert not (tmp_path / "maps").exists() or not os.listdir(tmp_path / "maps")


# --- progress and cancel ------------------------------------------------------------------------


def test_the_unwrap_is_a_step_of_its_own_with_progress(bust, tmp_path):
    obj = bust(TRIANGLES)
    options = bake.BakeOptions(resolution=256, out_dir=str(tmp_path), rain_settings=FAST_RAIN)
    steps = list(bake.iter_bake([obj], options))
    unwrap = [step for step in steps if step.map == bake.LIGHTMAP_STEP]
    assert steps[: len(unwrap)] == unwrap and {step.index for step in unwrap} == {0}
    assert {step.total for step in steps} == {1 + len(maps.names())}  # the unwrap, then every map
    fractions = [step.fraction for step in steps]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    stages = [step.stage.split(" (")[0] for step in unwrap]
    assert {"packing", "checking"} <= set(stages) and f"'{lightmap.LIGHTMAP_UV}'" in stages[-1]
    assert [(s.map, s.outcome.status) for s in steps if s.outcome] == [(name, "written") for name in maps.names()]


def test_closing_the_bake_during_the_unwrap_stops_it_at_once(bust, tmp_path, monkeypatch):
    started = []
    original = lightmap.subprocess.Popen

    def recorded(*args, **kwargs):
        started.append(original(*args, **kwargs))
        return started[-1]

    monkeypatch.setattr(lightmap.subprocess, "Popen", recorded)
    obj = bust(TRIANGLES)
    steps = bake.iter_bake([obj], bake.BakeOptions(maps=("rain",), resolution=256, out_dir=str(tmp_path)))
    first = next(steps)
    assert first.map == bake.LIGHTMAP_STEP and started and started[0].poll() is None  # it runs
    steps.close()  # as the operator's Esc does
    assert started[0].poll() is not None  # stopped, and waited for
    assert not obj.data.uv_layers and not os.listdir(tmp_path)
