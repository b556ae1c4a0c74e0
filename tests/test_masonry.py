"""Masonry (docs/model.md §8.5): coursed ashlar, each block its own draw of its stone's
parameters, the lime mortar in the joints.

- numpy: the block draws keep the stone's means over many blocks and its range; a block's mean
  field is its share of its draw; the joints lie where the ashlar's lengths put them, every
  other course set over by half a block; the mortar weathers faster than the stone it joins.
- render (Cycles CPU, tiny): a wall of ashlar, the per-pixel position read back from a probe;
  the rendered joints and blocks are the numpy layout's at those positions, neighbouring blocks
  differ, the per-point parameters are the numpy maths of the read-back fields and the mortar's
  values, and the rendered pixels are the model's at those parameters; the same wall in
  millimetres (unit scale 0.001) has the same joints and blocks; without masonry the material
  is today's.
"""

import bpy

import bmesh
import numpy as np
import pytest

import porous_weathering as pw
from benchmarks import probes
from benchmarks.scenes import through_gltf
from helpers import assert_matches, presets_row, stone_glossy_lobe, stone_parameters, stone_probe, stone_shifted
from porous_weathering.blender import mesh_arrays, render
from porous_weathering.contracts import STONE_NODE
from porous_weathering.core import model, stones
from porous_weathering.core.backends import NumpyOps
from porous_weathering.samples import studio
from porous_weathering.shading import nodes, presets
from porous_weathering.shading.presets import PRESETS

XP = NumpyOps(colour=True)
STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.04, roughness=0.6, porosity=0.2, pore_depth_ratio=2.5)
KD = np.array(STONE["base_color"])
LIMESTONE = PRESETS["LIMESTONE"].structure
MORTAR = PRESETS["LIME_MORTAR"]
#: The test wall's ashlar: joints a few pixels wide at the renders' 4.6 cm per pixel.
WALL_ASHLAR = stones.Ashlar(course_height=0.4, block_length=0.7, joint_width=0.1)


def parameters(stone, z_p, z_c, variation=1.0):
    s = STONE
    return stones.point_parameters(
        XP, stone, KD, s["porosity"], s["pore_depth_ratio"], s["roughness"], z_p, z_c, variation
    )


# --- the maths, in numpy ---------------------------------------------------------------------


@pytest.mark.parametrize("key", [key for key, preset in PRESETS.items() if preset.structure.block_porosity])
def test_block_draws_keep_the_stones_means_and_range(key):
    """Over many blocks, each its own draw b and its own points, the parameters' means are the
    material's and every value stays in the stone's range (the range without masonry)."""
    stone = PRESETS[key].structure
    rng = np.random.default_rng(1)
    blocks, points = 4000, 50
    draw = np.repeat(rng.uniform(-1.0, 1.0, blocks), points)
    z = rng.uniform(-1.0, 1.0, (2, blocks * points))
    z_p, z_c = stones.block_fields(XP, stone, z[0], z[1], draw)
    assert np.abs(z_p).max() <= 1.0 and np.abs(z_c).max() <= 1.0
    kd, alpha, sp, m = parameters(stone, z_p, z_c)
    s = STONE
    assert alpha.mean() == pytest.approx(s["porosity"], rel=0.01)
    assert m.mean() == pytest.approx(s["roughness"], rel=0.01)
    assert kd.mean(axis=0) == pytest.approx(KD, rel=0.01)
    low, high = s["porosity"] * (1 - stone.porosity), s["porosity"] * (1 + stone.porosity)
    assert low - 1e-12 <= alpha.min() and alpha.max() <= high + 1e-12
    # each block is its own bed: its mean field is its share of its draw
    per_block = z_p.reshape(blocks, points).mean(axis=1)
    assert np.corrcoef(per_block, draw[::points])[0, 1] > 0.8
    assert np.polyfit(draw[::points], per_block, 1)[0] == pytest.approx(stone.block_porosity, abs=0.02)


@pytest.mark.parametrize("key", PRESETS)
def test_docs_give_each_stones_block_shares(key):
    preset = PRESETS[key]
    cells = presets_row("## Masonry", preset.label)
    assert cells[1:3] == [f"{preset.structure.block_porosity:g}", f"{preset.structure.block_colour:g}"]


