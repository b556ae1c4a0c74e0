"""Scans as they come (docs/scans.md, "What the bake checks"): the bake warns, one line naming
the object, when a scan's up axis looks wrong for rain, when it is flat-shaded as a scan saved
without normals is, or when stray floaters set its size; objects set up right, the sample
scenes' included, get no warning. A smooth scan's rain attribute is baked per vertex, as its
corners would be."""

import math
import pathlib
import subprocess
import sys
import warnings

import bpy

import mathutils
import numpy as np
import pytest

from helpers import counted_probes, cycles_corner_bake
from porous_weathering.blender import mesh_arrays, scratch_scene
from porous_weathering.maps import bake, edges, lightmap, rain, scan_checks, sky_bake

ROOT = pathlib.Path(__file__).resolve().parent.parent
SAMPLES = sorted((ROOT / "sample_blends").glob("*.blend"))

#: How a Z-up scan comes in when read as Y-up (OBJ and PLY importers' default), and the reverse.
TURNED = {"Z-up read as Y-up": (math.pi / 2, 0, 0), "Y-up read as Z-up": (-math.pi / 2, 0, 0)}


def test_a_standing_scan_gets_no_warning(bust):
    assert scan_checks.problems(bust()) == []
    assert scan_checks.problems(bust(name="Turned about Z", rotation=(0, 0, 1.0))) == []


@pytest.mark.parametrize("rotation", TURNED.values(), ids=TURNED.keys())
def test_a_scan_on_its_side_is_named_in_one_warning(bust, rotation):
    [message] = scan_checks.problems(bust(rotation=rotation))
    assert message.startswith("object 'Bust' looks as if it lies on its side") and "docs/scans.md" in message
    assert "\n" not in message


def test_a_surface_facing_the_ground_is_warned_about(fresh_scene):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=4, rotation=(math.pi, 0, 0))
    [message] = scan_checks.problems(bpy.context.active_object)
    assert message.startswith("object 'Grid' faces the ground: 100% of its area")


def test_the_up_axis_is_not_checked_when_no_rain_is_baked(bust):
    assert scan_checks.problems(bust(rotation=TURNED["Z-up read as Y-up"]), rain=False) == []


@pytest.mark.parametrize("sample", SAMPLES, ids=[path.stem for path in SAMPLES])
def test_the_sample_scenes_get_no_warning(sample):
    """Façades and walls are longest across and mostly face sideways: a heuristic that warned on
    those alone would warn on every building."""
    bpy.ops.wm.open_mainfile(filepath=str(sample), load_ui=False)
    for obj in bpy.context.scene.objects:
        if obj.type == "MESH":
            assert scan_checks.problems(obj) == [], obj.name


def with_crumb(obj, centre, radius):
    """``obj`` with a loose icosphere of ``radius`` about ``centre`` (its own space) added."""
    import bmesh  # noqa: PLC0415

    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.create_icosphere(bm, subdivisions=1, radius=radius, matrix=mathutils.Matrix.Translation(centre))
    bm.to_mesh(obj.data)
    bm.free()
    return obj


def test_a_scans_stray_floater_is_warned_about_and_crumbs_on_it_are_not(bust):
    """A loose crumb far from the body (a scan's floater) sets the object's size, from which the
    edge radius and the run-off's lengths are taken: warned about, with what it does. Crumbs on
    the surface, or a surface split at its seams, change no size: no warning."""
    obj = bust()
    points = np.array([v.co[:] for v in obj.data.vertices])
    high, size = points.max(axis=0), np.linalg.norm(np.ptp(points, axis=0))
    for k in range(20):  # on the surface: within 1% of the size of a vertex
        with_crumb(obj, obj.data.vertices[k * 500].co, 0.005 * size)
    assert scan_checks.problems(obj) == []
    with_crumb(obj, mathutils.Vector((0.0, 0.0, float(high[2]) + size)), 0.005 * size)
    [message] = scan_checks.problems(obj)
    assert message.startswith("object 'Bust' has 1 loose part holding under 0.1% of its surface outside its body")
    assert "its size 1.9 times the body's" in message and "\n" not in message


def test_a_flat_shaded_scan_without_normals_is_warned_about(bust):
    obj = bust()
    assert not scan_checks.looks_faceted(obj.data)  # smooth, as the generator makes it
    obj.data.shade_flat()
    [message] = scan_checks.problems(obj)
    assert message.startswith("object 'Bust' is flat-shaded with no custom normals")


