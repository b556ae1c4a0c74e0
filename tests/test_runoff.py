"""The run-off map through the bake (docs/maps.md, "Run-off"): baked after the rain it reads,
by default, through the API and the command line, to a colour attribute or an image; one quad
and a fine grid, millimetres and metres get the same map; its settings re-bake it; a bake of the
run-off alone reads the rain baked before, and is refused, before any work, when there is none."""

import bpy

import numpy as np
import pytest

from helpers import run_cli
from meshes import add_to_scene, merge, quad
from porous_weathering.blender import mesh_arrays
from porous_weathering.common import imageio
from porous_weathering.maps import bake, rain, runoff
from porous_weathering.maps import registry as maps

FAST_RAIN = rain.RainSettings(samples=16)


def wall_under_a_coping(n=1, scale=1.0, name="Wall"):
    """A wall facing -y (x in [0, 1], z in [0, 1]) under a coping 0.3 deep that falls towards
    its face: vertical rain lands on the coping only, and runs down the wall from its front edge."""
    vertices, triangles = merge(
        quad((0, 0, 0), (1, 0, 0), (0, 0, 1), n, (0, -1, 0)),
        quad((0, 0, 1), (1, 0, 0), (0, 0.3, 0.05), n, (0, -0.05, 0.3)),
    )
    return add_to_scene(name, vertices * scale, triangles)