def test_block_share_zero_is_the_stone():
    z = np.linspace(-1.0, 1.0, 11)
    plaster = PRESETS["PLASTER"].structure
    z_p, z_c = stones.block_fields(XP, plaster, z, z[::-1], np.ones_like(z))
    assert np.array_equal(z_p, z) and np.array_equal(z_c, z[::-1])


def layout(x, z, ashlar=WALL_ASHLAR, y=0.0):
    return stones.ashlar(XP, x, y, z, ashlar.course_height, ashlar.block_length, ashlar.joint_width)


def test_joints_lie_where_the_ashlar_puts_them():
    a = stones.Ashlar(course_height=0.3, block_length=0.6, joint_width=0.01)
    h, length = a.course_height, a.block_length
    course, block, joint = layout(np.array([0.3, 0.3, 0.3, 0.3]), np.array([0.0, 0.004, 0.006, 0.15]), a)
    assert list(joint) == [1.0, 1.0, 0.0, 0.0]  # a bed joint 1 cm wide centred on z = 0
    assert list(course) == [0.0, 0.0, 0.0, 0.0]
    # head joints at x = k L in even courses, at x = (k + 1/2) L in odd ones
    x = np.array([length, length + 0.004, length + 0.006, length / 2, 1.5 * length])
    _, _, even = layout(x, np.full(5, 0.5 * h), a)
    _, _, odd = layout(x, np.full(5, 1.5 * h), a)
    assert list(even) == [1.0, 1.0, 0.0, 0.0, 0.0]
    assert odd[0] == 0.0 and odd[3] == 1.0 and odd[4] == 1.0
    # the joint's edge: stone into mortar over the arris (1 mm), half-way at the joint's edge
    _, _, edge = layout(np.full(3, 0.3), np.array([0.0045, 0.005, 0.0055]), a)
    assert edge[0] == 1.0 and edge[1] == pytest.approx(0.5) and edge[2] == 0.0
    # x + y: a block turns the corner of a wall along X into a return along Y
    _, block_front, _ = layout(np.array([2.9]), np.array([0.15]), a, y=0.0)
    _, block_side, _ = layout(np.array([3.0]), np.array([0.15]), a, y=-0.1)
    assert block_front == block_side


def test_an_ashlar_is_checked():
    with pytest.raises(ValueError, match="lengths"):
        stones.Ashlar(course_height=-0.3)
    with pytest.raises(ValueError, match="joint width"):
        stones.Ashlar(course_height=0.3, joint_width=0.2)
    with pytest.raises(ValueError, match="block shares"):
        stones.Stone((), 0.1, 0.1, 0.1, (0.0, 0.0, 0.0), "bad", block_porosity=1.5)


def test_the_mortar_weathers_faster_than_the_stone():
    """The lime mortar is more porous and rougher than limestone: by the receptivity's formula
    (docs/model.md §8.3) its pores fill faster."""
    lime = PRESETS["LIMESTONE"]
    r = stones.mortar_receptivity(XP, MORTAR.porosity, MORTAR.roughness, lime.porosity, lime.roughness)
    assert r == pytest.approx(np.sqrt(MORTAR.porosity / lime.porosity * MORTAR.roughness / lime.roughness))
    assert r > 1.3


def test_masonry_is_checked(fresh_scene):
    with pytest.raises(ValueError, match="needs a stone"):
        pw.make_porous_material("Bad", masonry=stones.Ashlar())
    with pytest.raises(ValueError, match="mortar"):
        pw.make_porous_material("Bad", stone="LIMESTONE", masonry=stones.Ashlar(mortar="CEMENT"))
    with pytest.raises(ValueError, match="Ashlar"):
        pw.make_porous_material("Bad", stone="LIMESTONE", masonry=dict(course_height=0.3))
    assert "Bad" not in bpy.data.materials


# --- renders ---------------------------------------------------------------------------------


