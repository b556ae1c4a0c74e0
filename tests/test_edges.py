"""Edge/cavity mask C (porous_weathering/edges.py) against shapes whose answer is known."""

import bpy

import bmesh
import numpy as np
import pytest

from benchmarks.scenes import through_gltf
from porous_weathering.blender import mesh_arrays
from porous_weathering.maps import bake, edges
from porous_weathering.maps import curvature as curvature_maths


def link(scene, mesh, name):
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def cube(scene, cuts=0, size=2.0, name="Cube"):
    """An axis-aligned cube, its faces cut into (cuts + 1)^2 quads, with the default cross UVs."""
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_cube(bm, size=size, calc_uvs=True)
    if cuts:
        bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=cuts, use_grid_fill=True)
    bm.to_mesh(mesh)
    bm.free()
    return link(scene, mesh, name)


def sphere(scene, kind, level, radius):
    mesh = bpy.data.meshes.new("Sphere")
    bm = bmesh.new()
    if kind == "uv":
        bmesh.ops.create_uvsphere(bm, u_segments=level, v_segments=level // 2, radius=radius)
    else:
        bmesh.ops.create_icosphere(bm, subdivisions=level, radius=radius)
    bm.to_mesh(mesh)
    bm.free()
    return link(scene, mesh, "Sphere")


def world_points(obj):
    """The evaluated mesh's vertices in world space, as curvature() numbers them."""
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    points = np.array([evaluated.matrix_world @ v.co for v in mesh.vertices])
    evaluated.to_mesh_clear()
    return points


# --- (a) the image target: the curvature field at every texel ----------------------------------


def island_plane(scene):
    """A tilted flat 3 x 3 grid of quads, every quad its own UV island, turned and mirrored."""
    size = 3
    vertices = [(x, y, 0.0) for y in range(size + 1) for x in range(size + 1)]
    faces = [
        (y * (size + 1) + x, y * (size + 1) + x + 1, (y + 1) * (size + 1) + x + 1, (y + 1) * (size + 1) + x)
        for y in range(size)
        for x in range(size)
    ]
    mesh = bpy.data.meshes.new("Islands")
    mesh.from_pydata(vertices, [], faces)
    uv = mesh.uv_layers.new(name="UVMap")
    square = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=float)
    for face in mesh.polygons:
        corners = np.roll(square, face.index, axis=0)  # each island turned by another quarter
        if face.index % 2:
            corners[:, 0] = 1 - corners[:, 0]  # and every other one mirrored
        origin = np.array([face.index % 3, face.index // 3]) * 0.33 + 0.03
        for loop, corner in zip(face.loop_indices, corners):
            uv.data[loop].uv = origin + 0.27 * corner
    obj = link(scene, mesh, "Islands")
    obj.rotation_euler = (0.4, -0.3, 0.2)
    return obj


def test_image_mask_of_a_flat_plane_is_zero_across_seams(fresh_scene):
    mask = edges.edge_mask_image(island_plane(fresh_scene), "UVMap", 64, edges.EdgeSettings(radius=0.5))
    assert mask.shape == (64, 64) and mask.dtype == np.float32
    assert np.abs(mask).max() < 1e-4


def test_image_mask_of_a_cube_is_high_on_every_edge_and_zero_mid_face(fresh_scene):
    """Every border of every face is a cube edge, inside a UV island or on a seam: the mask is
    high within a texel of it, whatever the cube's turn, and 0 beyond the smoothing's reach (two
    grid cells of the radius along each world axis: at most 2 sqrt(3) radii)."""
    resolution, radius = 128, 0.2  # a face is 2 units and 25.6 texels across, the reach 9.9 texels
    obj = cube(fresh_scene)
    obj.rotation_euler = (0.3, 0.2, 0.1)
    uv = obj.data.uv_layers["UVMap"].data
    for corner in uv:  # keep the islands off the image border, as a lightmap layout does
        corner.uv = 0.1 + 0.8 * np.array(corner.uv)
    mask = edges.edge_mask_image(obj, "UVMap", resolution, edges.EdgeSettings(radius=radius, edge_weight=1.0))
    # Texel centres in texels from the left and from the bottom (v = 0).
    column, row = np.meshgrid(np.arange(resolution) + 0.5, np.arange(resolution)[::-1] + 0.5)
    texels_per_unit = 0.8 / 4 * resolution / 2
    for face in obj.data.polygons:
        corners = np.array([uv[loop].uv for loop in face.loop_indices]) * resolution
        low, high = corners.min(axis=0), corners.max(axis=0)
        inset = np.minimum.reduce([column - low[0], high[0] - column, row - low[1], high[1] - row])
        reach = 2 * np.sqrt(3) * radius * texels_per_unit + 1
        assert np.all(mask[inset > reach] == 0) and (inset > reach).sum() > 16, f"face {face.index} mid-face"
        border = mask[(inset > 0) & (inset < 1)]
        assert border.size > 4 * (high - low).min() - 8 and border.min() > 0.8, f"face {face.index} border"


def test_image_mask_leaves_the_scene_as_it_was(fresh_scene):
    obj = cube(fresh_scene)
    material = bpy.data.materials.new("Stone")
    obj.data.materials.append(material)
    before = {kind: len(getattr(bpy.data, kind)) for kind in ("objects", "meshes", "materials", "images", "scenes")}
    edges.edge_mask_image(obj, "UVMap", 16)
    assert {kind: len(getattr(bpy.data, kind)) for kind in before} == before
    assert list(obj.data.materials) == [material]


def test_image_mask_refuses_a_missing_uv_map_or_no_faces(fresh_scene):
    with pytest.raises(ValueError, match="'Cube'.*'Lightmap'"):
        edges.edge_mask_image(cube(fresh_scene), "Lightmap", 16)
    mesh = bpy.data.meshes.new("Points")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0)], [(0, 1)], [])
    with pytest.raises(ValueError, match="'Points'"):
        edges.edge_mask_image(link(fresh_scene, mesh, "Points"), "UVMap", 16)


