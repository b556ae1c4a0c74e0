"""Image masks baked on the lightmap UV map are read through it, not the mesh's active UV map.

The plane's active UV map is the user's own, turned a quarter; the rain map is a ramp along
the lightmap's u, which runs along world x. Read through the active map, the ramp would run
along y instead.
"""

import bpy

import numpy as np
import pytest

from benchmarks import probes
from helpers import STONE, MaskedPlane, assert_matches, expected_image, lobes, model_weights, weathered
from porous_weathering.common import imageio
from porous_weathering.core import model
from porous_weathering.maps import bake, lightmap
from porous_weathering.shading import weathering

#: The lightmap maps the plane's x, y in [-1, 1] to u, v in [LOW, HIGH]: inside the ramp's texel
#: centres, so bilinear filtering of the ramp gives u exactly.
LOW, HIGH = 0.1, 0.9
RAMP_TEXELS = 16
STATE = dict(time=0.55, front_width=0.3)


@pytest.fixture
def plane(fresh_scene):
    plane = MaskedPlane(fresh_scene)
    mesh = plane.plane.data
    corners = np.array([vertex.co[:2] for vertex in mesh.vertices])[[loop.vertex_index for loop in mesh.loops]]
    lightmap.add_uv_map(mesh, lightmap.LIGHTMAP_UV, LOW + (HIGH - LOW) * (corners + 1) / 2)
    user_uvs = lightmap.corner_uvs(mesh, "UVMap")
    mesh.uv_layers["UVMap"].data.foreach_set("uv", np.stack([1 - user_uvs[:, 1], user_uvs[:, 0]], 1).ravel())
    assert mesh.uv_layers.active.name == "UVMap"
    assert next(layer for layer in mesh.uv_layers if layer.active_render).name == "UVMap"
    return plane


def ramp_map(path):
    """An EXR whose value is the lightmap u at every texel centre, baked (says its header) on it."""
    ramp = (np.arange(RAMP_TEXELS) + 0.5) / RAMP_TEXELS
    imageio.write_image(path, np.tile(ramp, (RAMP_TEXELS, 1)), metadata={bake.UV_MAP_KEY: lightmap.LIGHTMAP_UV})
    return str(path)


def lightmap_u(plane):
    """Per pixel the lightmap u of the plane point seen there, from its world x (clipped to
    [0, 1] where no point is seen)."""
    scale = 0.1
    x = (plane.render(probes.position_probe(scale))[..., 0] - 0.5) / scale
    return np.clip(LOW + (HIGH - LOW) * (x + 1) / 2, 0.0, 1.0)


def test_baked_image_mask_is_read_through_its_uv_map(plane, tmp_path):
    source = weathering.mask_source("rain_map", ramp_map(tmp_path / "Plane.rain.exr"))
    assert weathering.image_uv_map(source) == lightmap.LIGHTMAP_UV
    covered = plane.render(probes.position_probe())[..., 3] > 0.999
    expected_mask = lightmap_u(plane)
    assert np.ptp(expected_mask[covered]) > 0.6
    assert np.abs(plane.probe(source) - expected_mask)[covered].max() < 1e-3


def test_weathered_render_shows_the_baked_rain_map(plane, tmp_path):
    """The wet mode's water follows the rain ramp along x, as model.py says for E = lightmap u."""
    image = plane.render(
        weathered("Wet", (model.WET,), key_light=plane.sun, rain_map=ramp_map(tmp_path / "Plane.rain.exr"), **STATE)
    )
    covered = image[..., 3] > 0.999
    n_dot_l = np.dot(np.array(plane.sun.matrix_world.to_3x3().col[2]), (0.0, 0.0, 1.0))
    expected = expected_image(
        model_weights((model.WET,), n_dot_l, 1.0, rain_map=lightmap_u(plane), **STATE),
        lobes(plane.render, STONE["roughness"]),
    )
    assert np.ptp(expected[covered], axis=0).max() > 0.05, "the rain ramp must show in the render"
    assert_matches(image, expected, covered)


def generated_ramp(uv_map=None):
    """A ramp image made in Blender (no file), naming ``uv_map`` in its custom property."""
    image = bpy.data.images.new("Ramp", RAMP_TEXELS, RAMP_TEXELS, float_buffer=True, is_data=True)
    image.pixels.foreach_set(np.full(RAMP_TEXELS * RAMP_TEXELS * 4, 0.5, dtype=np.float32))
    if uv_map:
        image[bake.UV_MAP_KEY] = uv_map
    return image


def test_an_image_names_its_uv_map_or_is_read_through_the_active_one(plane):
    named = weathered("Named", (model.WET,), rain_map=generated_ramp(lightmap.LIGHTMAP_UV), **STATE)
    plain = weathered("Plain", (model.WET,), rain_map=generated_ramp(), **STATE)
    assert [node.uv_map for node in named.node_tree.nodes if node.type == "UVMAP"] == [lightmap.LIGHTMAP_UV]
    assert not any(node.type == "UVMAP" for node in plain.node_tree.nodes)
    with pytest.warns(model.PorousInputWarning, match="'Elsewhere', which no mesh has"):
        weathered("Lost", (model.WET,), rain_map=generated_ramp("Elsewhere"), **STATE)
