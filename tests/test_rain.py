"""Rain exposure E against known answers, lightmap UVs, and the bake pipeline's bookkeeping."""

import math

import bpy

import bmesh
import numpy as np
import pytest

from helpers import counted_probes, cycles_corner_bake
from porous_weathering.blender import mesh_arrays
from porous_weathering.common import imageio
from porous_weathering.maps import bake, lightmap, rain
from porous_weathering.samples import studio

SIZE = 32


def settings(**changes):
    return rain.RainSettings(**{"cone": 15.0, "samples": 32, **changes})


def grid(scene, name, size_x, size_y, cuts, location=(0, 0, 0), rotation=(0, 0, 0), uvs=True):
    """A flat grid facing +Z before ``rotation``, with ``cuts`` x ``cuts`` quads."""
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    if uvs:
        bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_grid(bm, x_segments=cuts, y_segments=cuts, size=0.5, calc_uvs=uvs)
    bmesh.ops.scale(bm, vec=(size_x, size_y, 1.0), verts=bm.verts)
    bm.to_mesh(mesh)
    bm.free()
    obj = studio.link(scene, bpy.data.objects.new(name, mesh))
    obj.location, obj.rotation_euler = location, rotation
    bpy.context.view_layer.update()
    return obj


def corner_positions(obj):
    positions = np.array([obj.matrix_world @ obj.data.vertices[loop.vertex_index].co for loop in obj.data.loops])
    return positions


def test_open_plane_under_vertical_rain_is_one(fresh_scene):
    plane = grid(fresh_scene, "Open", 2, 2, 1)
    image = rain.bake_rain_image(plane, "UVMap", SIZE, settings())
    assert image.mean() == pytest.approx(1.0, abs=0.01)
    assert np.abs(image - 1.0).max() < 0.05
    corners = rain.bake_rain_corners(plane, settings())
    assert np.allclose(corners, 1.0, atol=0.03)


def test_plane_under_an_opaque_roof_is_dry(fresh_scene):
    plane = grid(fresh_scene, "Floor", 2, 2, 1)
    roof = grid(fresh_scene, "Roof", 6, 6, 1, location=(0, 0, 0.5))
    image = rain.bake_rain_image(plane, "UVMap", SIZE, settings(), occluders=[roof])
    assert image.max() < 0.01
    # without the roof as an occluder (a chosen, empty occluder set) the plane is open again
    assert rain.bake_rain_image(plane, "UVMap", SIZE, settings()).mean() == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("beta", [30.0, 60.0])
def test_tilted_plane_gets_cos_beta(fresh_scene, beta):
    plane = grid(fresh_scene, "Tilted", 2, 2, 1, rotation=(math.radians(beta), 0, 0))
    image = rain.bake_rain_image(plane, "UVMap", SIZE, settings())
    assert image.mean() == pytest.approx(math.cos(math.radians(beta)), abs=0.01)


def overhang_exposure(depth, drop, rain_settings, count=400):
    """E at a point of a wall facing +Y, ``drop`` below a cornice reaching ``depth`` out from
    the wall (infinitely wide): quadrature over the rain cone, uniform in solid angle."""
    cone = math.radians(rain_settings.cone)
    # midpoint rule in (cos θ, φ): equal solid angle per cell
    mu = 1.0 - (np.arange(count) + 0.5) / count * (1.0 - math.cos(cone))
    phi = (np.arange(4 * count) + 0.5) / (4 * count) * 2 * math.pi
    mu, phi = np.meshgrid(mu, phi, indexing="ij")
    sin = np.sqrt(1 - mu**2)
    local = np.stack([sin * np.cos(phi), sin * np.sin(phi), mu], axis=-1)
    towards = np.array(rain_settings.towards_rain())
    axis = np.cross([0.0, 0.0, 1.0], towards)
    angle = math.acos(np.clip(towards[2], -1, 1))
    if np.linalg.norm(axis) > 1e-12:  # rotate the cone from +Z to the mean rain direction (Rodrigues)
        k = axis / np.linalg.norm(axis)
        local = (
            local * math.cos(angle)
            + np.cross(k, local) * math.sin(angle)
            + k * (local @ k)[..., None] * (1 - math.cos(angle))
        )
    facing = np.maximum(local[..., 1], 0.0)
    reaches_past_cornice = drop * local[..., 1] > depth * local[..., 2]
    return float((facing * reaches_past_cornice).sum() / (local @ towards).sum())