# --- (b) mesh curvature --------------------------------------------------------------------------


@pytest.mark.parametrize("kind, level", [("uv", 24), ("uv", 48), ("uv", 96), ("ico", 3), ("ico", 4), ("ico", 5)])
def test_sphere_curvature_is_one_over_its_radius(fresh_scene, kind, level):
    radius = 0.7
    curvature = edges.curvature(sphere(fresh_scene, kind, level, radius), 0.35 * radius) * radius
    assert curvature.dtype == np.float32
    assert abs(np.median(curvature) - 1) < 0.02
    assert np.abs(curvature - 1).max() < 0.1


def test_curvature_is_in_world_space_with_mirroring_scale_and_modifiers(fresh_scene):
    obj = sphere(fresh_scene, "ico", 3, 1.0)
    obj.scale = (-2.0, 2.0, 2.0)  # a mirror must not turn the convex sphere concave
    obj.modifiers.new("Subdivision", "SUBSURF").levels = 1
    curvature = edges.curvature(obj, 0.7)
    assert len(curvature) > len(obj.data.vertices)  # the evaluated mesh
    assert np.abs(curvature * 2.0 - 1).max() < 0.1


def edge_and_face_centre_vertices(points, half_size, radius):
    """Vertices on a cube's edges (away from its corners), and near the middle of its faces."""
    sorted_abs = np.sort(np.abs(points), axis=1)
    on_edge = np.all(np.abs(sorted_abs[:, 1:] - half_size) < 1e-4, axis=1) & (sorted_abs[:, 0] < half_size - 2 * radius)
    mid_face = sorted_abs[:, 1] < half_size - 2 * radius
    return on_edge, mid_face


@pytest.mark.parametrize("cuts", [4, 9, 19])
def test_cube_edges_are_convex_whatever_the_tessellation(fresh_scene, cuts):
    radius = 0.3
    obj = cube(fresh_scene, cuts)
    curvature = edges.curvature(obj, radius)
    on_edge, mid_face = edge_and_face_centre_vertices(world_points(obj), 1.0, radius)
    assert on_edge.sum() >= 12 and mid_face.sum() >= 6
    assert np.all(np.abs(curvature[on_edge] * radius - 0.6) < 0.05)  # ~independent of cuts
    assert np.all(curvature[mid_face] == 0) and curvature.min() >= 0
    assert np.all(edges.curvature_mask(curvature[on_edge], radius, cavity_weight=0.0, edge_weight=1.0) == 1)
    assert np.all(edges.curvature_mask(curvature, radius, cavity_weight=1.0, edge_weight=0.0) == 0)


