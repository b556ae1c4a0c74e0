"""The meshes users have: objects with modifiers (and mirrored ones) get every map, on both
targets, from the mesh the render sees (docs/maps.md, "Modifiers").

Each image-target case bakes every map of a box carrying one modifier, then bakes the same
shape with the modifiers applied, and compares the two maps at the same surface points (the
centres of the triangles of the mesh as rendered, read through each object's own lightmap). An
attribute target cannot follow a modifier that changes the mesh's vertices or corners: every map
is refused before any work, naming the modifiers; one that only moves them (Displace) is baked.
"""

import dataclasses

import bpy

import bmesh
import numpy as np
import pytest

from porous_weathering.blender import mesh_arrays, scratch_scene
from porous_weathering.cli import entry
from porous_weathering.common import imageio
from porous_weathering.contracts import EXIT_FAILED, map_image_property
from porous_weathering.maps import bake, lightmap, rain, registry
from porous_weathering.maps import registry as maps
from porous_weathering.samples import studio

RESOLUTION = 64
RAIN = rain.RainSettings(samples=64)


def _array(obj):
    """Two copies 1.6 m apart (a constant offset: a relative one would follow a stray vertex)."""
    modifier = obj.modifiers.new("Array", "ARRAY")
    modifier.use_relative_offset = False
    modifier.use_constant_offset = True
    modifier.constant_offset_displace = (1.6, 0.0, 0.0)


def _displace(obj):
    obj.modifiers.new("Displace", "DISPLACE").strength = 0.05


#: modifier -> how a user adds it (the defaults where they make a sensible shape).
MODIFIERS = {
    "Subdivision Surface": lambda obj: obj.modifiers.new("Subdivision", "SUBSURF"),  # levels 1, renders 2
    "Bevel": lambda obj: obj.modifiers.new("Bevel", "BEVEL"),
    "Array": _array,
    "Solidify": lambda obj: obj.modifiers.new("Solidify", "SOLIDIFY"),
    "Mirror": lambda obj: obj.modifiers.new("Mirror", "MIRROR"),  # the box stands off the mirror plane
    "Displace": _displace,
    "Weld": lambda obj: obj.modifiers.new("Weld", "WELD"),
    "Triangulate": lambda obj: obj.modifiers.new("Triangulate", "TRIANGULATE"),
}
#: What a per-point difference of each map may be, in the mean and at the 95th percentile
#: (the rain is a Monte Carlo estimate per texel; the run-off integrates it along its paths).
#: The sun is baked as the rain is (maps/sky_bake.py): its noise, its tolerance.
TOLERANCES = {
    "rain": (0.03, 0.15),
    "edges": (0.02, 0.1),
    "runoff": (0.02, 0.05),
    "sun": (0.03, 0.15),
    "damp": (0.02, 0.05),
}


def box(scene, name, scale=(1.0, 1.0, 1.0), uvs=False):
    """A 1 x 0.8 x 1.2 box standing on z = 0 beside the origin (x from 0.4 to 1.4), so that a
    mirror on X makes a second box; with ``uvs``, the UV map "UVMap" of Blender's cube."""
    mesh = bpy.data.meshes.new(name)
    solid = bmesh.new()
    if uvs:
        solid.loops.layers.uv.new("UVMap")
    bmesh.ops.create_cube(solid, size=1.0, calc_uvs=uvs)
    bmesh.ops.scale(solid, vec=(1.0, 0.8, 1.2), verts=solid.verts)
    bmesh.ops.translate(solid, vec=(0.9, 0.0, 0.6), verts=solid.verts)
    solid.to_mesh(mesh)
    solid.free()
    obj = studio.link(scene, bpy.data.objects.new(name, mesh))
    obj.scale = scale
    return obj


def alone():
    """An empty collection: the bakes' occluders, so that two objects baked side by side do not
    shelter each other."""
    return bpy.data.collections.new("Nothing")


def applied(scene, obj):
    """A new object of ``obj``'s mesh as the render sees it (modifiers applied, with the UV maps
    they carry, as Apply leaves them), where it stands."""
    with scratch_scene.rendered(obj) as seen:
        mesh = bpy.data.meshes.new_from_object(seen.evaluated)
    copy = studio.link(scene, bpy.data.objects.new(f"{obj.name} applied", mesh))
    copy.matrix_world = obj.matrix_world.copy()
    return copy


