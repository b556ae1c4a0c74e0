"""The composite soiling scene (docs/weathering.md, "The sample scenes and the composite scene"):
a wall with a cornice, its rain map and edge mask baked by the map pipeline (bake.bake_maps,
colour attributes), rendered with Cycles at late t.

docs/model.md §4 says where each area goes: white (rain-washed) where the rain exposure E reaches the
threshold, grey (surface deposit) where it does not, black (carbon in the pores) in sheltered
places from the highest edge/cavity values C down. Wind drives the rain onto the wall, so its
open face is washed, while the cornice shelters a band below it; the inner corner between
the wall and the cornice's soffit is the sheltered cavity where the crust forms.

Regions are picked by geometry (position and normal probes), not by the baked masks, so the
test fails if the bake or the material ignores the rain map; region colours are compared
with model.py, and the whole image pixel by pixel.
"""

import bpy

import bmesh  # importable only once bpy is
import numpy as np
import pytest
from mathutils import Vector

import porous_weathering as pw
from benchmarks import probes
from helpers import assert_matches, expected_image
from porous_weathering.blender import render
from porous_weathering.core import model
from porous_weathering.maps import bake, rain
from porous_weathering.samples import studio
from porous_weathering.shading import weathering

#: A porous stone with shallow pores: deep pores are nearly black when clean already (A_p near 1),
#: so carbon in them would hardly show (docs/weathering.md).
STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.05, roughness=0.3, porosity=0.5, pore_depth_ratio=0.5)
LATE = dict(time=1.0, rain_threshold=0.5)
#: The paper's equations alone (docs/model.md §6): no black crust.
PAPER_EXACT = dict(crust=0.0)
#: Rain driven from the front (-Y) at 40 degrees from the vertical: the open wall gets E = sin 40.
WIND = rain.RainSettings(wind_azimuth=-90.0, wind_tilt=40.0, samples=16)
#: Sun low in front, a little below the cornice, so the sheltered band is lit, not in its shadow.
SUN = (0.3, -0.9, -0.15)
#: The wall's cross-section in (y, z): front face at y = 0 up to 2.4 m, a cornice 0.5 m deep and
#: 0.3 m high on top, back face at y = 0.4. Extruded 2 m along X.
PROFILE = ((0.0, 0.0), (0.0, 2.4), (-0.5, 2.4), (-0.5, 2.7), (0.4, 2.7), (0.4, 0.0))
LENGTH, SPACING = 2.0, 0.05
SIZE = 64


def profile_points():
    """The profile's outline with a vertex every SPACING metres, so the per-corner maps resolve
    the shelter and the edges."""
    points = []
    for start, end in zip(PROFILE, PROFILE[1:] + PROFILE[:1]):
        start, end = np.array(start), np.array(end)
        count = max(1, int(round(np.linalg.norm(end - start) / SPACING)))
        points += [start + (end - start) * k / count for k in range(count)]
    return points


def add_wall(scene):
    """One closed mesh: the profile extruded along X in SPACING steps."""
    bm = bmesh.new()
    rings = [
        [bm.verts.new((x, y, z)) for y, z in profile_points()]
        for x in np.linspace(-LENGTH / 2, LENGTH / 2, int(round(LENGTH / SPACING)) + 1)
    ]
    count = len(rings[0])
    for left, right in zip(rings, rings[1:]):
        for k in range(count):
            bm.faces.new((left[k], left[(k + 1) % count], right[(k + 1) % count], right[k]))
    bm.faces.new(rings[0])
    bm.faces.new(reversed(rings[-1]))
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces)
    mesh = bpy.data.meshes.new("Wall")
    bm.to_mesh(mesh)
    bm.free()
    return studio.link(scene, bpy.data.objects.new("Wall", mesh))


def add_camera(scene):
    """Orthographic, from the front and 15 degrees below: the soffit and the inner corner show."""
    camera = studio.add_ortho_camera(scene, scale=2.1)
    camera.location = (0.0, -8.0, 1.85 - 8.0 * np.tan(np.radians(15.0)))
    camera.rotation_euler = (-Vector(camera.location) + Vector((0.0, 0.0, 1.85))).to_track_quat("-Z", "Y").to_euler()
    return camera


class Composite:
    def __init__(self, scene):
        self.scene = scene
        self.wall = add_wall(scene)
        self.sun = studio.add_sun(scene, SUN)
        self.camera = add_camera(scene)
        bake.bake_maps(
            [self.wall], bake.BakeOptions(maps=bake.MAPS, target="attribute", rain_settings=WIND, edge_radius=0.1)
        )
        render.use_cycles(scene, size=SIZE, samples=1)
        self.masks = {"rain_map": self.probe(bake.ATTRIBUTES["rain"]), "edge_map": self.probe(bake.ATTRIBUTES["edges"])}
        normals = self.render(probes.normal_probe())
        self.covered = normals[..., 3] > 0.999
        self.normals = normals[..., :3] * 2.0 - 1.0
        self.normals /= np.maximum(np.linalg.norm(self.normals, axis=-1, keepdims=True), 1e-9)
        self.positions = (self.render(probes.position_probe())[..., :3] - 0.5) / 0.1

    def render(self, material):
        studio.assign(self.wall, material)
        return render.render_array(self.scene)

    def probe(self, attribute):
        return self.render(
            probes.emission_probe(attribute, lambda graph, geometry: weathering.mask_socket(graph, attribute))
        )[..., 0]

    def cosines(self):
        towards_sun = np.array(self.sun.matrix_world.to_3x3().col[2])
        towards_camera = np.array(self.camera.matrix_world.to_3x3().col[2])
        return self.normals @ towards_sun, self.normals @ towards_camera

    def region(self, normal, y=(-9.0, 9.0), z=(-9.0, 9.0)):
        """Covered pixels whose surface faces ``normal`` and lies within the y and z bounds."""
        y_, z_ = self.positions[..., 1], self.positions[..., 2]
        return (
            self.covered
            & (self.normals @ np.array(normal) > 0.99)
            & (y[0] < y_)
            & (y_ < y[1])
            & (z[0] < z_)
            & (z_ < z[1])
        )