@pytest.mark.parametrize("cuts", [0, 1, 4, 39])
def test_the_field_between_vertices_does_not_depend_on_the_tessellation(fresh_scene, cuts):
    """H * radius read anywhere (as texels read it): on a cube edge, a smoothing radius in from
    it and mid-face, the same on a cube of 8 vertices as on one cut 39 times (edges and faces
    longer than the sample spacing are sampled along and across)."""
    radius = 0.3
    found = edges.surface(cube(fresh_scene, cuts), radius)
    z = np.linspace(-0.3, 0.3, 7)
    on_edge = np.stack([np.ones(7), np.ones(7), z], axis=1)
    inward = on_edge - [0.0, 0.5 * radius, 0.0]
    values = [
        edges.smooth_over_radius(found.sources, points, np.tile(normal, (len(points), 1)), radius) * radius
        for points, normal in ((on_edge, [0.7071, 0.7071, 0]), (inward, [1.0, 0, 0]), ([[1.0, 0, 0]], [1.0, 0, 0]))
    ]
    assert np.all(np.abs(values[0] - 0.6) < 0.05) and np.all(np.abs(values[1] - 0.33) < 0.03) and values[2][0] == 0


def test_inside_corners_of_a_hollow_box_are_concave(fresh_scene):
    """A box with walls: an outer cube and an inner one facing into the hollow.  The inner
    edges are concave, the outer ones convex, though the wall is no thicker than the
    smoothing radius (the two sides of a wall are kept apart)."""
    radius = thickness = 0.2
    bm = bmesh.new()
    for size in (2.0, 2.0 - 2 * thickness):
        shell = bmesh.ops.create_cube(bm, size=size)["verts"]
        faces = list({face for vertex in shell for face in vertex.link_faces})
        bmesh.ops.subdivide_edges(bm, edges=list({e for f in faces for e in f.edges}), cuts=9, use_grid_fill=True)
    inner = [face for face in bm.faces if max(abs(c) for c in face.calc_center_median()) < 1 - thickness / 2]
    bmesh.ops.reverse_faces(bm, faces=inner)
    mesh = bpy.data.meshes.new("Hollow")
    bm.to_mesh(mesh)
    bm.free()
    obj = link(fresh_scene, mesh, "Hollow")
    curvature = edges.curvature(obj, radius)
    points = world_points(obj)
    outer_edge, _ = edge_and_face_centre_vertices(points, 1.0, radius)
    inner_edge, _ = edge_and_face_centre_vertices(points, 1.0 - thickness, radius)
    assert outer_edge.sum() >= 12 and inner_edge.sum() >= 12
    assert curvature[outer_edge].min() * radius > 0.4
    assert curvature[inner_edge].max() * radius < -0.4
    assert np.all(edges.curvature_mask(curvature[inner_edge], radius, cavity_weight=1.0, edge_weight=0.0) > 0.8)
    assert np.all(edges.curvature_mask(curvature[inner_edge], radius, cavity_weight=0.0, edge_weight=1.0) == 0)


def test_degenerate_meshes_give_finite_curvature(fresh_scene):
    """Zero-area faces, a loose vertex, an edge shared by three faces and an n-gon."""
    vertices = [
        (0, 0, 0),
        (1, 0, 0),
        (1, 1, 0),
        (0, 1, 0),
        (0.5, 0.5, 1),
        (0.5, 0.5, -1),
        (2, 0, 0),
        (3, 0, 0),
        (5, 5, 5),
        (-1, 0.5, 0),
        (-0.5, 0.5, 0),
    ]
    faces = [
        (0, 1, 4),
        (0, 1, 5),
        (0, 1, 2),  # edge 0-1 is shared by three faces
        (1, 6, 7),  # zero area (a straight line)
        (0, 3, 9, 10),
    ]  # a concave n-gon
    mesh = bpy.data.meshes.new("Broken")
    mesh.from_pydata(vertices, [], faces)
    curvature = edges.curvature(link(fresh_scene, mesh, "Broken"), 0.5)
    assert curvature.shape == (len(vertices),) and np.isfinite(curvature).all()
    assert curvature[8] == 0  # the loose vertex