def test_flat_shading_with_custom_normals_or_hard_edges_is_not_warned_about(bust, fresh_scene):
    obj = bust()
    obj.data.shade_flat()
    normals = [vertex.normal.copy() for vertex in obj.data.vertices]
    obj.data.normals_split_custom_set_from_vertices(normals)  # a scan saved with its normals
    assert not scan_checks.looks_faceted(obj.data)
    bpy.ops.mesh.primitive_cube_add()
    bpy.ops.object.modifier_add(type="SUBSURF")
    bpy.ops.object.modifier_apply(modifier="Subdivision")
    bpy.context.active_object.data.shade_flat()
    assert not scan_checks.looks_faceted(bpy.context.active_object.data)  # a rounded box of 24 faces: 30° bends
    bpy.ops.mesh.primitive_cube_add()
    assert not scan_checks.looks_faceted(bpy.context.active_object.data)


def test_the_bake_warns_once_per_problem(bust, tmp_path):
    obj = bust(rotation=TURNED["Z-up read as Y-up"])
    obj.data.shade_flat()
    options = bake.BakeOptions(target="attribute", maps=("rain",))
    with warnings.catch_warnings(record=True) as given:
        warnings.simplefilter("always")
        bake.bake_maps([obj], options, dry_run=True)
    messages = [str(w.message) for w in given if issubclass(w.category, scan_checks.ScanWarning)]
    assert len(messages) == 2 and all(m.startswith("object 'Bust'") for m in messages)


