"""Bad meshes through everything that takes objects: the add-material operator and the map
bakes (image and attribute targets, every registered map). Each case either works, giving whole,
finite maps, or is refused with a message naming the object, leaving every datablock, UV map,
attribute, material slot and output folder as it was (tests/bad_meshes.py builds the cases)."""

import os
import time

import bpy

import bmesh
import numpy as np
import pytest

from bad_meshes import BUILDERS, cube, data_counts, mesh_object, snapshot
from helpers import run_cli
from porous_weathering.blender import mesh_arrays
from porous_weathering.common import imageio
from porous_weathering.maps import bake, edges, lightmap, rain
from porous_weathering.samples import studio

FAST_RAIN = rain.RainSettings(samples=2)
MAPS = bake.BakeOptions().maps  #: every registered map, in the order the bake takes them

#: (case, operation) -> what the refusal must say besides the object's name.
REFUSED = {
    ("no faces", "image"): "without faces",
    ("no faces", "attribute"): "without faces",
    ("only a zero-area face", "image"): "no face of non-zero area",
    ("only a zero-area face", "attribute"): "no face of non-zero area",
    ("curve", "image"): "type is CURVE",
    ("curve", "attribute"): "type is CURVE",
    ("text", "image"): "type is FONT",
    ("text", "attribute"): "type is FONT",
    ("linked library data", "operator"): "linked from the library",
    ("linked library data", "image"): "linked",
    ("linked library data", "attribute"): "linked",
    ("unapplied modifiers", "attribute"): "modifiers",
}


def cases():
    return [
        pytest.param(name, operation, id=f"{name}-{operation}")
        for name in BUILDERS
        for operation in ("operator", "image", "attribute")
    ]


def run(operation, obj, out_dir):
    """Run ``operation`` on ``obj``; returns what it made (material or outcomes)."""
    if operation == "operator":
        bpy.context.view_layer.objects.active = obj
        assert bpy.ops.porous_weathering.add_porous_material() == {"FINISHED"}
        return obj.active_material
    options = bake.BakeOptions(
        maps=MAPS, target=operation, resolution=16, out_dir=str(out_dir), rain_settings=FAST_RAIN
    )
    return bake.bake_maps([obj], options)


def attribute_values(mesh, name):
    attribute = mesh.color_attributes[name]
    colours = np.empty(len(attribute.data) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", colours)
    return colours[0::4]


def assert_whole(operation, obj, made):
    """A successful operation left complete, finite results."""
    if operation == "operator":
        assert made is not None and made["pw_light_mode"] == "AMBIENT"
        assert obj.data.materials[-1] == made
        return
    assert [(o.map, o.status) for o in made] == [(m, "written") for m in MAPS]
    for outcome in made:
        if operation == "image":
            pixels, metadata = imageio.read_image(outcome.where)
            assert pixels.shape == (16, 16, 1) and metadata["pw:map"] == outcome.map
            assert metadata["pw:uv_map"] in obj.data.uv_layers
            values = pixels
        else:
            values = attribute_values(obj.data, outcome.where)
            assert len(values) == len(obj.data.vertices if outcome.map == "edges" else obj.data.loops)
        assert np.isfinite(values).all() and values.min() >= 0.0 and values.max() <= 1.05


@pytest.mark.parametrize("case, operation", cases())
def test_bad_mesh_works_or_is_refused_leaving_nothing(fresh_scene, registered, tmp_path, case, operation):
    obj = BUILDERS[case](fresh_scene, tmp_path)
    bpy.context.view_layer.update()
    out_dir = tmp_path / "maps"
    before = snapshot([obj])
    if (case, operation) not in REFUSED:
        assert_whole(operation, obj, run(operation, obj, out_dir))
        return
    with pytest.raises((ValueError, RuntimeError)) as refusal:
        run(operation, obj, out_dir)
    assert f"'{obj.name}'" in str(refusal.value) and REFUSED[case, operation] in str(refusal.value)
    assert snapshot([obj]) == before
    assert not out_dir.exists() or not os.listdir(out_dir)


@pytest.mark.parametrize("target", ["image", "attribute"])
def test_the_command_refuses_a_mesh_without_surface_in_one_line(fresh_scene, tmp_path, target):
    """Named, it is refused before any work, as any object that cannot be baked: exit 2 (bad
    input), one line; unnamed, it is left out with a warning, as a mesh without faces is."""
    BUILDERS["only a zero-area face"](fresh_scene, tmp_path)
    studio.add_plane(fresh_scene)
    blend = tmp_path / "sliver.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    words = [
        "--target",
        target,
        "--save",
        "--out",
        tmp_path / "maps",
        "--samples",
        2,
        "--sun-samples",
        2,
        "--resolution",
        16,
    ]
    result = run_cli("bake", blend, "--objects", "Sliver", "Plane", *words)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert [line for line in result.stderr.splitlines() if line.startswith("error")] == [
        f"error: {blend}: object 'Sliver' has no face of non-zero area: nothing to bake on"
    ]
    assert not (tmp_path / "maps").exists() or not os.listdir(tmp_path / "maps")
    unnamed = run_cli("bake", blend, *words)
    assert unnamed.returncode == 0, unnamed.stderr
    assert "warning: object 'Sliver' is left out: its mesh has no face of non-zero area" in unnamed.stderr
    baked = [line.split()[1] for line in unnamed.stdout.splitlines() if line.startswith("written")]
    assert baked and all(name.startswith("Plane.") for name in baked)