class Wall:
    """A vertical wall 2 m square facing -Y (x along it, z up from 0.1 m), seen face on by an
    orthographic camera, under a sun from the front left; ``unit``: metres per scene unit."""

    def __init__(self, scene, size=48, unit=1.0):
        self.scene, self.unit = scene, unit
        scene.unit_settings.scale_length = unit
        k = 1.0 / unit
        mesh = bpy.data.meshes.new("Wall")
        corners = [(-1.0, 0.0, 0.1), (1.0, 0.0, 0.1), (1.0, 0.0, 2.1), (-1.0, 0.0, 2.1)]
        mesh.from_pydata([tuple(c * k for c in corner) for corner in corners], [], [(0, 1, 2, 3)])
        self.wall = studio.link(scene, bpy.data.objects.new("Wall", mesh))
        self.sun = studio.add_sun(scene, (-0.4, -0.8, 0.45))
        camera = studio.add_ortho_camera(scene, scale=2.2 * k, height=0.0)
        camera.location = (0.0, -5.0 * k, 1.1 * k)
        camera.rotation_euler = (np.pi / 2, 0.0, 0.0)
        camera.data.clip_end = 20.0 * k
        render.use_cycles(scene, size=size, samples=1)

    def render(self, material):
        studio.assign(self.wall, material)
        return render.render_array(self.scene)

    def metres(self):
        """(H, W, 3) object coordinates of each pixel, in metres."""
        probe = probes.position_probe(scale=0.1 * self.unit)
        return (self.render(probe)[..., :3] - 0.5) / 0.1


def probe(wall, material, outputs):
    """(H, W, 3) of up to three scalar outputs (or one colour) of ``material``'s stone node."""
    return stone_probe(wall.render, material, outputs)


def read_back(wall, material):
    """{kd, alpha, sp, m, r, z_p, z_c, b, joint} per pixel from the material's stone node. The
    fields, in [-1, 1], are emitted shifted by +1 (an emission is not negative)."""
    got = stone_parameters(wall.render, material, extra=("Joint",))
    fields = {
        name: stone_shifted(wall.render, material, socket)
        for name, socket in (("z_p", "Porosity Field"), ("z_c", "Colour Field"), ("b", "Block Field"))
    }
    return dict(got, joint=got.pop("Joint"), **fields)


def masonry_material(name, wall, **extra):
    return pw.make_porous_material(name, **STONE, stone="LIMESTONE", masonry=WALL_ASHLAR, key_light=wall.sun, **extra)


def test_joints_and_blocks_are_the_layouts(fresh_scene):
    """The rendered joints are the numpy layout's at each pixel's position; every block has one
    draw; neighbouring blocks differ, in their draw and in their mean colour and porosity."""
    wall = Wall(fresh_scene)
    material = masonry_material("Ashlar", wall)
    metres = wall.metres()
    got = read_back(wall, material)
    covered = wall.render(material)[..., 3] > 0.999
    course, block, joint = layout(metres[..., 0], metres[..., 2], y=metres[..., 1])
    assert np.abs(got["joint"] - joint)[covered].max() < 1e-3
    assert 0.1 < joint[covered].mean() < 0.5  # the joints show
    in_stone = covered & (joint == 0.0)
    ids = {}
    for key, b, z_p, kd in zip(
        zip(course[in_stone], block[in_stone]), got["b"][in_stone], got["z_p"][in_stone], got["kd"][in_stone]
    ):
        ids.setdefault(key, []).append((b, z_p, kd.mean()))
    assert len(ids) >= 10
    draws = {key: np.array(values) for key, values in ids.items()}
    for values in draws.values():
        assert np.ptp(values[:, 0]) < 1e-6  # one draw per block
    pairs = [(key, (key[0], key[1] + 1)) for key in draws if (key[0], key[1] + 1) in draws]
    assert len(pairs) >= 4
    differences = [abs(draws[a][0, 0] - draws[b][0, 0]) for a, b in pairs]
    assert np.median(differences) > 0.2  # |b - b'| of two uniform draws: 2/3 on average
    # the block's own bed moves its mean porosity field and mean colour with its draw
    mean_draw = np.array([values[0, 0] for values in draws.values()])
    mean_z_p = np.array([values[:, 1].mean() for values in draws.values()])
    mean_kd = np.array([values[:, 2].mean() for values in draws.values()])
    assert np.corrcoef(mean_draw, mean_z_p)[0, 1] > 0.7
    assert np.corrcoef(mean_draw, mean_kd)[0, 1] < -0.7  # darker where z_c is higher: c < 0


def expected_parameters(got):
    """The numpy maths at the read-back fields and joint: the stone's per-point values, the
    mortar's in the joints."""
    s = STONE
    kd, alpha, sp, m = parameters(LIMESTONE, got["z_p"], got["z_c"])
    r = stones.receptivity(XP, LIMESTONE, got["z_p"], 1.0)
    mortar_r = stones.mortar_receptivity(XP, MORTAR.porosity, MORTAR.roughness, s["porosity"], s["roughness"])
    mortar = (np.array(MORTAR.linear_base_color()[:3]), MORTAR.porosity, MORTAR.pore_depth_ratio, MORTAR.roughness)
    return stones.jointed(XP, got["joint"], (kd, alpha, sp, m, r), (*mortar, mortar_r))


