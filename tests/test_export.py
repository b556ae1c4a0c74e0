"""Publishing weathered states (porous_weathering/export.py, docs/export.md): the glTF mapping
against the glTF specification's BRDF, the baked textures of a tiny wall against the numpy
model texel by texel, the .glb's variants (and their re-import), the Khronos validator, the
paradata, the command line, the operator, and bad input that leaves nothing behind."""

import hashlib
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tomllib

import bpy

import numpy as np
import pytest

from helpers import SCAN, panel_calls, position_texels, rivulets_of, run_cli, stone_texels
from porous_weathering.contracts import GROUP_NODE
from porous_weathering.core import model, stones
from porous_weathering.maps import lightmap
from porous_weathering.publish import export, mapping, textures
from porous_weathering.samples.studio import add_sun
from porous_weathering.shading import material, nodes, weathering
from scripts import load_script

SIZE = 32  #: texels: the wall's UV map is the whole square, so every texel is one point of the model
STONE = dict(base_color=(0.6, 0.55, 0.45), ks=0.1, roughness=0.4, porosity=0.3, pore_depth_ratio=0.5)
SOILING = dict(rain_threshold=0.6, deposit_color=(0.06, 0.055, 0.05))
AGES = (0.0, 0.5, 1.0)
#: The run-off map R of a wall with ``runoff``, of the texel's u: strong where the rain
#: (E = u) is weak, so that it washes some of the sheltered side and streaks the rest. Linear,
#: as the per-corner values are interpolated across the faces.
RUNOFF = lambda u: 0.9 * (1.0 - u)
#: The share of the other walls' rain the standing wall of a stone's rivulets takes.
RIVULET_WALL_RAIN = 0.25


# --- a tiny wall and its export -------------------------------------------------------------


def make_wall(name="Wall", key_light=True, modes=("soiling",), runoff=False, stone=None, masonry=None):
    """A 2 m square of 8 x 8 quads facing +Z, its UV map the whole [0, 1]² square, with a rain
    map E = u and an edge map C = v (colour attributes), and a weathered material (sun mode) of
    ``stone`` laid as ``masonry``; with ``runoff``, a run-off map R = RUNOFF(u) read by the
    soiling too."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=8, y_subdivisions=8, size=2.0)
    wall = bpy.context.active_object
    wall.name = name
    mesh = wall.data
    uvs = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers.active.data.foreach_get("uv", uvs)
    uvs = uvs.reshape(-1, 2)
    maps = [("pw_rain", uvs[:, 0]), ("pw_edges", uvs[:, 1])]
    maps += [("pw_runoff", RUNOFF(uvs[:, 0]))] if runoff else []
    for attribute, values in maps:
        mesh.color_attributes.new(attribute, "FLOAT_COLOR", "CORNER").data.foreach_set("color", np.repeat(values, 4))
    sun = add_sun(bpy.context.scene, (0.3, -0.5, 0.8)) if key_light else None
    masks = dict(rain_map="pw_rain", edge_map="pw_edges", **SOILING) if "soiling" in modes else {}
    if runoff:
        masks["runoff_map"] = "pw_runoff"
    if "efflorescence" in modes:
        masks["efflorescence_map"] = "pw_edges"
    material = weathering.make_weathered_material(
        f"{name} Stone", modes=modes, key_light=sun, stone=stone, masonry=masonry, **STONE, **masks
    )
    wall.data.materials.append(material)
    return wall


def save(tmp_path, name="wall.blend"):
    path = str(tmp_path / name)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """The wall exported with ages 0, 0.5, 1 and wet, as PNG and as WebP (made once)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    folder = tmp_path_factory.mktemp("export")
    wall = make_wall()
    save(folder)
    notes = {"author": "test", "survey": None}
    results = {
        image_format: export.export_variants(
            [wall],
            AGES,
            wet=True,
            size=SIZE,
            out_dir=str(folder / image_format),
            image_format=image_format,
            notes=notes,
        )
        for image_format in export.IMAGE_FORMATS
    }
    return dict(results=results, folder=folder, notes=notes, digest=geometry_digest(wall))


def read_glb(path):
    """(glTF JSON, binary chunk) of a .glb."""
    with open(path, "rb") as stream:
        data = stream.read()
    magic, version, length = struct.unpack("<4sII", data[:12])
    assert (magic, version, length) == (b"glTF", 2, len(data))
    json_length = struct.unpack("<I", data[12:16])[0]
    gltf = json.loads(data[20 : 20 + json_length])
    binary = data[20 + json_length + 8 :]
    return gltf, binary


def glb_image(gltf, binary, texture_index, tmp_path):
    """The pixels (H, W, C) uint8 of a texture of a .glb, top row first (OpenImageIO)."""
    import OpenImageIO as oiio

    image = gltf["images"][gltf["textures"][texture_index].get("source", 0)]
    extension = gltf["textures"][texture_index].get("extensions", {}).get("EXT_texture_webp")
    if extension is not None:
        image = gltf["images"][extension["source"]]
    view = gltf["bufferViews"][image["bufferView"]]
    path = tmp_path / f"texture{texture_index}.{image['mimeType'].split('/')[1]}"
    path.write_bytes(binary[view.get("byteOffset", 0) : view.get("byteOffset", 0) + view["byteLength"]])
    buffer = oiio.ImageBuf(str(path))
    pixels = buffer.get_pixels(oiio.UINT8)
    assert pixels is not None, buffer.geterror()
    return np.asarray(pixels)