def test_curvature_refuses_what_it_cannot_measure(fresh_scene):
    mesh = bpy.data.meshes.new("Wire")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0)], [(0, 1)], [])
    with pytest.raises(ValueError, match="'Wire'"):
        edges.curvature(link(fresh_scene, mesh, "Wire"), 0.1)
    empty = bpy.data.objects.new("Empty", None)
    fresh_scene.collection.objects.link(empty)
    with pytest.raises(ValueError, match="'Empty'"):
        edges.curvature(empty, 0.1)
    with pytest.raises(ValueError, match="radius"):
        edges.curvature(cube(fresh_scene), 0.0)


@pytest.mark.parametrize(
    "block, direct_cells_max",
    [(7, curvature_maths.DIRECT_CELLS_MAX), (curvature_maths.BLOCK, 0), (64, 0)],
    ids=["small blocks", "sorted numbering", "both"],
)
def test_curvature_does_not_depend_on_how_the_work_is_split(fresh_scene, monkeypatch, block, direct_cells_max):
    """Blocks of faces, edges and points, and the two ways of numbering grid cells, give the
    same values bit for bit (the test meshes fit one block by default)."""
    obj = cube(fresh_scene, 3)
    obj.modifiers.new("Bevel", "BEVEL").width = 0.2  # triangles, quads and n-gons
    expected = edges.curvature(obj, 0.3)
    monkeypatch.setattr(curvature_maths, "BLOCK", block)
    monkeypatch.setattr(curvature_maths, "DIRECT_CELLS_MAX", direct_cells_max)
    assert np.array_equal(edges.curvature(obj, 0.3), expected)


def test_curvature_mask_weighs_cavities_and_edges_apart():
    """C = clip(H * radius / saturation, times edge_weight where convex, cavity_weight where
    concave): radius 0.25, saturation 0.5, so H = 2 saturates at weight 1."""
    curvature = np.array([-4.0, -1.0, 0.0, 1.0, 4.0])

    def mask(cavity, edge):
        return edges.curvature_mask(curvature, 0.25, cavity_weight=cavity, edge_weight=edge, saturation=0.5)

    assert np.allclose(mask(0.0, 1.0), [0, 0, 0, 0.5, 1])
    assert np.allclose(mask(1.0, 0.0), [1, 0.5, 0, 0, 0])
    assert np.allclose(mask(1.0, 1.0), [1, 0.5, 0, 0.5, 1])
    assert np.allclose(mask(0.5, 0.25), [1, 0.25, 0, 0.125, 0.5])
    defaults = edges.curvature_mask(curvature, 0.25, saturation=0.5)
    assert np.allclose(defaults, mask(edges.DEFAULT_CAVITY_WEIGHT, edges.DEFAULT_EDGE_WEIGHT))
    for bad in (dict(cavity_weight=-1.0), dict(edge_weight=float("nan"))):
        with pytest.raises(ValueError, match="weight"):
            edges.curvature_mask(curvature, 0.25, **bad)


def test_edge_attribute_is_written_whole_or_not_at_all(fresh_scene):
    obj = cube(fresh_scene, 4)
    mask = edges.write_curvature_attribute(obj, 0.3)
    attribute = obj.data.color_attributes[edges.EDGE_ATTRIBUTE]
    assert (attribute.domain, attribute.data_type) == ("POINT", "FLOAT_COLOR")
    colours = np.empty(len(mask) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", colours)
    colours = colours.reshape(-1, 4)
    assert np.allclose(colours[:, :3], mask[:, None]) and np.all(colours[:, 3] == 1) and mask.max() == 1

    with pytest.raises(ValueError, match="'Cube'"):
        edges.write_edge_attribute(obj, mask[:-1])  # one value short: the old attribute stays
    assert [a.name for a in obj.data.color_attributes] == [edges.EDGE_ATTRIBUTE]
    edges.write_edge_attribute(obj, np.zeros_like(mask))  # a new one replaces it
    attribute = obj.data.color_attributes[edges.EDGE_ATTRIBUTE]
    attribute.data.foreach_get("color", colours.ravel())
    assert [a.name for a in obj.data.color_attributes] == [edges.EDGE_ATTRIBUTE] and colours[:, :3].max() == 0


# --- (e) where parts meet: the corner no mesh edge carries (contacts) ---------------------------------

#: The slab and the wall standing on it, (low, high) corners: the wall's foot makes a right-angled
#: inside corner along x = 0 with the slab's top, z = 0.
SLAB, WALL = ((-2.0, -1.0, -0.5), (2.0, 1.0, 0.0)), ((-2.0, -1.0, 0.0), (0.0, 1.0, 2.0))


def boxes(scene, name, corners, cuts=7):
    """One object of axis-aligned boxes, each a loose part, its faces cut into quads."""
    bm = bmesh.new()
    for low, high in corners:
        verts = bmesh.ops.create_cube(bm, size=1.0)["verts"]
        bmesh.ops.scale(bm, vec=np.subtract(high, low), verts=verts)
        bmesh.ops.translate(bm, vec=(np.add(high, low) / 2), verts=verts)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=cuts, use_grid_fill=True)
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    return link(scene, mesh, name)