def test_masonry_is_the_maths_and_the_model_per_pixel(fresh_scene):
    wall = Wall(fresh_scene, size=32)
    material = masonry_material("Ashlar", wall)
    got = read_back(wall, material)
    image = wall.render(material)
    covered = image[..., 3] > 0.999
    kd, alpha, sp, m, r = expected_parameters(got)
    for name, value in (("kd", kd), ("alpha", alpha), ("sp", sp), ("m", m), ("r", r)):
        assert np.abs(got[name] - value)[covered].max() < 1e-5 * max(1.0, float(np.abs(value).max())), name
    diffuse = wall.render(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0))[..., :3]
    glossy_image = stone_glossy_lobe(wall.render, material)
    towards = np.array(wall.sun.matrix_world.to_3x3().col[2])
    n_dot_l = float(-towards[1])  # the wall faces -Y, the camera looks along +Y
    kd_poro, ks_poro = model.porous_coefficients(
        got["kd"], STONE["ks"], got["m"], got["alpha"], got["sp"], n_dot_l, 1.0
    )
    assert_matches(image, kd_poro * diffuse + ks_poro[..., None] * glossy_image, covered)


def test_the_same_process_reads_differently_on_adjacent_stones(fresh_scene):
    """Soiled to the same age, the mortar and the more receptive blocks are further along."""
    wall = Wall(fresh_scene, size=32)
    state = dict(time=0.5, rain_map=0.0, edge_map=0.55, crust=0.5)
    material = pw.make_weathered_material(
        "Weathered", modes=("soiling",), **STONE, stone="LIMESTONE", masonry=WALL_ASHLAR, key_light=wall.sun,
        environment=None, **state,
    )  # fmt: skip
    got = read_back(wall, material)
    covered = wall.render(material)[..., 3] > 0.999
    fill = model.pore_fill(0.55, np.minimum(0.5 * got["r"], 1.0), 1.0, 0.1)
    in_joint, in_stone = covered & (got["joint"] > 0.999), covered & (got["joint"] < 1e-3)
    assert fill[in_joint].mean() > fill[in_stone].mean() + 0.1
    course, block, _ = layout(*np.moveaxis(wall.metres()[..., [0, 2]], -1, 0))
    per_block = {}
    for key, value in zip(zip(course[in_stone], block[in_stone]), fill[in_stone]):
        per_block.setdefault(key, []).append(value)
    means = [np.mean(values) for values in per_block.values() if len(values) > 4]
    assert max(means) - min(means) > 0.1


def test_millimetres_and_metres_give_the_same_ashlar(fresh_scene):
    wall = Wall(fresh_scene, size=24)
    outputs = ("Joint", "Block Field", "Joint")
    in_metres = probe(wall, masonry_material("M", wall), outputs)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    wall_mm = Wall(scene, size=24, unit=0.001)
    in_millimetres = probe(wall_mm, masonry_material("MM", wall_mm), outputs)
    assert in_metres[..., 0].max() == 1.0 and in_metres[..., 0].min() == 0.0
    close = np.abs(in_metres - in_millimetres) < 1e-3
    assert close.mean() > 0.99, f"{(~close).sum()} values differ"


def test_a_wall_stood_up_and_scaled_gets_the_same_level_courses(fresh_scene):
    """The structure is read along the world's axes, in metres, from the object's origin (docs/
    model.md §8.2): the same wall modelled lying in its XY plane at half size, stood up by a
    rotation and scaled by 2 (as users add a plane and turn it), has the upright wall's courses,
    blocks and fields at the same points."""
    wall = Wall(fresh_scene, size=24)
    outputs = ("Joint", "Block Field", "Porosity Field")
    upright = probe(wall, masonry_material("Upright", wall), outputs)
    mesh = wall.wall.data
    mesh.clear_geometry()
    corners = [(-0.5, 0.05, 0.0), (0.5, 0.05, 0.0), (0.5, 1.05, 0.0), (-0.5, 1.05, 0.0)]
    mesh.from_pydata(corners, [], [(0, 1, 2, 3)])
    wall.wall.rotation_euler = (np.pi / 2, 0.0, 0.0)
    wall.wall.scale = (2.0, 2.0, 2.0)
    bpy.context.view_layer.update()
    turned = probe(wall, masonry_material("Turned", wall), outputs)
    close = np.abs(upright - turned) < 1e-3
    assert upright[..., 0].max() == 1.0 and close.mean() > 0.99, f"{(~close).sum()} values differ"