def values_at_face_points(obj, map_name, out_dir):
    """(points (P, 3), values (P,)): ``obj``'s image map ``map_name`` read (nearest texel, through
    the UV map it was baked on) at points of every face of its mesh as rendered, in world space:
    each face's centre and the midpoints between it and each corner (where a face's UVs are an
    affine image of it, as on a box's, their UVs are the same means of its corners' UVs)."""
    pixels, header = imageio.read_image(imageio.image_path(out_dir, obj.name, map_name))
    with scratch_scene.rendered(obj) as seen:
        uvs = lightmap.corner_uvs(seen.mesh, header[imageio.UV_MAP_KEY]).astype(np.float64)
        vertex_of = mesh_arrays.attribute(seen.mesh, ".corner_vert", np.int32)
        corners = mesh_arrays.attribute(seen.mesh, "position", np.float32, 3).astype(np.float64)[vertex_of]
        corners = corners @ seen.matrix_world[:3, :3].T + seen.matrix_world[:3, 3]
        starts = mesh_arrays.loop_starts(seen.mesh)
    sizes = np.diff(np.append(starts, len(vertex_of)))
    face_of = np.repeat(np.arange(len(starts)), sizes)
    centre_points = np.add.reduceat(corners, starts) / sizes[:, None]
    centre_uvs = np.add.reduceat(uvs, starts) / sizes[:, None]
    points = np.concatenate([centre_points, (centre_points[face_of] + corners) / 2])
    at = np.concatenate([centre_uvs, (centre_uvs[face_of] + uvs) / 2])
    size = pixels.shape[0]
    columns = np.clip((at[:, 0] * size).astype(int), 0, size - 1)
    rows = np.clip(((1.0 - at[:, 1]) * size).astype(int), 0, size - 1)
    return points, pixels[rows, columns, 0]


def differences(first, second, map_name, out_dir):
    """|first's map - second's map| at ``first``'s face points, each read at the nearest of
    ``second``'s (the two objects cover the same surface)."""
    points, values = values_at_face_points(first, map_name, out_dir)
    other_points, other_values = values_at_face_points(second, map_name, out_dir)
    nearest = np.argmin(((points[:, None, :] - other_points[None, :, :]) ** 2).sum(-1), axis=1)
    assert np.allclose(points, other_points[nearest], atol=1e-4)
    return np.abs(values - other_values[nearest])


def assert_agree(first, second, out_dir):
    for map_name in maps.names():
        difference = differences(first, second, map_name, out_dir)
        mean, high = TOLERANCES[map_name]
        assert difference.mean() <= mean and np.quantile(difference, 0.95) <= high, (
            f"{map_name}: mean {difference.mean():.3f}, 95th percentile {np.quantile(difference, 0.95):.3f}"
        )


def bake_images(objects, out_dir, occluders):
    options = bake.BakeOptions(
        target="image", resolution=RESOLUTION, out_dir=str(out_dir), rain_settings=RAIN, occluders=occluders
    )
    return bake.bake_maps(objects, options)


@pytest.mark.parametrize("modifier", MODIFIERS)
def test_every_map_of_a_modified_object_agrees_with_its_shape_applied(fresh_scene, tmp_path, modifier):
    obj = box(fresh_scene, "Box")
    MODIFIERS[modifier](obj)
    flat = applied(fresh_scene, obj)
    outcomes = bake_images([obj, flat], tmp_path, alone())
    assert {(o.object, o.map, o.status) for o in outcomes} == {
        (name, map_name, "written") for name in (obj.name, flat.name) for map_name in maps.names()
    }
    for map_name in maps.names():
        pixels = imageio.read_image(imageio.image_path(tmp_path, obj.name, map_name))[0]
        assert np.isfinite(pixels).all() and pixels.min() >= 0.0 and pixels.max() <= 1.0, map_name
    assert_agree(obj, flat, tmp_path)