def variant_materials(gltf):
    """{variant name: material} of the .glb's one mesh primitive."""
    names = [variant["name"] for variant in gltf["extensions"]["KHR_materials_variants"]["variants"]]
    mappings = gltf["meshes"][0]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"]
    return {
        names[index]: gltf["materials"][mapping["material"]] for mapping in mappings for index in mapping["variants"]
    }


def geometry_digest(obj):
    """sha256 of the world-space vertex positions and face corners, computed here again."""
    mesh = obj.data
    positions = np.array([vertex.co[:] for vertex in mesh.vertices], dtype=np.float64)
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    world = (positions @ matrix[:3, :3].T + matrix[:3, 3]).astype(np.float32)
    corners = np.array([loop.vertex_index for loop in mesh.loops], dtype=np.int32)
    sizes = np.array([polygon.loop_total for polygon in mesh.polygons], dtype=np.int32)
    return hashlib.sha256(world.tobytes() + corners.tobytes() + sizes.tobytes()).hexdigest()


# --- the mapping against the glTF specification -----------------------------------------------


def gltf_dielectric(base, specular_factor, specular_colour_factor, v_dot_h):
    """The weights of glTF's dielectric BRDF (core + KHR_materials_specular, its appendix):
    (diffuse weight, specular weight) = (base (1 - F), F) with F the Schlick mix of
    F0 = min(0.04 * colour, 1) * factor and F90 = factor."""
    f0 = np.minimum(0.04 * specular_colour_factor, 1.0) * specular_factor
    f90 = specular_factor
    fresnel = f0 + (f90 - f0) * (1.0 - v_dot_h) ** 5
    return base * (1.0 - fresnel)[..., None], fresnel


def test_mapping_keeps_each_lobe_weight_at_every_angle():
    """The porous material's Lambert k_d + GGX k_s (+ water) against glTF's Fresnel-weighted
    layering: with the mapping, the diffuse weight is k_d and the specular weight k_s + water
    whatever the angle (F0 = F90), for energy-conserving weights."""
    rng = np.random.default_rng(1)
    count = 2000
    kd = rng.uniform(0.0, 1.0, (count, 3))
    ks = rng.uniform(0.0, 0.3, count)
    water = rng.uniform(0.0, 0.3, (count, 3)) * rng.integers(0, 2, (count, 1))
    kd *= np.minimum(1.0, (1.0 - ks - water.mean(axis=1)) / kd.max(axis=1))[:, None]  # k_d + k_s + water <= 1
    m, water_roughness = rng.uniform(0.0, 1.5, count), rng.uniform(0.0, 0.2, count)
    base, specular, roughness = export.pbr_from_weights(kd, ks, water, m, water_roughness)
    assert base.max() <= 1.0 and specular.max() <= 1.0
    for v_dot_h in (1.0, 0.5, 0.05):
        diffuse_weight, specular_weight = gltf_dielectric(base, specular, mapping.SPECULAR_COLOR_FACTOR, v_dot_h)
        np.testing.assert_allclose(diffuse_weight, kd, atol=1e-9)
        np.testing.assert_allclose(specular_weight, ks + water.mean(axis=1), atol=1e-9)
    dry = water.max(axis=1) == 0.0
    np.testing.assert_allclose(roughness[dry], np.minimum(m[dry], 1.0))  # glTF and Blender: alpha = r²
    lobes = np.stack([np.minimum(m, 1.0), water_roughness])  # one lobe for two: between them
    assert np.all(roughness >= lobes.min(axis=0) - 1e-12) and np.all(roughness <= lobes.max(axis=0) + 1e-12)


def test_srgb_encoding():
    linear = np.array([0.0, 0.0031308, 0.2140, 0.5, 1.0])
    np.testing.assert_allclose(mapping.linear_to_srgb(linear), [0.0, 0.04045, 0.5, 0.7354, 1.0], atol=2e-4)


# --- the textures against the model -----------------------------------------------------------


def expected_weights(age, wet, size=SIZE, runoff=False, stone=None, rivulets=None, rain_share=1.0):
    """The model's weights on the wall's texel centres (top row first), in the ambient mode
    seen face on, as glTF values: (base colour, S, roughness). ``stone``: the stone's parameters
    at each texel (kd, m, alpha, sp and its structure's receptivity, field and variation:
    ``stone_at_texels``) in place of STONE's uniform ones; ``rivulets``: the model's (u, h, spacing)
    at each texel (``texel_rivulets``), which gather its run-off; ``rain_share``: E = that share of u
    (a wall whose rain map was scaled), the run-off still RUNOFF(u)."""
    u = (np.arange(size) + 0.5) / size
    across, edges = np.meshgrid(u, u[::-1])  # texel (row, column): u, and C = v
    rain = rain_share * across
    modes = ("soiling", "wet") if wet else ("soiling",)
    state = dict(time=age, rain_map=rain, edge_map=edges, **SOILING)
    if runoff:
        state["runoff_map"] = RUNOFF(across)
    uniform = dict(kd=STONE["base_color"], m=STONE["roughness"], alpha=STONE["porosity"], sp=STONE["pore_depth_ratio"])
    point = {**uniform, **(stone or {})}
    kd, ks, water = model.weathered_coefficients(
        point["kd"], STONE["ks"], point["m"], point["alpha"], point["sp"], None, 1.0, modes=modes,
        receptivity=point.get("receptivity"), field=point.get("field"), variation=point.get("variation"),
        rivulets=rivulets, **state,
    )  # fmt: skip
    ks = np.broadcast_to(ks, rain.shape)
    return export.pbr_from_weights(kd, ks, water, point["m"], 0.05)