def test_without_masonry_the_material_is_todays(fresh_scene):
    wall = Wall(fresh_scene, size=16)
    today = pw.make_porous_material("Today", **STONE, stone="LIMESTONE", key_light=wall.sun)
    none = pw.make_porous_material("None", **STONE, stone="LIMESTONE", key_light=wall.sun, masonry=None)
    assert none.node_tree.nodes[STONE_NODE].node_tree is today.node_tree.nodes[STONE_NODE].node_tree
    assert today.node_tree.nodes[STONE_NODE].node_tree.name == nodes.stone_group_name("LIMESTONE")
    assert np.array_equal(wall.render(today), wall.render(none))
    ashlar = masonry_material("Ashlar", wall)
    assert not np.array_equal(wall.render(today), wall.render(ashlar))


#: The texture node each kind of a stone's layer is built as (docs/model.md §8.1).
TEXTURE_NODES = {
    stones.CELLS: "TEX_VORONOI",
    stones.BEDS: "TEX_VORONOI",
    stones.WAVE: "TEX_WAVE",
    stones.NOISE: "TEX_NOISE",
}


def texture_nodes(group):
    """The group's procedural texture nodes by type, sorted: what it evaluates at every point."""
    return sorted(node.type for node in group.nodes if node.type.startswith("TEX_"))


def test_each_group_builds_only_the_textures_it_uses():
    """A stone's group builds one texture per layer and nothing of masonry; its ashlar group adds
    the blocks' one White Noise, its group of the mesh's blocks that and the face attribute."""
    for key, preset in PRESETS.items():
        if preset.structure is None:
            continue
        layers = sorted(TEXTURE_NODES[texture.kind] for texture in preset.structure.textures)
        stone = nodes.stone_group(key, preset.structure)
        ashlar = nodes.masonry_group(key, preset.structure)
        blocks = nodes.mesh_blocks_group(key, preset.structure, stones.BLOCK_ATTRIBUTE)
        assert texture_nodes(stone) == layers, key
        assert texture_nodes(ashlar) == texture_nodes(blocks) == sorted([*layers, "TEX_WHITE_NOISE"]), key
        assert [node for node in stone.nodes if node.type == "ATTRIBUTE"] == [], key
        assert [node for node in ashlar.nodes if node.type == "ATTRIBUTE"] == [], key
        assert len([node for node in blocks.nodes if node.type == "ATTRIBUTE"]) == 1, key
        assert not any(name.startswith("Mortar") for name in stone.interface.items_tree.keys()), key


def upstream_types(socket):
    """The types of every node whose output reaches ``socket`` through the group's links."""
    seen, sockets = set(), [socket]
    while sockets:
        for link in sockets.pop().links:
            if link.from_node.name not in seen:
                seen.add(link.from_node.name)
                sockets.extend(link.from_node.inputs)
    return {socket.id_data.nodes[name].type for name in seen}


def test_each_block_has_beds_of_its_own():
    """The limestone's beds (docs/model.md §8.1, §8.5): a 1D Voronoi of the height, moved along Z by
    the block's own draw (its White Noise) in the ashlar and in the mesh's blocks, so the beds of
    two blocks of a course do not run on across their joint; without masonry there is no draw."""
    assert [texture.size for texture in LIMESTONE.textures if texture.kind == stones.BEDS] == [0.12]
    for group, drawn in (
        (nodes.stone_group("LIMESTONE", LIMESTONE), False),
        (nodes.masonry_group("LIMESTONE", LIMESTONE), True),
        (nodes.mesh_blocks_group("LIMESTONE", LIMESTONE, stones.BLOCK_ATTRIBUTE), True),
    ):
        [beds] = [node for node in group.nodes if node.type == "TEX_VORONOI" and node.voronoi_dimensions == "1D"]
        assert ("TEX_WHITE_NOISE" in upstream_types(beds.inputs["W"])) == drawn, group.name


# --- blocks the mesh knows (MeshBlocks, mark_blocks) -------------------------------------------