def face_means(obj, values):
    """{rounded world normal of a face: mean of the corner ``values`` on it}."""
    rotation = obj.matrix_world.to_3x3()
    means = {}
    for polygon in obj.data.polygons:
        normal = tuple(int(round(c)) for c in (rotation @ polygon.normal).normalized())
        means[normal] = float(np.mean(values[list(polygon.loop_indices)]))
    return means


def test_mirrored_cube_bakes_like_the_cube_it_mirrors(fresh_scene):
    plain = cube(fresh_scene, "Plain")
    mirrored = cube(fresh_scene, "Mirrored", location=(4.0, 0.0, 0.0))
    mirrored.scale = (-1.0, 1.0, 1.0)
    bpy.context.view_layer.update()
    options = bake.BakeOptions(maps=MAPS, target="attribute", rain_settings=FAST_RAIN)
    bake.bake_maps([plain, mirrored], options)
    for obj in (plain, mirrored):
        rain_by_face = face_means(obj, attribute_values(obj.data, rain.RAIN_ATTRIBUTE))
        assert rain_by_face[(0, 0, 1)] == pytest.approx(1.0, abs=0.05) and rain_by_face[(0, 0, -1)] < 0.01
    # convex corners either way: the mirroring transform does not turn the cube inside out
    assert np.all(edges.curvature(mirrored, 0.05) > 0)
    assert np.allclose(
        attribute_values(mirrored.data, edges.EDGE_ATTRIBUTE),
        attribute_values(plain.data, edges.EDGE_ATTRIBUTE),
        atol=1e-5,
    )


def test_inside_out_cube_is_baked_from_outside(fresh_scene, tmp_path):
    obj = BUILDERS["flipped normals"](fresh_scene, tmp_path)
    before = [tuple(v.co) for v in obj.data.vertices], [p.vertices[:] for p in obj.data.polygons]
    by_face = face_means(obj, rain.bake_rain_corners(obj, FAST_RAIN))
    # rained on as the renders shade it, from outside: its top face's normal points down
    assert by_face[(0, 0, -1)] == pytest.approx(1.0, abs=0.05) and by_face[(0, 0, 1)] < 0.01
    assert ([tuple(v.co) for v in obj.data.vertices], [p.vertices[:] for p in obj.data.polygons]) == before
    assert np.all(edges.curvature(obj, 0.05) > 0)  # its corners are convex from outside too


def tall_box(scene, name, inside_out=False, at=(0.0, 0.0, 0.0), size=1.0):
    """A size x size x 4 size box standing at ``at`` (the scene in metres), in faces a tenth of
    its sides, so that its run-off and its damp front (1.5 m for 1 m, over 0.5 m for a 1/8 box)
    are resolved; turned inside out or not."""
    obj = cube(scene, name, location=(at[0], at[1], at[2] + 2.0 * size))
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=9, use_grid_fill=True)
    bm.to_mesh(obj.data)
    bm.free()
    obj.scale = (size, size, 4.0 * size)
    if inside_out:
        obj.data.flip_normals()
    bpy.context.view_layer.update()
    return obj