def texel_rivulets(wall, size=SIZE):
    """The model's rivulets (docs/model.md §8.8) at the wall's texel centres, top row first, from
    their positions as the bake puts them (a rivulet's profile is narrower than a texel: its
    weight moves by an 8-bit step where the point moves by 0.1 mm) and the wall's normal."""
    points = position_texels(wall, size, shift=10.0)
    normal = np.array(wall.matrix_world)[:3, :3] @ (0.0, 0.0, 1.0)
    normals = np.broadcast_to(normal / np.linalg.norm(normal), points.shape)
    return rivulets_of(wall.active_material, points, normals, wall, bpy.context.scene)


def stone_at_texels(wall, size=SIZE):
    """The parameters of ``wall``'s stone at its texel centres, as ``expected_weights`` takes them."""
    alpha, m, sp = np.moveaxis(stone_texels(wall, ("Porosity", "Roughness", "Pore Depth Ratio"), size), -1, 0)
    structure = (nodes.RECEPTIVITY, "Porosity Field", "Variation")
    receptivity, field, variation = np.moveaxis(stone_texels(wall, structure, size, shift=1.0), -1, 0)
    kd = stone_texels(wall, ("Base Color",), size)
    return dict(kd=kd, m=m, alpha=alpha, sp=sp, receptivity=receptivity, field=field, variation=variation)


def material_values(material, gltf, binary, tmp_path, size=SIZE):
    """(base colour, S, roughness) per texel of a glTF material, decoded as a viewer does."""
    pbr = material["pbrMetallicRoughness"]
    specular = material["extensions"]["KHR_materials_specular"]
    assert specular["specularColorFactor"] == [mapping.SPECULAR_COLOR_FACTOR] * 3
    assert pbr["metallicFactor"] == 0
    if "baseColorTexture" in pbr:
        codes = glb_image(gltf, binary, pbr["baseColorTexture"]["index"], tmp_path)[..., :3] / 255.0
        base = np.where(codes <= 0.04045, codes / 12.92, ((codes + 0.055) / 1.055) ** 2.4)
    else:
        base = np.broadcast_to(pbr["baseColorFactor"][:3], (size, size, 3))
    s = np.full((size, size), specular.get("specularFactor", 1.0))
    if "specularTexture" in specular:
        s = s * glb_image(gltf, binary, specular["specularTexture"]["index"], tmp_path)[..., 3] / 255.0
    r = np.full((size, size), pbr.get("roughnessFactor", 1.0))
    if "metallicRoughnessTexture" in pbr:
        r = r * glb_image(gltf, binary, pbr["metallicRoughnessTexture"]["index"], tmp_path)[..., 1] / 255.0
    return base, s, r


@pytest.mark.parametrize(
    "variant, age, wet", [("clean", 0.0, False), ("t=0.5", 0.5, False), ("t=1", 1.0, False), ("wet", 1.0, True)]
)
def test_textures_match_the_model(exported, tmp_path, variant, age, wet):
    """Each variant's textures, decoded from the .glb, are the numpy model's weights on the
    texel centres mapped to glTF (8-bit rounding aside): the bake, the ambient mode the export
    puts the sun-mode material in, the wet mode it adds, and the writing are all right."""
    gltf, binary = read_glb(exported["results"]["png"].path)
    base, s, r = material_values(variant_materials(gltf)[variant], gltf, binary, tmp_path)
    want_base, want_s, want_r = expected_weights(age, wet)
    srgb = mapping.linear_to_srgb
    assert np.abs(srgb(base) - srgb(want_base)).max() <= 1.5 / 255
    assert np.abs(s - want_s).max() <= want_s.max() / 255 + 1e-6
    assert np.abs(r - want_r).max() <= 1.5 / 255
    if variant == "clean":  # the clean state is uniform: factors, no textures
        assert not {"baseColorTexture", "metallicRoughnessTexture"} & set(
            variant_materials(gltf)[variant]["pbrMetallicRoughness"]
        )
    if variant == "t=1":  # weathered: the soiled wall varies (else the test would prove little)
        assert np.ptp(srgb(want_base)) > 0.2 and np.ptp(want_s) > 0.01
    if variant == "wet":  # the water shows: darker stone, and the water lobe's face-on weight (~2%) in S
        dry_base, dry_s, _ = expected_weights(age, False)
        assert (srgb(dry_base) - srgb(want_base)).max() > 0.1
        assert (want_s - dry_s).max() > 10 * want_s.max() / 255


def test_the_runoff_reaches_the_exported_textures(tmp_path):
    """A wall whose soiling reads a run-off map: its t = 1 textures are the model's with the
    run-off (washed in the map's band, streaked beside it), not the model's without it."""
    wall = make_wall(runoff=True)
    save(tmp_path)
    result = export.export_variants([wall], (1.0,), size=SIZE, out_dir=str(tmp_path / "out"))
    gltf, binary = read_glb(result.path)
    base, _, _ = material_values(variant_materials(gltf)["t=1"], gltf, binary, tmp_path)
    srgb = mapping.linear_to_srgb
    with_runoff, without = (expected_weights(1.0, False, runoff=flag)[0] for flag in (True, False))
    assert np.abs(srgb(base) - srgb(with_runoff)).max() <= 1.5 / 255
    assert np.abs(srgb(with_runoff) - srgb(without)).max() > 0.1