@pytest.mark.parametrize("modifier", MODIFIERS)
def test_an_attribute_target_bakes_what_keeps_the_corners_and_refuses_the_rest(fresh_scene, modifier):
    obj = box(fresh_scene, "Box")
    MODIFIERS[modifier](obj)
    options = bake.BakeOptions(target="attribute", rain_settings=rain.RainSettings(samples=4))
    with scratch_scene.rendered(obj) as seen:
        keeps = len(seen.mesh.loops) == len(obj.data.loops)
    if not keeps:
        with pytest.raises(ValueError, match=rf"'Box': its modifiers \({obj.modifiers[0].name}\) change its vertices"):
            bake.bake_maps([obj], options)
        assert not obj.data.color_attributes
        return
    outcomes = bake.bake_maps([obj], options)
    assert [o.status for o in outcomes] == ["written"] * len(maps.names())
    for kind in maps.all_kinds():
        attribute = obj.data.color_attributes[kind.attribute]
        colours = np.empty(len(attribute.data) * 4, np.float32)
        attribute.data.foreach_get("color", colours)
        assert np.isfinite(colours).all() and colours.min() >= 0.0 and colours.max() <= 1.0


def test_a_mirrored_object_gets_its_mirror_images_maps(fresh_scene, tmp_path):
    """A box mirrored by a negative scale gets the maps of the same box built mirrored (its
    vertices mirrored and its faces turned to face out, its UVs kept): the run-off's normals
    follow the mirror, as the curvature's do. Both lean, so that no face is level: the routing
    of water across an exactly level face depends on how it is sampled (docs/maps.md)."""
    mirrored = box(fresh_scene, "Mirrored", scale=(-1.0, 1.0, 1.0), uvs=True)
    built = box(fresh_scene, "Built", uvs=True)  # the same UVs: the same texels
    solid = bmesh.new()
    solid.from_mesh(built.data)
    bmesh.ops.scale(solid, vec=(-1.0, 1.0, 1.0), verts=solid.verts)
    bmesh.ops.reverse_faces(solid, faces=solid.faces)
    solid.to_mesh(built.data)
    solid.free()
    for obj in (mirrored, built):
        obj.rotation_euler = (0.25, 0.15, 0.0)
    bpy.context.view_layer.update()
    bake_images([mirrored, built], tmp_path, alone())
    assert_agree(mirrored, built, tmp_path)
    assert values_at_face_points(mirrored, "runoff", tmp_path)[1].mean() > 0.2  # its walls run with water


def buggy_edges(monkeypatch, victim):
    """The edge map's bake, raising what a bug would (an IndexError) on the object ``victim``."""
    kind = maps.get("edges")

    def bake_image(obj, *args):
        if obj.name == victim:
            raise IndexError("index 24 is out of bounds for axis 0 with size 24")
        return kind.bake_image(obj, *args)

    monkeypatch.setitem(
        registry._DISCOVERED, "edges", dataclasses.replace(kind, bake_image=bake_image)
    )  # found by maps.get


def test_a_file_that_fails_does_not_stop_the_others_and_keeps_its_maps(fresh_scene, tmp_path, monkeypatch, capsys):
    """However a file fails (here a bug in a map's bake), the command says so in one line, goes
    on with the next file, and with --save keeps the maps baked before the failure, linked."""
    for name in ("Buggy", "Fine"):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        box(bpy.context.scene, name)
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / f"{name}.blend"))
    buggy_edges(monkeypatch, "Buggy")
    out = tmp_path / "maps"
    code = entry.main(
        ["bake", str(tmp_path / "Buggy.blend"), str(tmp_path / "Fine.blend"), "--out", str(out), "--maps",
         "rain,edges", "--resolution", "16", "--samples", "2", "--save"]
    )  # fmt: skip
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error:")]
    assert code == EXIT_FAILED
    assert errors == [f"error: {tmp_path / 'Buggy.blend'}: IndexError: index 24 is out of bounds for axis 0 with "
                      "size 24 (a bug: please report it)"]  # fmt: skip
    assert sorted(path.name for path in out.iterdir()) == ["Buggy.rain.exr", "Fine.edges.exr", "Fine.rain.exr"]
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "Buggy.blend"), use_scripts=False)
    assert bpy.data.objects["Buggy"].get(map_image_property("rain")) in bpy.data.images