def baked_per_face(obj, target, out_dir, maps):
    """{map: values at the faces' centres, ordered by the centres}: the attribute's face means,
    or the image's texel at each face's UV centre."""
    rain_settings = rain.RainSettings(samples=64)  # the two boxes' rain noise apart, within the tolerance
    options = bake.BakeOptions(
        maps=maps, target=target, resolution=256, out_dir=str(out_dir), rain_settings=rain_settings
    )
    made = bake.bake_maps([obj], options)
    mesh = obj.data
    order = np.lexsort(np.array([tuple(p.center) for p in mesh.polygons]).round(4).T)
    found = {}
    for outcome in made:
        if target == "attribute":
            values = attribute_values(mesh, outcome.where)  # per vertex (the edges) or per corner
            at = (lambda p: p.vertices) if len(values) == len(mesh.vertices) else (lambda p: p.loop_indices)
            per_face = [values[list(at(p))].mean() for p in mesh.polygons]
        else:
            pixels = imageio.read_image(outcome.where)[0][..., 0]  # top row first
            uvs = mesh.uv_layers[lightmap.LIGHTMAP_UV].data
            centres = [np.mean([uvs[i].uv for i in p.loop_indices], axis=0) for p in mesh.polygons]
            per_face = [pixels[int((1.0 - v) * 256), int(u * 256)] for u, v in centres]
        found[outcome.map] = np.array(per_face)[order]
    return found


@pytest.mark.parametrize("target", ["attribute", "image"])
def test_inside_out_box_gets_the_maps_of_the_box_right_way_out(fresh_scene, tmp_path, target):
    # a scan saved with its normals turned in: the run-off's flow and drips, the damp's
    # thickness rays and the edge mask's texel normals all read it from outside, as the rain does
    maps = ("rain", "edges", "runoff", "damp")
    right = baked_per_face(tall_box(fresh_scene, "Right"), target, tmp_path / "right", maps)
    bpy.data.objects.remove(bpy.data.objects["Right"])  # not an occluder of the other
    turned = baked_per_face(tall_box(fresh_scene, "Turned", inside_out=True), target, tmp_path / "turned", maps)
    assert right["damp"].min() == 0.0 and right["damp"].max() == 1.0  # its front stands on the box
    assert right["runoff"].max() > 0.5
    for name in maps:
        if target == "image" and name in ("edges", "runoff"):
            # the two lightmaps differ, and a texel's place in its face with them: the mask falls
            # steeply from each edge, so compare means (before: 0.094 against 0.024)
            assert turned[name].mean() == pytest.approx(right[name].mean(), abs=0.003), name
        else:
            np.testing.assert_allclose(turned[name], right[name], atol=0.03, err_msg=name)


@pytest.mark.parametrize("target", ["attribute", "image"])
@pytest.mark.parametrize(
    "at, size", [((1000.0, 0.0, 30.0), 0.125), ((12345.0, 23456.0, 100.0), 1.0)], ids=["1 km", "26 km"]
)
def test_an_object_far_from_the_origin_gets_the_maps_it_gets_there(fresh_scene, tmp_path, target, at, size):
    # a statue in a site model, a building in a national grid: where it stands changes no map
    # (before: the damp's rays started outside it in single precision, 0.68 for 1 on the small
    # box; the edge mask's grid stood on the world's origin, up to 0.06 apart)
    maps = ("rain", "edges", "runoff", "damp")
    here = baked_per_face(tall_box(fresh_scene, "Here", size=size), target, tmp_path / "here", maps)
    bpy.data.objects.remove(bpy.data.objects["Here"])
    there = baked_per_face(tall_box(fresh_scene, "There", at=at, size=size), target, tmp_path / "there", maps)
    # the run-off within 0.001: the box's vertices lie on its flow cells' faces, where a rounding
    # of the far place's sum picks the cell on either side
    tolerance = {"rain": 1e-4, "damp": 1e-4, "edges": 0.002, "runoff": 0.002}
    for name in maps:
        np.testing.assert_allclose(there[name], here[name], atol=tolerance[name], err_msg=name)


def test_open_mesh_facing_down_is_taken_as_given(fresh_scene):
    obj = studio.add_plane(fresh_scene, "Ceiling")
    obj.data.flip_normals()
    assert not mesh_arrays.is_inside_out(obj.data)
    assert np.all(rain.bake_rain_corners(obj, FAST_RAIN) < 0.01)