def soiled(composite, **state):
    material = pw.make_weathered_material(
        "Soiled",
        modes=(model.SOILING,),
        key_light=composite.sun,
        rain_map=bake.ATTRIBUTES["rain"],
        edge_map=bake.ATTRIBUTES["edges"],
        environment=None,  # the API's plain defaults, as model_image takes them
        **STONE,
        **state,
    )
    return composite.render(material)[..., :3]


def model_image(composite, lobe_images, **state):
    n_dot_l, n_dot_v = composite.cosines()
    p = STONE
    weights = model.weathered_coefficients(
        p["base_color"],
        p["ks"],
        p["roughness"],
        p["porosity"],
        p["pore_depth_ratio"],
        n_dot_l,
        n_dot_v,
        (model.SOILING,),
        **state,
        **composite.masks,
    )
    return expected_image(weights, (*lobe_images, 0.0))


@pytest.fixture(scope="module")
def renders():
    """The baked masks, the clean (t = 0) and late renders, the model's images of both, and the
    areas by geometry, as arrays (every test starts from a fresh scene)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    composite = Composite(bpy.context.scene)
    lobe_images = [
        composite.render(pw.make_base_material(name, base_color=kd, ks=ks, roughness=STONE["roughness"]))[..., :3]
        for name, kd, ks in (("D", (1, 1, 1), 0.0), ("G", (0, 0, 0), 1.0))
    ]
    lit = composite.covered & (composite.cosines()[0] > 0.05)
    areas = {
        "white": composite.region((0, -1, 0), z=(0.9, 1.45)),  # the open wall, under driven rain
        "grey": composite.region((0, -1, 0), z=(1.95, 2.2)),  # the wall in the cornice's shelter
        "black": composite.region((0, -1, 0), z=(2.33, 2.4)) | composite.region((0, 0, -1), y=(-0.06, 0.0)),
    }
    return dict(
        masks=composite.masks,
        clean=soiled(composite, time=0.0),
        late=soiled(composite, **LATE),
        paper=soiled(composite, **LATE, **PAPER_EXACT),
        lit=lit,
        model_clean=model_image(composite, lobe_images, time=0.0),
        model_late=model_image(composite, lobe_images, **LATE),
        model_paper=model_image(composite, lobe_images, **LATE, **PAPER_EXACT),
        areas={name: area & lit for name, area in areas.items()},
    )


def luminance(rgb):
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def test_baked_masks_put_each_area_where_spec_says(renders):
    """Driven rain washes the open wall (E >= threshold), the cornice shelters the band below
    it, and the inner corner is the strongest cavity of the sheltered surface."""
    rain_map, edge_map = renders["masks"]["rain_map"], renders["masks"]["edge_map"]
    areas = renders["areas"]
    for name, area in areas.items():
        assert area.sum() >= 8, f"the {name} area must be in view and lit"
    threshold = LATE["rain_threshold"]
    assert (rain_map[areas["white"]] >= threshold).mean() > 0.95
    assert (rain_map[areas["grey"]] < threshold).mean() > 0.95
    assert (rain_map[areas["black"]] < threshold).mean() > 0.95
    assert np.median(edge_map[areas["black"]]) > 2.0 * np.median(edge_map[areas["grey"]]) + 0.25


def test_render_matches_model_pixel_by_pixel(renders):
    """Clean, late with the API's defaults (the black crust on), late with the paper-exact setting."""
    for name in ("clean", "late", "paper"):
        assert_matches(renders[name], renders[f"model_{name}"], renders["lit"])
    assert np.abs(renders["late"] - renders["paper"])[renders["areas"]["black"]].max() > 0.02, "the crust shows"


def test_white_grey_and_black_areas_at_late_time(renders):
    """Each area's darkening (late over clean luminance) is what model.py predicts for it:
    none in the white area, the deposit in the grey one, the crust in the black one."""
    ratio = luminance(renders["late"]) / np.maximum(luminance(renders["clean"]), 1e-6)
    model_ratio = luminance(renders["model_late"]) / np.maximum(luminance(renders["model_clean"]), 1e-6)
    means = {name: float(ratio[area].mean()) for name, area in renders["areas"].items()}
    for name, area in renders["areas"].items():
        assert means[name] == pytest.approx(float(model_ratio[area].mean()), abs=0.01), name
    assert means["white"] == pytest.approx(1.0, abs=0.01), "the rain-washed wall stays the clean stone"
    assert means["grey"] < means["white"] - 0.05, "the sheltered wall is greyed by the deposit"
    assert means["black"] < means["grey"] - 0.1, "the sheltered corner is blackened by the crust"