#: Coursed ashlar whose joints about a fifth of the wall's texel centres fall in (docs/model.md §8.5): its
#: lengths are not multiples of the texels' spacing, so that the joints do not fall between them.
WIDE_JOINTED_ASHLAR = stones.Ashlar(course_height=0.3, block_length=0.55, joint_width=0.04)


@pytest.mark.parametrize("masonry", [None, WIDE_JOINTED_ASHLAR], ids=["stone", "ashlar"])
def test_a_stones_textures_are_the_model_per_texel(tmp_path, masonry):
    """A stone's structure (docs/model.md §8) is baked into the textures as the model has it, texel
    by texel: each variant's (new, soiled, wet) base colour, S and roughness are the model's
    weights at the stone's own parameters at that texel (its stone node's outputs read back by
    bakes at the texel centres, as the export bakes), its fronts following the stone's
    receptivity and uptake (§8.3, §8.7) and its deposit mixed with the stone's colour (§8.6); the
    clean stone varies from texel to texel, its mean the uniform wall's. Laid as ashlar (§8.5),
    each block and the mortar in the joints are held alike, on a wall standing up (its courses
    level)."""
    wall = make_wall(stone="LIMESTONE", masonry=masonry)
    if masonry is not None:  # lying at z = 0 the whole wall would be one bed joint
        wall.rotation_euler = (math.radians(90.0), 0.0, 0.0)
        bpy.context.view_layer.update()
    save(tmp_path)
    result = export.export_variants([wall], (0.0, 0.5), wet=True, size=SIZE, out_dir=str(tmp_path / "out"))
    gltf, binary = read_glb(result.path)
    stone = stone_at_texels(wall)
    srgb = mapping.linear_to_srgb
    for variant, age, wet in (("clean", 0.0, False), ("t=0.5", 0.5, False), ("wet", 0.5, True)):
        base, s, r = material_values(variant_materials(gltf)[variant], gltf, binary, tmp_path)
        want_base, want_s, want_r = expected_weights(age, wet, stone=stone)
        assert np.abs(srgb(base) - srgb(want_base)).max() <= 1.5 / 255, variant
        assert np.abs(s - want_s).max() <= want_s.max() / 255 + 1e-6, variant
        assert np.abs(r - want_r).max() <= 1.5 / 255, variant
    uniform = expected_weights(0.0, False)[0]
    clean = expected_weights(0.0, False, stone=stone)[0]
    assert clean.std(axis=(0, 1)).min() > 0.005 and uniform.std(axis=(0, 1)).max() < 1e-6
    assert np.abs(clean.mean(axis=(0, 1)) - uniform.mean(axis=(0, 1))).max() < 0.03  # its mean kept
    if masonry is not None:  # the joints are among the texels held to the model
        joint = stone_texels(wall, ("Joint",), SIZE)[..., 0]
        assert 0.05 < (joint > 0.99).mean() < 0.5 and (joint < 0.01).mean() > 0.5
    # the soiled wall's fronts are the stone's: without its receptivity and uptake they lie elsewhere
    without = dict(stone, receptivity=None, field=None)
    soiled, unreceptive = (expected_weights(0.5, False, stone=point)[0] for point in (stone, without))
    assert np.abs(srgb(soiled) - srgb(unreceptive)).max() > 0.05


