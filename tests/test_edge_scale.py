"""The edge/cavity mask at a physical scale (docs/maps.md, "Edge/cavity mask"): the same object in
millimetres, metres or tenths of a unit gets the same mask, scan noise below the scale does not
light it up, a flat-shaded scan gets the mask of its smooth form, cavities and edges are
weighted apart, and the scale rule holds for the API, BakeOptions, the command line and the
bake operator."""

import math
import warnings

import bpy

import numpy as np
import pytest

from porous_weathering.cli import bake as bake_command
from porous_weathering.common import imageio, options
from porous_weathering.maps import bake, edges
from scripts import load_script

scan_generator = load_script("sample_blends/scan_generator.py")

#: Scale factors from a bust in millimetres: to metres, and to a bust 0.1 units across.
UNITS = {"mm": 1.0, "m": 0.001, "tenth": 0.1 / scan_generator.NOMINAL_DIAGONAL_MM}


#: Bumps on the sphere: (longitude, latitude), angular width, height (in radii).
BUMPS = (((0.3, 0.5), 0.25, 0.1), ((1.9, -0.3), 0.3, -0.12), ((3.5, 0.2), 0.12, 0.08), ((4.8, -0.6), 0.35, -0.1))


def bumpy_sphere(name, radius=1.0, segments=192, noise=0.0, flat=False):
    """A latitude-longitude sphere with bumps and dents wider than the default edge radius,
    optional white radial noise of ``noise`` radii (a scan's, below the radius), and one UV
    island: (longitude, latitude) squeezed into [0.02, 0.98]^2."""
    around, rows = segments, segments // 2 - 1

    def direction(lon, lat):
        return np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], -1)

    lon, lat = np.meshgrid(2 * np.pi * np.arange(around) / around, np.pi * (np.arange(1, rows + 1) / (rows + 1) - 0.5))
    directions = np.concatenate([direction(lon.T, lat.T).reshape(-1, 3), [[0, 0, -1], [0, 0, 1]]])
    lengths = np.ones(len(directions))
    for centre, width, height in BUMPS:
        angle = np.arccos(np.clip(directions @ direction(*centre), -1, 1))
        lengths += height * np.exp(-((angle / width) ** 2))
    lengths += noise * np.random.default_rng(0).standard_normal(len(directions))
    south, north = len(directions) - 2, len(directions) - 1

    def vertex(i, j):
        return (i % around) * rows + j

    def uv(i, j):  # j from -1 (south pole) to rows (north pole)
        return 0.02 + 0.96 * i / around, 0.02 + 0.96 * (j + 1) / (rows + 1)

    faces, uvs = [], []
    for i in range(around):
        for j in range(rows - 1):
            faces.append((vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)))
            uvs += [uv(i, j), uv(i + 1, j), uv(i + 1, j + 1), uv(i, j + 1)]
        faces += [(vertex(i + 1, 0), vertex(i, 0), south), (vertex(i, rows - 1), vertex(i + 1, rows - 1), north)]
        uvs += [uv(i + 1, 0), uv(i, 0), uv(i + 0.5, -1), uv(i, rows - 1), uv(i + 1, rows - 1), uv(i + 0.5, rows)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata((directions * lengths[:, None] * radius).tolist(), [], faces)
    mesh.uv_layers.new(name="UVMap").data.foreach_set("uv", np.array(uvs, dtype=np.float32).ravel())
    if not flat:
        mesh.shade_smooth()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


#: The bumpy sphere's radius in each unit: a metre, and about 0.1 units across.
SPHERE_RADII = {"mm": 1000.0, "m": 1.0, "tenth": 0.03}


def sample_image(image, uvs):
    """Bilinear lookup of ``image`` (top row first) at ``uvs`` (n, 2), as texture filtering does."""
    size = image.shape[0]
    x, y = uvs[:, 0] * size - 0.5, (1.0 - uvs[:, 1]) * size - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0

    def at(row, column):
        return image[np.clip(row, 0, size - 1), np.clip(column, 0, size - 1)]

    top = at(y0, x0) * (1 - fx) + at(y0, x0 + 1) * fx
    bottom = at(y0 + 1, x0) * (1 - fx) + at(y0 + 1, x0 + 1) * fx
    return top * (1 - fy) + bottom * fy


def corner_uvs_and_vertices(obj, inset=0.03):
    """(UV, vertex) of every face corner away from the UV island's border (the seam and poles)."""
    mesh = obj.data
    uvs = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers["UVMap"].data.foreach_get("uv", uvs)
    uvs = uvs.reshape(-1, 2)
    vertices = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", vertices)
    inside = np.all((uvs > 0.02 + inset) & (uvs < 0.98 - inset), axis=1)
    return uvs[inside], vertices[inside]


# --- the same mask at every unit ----------------------------------------------------------------


def test_attribute_mask_is_the_same_in_millimetres_metres_and_tenths(bust):
    busts = {unit: bust(30_000, f"Bust {unit}", scale=UNITS[unit]) for unit in UNITS}
    masks = {unit: edges.write_curvature_attribute(obj) for unit, obj in busts.items()}
    assert masks["mm"].max() == 1.0 and 0.02 < masks["mm"].mean() < 0.3  # the mask shows the form
    for unit in ("m", "tenth"):
        assert np.abs(masks[unit] - masks["mm"]).max() < 1e-3, unit
    # A radius in scene units would not do: the millimetre bust's radius on the metre bust.
    radius_mm = edges.effective_radius(busts["mm"], edges.EdgeSettings())
    assert radius_mm == pytest.approx(0.01 * scan_generator.NOMINAL_DIAGONAL_MM, rel=0.01)
    assert np.abs(edges.write_curvature_attribute(busts["m"], radius_mm) - masks["mm"]).max() > 0.5


def test_image_mask_is_the_same_at_every_unit_and_matches_the_attribute(fresh_scene):
    """At the same texels (the same surface points, as the UVs are the same) the images agree
    within 0.02; and sampled at the vertices they agree with the attribute mask. At cavity
    weight 1, so that 0.02 is in units of the curvature itself (a weight scales both sides)."""
    resolution = 256
    unit_weight = edges.EdgeSettings(cavity_weight=1.0)
    spheres = {unit: bumpy_sphere(f"Sphere {unit}", radius) for unit, radius in SPHERE_RADII.items()}
    images = {unit: edges.edge_mask_image(obj, "UVMap", resolution, unit_weight) for unit, obj in spheres.items()}
    islands = images["mm"] > 0
    assert islands.mean() > 0.5 and images["mm"].max() > 0.25
    for unit in ("m", "tenth"):
        assert np.abs(images[unit] - images["mm"]).max() < 0.02, unit
    attribute = edges.write_curvature_attribute(spheres["tenth"], settings=unit_weight)
    uvs, vertices = corner_uvs_and_vertices(spheres["tenth"])
    assert np.abs(sample_image(images["tenth"], uvs) - attribute[vertices]).max() < 0.02


# --- detail below the scale ---------------------------------------------------------------------


def test_scan_noise_below_the_scale_does_not_light_up_the_mask(bust):
    """The 100k-triangle bust with and without its scan noise (1.2-4 mm, RMS 0.1 mm): the
    same mask within 0.1 everywhere at the default scale, while at a scale near the noise's
    own the noise lights it up (so the comparison can tell). At cavity weight 1: the bounds are
    in units of the curvature (the default weight 3 scales the concave part, noise included)."""
    noisy, clean = bust(100_000, "Noisy"), bust(100_000, "Clean", scan_noise=False)
    unit_weight = edges.EdgeSettings(cavity_weight=1.0)
    masks = [edges.write_curvature_attribute(obj, settings=unit_weight) for obj in (noisy, clean)]
    difference = np.abs(masks[0] - masks[1])
    assert difference.max() < 0.1 and difference.mean() < 0.01
    fine = edges.EdgeSettings(scale=0.005, cavity_weight=1.0)
    fine_masks = [edges.write_curvature_attribute(obj, settings=fine) for obj in (noisy, clean)]
    assert np.abs(fine_masks[0] - fine_masks[1]).max() > 0.15


# --- flat-shaded scans --------------------------------------------------------------------------


def test_flat_shaded_scan_gets_the_mask_of_its_smooth_form(fresh_scene, tmp_path):
    """A flat-shaded mesh without custom normals (a scan saved without normals) gets the same
    masks as the smooth-shaded one, its mesh stays flat, and the bake says so once, naming it."""
    smooth = bumpy_sphere("Smooth Scan", noise=0.001)
    flat = bumpy_sphere("Flat Scan", noise=0.001, flat=True)
    assert np.abs(edges.edge_mask_image(flat, "UVMap", 128) - edges.edge_mask_image(smooth, "UVMap", 128)).max() < 1e-4
    assert np.array_equal(edges.write_curvature_attribute(flat), edges.write_curvature_attribute(smooth))
    assert not any(polygon.use_smooth for polygon in flat.data.polygons)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bake.bake_maps([flat, smooth], bake.BakeOptions(maps=("edges",), resolution=32, out_dir=str(tmp_path)))
    said = [str(warning.message) for warning in caught if "flat-shaded" in str(warning.message)]
    assert len(said) == 1 and "'Flat Scan'" in said[0] and "edge mask takes smooth normals" in said[0]


# --- cavities and edges -------------------------------------------------------------------------


def stepped_block(scene):
    """An L-shaped prism 2 units wide, deep and tall: one concave edge (the inner corner of the
    step, along y at x = z = 1), convex edges elsewhere; its two caps are concave hexagons."""
    profile = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
    vertices = [(x, y, z) for y in (0.0, 2.0) for x, z in profile]
    sides = [(6 + i, 6 + (i + 1) % 6, (i + 1) % 6, i) for i in range(6)]
    mesh = bpy.data.meshes.new("Step")
    mesh.from_pydata(vertices, [], [*sides, tuple(range(6)), tuple(range(6, 12))[::-1]])
    mesh.validate()
    obj = bpy.data.objects.new("Step", mesh)
    scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    assert mesh.polygons[0].normal.z < 0  # the side along the bottom faces down: outwards
    return obj


@pytest.mark.parametrize("cavity_weight, edge_weight", [(1.0, 0.0), (0.0, 1.0), (1.0, 0.5), (0.25, 1.0)])
def test_cavity_and_edge_weights_weigh_the_concave_and_convex_parts(fresh_scene, tmp_path, cavity_weight, edge_weight):
    """The bake (image target, through BakeOptions) of the stepped block: texels within a
    tenth of the radius of its concave edge read the cavity weight times the mask of a
    right-angled crease, those at its convex edges the edge weight times the same."""
    obj = stepped_block(fresh_scene)
    radius, resolution = 0.3, 256
    options = bake.BakeOptions(
        maps=("edges",),
        resolution=resolution,
        out_dir=str(tmp_path),
        edge_radius=radius,
        cavity_weight=cavity_weight,
        edge_weight=edge_weight,
    )
    (outcome,) = bake.bake_maps([obj], options)
    image, _ = imageio.read_image(outcome.where)
    uv_map = imageio.read_metadata(outcome.where)[bake.UV_MAP_KEY]
    positions, _, islands = edges.bake_texel_geometry(obj, uv_map, resolution)
    x, y, z = positions[..., 0], positions[..., 1], positions[..., 2]
    inner = (np.hypot(x - 1, z - 1) < 0.1 * radius) & (np.abs(y - 1) < 0.5) & islands
    outer = (np.hypot(x - 2, z - 1) < 0.1 * radius) & (np.abs(y - 1) < 0.5) & islands  # the step's nose
    assert inner.sum() > 10 and outer.sum() > 10
    crease = 0.6 / edges.DEFAULT_SATURATION  # |H| * radius ~ 0.6 near a right-angled edge (test_edges.py)
    for texels, weight in ((inner, cavity_weight), (outer, edge_weight)):
        assert np.all(np.abs(image[texels, 0] - min(1.0, weight * crease)) < 0.15 * max(weight, 0.1))


# --- one scale rule for the API, BakeOptions, the command line and the operator ------------------


def test_edge_settings_default_to_a_radius_relative_to_the_object(fresh_scene):
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    cube = bpy.context.active_object
    assert edges.EdgeSettings().radius is None
    assert edges.effective_radius(cube, edges.EdgeSettings()) == pytest.approx(0.01 * 2 * math.sqrt(3))
    cube.rotation_euler = (0.3, 0.4, 0.5)
    cube.scale = (3.0, 3.0, 3.0)
    bpy.context.view_layer.update()
    assert edges.effective_radius(cube, edges.EdgeSettings(scale=0.02)) == pytest.approx(0.02 * 6 * math.sqrt(3))
    assert edges.effective_radius(cube, edges.EdgeSettings(radius=0.3, scale=0.02)) == 0.3
    for bad in (
        dict(radius=0.0),
        dict(scale=0.0),
        dict(scale=1.5),
        dict(cavity_weight=-1.0),
        dict(edge_weight=math.inf),
    ):
        with pytest.raises(ValueError, match=next(iter(bad)).split("_")[0]):
            edges.EdgeSettings(**bad)


def test_bake_options_carry_the_edge_settings_by_name_and_alias():
    assert bake.BakeOptions().edge_settings == edges.EdgeSettings()
    given = bake.BakeOptions(edge_radius=0.3, edge_scale=0.02, cavity_weight=2.0, edge_weight=0.0)
    assert given.edge_settings == edges.EdgeSettings(radius=0.3, scale=0.02, cavity_weight=2.0, edge_weight=0.0)
    assert (given.edge_radius, given.edge_scale, given.cavity_weight, given.edge_weight) == (0.3, 0.02, 2.0, 0.0)
    with pytest.raises(ValueError, match="edge radius"):
        bake.BakeOptions(edge_radius=-1.0)


def parse_bake_command(*words):
    import argparse

    parser = argparse.ArgumentParser()
    bake_command.configure_parser(parser)
    return bake.options_from_values(vars(parser.parse_args(["scene.blend", *words])))


def test_command_line_keeps_the_edge_radius_and_adds_the_scale_and_weights():
    assert parse_bake_command().edge_settings == edges.EdgeSettings()
    assert parse_bake_command("--edge-radius", "0.3").edge_settings.radius == 0.3
    chosen = parse_bake_command("--edge-scale", "0.02", "--cavity-weight", "2", "--edge-weight", "0.25")
    assert chosen.edge_settings == edges.EdgeSettings(scale=0.02, cavity_weight=2.0, edge_weight=0.25)
    argv = chosen.to_argv()  # what a Dask worker gets: no --edge-radius, as none was given
    assert "--edge-radius" not in argv and argv[argv.index("--edge-scale") + 1] == "0.02"
    assert parse_bake_command(*argv).edge_settings == chosen.edge_settings
    assert parse_bake_command(*bake.BakeOptions(edge_radius=0.3).to_argv()).edge_settings.radius == 0.3


def test_operator_shows_the_automatic_radius_as_0_and_bakes_with_it(fresh_scene, registered):
    radius = next(entry for entry in bake.option_entries() if entry.dest == "edge_radius")
    assert options.operator_value(radius.option, 0.0) is None
    assert options.operator_value(radius.option, 0.3) == 0.3
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    cube = bpy.context.active_object
    bpy.ops.object.modifier_add(type="SUBSURF")
    bpy.ops.object.modifier_apply(modifier="Subdivision")
    assert bpy.ops.porous_weathering.bake_maps(maps={"edges"}, target="attribute") == {"FINISHED"}
    colours = np.empty(len(cube.data.vertices) * 4, dtype=np.float32)
    cube.data.color_attributes[edges.EDGE_ATTRIBUTE].data.foreach_get("color", colours)
    automatic = edges.write_curvature_attribute(cube)
    assert np.allclose(colours[0::4], automatic) and not np.allclose(
        automatic, edges.write_curvature_attribute(cube, 0.3)
    )


def test_the_input_hash_follows_the_effective_radius_and_the_weights(fresh_scene, tmp_path):
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    cube = bpy.context.active_object
    baked = bake.BakeOptions(maps=("edges",), target="attribute")
    bake.bake_maps([cube], baked)

    def status(**given):
        (outcome,) = bake.bake_maps(
            [cube], bake.BakeOptions(maps=("edges",), target="attribute", **given), dry_run=True
        )
        return outcome.status

    assert status() == "unchanged"
    assert status(edge_radius=edges.effective_radius(cube, edges.EdgeSettings())) == "unchanged"  # the same radius
    assert status(edge_scale=0.02) == "planned"
    assert status(cavity_weight=0.5) == "planned"
    assert status(edge_weight=1.0) == "planned"


def test_a_radius_too_small_names_the_object_and_the_options(fresh_scene):
    bpy.ops.mesh.primitive_cube_add(size=100.0)
    bpy.context.active_object.name = "Quarry Block"
    with pytest.raises(ValueError, match="'Quarry Block'.*radius is too small.*--edge-radius.*--edge-scale"):
        edges.write_curvature_attribute(bpy.context.active_object, 1e-6)