def blocks_mesh(name, parts):
    """A mesh of ``parts`` vertical quads in the XZ plane (x from -1 to 1, z from 0.1 to 2.1, a gap
    of 4 cm between neighbours), each its own loose part."""
    width = (2.0 - 0.04 * (parts - 1)) / parts
    vertices, faces = [], []
    for k in range(parts):
        x0 = -1.0 + k * (width + 0.04)
        vertices += [(x0, 0.0, 0.1), (x0 + width, 0.0, 0.1), (x0 + width, 0.0, 2.1), (x0, 0.0, 2.1)]
        faces.append(tuple(range(4 * k, 4 * k + 4)))
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    return mesh


def test_islands_are_the_loose_parts_in_the_order_of_their_first_faces(fresh_scene):
    from porous_weathering.blender import mesh_arrays

    mesh = bpy.data.meshes.new("Parts")
    # part A: two quads sharing an edge; part B: one quad; part C: two triangles sharing one vertex
    vertices = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)]
    vertices += [(5, 0, 0), (6, 0, 0), (6, 1, 0), (5, 1, 0)]
    vertices += [(8, 0, 0), (9, 0, 0), (9, 1, 0), (10, 1, 0), (10, 2, 0)]
    faces = [(6, 7, 8, 9), (0, 1, 2, 3), (10, 11, 12), (1, 4, 5, 2), (12, 13, 14)]
    mesh.from_pydata(vertices, [], faces)
    assert list(mesh_arrays.face_islands(mesh)) == [0, 1, 2, 1, 2]
    # a long strip (one part, many passes of the labels)
    strip = bpy.data.meshes.new("Strip")
    count = 500
    strip.from_pydata(
        [(x, y, 0) for x in range(count + 1) for y in (0, 1)],
        [],
        [(2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1) for i in range(count)],
    )
    assert not mesh_arrays.face_islands(strip).any()


def test_mark_blocks_writes_each_faces_block(fresh_scene):
    obj = studio.link(fresh_scene, bpy.data.objects.new("Blocks", blocks_mesh("Blocks", 3)))
    assert presets.mark_blocks(obj) == 3
    values = np.empty(3, dtype=np.int32)
    obj.data.attributes[stones.MeshBlocks().attribute].data.foreach_get("value", values)
    assert list(values) == [0, 1, 2]
    with pytest.raises(ValueError, match="no face sets"):
        presets.mark_blocks(obj, "FACE_SETS")
    face_sets = obj.data.attributes.new(presets.FACE_SET_ATTRIBUTE, "INT", "FACE")
    face_sets.data.foreach_set("value", np.array([7, 7, 9], dtype=np.int32))
    assert presets.mark_blocks(obj, "FACE_SETS") == 2
    obj.data.attributes[stones.MeshBlocks().attribute].data.foreach_get("value", values)
    assert list(values) == [7, 7, 9]
    with pytest.raises(ValueError, match="source"):
        presets.mark_blocks(obj, "VERTEX_GROUPS")
    with pytest.raises(ValueError, match="not a mesh"):
        presets.mark_blocks(fresh_scene.camera or bpy.data.objects.new("Empty", None))


def test_a_block_split_along_its_seams_is_one_block(fresh_scene):
    """Blender's glTF importer splits a mesh at its UV seams and hard edges: a wall of three
    flat-shaded blocks, each split at every edge, is 18 loose faces, yet each block's faces are
    one block. Two blocks that touch face to face stay two (where four borders meet, nothing is
    joined: the two hidden faces between them are blocks of their own, which no view shows)."""
    bm = bmesh.new()
    for x in (0.0, 0.5, 1.02):  # the first two touch; a 2 cm joint before the third
        made = bmesh.ops.create_cube(bm, size=0.5)
        bmesh.ops.translate(bm, vec=(x, 0.0, 0.0), verts=made["verts"])
    bmesh.ops.split_edges(bm, edges=bm.edges[:])
    mesh = bpy.data.meshes.new("Split blocks")
    bm.to_mesh(mesh)
    bm.free()
    obj = studio.link(fresh_scene, bpy.data.objects.new("Split blocks", mesh))
    assert len(np.unique(mesh_arrays.face_islands(mesh))) == 18  # one per face
    blocks = presets.face_blocks(obj)
    centres = np.array([face.center for face in mesh.polygons])
    seen = np.abs(centres[:, 0] - 0.25) > 1e-6  # not the two faces where the blocks touch
    per_block = [np.unique(blocks[k : k + 6][seen[k : k + 6]]) for k in (0, 6, 12)]
    assert [len(found) for found in per_block] == [1, 1, 1]
    assert len(np.unique(np.concatenate(per_block))) == 3