def step(scene, name):
    """The slab and the wall as one mesh: an L in section (x, z), extruded along y."""
    section = [(-2.0, -0.5), (2.0, -0.5), (2.0, 0.0), (0.0, 0.0), (0.0, 2.0), (-2.0, 2.0)]
    bm = bmesh.new()
    verts = [bm.verts.new((x, -1.0, z)) for x, z in section]
    face = bm.faces.new(verts)
    bmesh.ops.extrude_face_region(bm, geom=[face])
    for vertex in bm.verts[len(section) :]:
        vertex.co.y = 1.0
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces[:])
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=7, use_grid_fill=True)
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    return link(scene, mesh, name)


def across_the_corner(obj, radius, beside=()):
    """H r on the slab's top (z = 0) at x = 0 .. 3 r from the wall's foot, y = 0."""
    found = edges.surface(obj, radius, beside=beside)
    distances = np.linspace(0.02, 3.0, 60) * radius
    points = np.stack([distances, np.zeros_like(distances), np.zeros_like(distances)], axis=1)
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    return distances, edges.smooth_over_radius(found.sources, points, normals, radius) * radius


def trapezoid(values, at):
    """The integral of ``values`` over the points ``at`` by the trapezoidal rule (numpy 1 and 2)."""
    return float(np.sum((values[1:] + values[:-1]) / 2 * np.diff(at)))


def test_a_corner_where_parts_meet_is_as_concave_as_one_mesh_makes_it(fresh_scene):
    """The slab and the wall on it as one L-shaped mesh, as two loose parts of one object, and as
    two objects (the wall beside the slab): the inside corner at the wall's foot is concave in
    all three, and the field across it on the slab's top adds up to the one mesh's to 35% (the
    parts' corner lies on their faces, not on an edge: docs/maps.md, "Where parts meet"); the
    slab alone is flat, and its mask at the wall's foot saturates as the one mesh's does."""
    radius = 0.4
    one_mesh = step(fresh_scene, "Step")
    two_parts = boxes(fresh_scene, "Parts", (SLAB, WALL))
    slab, wall = boxes(fresh_scene, "Slab", (SLAB,)), boxes(fresh_scene, "Wall", (WALL,))
    distances, edge = across_the_corner(one_mesh, radius)
    integral = trapezoid(edge, distances) / radius
    for obj, beside in ((two_parts, ()), (slab, (wall,))):
        _, met = across_the_corner(obj, radius, beside)
        assert met[distances < 0.5 * radius].max() < -0.3
        assert trapezoid(met, distances) / radius == pytest.approx(integral, rel=0.35)
    _, alone = across_the_corner(slab, radius)
    assert np.all(alone == 0.0)
    mask = edges.curvature_mask(edges.curvature(slab, radius, beside=(wall,)), radius)
    points = world_points(slab)  # the slab's vertices at the wall's foot, away from its ends
    foot = np.all(np.abs(points[:, [0, 2]]) < 1e-6, axis=1) & (np.abs(points[:, 1]) < 0.6)
    assert foot.any() and np.all(mask[foot] > 0.8)