def vertical_rain(obj):
    """The rain map of vertical rain on an open surface, E = max(0, N.z) at every corner, as if
    baked: the maps of two meshes are compared without the rain bake's noise."""
    mesh = obj.data
    normals = np.empty(len(mesh.loops) * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", normals)
    mesh_arrays.write_corner_attribute(mesh, rain.RAIN_ATTRIBUTE, np.clip(normals.reshape(-1, 3)[:, 2], 0.0, 1.0))
    mesh[f"{rain.RAIN_ATTRIBUTE}_inputs"] = "vertical rain"


def corner_values(obj, attribute):
    values = np.empty(len(obj.data.loops) * 4, np.float32)
    obj.data.color_attributes[attribute].data.foreach_get("color", values)
    return values.reshape(-1, 4)[:, 0]


def corner_positions(obj):
    corners = np.empty(len(obj.data.loops), np.int32)
    obj.data.loops.foreach_get("vertex_index", corners)
    points = np.array([obj.matrix_world @ v.co for v in obj.data.vertices])
    return points[corners]


def corner_faces(obj):
    """Each corner's position (scaled back by ``scale``) and its face's normal, as a key: a
    point where faces meet holds a value per face."""
    normals = np.empty(len(obj.data.loops) * 3, np.float32)
    obj.data.corner_normals.foreach_get("vector", normals)
    return [tuple(np.round(np.concatenate([p, n]), 3)) for p, n in zip(corner_positions(obj), normals.reshape(-1, 3))]


def test_runoff_is_a_map_of_the_registry_baked_by_default_after_the_rain():
    names = maps.names()
    assert names.index("runoff") > names.index("rain") and maps.get("runoff").reads == ("rain",)
    assert bake.BakeOptions().maps == maps.names()
    assert bake.BakeOptions(maps=("runoff", "rain")).maps == ("rain", "runoff")  # the rain first
    assert bake.BakeOptions(maps=("edges", "runoff", "rain")).maps == ("edges", "rain", "runoff")
    assert [entry.option.flag for entry in bake.option_entries() if entry.owner == "runoff"] == [
        "--runoff-length",
        "--absorption-length",
        "--drip-angle",
    ]


def test_the_wall_below_an_exposed_coping_gets_its_water(fresh_scene):
    wall = wall_under_a_coping(8)
    options = bake.BakeOptions(maps=("rain", "runoff"), target="attribute", rain_settings=FAST_RAIN)
    assert [o.status for o in bake.bake_maps([wall], options)] == ["written", "written"]
    points, values = corner_positions(wall), corner_values(wall, runoff.RUNOFF_ATTRIBUTE)
    exposure = corner_values(wall, rain.RAIN_ATTRIBUTE)
    # the face, but for the cell at its open bottom edge, where the water leaves
    on_wall = (np.abs(points[:, 1]) < 1e-6) & (points[:, 2] > 0.05) & (points[:, 2] < 0.95)
    on_wall &= np.abs(points[:, 0] - 0.5) < 0.4
    on_coping = points[:, 2] > 1.0 + 1e-6
    # dQ/ds = E - Q / l along the path: over the coping (0.304 long, E_top) Q reaches
    # Q0 = E_top l (1 - exp(-0.304 / l)), then down the face, which adds the little rain the
    # cone gives it (E_wall): Q = Q0 exp(-s / l) + E_wall l (1 - exp(-s / l)); R = 1 - exp(-Q / L)
    runoff_length, absorption_length = runoff.RunoffSettings().lengths(runoff.edges.object_size(wall))
    top, face = exposure[on_coping].mean(), exposure[on_wall].mean()
    s = 1.0 - points[on_wall, 2]
    kept = np.exp(-s / absorption_length)
    at_the_edge = top * absorption_length * -np.expm1(-np.hypot(0.3, 0.05) / absorption_length)
    expected = -np.expm1(-(at_the_edge * kept + face * absorption_length * (1.0 - kept)) / runoff_length)
    assert np.abs(values[on_wall] - expected).max() < 0.05
    assert values[on_wall].min() > 0.2 and face < 0.1  # the wall is reached: its own rain is little


def test_one_quad_and_a_fine_grid_and_every_unit_give_the_same_attribute_map(fresh_scene):
    options = bake.BakeOptions(maps=("runoff",), target="attribute")
    reference = None
    for n, scale in ((1, 1.0), (64, 1.0), (8, 1000.0), (8, 0.1)):
        wall = wall_under_a_coping(n, scale, name=f"Wall{n}x{scale:g}")
        vertical_rain(wall)
        bake.bake_maps([wall], options)
        wall.scale = (1.0 / scale,) * 3  # compared where the corners are at the unit scale
        bpy.context.view_layer.update()
        at_corners = dict(zip(corner_faces(wall), corner_values(wall, runoff.RUNOFF_ATTRIBUTE)))
        wall.scale = (1.0,) * 3
        if reference is None:
            reference = at_corners
            continue
        shared = [key for key in reference if key in at_corners]
        assert shared
        assert max(abs(reference[key] - at_corners[key]) for key in shared) < 0.02, (n, scale)


def test_a_seam_where_the_surface_is_split_is_no_border(fresh_scene):
    """A level roof drains to its nearest open edges. Split down its middle into two loose
    halves (as importers leave a glTF at its UV seams), its seam lies on itself: no edge water
    leaves by (``mesh_arrays.open_edges``), so the roof gets the map it gets whole; read as a
    border, the seam drained the middle (R 0.89 lower there)."""
    options = bake.BakeOptions(maps=("runoff",), target="attribute")
    maps = []
    halves = (quad((0, 0, 0), (0.5, 0, 0), (0, 1, 0), (4, 8)), quad((0.5, 0, 0), (0.5, 0, 0), (0, 1, 0), (4, 8)))
    for name, (vertices, triangles) in (("Whole", quad((0, 0, 0), (1, 0, 0), (0, 1, 0), 8)), ("Split", merge(*halves))):
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(vertices.tolist(), [], triangles.tolist())  # not welded
        roof = bpy.data.objects.new(name, mesh)
        fresh_scene.collection.objects.link(roof)
        vertical_rain(roof)
        bake.bake_maps([roof], options)
        maps.append(dict(zip(corner_faces(roof), corner_values(roof, runoff.RUNOFF_ATTRIBUTE))))
    whole, split = maps
    assert mesh_arrays.open_edges(mesh).sum() == 32 and (mesh_arrays.edge_uses(mesh) == 1).sum() == 48
    shared = [key for key in whole if key in split]
    assert len(shared) == 81 and max(abs(whole[key] - split[key]) for key in shared) < 1e-6


def test_image_maps_of_one_quad_and_a_fine_grid_agree(fresh_scene, tmp_path):
    images = []
    for n in (1, 32):
        wall = wall_under_a_coping(n, name=f"Wall{n}")
        out = tmp_path / f"grid{n}"
        options = bake.BakeOptions(maps=("rain",), resolution=64, out_dir=str(out), rain_settings=FAST_RAIN)
        bake.bake_maps([wall], options)
        # the rain of vertical rain, without the rain bake's noise, in place of the baked one
        positions, normals, islands = runoff.edges.bake_texel_geometry(wall, "PW Lightmap", 64)
        _, header = imageio.read_image(out / f"Wall{n}.rain.exr")
        exposure = np.where(islands, np.clip(normals[..., 2], 0.0, 1.0), 0.0)
        imageio.write_image(out / f"Wall{n}.rain.exr", exposure[..., None].astype(np.float32), metadata=header)
        bake.bake_maps([wall], bake.BakeOptions(maps=("runoff",), resolution=64, out_dir=str(out)))
        pixels, _ = imageio.read_image(out / f"Wall{n}.runoff.exr")
        images.append((positions[islands], normals[islands], pixels[..., 0][islands]))
    # the two lightmaps differ: compare at the same surface points, the nearest texel of the other
    (points_a, normals_a, values_a), (points_b, normals_b, values_b) = images
    distance = np.linalg.norm(points_a[:, None, :] - points_b[None, :, :], axis=2)
    distance[normals_a @ normals_b.T < 0.5] = np.inf  # on the same face
    rms = np.sqrt(np.mean((values_a - values_b[np.argmin(distance, axis=1)]) ** 2))
    assert rms < 0.03


def test_a_changed_setting_rebakes_the_runoff_and_a_rebaked_rain_too(fresh_scene):
    wall = wall_under_a_coping(4)
    options = bake.BakeOptions(maps=("rain", "runoff"), target="attribute", rain_settings=FAST_RAIN)
    bake.bake_maps([wall], options)
    assert [o.status for o in bake.bake_maps([wall], options)] == ["unchanged", "unchanged"]
    drip = bake.BakeOptions(
        maps=("rain", "runoff"),
        target="attribute",
        rain_settings=FAST_RAIN,
        runoff_settings=runoff.RunoffSettings(drip_angle=45.0),
    )
    assert [o.status for o in bake.bake_maps([wall], drip)] == ["unchanged", "written"]
    windy = bake.BakeOptions(
        maps=("rain", "runoff"), target="attribute", rain_settings=rain.RainSettings(samples=16, wind_tilt=20.0)
    )
    assert [o.status for o in bake.bake_maps([wall], windy)] == ["written", "written"]


def test_the_runoff_alone_reads_the_rain_baked_before_or_is_refused_before_any_work(fresh_scene):
    wall = wall_under_a_coping(2)
    alone = bake.BakeOptions(maps=("runoff",), target="attribute")
    with pytest.raises(ValueError, match=r"object 'Wall': the runoff map reads the rain map.*--maps rain,runoff"):
        bake.bake_maps([wall], alone)
    assert runoff.RUNOFF_ATTRIBUTE not in wall.data.color_attributes
    bake.bake_maps([wall], bake.BakeOptions(maps=("rain",), target="attribute", rain_settings=FAST_RAIN))
    assert [o.status for o in bake.bake_maps([wall], alone)] == ["written"]


def test_the_command_line_bakes_the_runoff_by_default_and_takes_its_options(fresh_scene, tmp_path):
    wall_under_a_coping(4)
    blend = tmp_path / "wall.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    common = [blend, "--out", tmp_path / "maps", "--resolution", "32", "--samples", "8"]
    first = run_cli("bake", *common, "--absorption-length", "inf", "--drip-angle", "40")
    assert first.returncode == 0, first.stderr
    assert "written   Wall.runoff -> " in first.stdout
    again = run_cli("bake", *common, "--absorption-length", "inf", "--drip-angle", "40")
    assert "unchanged Wall.runoff" in again.stdout
    bad = run_cli("bake", *common, "--drip-angle", "120")
    assert bad.returncode == 2 and "drip angle" in bad.stderr