@pytest.mark.parametrize("wind_tilt", [0.0, 40.0])
def test_wall_under_a_cornice_matches_the_overhang_fraction(fresh_scene, wind_tilt):
    rain_settings = settings(cone=35.0, wind_tilt=wind_tilt, wind_azimuth=90.0, samples=256)
    wall = grid(fresh_scene, "Wall", 1, 2, 4, location=(0, 0, 1), rotation=(-math.pi / 2, 0, 0))
    cornice = grid(fresh_scene, "Cornice", 40, 0.4, 1, location=(0, 0.2, 2.0))
    values = rain.bake_rain_corners(wall, rain_settings, occluders=[cornice])
    positions = corner_positions(wall)
    assert np.allclose(positions[:, 1], 0.0, atol=1e-6)
    checked = 0
    for drop in (0.5, 1.0, 1.5, 2.0):
        at = np.isclose(2.0 - positions[:, 2], drop) & (np.abs(positions[:, 0]) < 0.3)
        expected = overhang_exposure(0.4, drop, rain_settings)
        assert values[at].mean() == pytest.approx(expected, abs=0.02), f"drop {drop}"
        checked += at.sum()
    assert checked >= 8
    # the overhang matters: the exposure grows with the drop below it
    assert overhang_exposure(0.4, 0.5, rain_settings) < overhang_exposure(0.4, 2.0, rain_settings) - 0.05


def cube_face_means(obj, values):
    normals = np.array([obj.data.polygons[p].normal for p in range(len(obj.data.polygons))])
    per_corner_face = np.empty(len(obj.data.loops), dtype=np.int64)
    for polygon in obj.data.polygons:
        per_corner_face[list(polygon.loop_indices)] = polygon.index
    return {tuple(np.round(normals[f]).astype(int)): values[per_corner_face == f].mean() for f in range(len(normals))}


def test_wind_moves_exposure_to_the_windward_face(fresh_scene):
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    cube = bpy.context.active_object
    still = cube_face_means(cube, rain.bake_rain_corners(cube, settings()))
    windy = cube_face_means(cube, rain.bake_rain_corners(cube, settings(wind_tilt=45.0, wind_azimuth=0.0)))
    assert still[(1, 0, 0)] == pytest.approx(still[(-1, 0, 0)], abs=0.02)
    assert windy[(1, 0, 0)] == pytest.approx(math.cos(math.radians(45)), abs=0.03)
    assert windy[(-1, 0, 0)] < 0.01
    assert windy[(0, 0, 1)] == pytest.approx(math.cos(math.radians(45)), abs=0.03)


def test_a_flat_shaded_mesh_is_baked_once_per_vertex_and_face_plane_as_cycles_bakes_its_corners(
    fresh_scene, monkeypatch
):
    """A box cut into quads, flat-shaded, half under a slab, in a slanting rain: the corners that
    share a vertex and a face plane share E, baked once per such pair (about a third of the
    corners), and E is Cycles' own per-corner bake's within its noise, shelter included."""
    mesh = bpy.data.meshes.new("Box")
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=3, use_grid_fill=True)
    bm.to_mesh(mesh)
    bm.free()
    box = studio.link(fresh_scene, bpy.data.objects.new("Box", mesh))
    slab = grid(fresh_scene, "Slab", 0.8, 2, 1, location=(0.5, 0, 0.8))
    rain_settings = settings(cone=35.0, wind_tilt=30.0, wind_azimuth=90.0, samples=128)
    probes = counted_probes(monkeypatch)
    values = rain.bake_rain_corners(box, rain_settings, occluders=[slab])
    face_of = mesh_arrays.corner_faces(mesh)
    normals = np.array([p.normal for p in mesh.polygons])[face_of]
    pairs = np.column_stack([mesh_arrays.attribute(mesh, ".corner_vert", np.int32), np.round(normals).astype(int)])
    _, pair = np.unique(pairs, axis=0, return_inverse=True)
    pair = pair.ravel()
    assert len(probes) == 1 and probes[0] <= pair.max() + 1 < 0.4 * len(values)
    for index in range(pair.max() + 1):
        assert np.ptp(values[pair == index]) == 0.0
    per_corner = cycles_corner_bake(box, rain.sky(rain_settings), occluders=[slab])
    sheltered = (normals[:, 2] > 0.5) & (corner_positions(box)[:, 0] > 0.15)
    assert values[sheltered].mean() < 0.5 * values[normals[:, 2] > 0.5].max()  # the slab shelters
    assert abs(values.mean() - per_corner.mean()) < 5e-3
    assert abs(values[sheltered].mean() - per_corner[sheltered].mean()) < 0.02
    assert np.sqrt(np.mean((values - per_corner) ** 2)) < 0.02  # 128 samples' noise, twice