def test_an_object_alone_keeps_its_mask_and_flush_blocks_read_flat(fresh_scene):
    """A block whose neighbours are far gets the mask it gets alone, bit for bit; two blocks
    laid face to face (a wall modelled block by block, without joints) read their seam nearly
    flat, as their union is, where a lone block reads its edge convex: the faces they hide
    carry nothing, and each fills the other's ball."""
    radius = 0.3
    lone = boxes(fresh_scene, "Lone", (((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),))
    far = boxes(fresh_scene, "Far", (((5.0, 0.0, 0.0), (6.0, 1.0, 1.0)),))
    assert np.array_equal(edges.curvature(lone, radius), edges.curvature(lone, radius, beside=(far,)))
    flush = boxes(fresh_scene, "Flush", (((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)), ((1.0, 0.0, 0.0), (2.0, 1.0, 1.0))))
    points = np.array([[1.0 - 0.1 * radius, 0.0, 0.5]])  # on the front face, at the seam
    normals = np.array([[0.0, -1.0, 0.0]])
    seam = edges.smooth_over_radius(edges.surface(flush, radius).sources, points, normals, radius)[0]
    edge = edges.smooth_over_radius(edges.surface(lone, radius).sources, points, normals, radius)[0]
    assert edge * radius > 0.4 and abs(seam) < 0.25 * edge


def test_geometry_duplicated_in_place_reads_as_the_part_alone(fresh_scene):
    """A box and its copy in place, as Shift+D in Edit Mode leaves them when the move is
    cancelled: which of two coincident faces a ray leaves through first is chance, so without
    the copy's faces left out (``contacts.repeats_another_part``) half of each box's inside
    would read as the other's, and the whole box as a cavity. Each copy reads as the box alone."""
    radius = 0.3
    one = edges.curvature(boxes(fresh_scene, "One", (((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),)), radius)
    twice = edges.curvature(boxes(fresh_scene, "Twice", (((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),) * 2), radius)
    assert one.max() * radius > 0.4
    np.testing.assert_allclose(np.sort(twice), np.sort(np.repeat(one, 2)), rtol=1e-4, atol=1e-4 / radius)


def test_a_surface_split_along_its_seams_reads_as_one(fresh_scene):
    """A sphere cut along a meridian into two open halves, each a loose part (as importers leave
    a glTF split at its UV seams): its open borders lie on each other, so it is one part
    (``mesh_arrays.face_islands(mesh, border_places(mesh))``), no corner where they meet, and its
    seam as convex as the sphere elsewhere, not a cavity."""
    radius = 0.1
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=64, v_segments=32, radius=1.0)
    bmesh.ops.split_edges(bm, edges=[e for e in bm.edges if all(abs(v.co.x) < 1e-6 for v in e.verts)])
    mesh = bpy.data.meshes.new("Halves")
    bm.to_mesh(mesh)
    bm.free()
    halves = link(fresh_scene, mesh, "Halves")
    assert (
        mesh_arrays.face_islands(mesh).max() == 1
        and not mesh_arrays.face_islands(mesh, mesh_arrays.border_places(mesh)).any()
    )
    across = np.abs(world_points(halves)[:, 0])
    h = edges.curvature(halves, radius)
    seam, far = across < 1e-6, across > 2.0 * radius  # the sphere's 1 / radius, beyond the smoothing's reach
    assert seam.sum() >= 60 and np.all(h[seam] > 0.5) and np.all(np.abs(h[far] - 1.0) < 0.05)


def test_a_cube_split_at_its_hard_edges_reads_as_the_cube(fresh_scene):
    """Importers leave a glTF's faces split at its hard edges (and UV seams): every edge of a
    flat-shaded cube is then two borders lying on each other, no edge between two faces. Read
    across its seams (``edges._surface``), it carries the cube's curvature, where before its
    mask was 0 everywhere."""
    radius = 0.1
    fields = []
    for name, split in (("Welded", False), ("Split", True)):
        bm = bmesh.new()
        bmesh.ops.create_cube(bm, size=1.0)
        bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=7, use_grid_fill=True)
        if split:
            bmesh.ops.split_edges(bm, edges=[e for e in bm.edges if e.calc_face_angle(0.0) > 0.1])
        mesh = bpy.data.meshes.new(name)
        bm.to_mesh(mesh)
        bm.free()
        cube = link(fresh_scene, mesh, name)
        at = {tuple(np.round(p, 4)): h for p, h in zip(world_points(cube), edges.curvature(cube, radius))}
        fields.append(at)
    welded, split = fields
    assert len(mesh.vertices) > len(welded) and max(welded.values()) * radius > 1.0
    assert max(abs(split[key] - welded[key]) for key in split) < 0.02 * max(welded.values())


def test_a_mesh_through_gltf_reads_as_it_does_welded(fresh_scene, tmp_path):
    """Blender's glTF importer leaves a mesh split at its UV seams and hard edges (here a bent
    sphere in 30-odd UV islands): read across the seams, its edge mask is, at every vertex, the
    mask of the same mesh welded (measured before: the scan-like bust's mask through glTF 0.81 on
    average against 0.32 welded, each seam read as a corner where parts meet)."""
    radius = 0.1
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=1.0)
    bmesh.ops.translate(bm, verts=[v for v in bm.verts if v.co.z > 0.5], vec=(0.0, 0.0, 0.3))  # a bend
    mesh = bpy.data.meshes.new("Exported")
    bm.to_mesh(mesh)
    bm.free()
    imported = through_gltf(link(fresh_scene, mesh, "Exported"), tmp_path)
    assert mesh_arrays.face_islands(imported.data).max() > 10  # split, as the importer leaves it
    bm = bmesh.new()
    bm.from_mesh(imported.data)
    bmesh.ops.remove_doubles(bm, verts=bm.verts[:], dist=1e-6)  # the seams: their vertices at one place
    mesh = bpy.data.meshes.new("Welded")
    bm.to_mesh(mesh)
    bm.free()
    welded = link(bpy.context.scene, mesh, "Welded")
    welded.matrix_world = imported.matrix_world
    assert len(mesh.vertices) < len(imported.data.vertices)
    field = dict(zip(map(tuple, np.round(world_points(welded), 4)), edges.curvature(welded, radius)))
    assert np.ptp(list(field.values())) * radius > 0.1  # the bend: not one curvature all over
    at = [field[key] for key in map(tuple, np.round(world_points(imported), 4))]
    np.testing.assert_allclose(edges.curvature(imported, radius), at, atol=1e-4 / radius)