def test_objects_sharing_a_mesh_are_not_baked_over_each_other(fresh_scene, tmp_path):
    twin_a = BUILDERS["shared mesh"](fresh_scene, tmp_path)
    twin_b = bpy.data.objects["Twin B"]
    cube(fresh_scene, "Roof", size=3.0, location=(3.0, 0.0, 3.0))  # shelters Twin B only
    bpy.context.view_layer.update()
    options = bake.BakeOptions(maps=("rain",), target="attribute", rain_settings=FAST_RAIN)
    try:
        bake.bake_maps([twin_a, twin_b], options)
    except ValueError as refusal:
        assert "'Twin A'" in str(refusal) and "'Twin B'" in str(refusal) and "share" in str(refusal)
        return
    assert face_means(twin_a, attribute_values(twin_a.data, rain.RAIN_ATTRIBUTE))[(0, 0, 1)] > 0.9


def test_shared_mesh_gets_one_lightmap_and_a_map_file_per_object(fresh_scene, tmp_path):
    twin_a = BUILDERS["shared mesh"](fresh_scene, tmp_path)
    twin_b = bpy.data.objects["Twin B"]
    outcomes = bake.bake_maps(
        [twin_a, twin_b],
        bake.BakeOptions(maps=("rain",), resolution=16, out_dir=str(tmp_path / "maps"), rain_settings=FAST_RAIN),
    )
    assert [o.status for o in outcomes] == ["written", "written"]
    assert sorted(os.listdir(tmp_path / "maps")) == ["Twin A.rain.exr", "Twin B.rain.exr"]
    assert [layer.name for layer in twin_a.data.uv_layers].count("PW Lightmap") == 1


@pytest.mark.parametrize("case", ["curve", "text"])
def test_curvature_attribute_on_a_curve_says_it_is_not_a_mesh(fresh_scene, case):
    obj = BUILDERS[case](fresh_scene, None)
    bpy.context.view_layer.update()
    before = data_counts()
    with pytest.raises(ValueError, match=f"'{obj.name}'.*(not a mesh|type)"):
        edges.write_curvature_attribute(obj, 0.05)
    assert data_counts() == before


@pytest.mark.parametrize("case", ["curve", "text"])
def test_direct_bake_functions_refuse_curves_by_name(fresh_scene, case):
    obj = BUILDERS[case](fresh_scene, None)
    before = data_counts()
    with pytest.raises(ValueError, match=f"{obj.name}: a rain bake needs a mesh object"):
        rain.bake_rain_corners(obj, FAST_RAIN)
    with pytest.raises(ValueError, match=f"'{obj.name}' has no UV map"):
        rain.bake_rain_image(obj, "UVMap", 16, FAST_RAIN)
    with pytest.raises(ValueError, match=f"'{obj.name}' has no faces"):
        edges.edge_mask_image(obj, "UVMap", 16)
    assert data_counts() == before


def test_refusal_of_a_linked_object_names_its_library(fresh_scene, registered, tmp_path):
    """The operator refuses linked data, and a local object that uses linked mesh data too."""
    linked = BUILDERS["linked library data"](fresh_scene, tmp_path)
    local = studio.link(fresh_scene, bpy.data.objects.new("Local User", linked.data))
    for obj in (linked, local):
        bpy.context.view_layer.objects.active = obj
        before = snapshot([obj])
        with pytest.raises(RuntimeError, match=f"'{obj.name}'.*library stones.blend"):
            bpy.ops.porous_weathering.add_porous_material()
        assert snapshot([obj]) == before


# --- stray points and far-apart faces ------------------------------------------------------------

#: Where a scan's stray point lies: far from the object, on every axis.
STRAY = (-1e5, -1e5, -1e5)


def within(steps, seconds):
    """The value a generator returns, driving it for at most ``seconds`` (it is closed then:
    an unwrap's child process is stopped), else the test fails."""
    deadline = time.monotonic() + seconds
    try:
        while True:
            next(steps)
            assert time.monotonic() < deadline, f"still running after {seconds} s"
    except StopIteration as done:
        return done.value
    finally:
        steps.close()