def test_corners_at_the_foot_of_a_step_are_baked_as_cycles_bakes_them(fresh_scene):
    """A block standing on a floor cut into quads, flat-shaded, in a slanting rain: the floor's
    corners along the block's foot (a concave corner) take E from just inside their faces
    (sky_bake.CORNER_INSET), not the half-hidden sky of the foot itself, which a probe at the
    vertex saw (0.46 here against 0.94 on the open floor). Cycles' own per-corner bake gives 0.56
    there, the inset bake 0.63 (1024 samples): no less than Cycles', no more than the open floor,
    and the whole mesh's mean as Cycles' (docs/maps.md, "Colour attribute")."""
    mesh = bpy.data.meshes.new("Step")
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=8, y_segments=8, size=1.0)
    block = bmesh.ops.create_cube(bm, size=0.5)["verts"]
    bmesh.ops.translate(bm, vec=(0.0, 0.0, 0.25), verts=block)
    # the block's bottom and the floor beneath it go: the floor meets the block's walls at its foot
    beneath = [f for f in bm.faces if f.normal.z < -0.5 or max(map(abs, f.calc_center_median().to_2d())) < 0.25]
    bmesh.ops.delete(bm, geom=beneath, context="FACES")
    bm.to_mesh(mesh)
    bm.free()
    step = studio.link(fresh_scene, bpy.data.objects.new("Step", mesh))
    rain_settings = settings(cone=35.0, wind_tilt=20.0, wind_azimuth=0.0, samples=256)
    values = rain.bake_rain_corners(step, rain_settings)
    per_corner = cycles_corner_bake(step, rain.sky(rain_settings))
    position = corner_positions(step)
    face_of = mesh_arrays.corner_faces(mesh)
    floor = (np.array([p.normal.z for p in mesh.polygons])[face_of] > 0.5) & (np.abs(position[:, 2]) < 1e-6)
    outside = np.max(np.abs(position[:, :2]), axis=1)
    foot = floor & np.isclose(outside, 0.25)  # the floor's corners on the block's foot
    assert foot.sum() >= 8
    assert per_corner[foot].mean() - 0.03 < values[foot].mean() < values[floor & (outside > 0.8)].mean()
    assert abs(values.mean() - per_corner.mean()) < 0.01


def test_bake_leaves_the_scene_as_it_was(fresh_scene):
    plane = grid(fresh_scene, "Plane", 2, 2, 1)
    before = {
        kind: len(getattr(bpy.data, kind))
        for kind in ("objects", "meshes", "materials", "images", "scenes", "lights", "worlds")
    }
    rain.bake_rain_image(plane, "UVMap", SIZE, settings(sky="world", samples=4))
    rain.bake_rain_corners(plane, settings(samples=4))
    after = {kind: len(getattr(bpy.data, kind)) for kind in before}
    assert after == before
    assert not plane.data.color_attributes and plane.data.materials[:] == []


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="cone"):
        rain.RainSettings(cone=0)
    with pytest.raises(ValueError, match="tilt"):
        rain.RainSettings(wind_tilt=120)


# --- lightmap UVs ---------------------------------------------------------------------------


def test_lightmap_is_a_new_non_overlapping_map(fresh_scene):
    bpy.ops.mesh.primitive_monkey_add()
    monkey = bpy.context.active_object
    bpy.ops.object.modifier_add(type="SUBSURF")
    bpy.ops.object.modifier_apply(modifier=monkey.modifiers[0].name)
    mesh = monkey.data
    user_uvs = lightmap.corner_uvs(mesh, "UVMap").copy()
    unwrapped = lightmap.lightmap_uvs(mesh, 128)
    corners, _ = lightmap.triangle_corners(mesh)
    assert lightmap.overlapping_texels(unwrapped[corners], 128) == 0
    assert unwrapped.min() >= 0 and unwrapped.max() <= 1
    lightmap.add_uv_map(mesh, lightmap.LIGHTMAP_UV, unwrapped)
    assert np.array_equal(lightmap.corner_uvs(mesh, "UVMap"), user_uvs)
    assert mesh.uv_layers.active.name == "UVMap"
    assert lightmap.find_bakeable_uv_map(mesh, 128) == lightmap.LIGHTMAP_UV


def test_overlapping_user_map_is_not_reused(fresh_scene):
    bpy.ops.mesh.primitive_cube_add()
    mesh = bpy.context.active_object.data
    square = np.tile(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32), (6, 1))
    mesh.uv_layers["UVMap"].data.foreach_set("uv", square.ravel())
    corners, _ = lightmap.triangle_corners(mesh)
    assert (
        lightmap.overlapping_texels(square[corners], 16) == 16 * 16
    )  # six faces on each centre (a diagonal's: once each)
    assert lightmap.find_bakeable_uv_map(mesh, 16) is None