def test_a_triangle_soup_reads_as_its_welded_mesh(fresh_scene):
    """Some exporters write every triangle with corners of its own (a soup): each edge is then two
    borders on each other, a seam, so the soup's places are the welded mesh's vertices and it is
    one part; a third border on an edge (a fin) joins nothing there."""
    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=3, radius=1.0)
    bmesh.ops.triangulate(bm, faces=bm.faces[:])
    welded_count = len(bm.verts)
    bmesh.ops.split_edges(bm, edges=bm.edges[:])  # every triangle its own three vertices
    mesh = bpy.data.meshes.new("Soup")
    bm.to_mesh(mesh)
    bm.free()
    assert len(mesh.vertices) == 3 * len(mesh.polygons)
    places = mesh_arrays.border_places(mesh)
    assert len(np.unique(places)) == welded_count
    assert not mesh_arrays.face_islands(mesh, places).any()
    assert not mesh_arrays.open_edges(mesh, places).any()
    fin = bpy.data.meshes.new("Soup and fin")
    points = [tuple(v.co) for v in mesh.vertices]
    a, b, _ = mesh.polygons[0].vertices
    apex = tuple(2.0 * np.array(points[a]) + 0.5)  # a third triangle on the first triangle's first edge
    faces = [tuple(face.vertices) for face in mesh.polygons] + [(len(points), len(points) + 1, len(points) + 2)]
    fin.from_pydata(points + [points[a], points[b], apex], [], faces)
    fin_places = mesh_arrays.border_places(fin)
    assert len(np.unique(fin_places)) > welded_count + 1  # the edge's three borders are not joined
    assert fin_places[len(points)] == len(points)  # the fin's corners stay their own