def test_a_stone_exports_at_its_scenes_unit(tmp_path, monkeypatch):
    """A stone wall made in metres, then modelled in millimetres (the unit scale set to 0.001 and
    the wall 1000 units across), exports the textures it exported in metres: the bake material
    takes the object's scene's unit (docs/model.md §8.2); at the unit as made it would not."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    wall = make_wall(stone="LIMESTONE")

    def clean_base(name):
        save(tmp_path, f"{name}.blend")
        result = export.export_variants([wall], (1.0,), size=SIZE, out_dir=str(tmp_path / name))
        gltf, binary = read_glb(result.path)
        return material_values(variant_materials(gltf)["clean"], gltf, binary, tmp_path)[0]

    in_metres = clean_base("metres")
    bpy.context.scene.unit_settings.scale_length = 0.001
    wall.data.transform(np.diag([1000.0, 1000.0, 1000.0, 1.0]))
    wall.data.update()
    in_millimetres = clean_base("millimetres")
    assert in_metres.std(axis=(0, 1)).min() > 0.005  # the stone shows
    assert (np.abs(in_millimetres - in_metres).max(axis=-1) <= 1.5 / 255).mean() > 0.99
    monkeypatch.setattr(export, "object_metres_per_unit", lambda obj: 1.0)  # the stone 1000 times too large
    stale = clean_base("stale")
    assert np.abs(stale - in_metres).max() > 0.02


def test_a_stones_rivulets_are_the_models_in_the_textures(tmp_path):
    """A wall standing up, of a stone, whose soiling reads a run-off map: its run-off gathers into
    the stone's rivulets (docs/model.md §8.8), and its t = 1 textures are the model's with them at
    each texel (its stone and its place across the fall line), not the model's without them. Its
    rain is a quarter of the other walls' (E = u / 4), so that the water the rivulets gather and
    take away decides where it washes."""
    wall = make_wall(stone="LIMESTONE", runoff=True)
    rain = wall.data.color_attributes["pw_rain"].data
    values = np.empty(len(rain) * 4, dtype=np.float32)
    rain.foreach_get("color", values)
    rain.foreach_set("color", values * RIVULET_WALL_RAIN)
    wall.rotation_euler = (math.radians(90.0), 0.0, 0.0)  # facing -Y, its v up
    bpy.context.view_layer.update()
    save(tmp_path)
    assert nodes.RIVULET_SPACING in wall.active_material.node_tree.nodes[GROUP_NODE].inputs
    result = export.export_variants([wall], (1.0,), size=SIZE, out_dir=str(tmp_path / "out"))
    gltf, binary = read_glb(result.path)
    base, s, r = material_values(variant_materials(gltf)["t=1"], gltf, binary, tmp_path)
    stone, rivulets = stone_at_texels(wall), texel_rivulets(wall)
    want_base, want_s, want_r = expected_weights(
        1.0, False, runoff=True, stone=stone, rivulets=rivulets, rain_share=RIVULET_WALL_RAIN
    )
    srgb = mapping.linear_to_srgb
    assert np.abs(srgb(base) - srgb(want_base)).max() <= 1.5 / 255
    assert np.abs(s - want_s).max() <= want_s.max() / 255 + 1e-6
    assert np.abs(r - want_r).max() <= 1.5 / 255
    without = expected_weights(1.0, False, runoff=True, stone=stone, rain_share=RIVULET_WALL_RAIN)[0]
    assert np.abs(srgb(want_base) - srgb(without)).max() > 0.05  # the rivulets show


def test_a_scans_vertex_colours_reach_the_exported_textures(tmp_path):
    """A wall whose base colour is its colour attribute (a scan's vertex colours, read by an
    Attribute node): the clean variant's base colour is the model's with k_d the attribute's
    colour at each texel (the stone's colour times 0.5 + 0.5 v at the corners, linear across the
    faces, so exact at the texel centres)."""
    wall = make_wall()
    mesh = wall.data
    uvs = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers.active.data.foreach_get("uv", uvs)
    shade = 0.5 + 0.5 * uvs.reshape(-1, 2)[:, 1]
    colours = np.column_stack([np.outer(shade, STONE["base_color"]), np.ones(len(shade))])
    mesh.color_attributes.new("Col", "FLOAT_COLOR", "CORNER").data.foreach_set(
        "color", colours.astype(np.float32).ravel()
    )
    masks = dict(rain_map="pw_rain", edge_map="pw_edges", **SOILING)
    made = weathering.make_weathered_material(
        "Scan Stone", modes=("soiling",), **{**STONE, "base_color": material.ColorAttribute("Col")}, **masks
    )
    mesh.materials.clear()
    mesh.materials.append(made)
    save(tmp_path)
    result = export.export_variants([wall], (0.0, 1.0), size=SIZE, out_dir=str(tmp_path / "out"))
    gltf, binary = read_glb(result.path)
    base, _, _ = material_values(variant_materials(gltf)["clean"], gltf, binary, tmp_path)
    v = (np.arange(SIZE)[::-1] + 0.5) / SIZE  # the texels' rows, top row first
    srgb = mapping.linear_to_srgb
    for row, v_row in enumerate(v):
        stone = dict(STONE, base_color=tuple(np.multiply(STONE["base_color"], 0.5 + 0.5 * v_row)))
        kd, ks, water = model.weathered_coefficients(
            *stone.values(), None, 1.0, modes=("soiling",), time=0.0, rain_map=0.5, edge_map=0.5, **SOILING
        )
        want = export.pbr_from_weights(kd, np.asarray(ks), water, STONE["roughness"], 0.05)[0]
        assert np.abs(srgb(base[row]) - srgb(np.asarray(want))).max() <= 1.5 / 255, row
    assert np.ptp(srgb(base[:, :, 0])) > 0.1  # the colours vary down the wall


def test_webp_textures_match_the_png_ones(exported, tmp_path):
    png, png_binary = read_glb(exported["results"]["png"].path)
    webp, webp_binary = read_glb(exported["results"]["webp"].path)
    assert "EXT_texture_webp" in webp["extensionsUsed"]
    for variant in ("t=1", "wet"):
        lossless = material_values(variant_materials(png)[variant], png, png_binary, tmp_path)
        lossy = material_values(variant_materials(webp)[variant], webp, webp_binary, tmp_path)
        for exact, compressed in zip(lossless, lossy):
            assert np.abs(mapping.linear_to_srgb(exact) - mapping.linear_to_srgb(compressed)).mean() < 3 / 255


# --- the .glb, its re-import and the validator -----------------------------------------------


def test_glb_holds_the_variants(exported):
    gltf, _ = read_glb(exported["results"]["png"].path)
    assert {"KHR_materials_variants", "KHR_materials_specular"} <= set(gltf["extensionsUsed"])
    assert list(variant_materials(gltf)) == ["clean", "t=0.5", "t=1", "wet"]
    primitive = gltf["meshes"][0]["primitives"][0]
    assert gltf["materials"][primitive["material"]]["name"] == "Wall clean"  # the default: the clean state
    assert set(primitive["attributes"]) == {"POSITION", "NORMAL", "TEXCOORD_0"}  # the masks are in the textures
    assert [node["name"] for node in gltf["nodes"]] == ["Wall"]  # the user's name, not the scratch copy's
    assert gltf["scenes"][0]["extras"]["porous_weathering"]["kind"] == "visualisation"
    images = gltf["images"]
    assert len({image["name"] for image in images}) == len(images)  # one image per distinct texture


def test_glb_reimports_with_its_variants(exported):
    preferences = bpy.context.preferences.addons["io_scene_gltf2"].preferences
    enabled = preferences.KHR_materials_variants_ui
    preferences.KHR_materials_variants_ui = True
    try:
        bpy.ops.import_scene.gltf(filepath=exported["results"]["png"].path)
        variants = [item.name for item in bpy.data.scenes[0].gltf2_KHR_materials_variants_variants]
        wall = bpy.data.objects["Wall"]
        mapped = {
            variants[item.variant.variant_idx]: entry.material.name
            for entry in wall.data.gltf2_variant_mesh_data
            for item in entry.variants
        }
    finally:
        preferences.KHR_materials_variants_ui = enabled
    assert variants == ["clean", "t=0.5", "t=1", "wet"]
    assert mapped == {name: f"Wall {name}" for name in variants}
    principled = bpy.data.materials["Wall wet"].node_tree.nodes["Principled BSDF"]
    assert principled.inputs["Specular Tint"].default_value[0] == pytest.approx(mapping.SPECULAR_COLOR_FACTOR)
    # textures: the wet wall's colour and specular vary (its roughness does not: the water lobe weighs ~2% face on)
    assert principled.inputs["Base Color"].is_linked and principled.inputs["Specular IOR Level"].is_linked


def validator():
    """The Khronos glTF validator (npm package gltf-validator, which scripts/env.sh installs
    beside the virtual environment when npm exists), or a skip saying what is missing."""
    node = shutil.which("node")
    package = os.environ.get("PW_GLTF_VALIDATOR") or os.path.join(sys.prefix, "node", "node_modules", "gltf-validator")
    if node is None:
        pytest.skip("Node.js is not installed: the glTF validator cannot run")
    if not os.path.isfile(os.path.join(package, "package.json")):
        pytest.skip(f"gltf-validator is not installed in {package} (scripts/env.sh installs it when npm exists)")
    return node, package


VALIDATE = """
const fs = require('fs');
const validator = require(process.argv[1]);
validator.validateBytes(new Uint8Array(fs.readFileSync(process.argv[2])), {maxIssues: 100})
  .then((report) => process.stdout.write(JSON.stringify(report)))
  .catch((error) => { console.error(String(error)); process.exit(1); });