def test_the_bake_operator_links_the_maps_it_wrote_before_an_error(fresh_scene, tmp_path, monkeypatch, registered):
    obj = box(fresh_scene, "Buggy")
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    buggy_edges(monkeypatch, "Buggy")
    with pytest.raises(RuntimeError, match=r"IndexError: index 24 .* \(a bug: please report it\)"):
        bpy.ops.porous_weathering.bake_maps(maps={"rain", "edges"}, out_dir=str(tmp_path), resolution=16, samples=2)
    assert obj.get(map_image_property("rain")) in bpy.data.images
    assert obj.get(map_image_property("edges")) is None


def test_everything_at_once_bakes_every_map_and_a_stray_vertex_changes_nothing(fresh_scene, tmp_path):
    """A mirrored box with Subdivision, Bevel, Array and Solidify, loose vertices and edges, and a
    stray vertex far away (as scans carry): every map on both targets' terms, finite, in [0, 1],
    and the image maps those of the same object without the stray vertex."""
    objects = []
    for name, stray in (("Stray", True), ("Tidy", False)):
        obj = box(fresh_scene, name, scale=(-1.0, 1.0, 1.0))
        solid = bmesh.new()
        solid.from_mesh(obj.data)
        loose = [solid.verts.new(point) for point in ((0.9, 0.0, 1.5), (0.9, 0.2, 1.5))]
        solid.edges.new(loose)
        if stray:
            solid.verts.new((-1e5, -1e5, -1e5))
        solid.to_mesh(obj.data)
        solid.free()
        for modifier in ("Subdivision Surface", "Bevel", "Array", "Solidify"):
            MODIFIERS[modifier](obj)
        objects.append(obj)
    bpy.context.view_layer.update()
    outcomes = bake_images(objects, tmp_path, alone())
    assert all(outcome.status == "written" for outcome in outcomes)
    for obj in objects:
        for map_name in maps.names():
            pixels = imageio.read_image(imageio.image_path(tmp_path, obj.name, map_name))[0]
            assert np.isfinite(pixels).all() and pixels.min() >= 0.0 and pixels.max() <= 1.0, map_name
    assert_agree(*objects, tmp_path)


def test_a_bake_that_writes_nothing_takes_its_carrier_lightmap_back(fresh_scene, tmp_path, monkeypatch):
    """The lightmap of an Array (a carrier object and a Data Transfer modifier) is undone when
    none of the object's maps is written, as a new UV map is: the user's object as it was."""
    obj = box(fresh_scene, "Box")
    MODIFIERS["Array"](obj)
    kind = maps.get("rain")

    def failing(*args):
        raise RuntimeError("the rain bake failed")

    monkeypatch.setitem(
        registry._DISCOVERED, "rain", dataclasses.replace(kind, bake_image=failing)
    )  # found by maps.get
    objects_before = set(bpy.data.objects.keys())
    with pytest.raises(RuntimeError, match="the rain bake failed"):
        bake_images([obj], tmp_path, alone())
    assert [modifier.name for modifier in obj.modifiers] == ["Array"]
    assert not obj.data.uv_layers and set(bpy.data.objects.keys()) == objects_before
    assert not [mesh for mesh in bpy.data.meshes if mesh.name.endswith(lightmap.LIGHTMAP_UV)]


def test_a_changed_modifier_gets_its_carrier_lightmap_made_again(fresh_scene, tmp_path):
    """After the Array gains a copy, the carrier no longer fits its corners: the next bake makes
    the lightmap again on the carrier (not refused as a stale lightmap of the user's would be),
    and every map agrees with the new shape applied."""
    obj = box(fresh_scene, "Box")
    MODIFIERS["Array"](obj)
    bake_images([obj], tmp_path, alone())
    obj.modifiers["Array"].count = 3
    bpy.context.view_layer.update()
    outcomes = bake_images([obj], tmp_path, alone())
    assert [outcome.status for outcome in outcomes] == ["written"] * len(maps.names())
    carrier = obj.modifiers[lightmap.LIGHTMAP_MODIFIER].object
    with scratch_scene.rendered(obj) as seen:
        assert len(carrier.data.loops) == len(seen.mesh.loops) == 3 * len(obj.data.loops)
    flat = applied(fresh_scene, obj)
    bake_images([flat], tmp_path, alone())
    assert_agree(obj, flat, tmp_path)