def test_image_bake_without_uvs_makes_a_dilated_lightmap(fresh_scene, tmp_path):
    plane = grid(fresh_scene, "Bare", 2, 1, 3, uvs=False)
    assert not plane.data.uv_layers
    [outcome] = bake.bake_maps(
        [plane],
        bake.BakeOptions(maps=("rain",), resolution=SIZE, out_dir=str(tmp_path), rain_settings=settings(samples=8)),
    )
    assert outcome.status == "written" and [m.name for m in plane.data.uv_layers] == [lightmap.LIGHTMAP_UV]
    pixels, metadata = imageio.read_image(outcome.where)
    assert metadata["pw:uv_map"] == lightmap.LIGHTMAP_UV
    # every texel a bilinear lookup inside the island can touch is filled (with E = 1)
    corners, _ = lightmap.triangle_corners(plane.data)
    triangles = lightmap.corner_uvs(plane.data, lightmap.LIGHTMAP_UV)[corners] * SIZE
    centres = np.stack(np.meshgrid(np.arange(SIZE) + 0.5, np.arange(SIZE) + 0.5), axis=-1).reshape(-1, 2)
    lo, hi = triangles.reshape(-1, 2).min(axis=0), triangles.reshape(-1, 2).max(axis=0)
    near = np.all((centres > lo - 1.5) & (centres < hi + 1.5), axis=1).reshape(SIZE, SIZE)[::-1]
    assert near.sum() > 50
    assert np.allclose(pixels[..., 0][near], 1.0, atol=0.02)


def test_a_failed_bake_leaves_no_uv_map_and_no_file(fresh_scene, tmp_path, monkeypatch):
    plane = grid(fresh_scene, "Bare", 2, 2, 1, uvs=False)

    def broken(*args, **kwargs):
        raise RuntimeError("simulated failure")

    monkeypatch.setattr(rain, "bake_rain_image", broken)
    with pytest.raises(RuntimeError, match="simulated"):
        bake.bake_maps([plane], bake.BakeOptions(maps=("rain",), resolution=SIZE, out_dir=str(tmp_path)))
    assert not plane.data.uv_layers
    assert list(tmp_path.iterdir()) == []


def test_attribute_bake_is_skipped_until_an_input_changes(fresh_scene):
    plane = grid(fresh_scene, "Plane", 2, 2, 1)
    options = bake.BakeOptions(maps=("rain",), target="attribute", rain_settings=settings(samples=4))
    assert [o.status for o in bake.bake_maps([plane], options)] == ["written"]
    assert rain.RAIN_ATTRIBUTE in plane.data.color_attributes
    assert [o.status for o in bake.bake_maps([plane], options)] == ["unchanged"]
    plane.location.z += 1.0
    bpy.context.view_layer.update()
    assert [o.status for o in bake.bake_maps([plane], options)] == ["written"]
    changed = bake.BakeOptions(maps=("rain",), target="attribute", rain_settings=settings(samples=4, cone=20.0))
    assert [o.status for o in bake.bake_maps([plane], changed)] == ["written"]


def test_cancel_stops_between_steps(fresh_scene, tmp_path):
    planes = [grid(fresh_scene, f"P{i}", 1, 1, 1, location=(3 * i, 0, 0)) for i in range(3)]
    asked = []

    def cancelled():
        asked.append(1)
        return len(asked) > 1

    with pytest.raises(bake.BakeCancelled):
        bake.bake_maps(
            planes,
            bake.BakeOptions(maps=("rain",), resolution=SIZE, out_dir=str(tmp_path), rain_settings=settings(samples=2)),
            cancelled=cancelled,
        )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["P0.rain.exr"]


def test_non_mesh_object_is_named_in_the_error(fresh_scene, tmp_path):
    empty = studio.link(fresh_scene, bpy.data.objects.new("Marker", None))
    with pytest.raises(ValueError, match="'Marker' has no mesh"):
        bake.bake_maps([empty], bake.BakeOptions(out_dir=str(tmp_path)))


def test_operator_bakes_the_selected_meshes(fresh_scene, registered, tmp_path):
    plane = grid(fresh_scene, "Plane", 2, 2, 1)
    plane.select_set(True)
    bpy.context.view_layer.objects.active = plane
    result = bpy.ops.porous_weathering.bake_maps(resolution=SIZE, samples=4, out_dir=str(tmp_path))
    assert result == {"FINISHED"}
    pixels, _ = imageio.read_image(tmp_path / "Plane.rain.exr")
    assert pixels.mean() == pytest.approx(1.0, abs=0.02)
    assert bpy.data.images[plane["pw_rain_image"]].colorspace_settings.name == "Non-Color"