"""


def validate(path):
    node, package = validator()
    done = subprocess.run([node, "-e", VALIDATE, package, path], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize("image_format", export.IMAGE_FORMATS)
def test_validator_reports_no_errors(exported, image_format):
    report = validate(exported["results"][image_format].path)
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"]
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]
    assert "KHR_materials_variants" in report["info"]["extensionsUsed"]


def test_validator_catches_a_broken_file(tmp_path, exported):
    """The check above can fail: a .glb whose variant names a missing material is an error."""
    gltf, binary = read_glb(exported["results"]["png"].path)
    mappings = gltf["meshes"][0]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"]
    mappings[0]["material"] = len(gltf["materials"]) + 5
    text = json.dumps(gltf).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(binary), b"BIN\0") + binary
    broken = tmp_path / "broken.glb"
    broken.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    assert validate(str(broken))["issues"]["numErrors"] > 0


# --- paradata ---------------------------------------------------------------------------------


def test_the_version_comes_from_the_manifest_else_the_installed_package(monkeypatch, tmp_path):
    import importlib.metadata

    from porous_weathering.publish import paradata

    with open(paradata.MANIFEST, "rb") as stream:
        assert paradata.extension_version() == tomllib.load(stream)["version"]
    monkeypatch.setattr(paradata, "MANIFEST", str(tmp_path / "none.toml"))  # installed by pip: no manifest
    monkeypatch.setattr(importlib.metadata, "version", lambda name: {"porous-weathering": "7.8.9"}[name])
    assert paradata.extension_version() == "7.8.9"

    def not_installed(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", not_installed)
    assert paradata.extension_version() == "unknown"


def test_paradata_says_what_made_it(exported):
    result = exported["results"]["png"]
    with open(result.paradata, encoding="utf-8") as stream:
        paradata = json.load(stream)
    assert paradata["kind"] == "visualisation" and "not a survey" in paradata["statement"]
    assert paradata["generator"]["blender"] == bpy.app.version_string
    assert paradata["generator"]["extension"].startswith("Porous Weathering ")
    assert paradata["source"]["blend_file"] == str(exported["folder"] / "wall.blend")
    with open(result.path, "rb") as stream:
        assert paradata["export"]["sha256"] == hashlib.sha256(stream.read()).hexdigest()
    assert paradata["export"]["texture_size"] == SIZE
    assert [(v["name"], v["age"], v["wet"]) for v in paradata["variants"]] == [
        ("clean", 0.0, False),
        ("t=0.5", 0.5, False),
        ("t=1", 1.0, False),
        ("wet", 1.0, True),
    ]
    (wall,) = paradata["objects"]
    assert wall["geometry_sha256"] == exported["digest"]
    assert wall["uv_map"] == {"name": "UVMap", "made_by_export": False}
    (stone,) = wall["materials"]
    assert stone["modes"] == ["soiling", "wet"] and stone["light_mode_of_the_material"] == "SUN"
    assert stone["inputs"]["Porosity"] == pytest.approx(STONE["porosity"])
    assert stone["inputs"]["Rain Threshold"] == pytest.approx(SOILING["rain_threshold"])
    assert stone["maps"]["Rain Map"]["attribute"] == "pw_rain"
    assert paradata["notes"] == exported["notes"]


# --- the user's data, lightmaps, bad input ----------------------------------------------------


def test_leaves_the_users_data_as_it_was(tmp_path):
    wall = make_wall()
    save(tmp_path)
    preferences = bpy.context.preferences.addons["io_scene_gltf2"].preferences

    def state():
        return (
            sorted(bpy.data.objects.keys()),
            sorted(bpy.data.meshes.keys()),
            sorted(bpy.data.materials.keys()),
            sorted(bpy.data.scenes.keys()),
            sorted(bpy.data.images.keys()),
            [layer.name for layer in wall.data.uv_layers],
            sorted(wall.data.color_attributes.keys()),
            preferences.KHR_materials_variants_ui,
            bpy.context.window.scene.name,
        )

    before = state()
    export.export_variants([wall], (0.0, 1.0), size=16, out_dir=str(tmp_path / "out"))
    assert state() == before
    assert wall.data.materials[0].node_tree.nodes["Porous"].node_tree.name.endswith("(Sun)")


def test_keeps_the_users_own_glTF_variants(tmp_path, capfd):
    """With the glTF add-on's variants already on and variants of the user's own, the export
    writes its variants only and gives the user's back (and never registers the add-on's UI twice)."""
    preferences = bpy.context.preferences.addons["io_scene_gltf2"].preferences
    enabled = preferences.KHR_materials_variants_ui
    preferences.KHR_materials_variants_ui = True
    try:
        wall = make_wall()
        save(tmp_path)
        mine = bpy.data.scenes[0].gltf2_KHR_materials_variants_variants.add()
        mine.name, mine.variant_idx = "mine", 0
        result = export.export_variants([wall], (1.0,), size=16, out_dir=str(tmp_path))
        assert [item.name for item in bpy.data.scenes[0].gltf2_KHR_materials_variants_variants] == ["mine"]
        assert preferences.KHR_materials_variants_ui
    finally:
        preferences.KHR_materials_variants_ui = enabled
    assert list(variant_materials(read_glb(result.path)[0])) == ["clean", "t=1"]
    assert "already registered" not in capfd.readouterr().err


def test_a_mesh_without_uvs_gets_a_lightmap(tmp_path):
    """A scan without UVs gets the lightmap the bake would make (on the export's copy only)."""
    wall = make_wall()
    wall.data.uv_layers.remove(wall.data.uv_layers[0])
    save(tmp_path)
    result = export.export_variants([wall], (1.0,), size=64, out_dir=str(tmp_path))
    gltf, _ = read_glb(result.path)
    assert "TEXCOORD_0" in gltf["meshes"][0]["primitives"][0]["attributes"]
    with open(result.paradata, encoding="utf-8") as stream:
        assert json.load(stream)["objects"][0]["uv_map"] == {"name": lightmap.LIGHTMAP_UV, "made_by_export": True}
    assert not wall.data.uv_layers


def test_a_lightmap_made_for_a_smaller_bake_keeps_its_maps_and_the_textures_get_their_own():
    """The corpus's draped figure unwrapped for 256² maps: its faces, apart at 256², lie on one
    2048² texel centre (its sub-texel folds): the export's copy bakes its textures on a lightmap
    of its own, and its maps are still read through the one they were baked on (before, the
    export was refused: remove the lightmap, which its maps need)."""
    vertices, faces = load_script("sample_blends/corpus_generator.py").shape_mesh("draped_figure", "mm")
    mesh = SCAN.add_to_scene("Draped", vertices, faces).data
    lightmap.add_uv_map(mesh, lightmap.LIGHTMAP_UV, lightmap.lightmap_uvs(mesh, 256))
    baked_on = lightmap.corner_uvs(mesh, lightmap.LIGHTMAP_UV).copy()
    assert lightmap.find_bakeable_uv_map(mesh, 256) == lightmap.LIGHTMAP_UV
    assert lightmap.find_bakeable_uv_map(mesh, 2048) is None
    assert textures.bake_uv_map(mesh, 2048) == (textures.EXPORT_UV, True)
    assert lightmap.find_bakeable_uv_map(mesh, 2048) == textures.EXPORT_UV
    assert np.array_equal(lightmap.corner_uvs(mesh, lightmap.LIGHTMAP_UV), baked_on)


def test_a_broken_lightmap_is_refused_in_one_line(tmp_path):
    wall = make_wall()
    broken = wall.data.uv_layers.new(name=lightmap.LIGHTMAP_UV)
    broken.data.foreach_set("uv", np.zeros(len(wall.data.loops) * 2, dtype=np.float32))  # every face on one point
    wall.data.uv_layers.remove(wall.data.uv_layers["UVMap"])
    save(tmp_path)
    with pytest.raises(ValueError, match=lightmap.LIGHTMAP_UV) as error:
        export.export_variants([wall], (1.0,), size=16, out_dir=str(tmp_path / "out"))
    assert "\n" not in str(error.value)
    assert not os.listdir(tmp_path / "out")


@pytest.mark.parametrize(
    "case, message",
    [
        ("unsaved", "not saved"),
        ("no porous material", "not a Porous Weathering material"),
        ("size", "power of two"),
        ("too big", "from 16 to 8192"),
        ("age", r"\[0, 1\]"),
        ("wet without rain", "no rain map"),
        ("format", "must be one of"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, case, message):
    wall = make_wall(modes=("efflorescence",) if case == "wet without rain" else ("soiling",))
    if case != "unsaved":
        save(tmp_path)
    if case == "no porous material":
        wall.data.materials[0] = bpy.data.materials.new("Plain")
    arguments = dict(ages=(0.0, 1.0), size=16, out_dir=str(tmp_path / "out"))
    arguments.update(
        {
            "size": dict(size=1000),
            "too big": dict(size=16384),
            "age": dict(ages=(0.5, 1.5)),
            "wet without rain": dict(wet=True),
            "format": dict(image_format="ktx2"),
        }.get(case, {})
    )
    ages = arguments.pop("ages")
    with pytest.raises(ValueError, match=message) as error:
        export.export_variants([wall], ages, **arguments)
    assert "\n" not in str(error.value)
    assert not os.path.exists(tmp_path / "out") or not os.listdir(tmp_path / "out")


def test_an_interrupted_export_leaves_nothing(tmp_path):
    """Stopped while it writes (the last step), the export leaves no file and no scratch data."""
    wall = make_wall()
    save(tmp_path)
    scenes, images = len(bpy.data.scenes), len(bpy.data.images)

    def stop_at_the_write(fraction, message):
        if message.startswith("writing"):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        export.export_variants([wall], (1.0,), size=16, out_dir=str(tmp_path / "out"), progress=stop_at_the_write)
    assert not os.listdir(tmp_path / "out")
    assert (len(bpy.data.scenes), len(bpy.data.images)) == (scenes, images)
    steps = export.iter_export([wall], export.ExportOptions(ages=(1.0,), size=16, out_dir=str(tmp_path / "out")))
    next(steps), next(steps)
    steps.close()  # the operator's Esc
    assert not os.listdir(tmp_path / "out") and len(bpy.data.scenes) == scenes


# --- the command line and the operator --------------------------------------------------------


def test_command_line(tmp_path):
    make_wall()
    bpy.context.scene.collection.children.link(bpy.data.collections.new("Lights"))
    blend = save(tmp_path)
    out = tmp_path / "out"
    done = run_cli(
        "export",
        blend,
        "--objects",
        "Wall",
        "--ages",
        "0,1",
        "--wet",
        "--size",
        "16",
        "--out",
        str(out),
        "--note",
        "author=me",
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert sorted(os.listdir(out)) == ["wall.glb", "wall.paradata.json"]
    assert "variants clean, t=1, wet" in done.stdout
    assert "ERROR" not in done.stdout + done.stderr  # the bpy wheel's add-on lacks Draco: not asked for
    # one line per file written: not the add-on's log of its steps ("01:45:46 | INFO: Starting ...")
    assert [line.split()[0] for line in done.stdout.splitlines()] == ["wrote", "wrote"]
    with open(out / "wall.paradata.json", encoding="utf-8") as stream:
        assert json.load(stream)["notes"] == {"author": "me"}
    for words, message in (
        (["--objects", "Nope"], "no object named Nope"),
        (["--size", "3000"], "power of two"),
        (["--ages", "0,x"], "not 'x'"),
        (["--collection", "Lights"], "no mesh objects to export"),
    ):
        done = run_cli("export", blend, *words, "--out", str(tmp_path / "bad"), timeout=300)
        errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
        assert done.returncode == 2 and len(errors) == 1 and message in errors[0], done.stderr
        assert not os.path.exists(tmp_path / "bad") or not os.listdir(tmp_path / "bad")
    bpy.data.objects["Wall"].data.materials.clear()  # a scan as imported: nothing made for it yet
    unmade = save(tmp_path, "unmade.blend")
    done = run_cli("export", unmade, "--out", str(tmp_path / "bad"), timeout=300)
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert done.returncode == 2 and len(errors) == 1, done.stderr
    assert "only Porous Weathering materials to export: give them one first (the panel's Make" in errors[0]
    done = run_cli("export", str(tmp_path / "missing.blend"), timeout=300)
    assert done.returncode == 2 and "no such .blend file" in done.stderr
    (tmp_path / "broken.blend").write_bytes(b"not a blend file")
    done = run_cli("export", str(tmp_path / "broken.blend"), "--out", str(tmp_path / "bad"), timeout=300)
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert done.returncode == 1 and len(errors) == 1 and "broken.blend" in errors[0], done.stderr


def test_operator_and_panel_button(tmp_path):
    import porous_weathering

    porous_weathering.register()
    try:
        wall = make_wall()
        save(tmp_path)
        wall.select_set(True)
        bpy.context.view_layer.objects.active = wall
        calls = panel_calls()
        assert ("operator", ("porous_weathering.export_variants",)) in calls
        operator = bpy.ops.porous_weathering.export_variants
        declared = {entry.dest for entry in export.option_entries() if entry.option.ui}
        assert declared <= {prop.identifier for prop in operator.get_rna_type().properties}
        assert operator(ages="1", size=16, out_dir=str(tmp_path / "out"), name="panel") == {"FINISHED"}
        assert sorted(os.listdir(tmp_path / "out")) == ["panel.glb", "panel.paradata.json"]
    finally:
        porous_weathering.unregister()