def test_the_command_line_prints_each_warning_as_one_line(bust, tmp_path):
    bust(rotation=TURNED["Z-up read as Y-up"])
    path = tmp_path / "lying.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    run = subprocess.run(
        [sys.executable, "-m", "porous_weathering", "bake", str(path), "--target", "attribute", "--dry-run"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    lines = run.stderr.replace("\r", "\n").splitlines()
    [warning] = [line for line in lines if "lies on its side" in line]
    assert warning.startswith("warning: object 'Bust' looks as if it lies on its side")
    assert not any("scan_checks" in line or "warnings.warn" in line for line in lines)  # no source line


def test_the_operator_reports_the_warnings(bust, registered, tmp_path, capfd):
    obj = bust(rotation=TURNED["Z-up read as Y-up"])
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    result = bpy.ops.porous_weathering.bake_maps(maps={"rain"}, target="attribute", samples=1, out_dir=str(tmp_path))
    assert result == {"FINISHED"}
    assert "object 'Bust' looks as if it lies on its side" in capfd.readouterr().out


# --- the rain of a smooth scan, per vertex ---------------------------------------------------------


def test_a_smooth_scan_is_baked_per_vertex_as_its_corners_would_be(bust):
    """Corners at a vertex share its position and normal: baked once per vertex (six times fewer
    samples), E is Cycles' own per-corner bake's, within its noise."""
    obj = bust()
    assert sky_bake.smooth_at_vertices(obj)
    settings = rain.RainSettings(samples=16)
    per_vertex = rain.bake_rain_corners(obj, settings)
    corner_vertex = np.array([loop.vertex_index for loop in obj.data.loops])
    assert np.array_equal(per_vertex, per_vertex[np.unique(corner_vertex, return_index=True)[1]][corner_vertex])
    per_corner = cycles_corner_bake(obj, rain.sky(settings))
    assert abs(per_vertex.mean() - per_corner.mean()) < 2e-3  # no bias
    assert np.corrcoef(per_vertex, per_corner)[0, 1] > 0.99
    assert np.sqrt(np.mean((per_vertex - per_corner) ** 2)) < 0.02  # 16 samples' noise


def test_a_flat_shaded_or_displaced_scan_is_not_taken_as_smooth_at_its_vertices(bust):
    obj = bust()
    obj.data.shade_flat()
    assert not sky_bake.smooth_at_vertices(obj)
    obj.data.shade_smooth()
    obj.modifiers.new("Displace", "DISPLACE")
    assert not sky_bake.smooth_at_vertices(obj)


def test_vertices_turned_from_the_whole_rain_cone_get_no_probe_and_the_zero_a_corner_bake_gives(bust, monkeypatch):
    """Slanting rain (30° from +X): a vertex more than 90° + the cone from its axis gets no probe
    and E = 0, exactly what Cycles gives it baked per corner; the others agree within noise."""
    obj = bust()
    settings = rain.RainSettings(samples=16, cone=10.0, wind_tilt=30.0)
    probes = counted_probes(monkeypatch)
    through_vertices = rain.bake_rain_corners(obj, settings)
    normals = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    obj.data.vertex_normals.foreach_get("vector", normals)
    turned_away = (normals.reshape(-1, 3) @ settings.towards_rain() < -math.sin(math.radians(12.0)))[
        mesh_arrays.attribute(obj.data, ".corner_vert", np.int32)
    ]
    assert 0.2 < turned_away.mean() < 0.6 and probes[0] < 0.8 * len(obj.data.vertices)
    per_corner = cycles_corner_bake(obj, rain.sky(settings))
    assert np.all(per_corner[turned_away] == 0.0) and np.all(through_vertices[turned_away] == 0.0)
    assert abs(through_vertices.mean() - per_corner.mean()) < 5e-3


def test_an_image_hardly_finer_than_the_scan_is_drawn_through_its_vertices(bust, monkeypatch):
    """At 256² the 20k-triangle bust has 6.5 texels per vertex: E is baked at the vertices and
    drawn across the triangles, and comes out as a per-texel bake does, within its noise."""
    obj = bust()
    lightmap.add_uv_map(obj.data, lightmap.LIGHTMAP_UV, lightmap.lightmap_uvs(obj.data, 256))
    settings = rain.RainSettings(samples=16)
    through_vertices = []
    original = sky_bake._bake_vertices
    monkeypatch.setattr(sky_bake, "_bake_vertices", lambda *args: through_vertices.append(1) or original(*args))
    drawn = rain.bake_rain_image(obj, lightmap.LIGHTMAP_UV, 256, settings, margin=0)
    assert through_vertices == [1]
    monkeypatch.setattr(sky_bake, "TEXELS_PER_VERTEX", 0)
    per_texel = rain.bake_rain_image(obj, lightmap.LIGHTMAP_UV, 256, settings, margin=0)
    assert through_vertices == [1]  # per texel this time
    covered = (drawn > 0) | (per_texel > 0)
    assert covered.mean() > 0.1  # rain reaches some of what the lightmap covers
    assert abs(drawn[covered].mean() - per_texel[covered].mean()) < 5e-3
    assert np.sqrt(np.mean((drawn[covered] - per_texel[covered]) ** 2)) < 0.04  # 16 samples' noise, twice


def test_a_scan_finer_than_the_edge_radius_gets_its_image_mask_drawn_through_its_vertices(bust, monkeypatch):
    """At 5% of its size the 20k-triangle bust's median edge is under a quarter of the radius:
    the image mask is the field read at the vertices drawn across the triangles, and comes out
    as the field read at every texel does, within the interpolation's error."""
    obj = bust()
    lightmap.add_uv_map(obj.data, lightmap.LIGHTMAP_UV, lightmap.lightmap_uvs(obj.data, 256))
    settings = edges.EdgeSettings(scale=0.05)
    assert edges._median_edge(obj) <= edges.VERTEX_SPACING * edges.effective_radius(obj, settings)
    drawn_through = []
    original = scratch_scene.bake_point_values
    monkeypatch.setattr(
        scratch_scene, "bake_point_values", lambda *args, **kw: drawn_through.append(1) or original(*args, **kw)
    )
    drawn = edges.edge_mask_image(obj, lightmap.LIGHTMAP_UV, 256, settings)
    assert drawn_through == [1]
    monkeypatch.setattr(edges, "VERTEX_SPACING", 0.0)
    per_texel = edges.edge_mask_image(obj, lightmap.LIGHTMAP_UV, 256, settings)
    assert drawn_through == [1]  # per texel this time
    covered = (drawn > 0) | (per_texel > 0)
    assert covered.mean() > 0.2 and per_texel[covered].max() > 0.5  # the brim and the hollows show
    assert np.sqrt(np.mean((drawn[covered] - per_texel[covered]) ** 2)) < 0.01
    assert np.percentile(np.abs(drawn - per_texel)[covered], 99) < 0.05