def test_only_points_within_the_radius_of_another_parts_box_are_asked():
    """``contacts.near_another``: a point is near when it lies within the radius of a box
    other than its own part's, of its own object or of one beside it; a point of no part
    (-1) never is."""
    from types import SimpleNamespace

    from porous_weathering.maps import contacts

    own = SimpleNamespace(boxes=np.array([[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]], [[1.5, 0.0, 0.0], [2.5, 1.0, 1.0]]]))
    beside = SimpleNamespace(boxes=np.array([[[0.0, 0.0, -1.0], [2.5, 1.0, -0.6]]]))
    points = np.array(
        [
            [0.95, 0.5, 0.5],  # part 0, 0.55 from part 1's box: within 0.6
            [0.5, 0.5, 0.5],  # part 0, 1.0 from part 1's box and 1.1 below it from the beside box
            [0.5, 0.5, 0.1],  # part 0, 0.7 above the beside box: not within 0.6
            [2.0, 0.5, 0.0],  # part 1, 0.6 above the beside box: on the margin
            [0.95, 0.5, 0.5],  # no part
        ]
    )
    part = np.array([0, 0, 0, 1, -1])
    assert contacts.near_another(points, part, own, None, 0.6).tolist() == [True, False, False, False, False]
    assert contacts.near_another(points, part, own, beside, 0.6).tolist() == [True, False, False, True, False]
    assert not contacts.near_another(points, part, own, beside, 0.5).any()


def test_the_edge_map_bakes_again_when_an_object_it_meets_moves(fresh_scene):
    """The objects a mask meets are in its input hash (their corners with it are in the mask): the
    slab's edge map bakes again when the wall on it moves, not when a block far from it does,
    and the wall's foot darkens the slab's mask only where it stands."""
    radius = 0.4
    slab, wall = boxes(fresh_scene, "Slab", (SLAB,)), boxes(fresh_scene, "Wall", (WALL,))
    far = boxes(fresh_scene, "Far", (((10.0, 0.0, 0.0), (11.0, 1.0, 1.0)),))
    options = bake.BakeOptions(maps=("edges",), target="attribute", edge_radius=radius)
    assert [o.status for o in bake.bake_maps([slab], options)] == ["written"]
    far.location.x += 1.0
    assert [o.status for o in bake.bake_maps([slab], options)] == ["unchanged"]
    before = edges.curvature_mask(edges.curvature(slab, radius, beside=(wall,)), radius)
    wall.location.x -= 1.0
    bpy.context.view_layer.update()
    assert [o.status for o in bake.bake_maps([slab], options)] == ["written"]
    after = edges.curvature_mask(edges.curvature(slab, radius, beside=(wall,)), radius)
    points = world_points(slab)
    top = (np.abs(points[:, 2]) < 1e-6) & (np.abs(points[:, 1]) < 0.6)  # away from the slab's ends
    old_foot, new_foot = top & (np.abs(points[:, 0]) < 1e-6), top & (np.abs(points[:, 0] + 1.0) < 1e-6)
    assert np.all(before[old_foot] > 0.8) and np.all(after[old_foot] < 0.1)
    assert np.all(after[new_foot] > 0.8)


def test_a_ground_plane_is_as_solid_as_a_slab_where_a_wall_stands_on_it(fresh_scene):
    """A wall on an open ground plane (one face, no thickness: the usual scene's ground) gets the
    corner at its foot that a closed slab gives it: all that lies behind an open part's faces is
    inside it, whichever way a ray from a point goes."""
    radius = 0.4
    wall, slab = boxes(fresh_scene, "Wall", (WALL,)), boxes(fresh_scene, "Slab", (SLAB,))
    bpy.ops.mesh.primitive_plane_add(size=6.0)
    ground = bpy.context.active_object
    heights = np.linspace(0.02, 3.0, 60) * radius
    points = np.stack([np.zeros_like(heights), np.zeros_like(heights), heights], axis=1)
    normals = np.tile([1.0, 0.0, 0.0], (len(points), 1))
    up_the_wall = {
        name: edges.smooth_over_radius(edges.surface(wall, radius, beside=(below,)).sources, points, normals, radius)
        for name, below in (("slab", slab), ("ground", ground))
    }
    on_slab, on_ground = (trapezoid(up_the_wall[name], heights) for name in ("slab", "ground"))
    assert on_slab < -0.25 and on_ground == pytest.approx(on_slab, rel=0.15)