def test_a_wall_of_blocks_through_gltf_keeps_its_blocks(fresh_scene, tmp_path):
    """A wall modelled block by block (flat-shaded, UV-unwrapped), exported and imported with
    Blender's glTF add-on as a user brings it: the importer splits each block at its hard edges
    and UV seams, yet Loose Parts finds the wall's four blocks, each whole (before: one block per
    face, two dozen)."""
    starts = (0.0, 0.51, 1.02, 1.52)  # 1 cm joints; the last two touch face to face
    bm = bmesh.new()
    for x in starts:
        made = bmesh.ops.create_cube(bm, size=0.5)
        bmesh.ops.translate(bm, vec=(x + 0.25, 0.0, 0.25), verts=made["verts"])
    mesh = bpy.data.meshes.new("Wall")
    bm.to_mesh(mesh)
    bm.free()
    imported = through_gltf(studio.link(fresh_scene, bpy.data.objects.new("Wall", mesh)), tmp_path)
    assert mesh_arrays.face_islands(imported.data).max() + 1 >= 24  # split, as the importer leaves it
    centres = np.array([imported.matrix_world @ face.center for face in imported.data.polygons])
    seen = np.abs(centres[:, 0] - 1.52) > 1e-4  # not the two faces where the last blocks touch
    cube = np.searchsorted(starts, centres[:, 0] + 1e-4) - 1  # the block each face lies on
    blocks = presets.face_blocks(imported)
    found = [np.unique(blocks[seen & (cube == k)]) for k in range(len(starts))]
    assert [len(each) for each in found] == [1, 1, 1, 1]
    assert len(np.unique(np.concatenate(found))) == len(starts)


def test_blocks_the_mesh_knows_each_take_their_own_draw(fresh_scene):
    """A wall of six blocks modelled one by one: each block (its loose part) has one draw b,
    neighbours differ, and the per-point parameters are the numpy maths of the read-back fields
    (the stone's, each block its bed); the blocks' draws follow the attribute, not the place."""
    wall = Wall(fresh_scene, size=32)
    wall.wall.data = blocks_mesh("Six", 6)
    presets.mark_blocks(wall.wall)
    material = pw.make_porous_material(
        "Blocks", **STONE, stone="LIMESTONE", masonry=stones.MeshBlocks(), key_light=wall.sun
    )
    assert material.node_tree.nodes[STONE_NODE].node_tree.name == nodes.mesh_blocks_group_name(
        "LIMESTONE", stones.MeshBlocks().attribute
    )
    got = stone_parameters(wall.render, material)
    b = stone_shifted(wall.render, material, "Block Field")
    z_p = stone_shifted(wall.render, material, "Porosity Field")
    z_c = stone_shifted(wall.render, material, "Colour Field")
    covered = wall.render(material)[..., 3] > 0.999
    x = wall.metres()[..., 0]
    part = np.floor((x + 1.0) / (2.0 / 6)).astype(int)
    draws = []
    for k in range(6):
        inside = covered & (part == k) & (np.abs((x + 1.0) - (k + 0.5) * 2.0 / 6) < 0.1)
        assert inside.sum() > 10
        assert np.ptp(b[inside]) < 1e-6  # one draw per block
        draws.append(b[inside][0])
    assert np.median(np.abs(np.diff(draws))) > 0.15
    kd, alpha, sp, m = parameters(LIMESTONE, z_p, z_c)
    for name, value in (("kd", kd), ("alpha", alpha), ("sp", sp), ("m", m)):
        assert np.abs(got[name] - value)[covered].max() < 1e-5 * max(1.0, float(np.abs(value).max())), name
    # the same blocks numbered otherwise: the draws move with the numbers
    values = np.arange(6, dtype=np.int32)[::-1].copy()
    wall.wall.data.attributes[stones.MeshBlocks().attribute].data.foreach_set("value", values)
    renumbered = stone_shifted(wall.render, material, "Block Field")
    first = covered & (part == 0) & (np.abs(x + 1.0 - 1.0 / 6) < 0.1)
    last = covered & (part == 5) & (np.abs(x + 1.0 - 11.0 / 6) < 0.1)
    assert renumbered[first][0] == pytest.approx(draws[5], abs=1e-6)
    assert renumbered[last][0] == pytest.approx(draws[0], abs=1e-6)