def baked_maps(obj, options):
    """{map: its values} of ``obj`` once ``options`` are baked (within a minute)."""
    outcomes = [step.outcome for step in within(_steps(obj, options), 60) if step.outcome is not None]
    if options.target == "image":
        return {o.map: imageio.read_image(o.where)[0] for o in outcomes}
    return {o.map: attribute_values(obj.data, o.where) for o in outcomes}


def _steps(obj, options):
    """The bake's steps as a generator that returns them all."""
    steps = []
    for step in bake.iter_bake([obj], options):
        steps.append(step)
        yield step
    return steps


@pytest.mark.parametrize("target", ["image", "attribute"])
def test_a_stray_vertex_changes_no_map_and_no_time(fresh_scene, tmp_path, target):
    """A tilted plane's maps (the unwrap, rain, edges, run-off), then the same with one loose
    vertex far away: the defaults scale with the faces, and the unwrap sees only their points."""
    options = bake.BakeOptions(target=target, resolution=32, out_dir=str(tmp_path), rain_settings=FAST_RAIN)
    obj = studio.add_plane(fresh_scene, "Tilted", size=1.0)
    obj.rotation_euler = (0.5, 0.0, 0.0)
    while obj.data.uv_layers:  # a scan's: the image bake unwraps it
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    bpy.context.view_layer.update()
    size = edges.object_size(obj)
    clean = baked_maps(obj, options)
    if target == "image":
        obj.data.uv_layers.remove(obj.data.uv_layers[lightmap.LIGHTMAP_UV])  # unwrapped again
    obj.data.vertices.add(1)
    obj.data.vertices[-1].co = STRAY
    obj.data.update()
    bpy.context.view_layer.update()
    started = time.monotonic()
    stray = baked_maps(obj, options)
    assert time.monotonic() - started < 30
    assert clean["runoff"].max() > 0.9
    for name, values in clean.items():
        assert np.allclose(stray[name][: len(values)], values, atol=1e-6), name
    assert edges.object_size(obj) == size


def test_faces_a_million_sizes_apart_get_a_lightmap_in_bounded_time(fresh_scene):
    """Two unit cubes 10^6 apart in one mesh: xatlas (float32) charted them into zero-area UVs,
    and its packing of those never ended."""
    corners = np.array([(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    obj = mesh_object(
        fresh_scene,
        "Far Apart",
        np.concatenate([corners, corners + 1e6]),
        faces=quads + [tuple(np.add(q, 8)) for q in quads],
    )
    made = within(lightmap.iter_lightmap(obj.data, 32), 30)
    assert made.name == lightmap.LIGHTMAP_UV and made.report.ok


def test_drips_land_where_they_land_beside_a_far_stray_vertex(fresh_scene):
    """A slab over a floor, one mesh: the slab's edges drip onto the floor beneath it, sheltered
    from the rain (the run-off's drip rays). One loose vertex far away moves nothing (before: the
    drips' BVH stood on the lowest vertex, the stray one, and lost the slab's size in single
    precision)."""

    def slab(low, high):
        corners = np.array([(x, y, z) for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
        return corners, [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]

    floor, quads = slab((-2.0, -2.0, 0.0), (2.0, 2.0, 0.1))
    top, _ = slab((-0.5, -0.5, 1.0), (0.5, 0.5, 1.1))
    obj = mesh_object(
        fresh_scene, "Table", np.concatenate([floor, top]), faces=quads + [tuple(np.add(q, 8)) for q in quads]
    )
    bmesh_cut = bmesh.new()
    bmesh_cut.from_mesh(obj.data)
    bmesh.ops.subdivide_edges(bmesh_cut, edges=bmesh_cut.edges[:], cuts=7, use_grid_fill=True)
    bmesh_cut.to_mesh(obj.data)
    bmesh_cut.free()
    bpy.context.view_layer.update()
    options = bake.BakeOptions(maps=("rain", "runoff"), target="attribute", rain_settings=FAST_RAIN)
    bake.bake_maps([obj], options)
    clean = attribute_values(obj.data, "pw_runoff")
    assert clean.max() > 0.5
    obj.data.vertices.add(1)
    obj.data.vertices[-1].co = (-1e7, -1e7, -1e7)
    obj.data.update()
    bpy.context.view_layer.update()
    bake.bake_maps([obj], options)
    stray = attribute_values(obj.data, "pw_runoff")
    np.testing.assert_allclose(stray, clean, atol=1e-6)
