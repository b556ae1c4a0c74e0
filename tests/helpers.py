"""Shared test helpers: render harnesses whose images are checked pixel by pixel against model.py.

- ``assert_matches`` and ``TOLERANCE``: a render against the image model.py predicts.
- ``LitSphere``: a sphere under one sun. A porous pixel must equal k_d,poro * D + k_s,poro * G,
  where D and G are renders of a white Lambert and a white GGX lobe of the same roughness under
  the same light, and the weights come from model.py at that pixel's shading normal (read from
  a probe render).
- ``MaskedPlane``: a plane under one sun, its weathering masks varying across it.
- ``STONE``, ``weathered``, ``lobes``, ``model_weights``, ``expected_image``: a weathered stone
  and the image model.weathered_coefficients predicts for it, k_d D + k_s G + k_water W (W: a
  white GGX of the water's roughness).
- ``paper_modes``: the modes as the paper writes them, without the layers beyond it (SPEC 6).
"""

import contextlib
import dataclasses

import numpy as np

import porous_weathering as pw
from porous_weathering.blender import render
from porous_weathering.core import model
from porous_weathering.core import modes as weathering_modes
from porous_weathering.core.modes import soiling, wet
from porous_weathering.samples import studio
from porous_weathering.shading import weathering

#: Cycles evaluates the node maths in float32 and stores float32 EXR: agreement to 1e-4
#: of the brightest pixel is far tighter than anything visible (1/255 = 4e-3).
TOLERANCE = 1e-4

STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.08, roughness=0.6, porosity=0.35, pore_depth_ratio=2.5)
WATER_ROUGHNESS = 0.3  # a lobe wide enough to be seen under a sun of angle 0


def assert_matches(image, expected, mask, tolerance=TOLERANCE):
    assert mask.sum() > 200, "the check must cover the lit part of the sphere"
    assert np.isfinite(image).all()
    error = np.abs(image[..., :3] - expected)[mask]
    scale = max(float(expected[mask].max()), 1e-6)
    assert error.max() <= tolerance * scale, f"max error {error.max():.3g} vs scale {scale:.3g}"


class LitSphere:
    """A sphere under one sun, its shading normals read from a probe render."""

    def __init__(self, scene, towards=(0.5, 0.3, 0.8), size=48, samples=1, eevee=False):
        self.scene = scene
        self.sphere = studio.add_sphere(scene)
        self.sun = studio.add_sun(scene, towards)
        studio.add_ortho_camera(scene)
        if eevee:
            render.use_eevee(scene, size=size, samples=samples)
        else:
            render.use_cycles(scene, size=size, samples=samples)
        self.normals = self.probe_normals()

    def render(self, material):
        studio.assign(self.sphere, material)
        return render.render_array(self.scene)

    def probe_normals(self):
        """(H, W, 3) unit shading normals and an (H, W) mask of the covered pixels."""
        probe = self.render(studio.normal_probe())
        self.covered = probe[..., 3] > 0.999
        normals = probe[..., :3] * 2.0 - 1.0
        return normals / np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-9)

    def cosines(self):
        """(N.S, N.V) per pixel for the current sun direction."""
        towards = np.array(self.sun.matrix_world.to_3x3().col[2])
        return self.normals @ towards, self.normals @ np.array(studio.VIEW_DIRECTION)

    def lobes(self, roughness):
        """Renders of the white Lambert lobe D and the white GGX lobe G."""
        diffuse = self.render(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0, roughness=roughness))
        glossy = self.render(pw.make_base_material("G", base_color=(0, 0, 0), ks=1.0, roughness=roughness))
        return diffuse[..., :3], glossy[..., :3]

    def expected(self, kd, ks, m, alpha, sp, ambient=False):
        """The porous image model.py predicts, and the mask of lit, covered pixels."""
        n_dot_l, n_dot_v = self.cosines()
        diffuse, glossy = self.lobes(m)
        kd_poro, ks_poro = model.porous_coefficients(kd, ks, m, alpha, sp, None if ambient else n_dot_l, n_dot_v)
        image = kd_poro * diffuse + np.asarray(ks_poro)[..., None] * glossy
        return image, self.covered & (n_dot_l > 0.0)


class MaskedPlane:
    """A plane facing +Z under a tilted sun, its masks varying across it."""

    def __init__(self, scene, size=32):
        self.scene = scene
        self.plane = studio.add_plane(scene)
        self.sun = studio.add_sun(scene, (0.5, 0.3, 0.8))
        studio.add_ortho_camera(scene)
        render.use_cycles(scene, size=size, samples=1)

    def render(self, material):
        studio.assign(self.plane, material)
        return render.render_array(self.scene)

    def probe(self, source):
        """Per-pixel values of a mask source, read through the same nodes the material uses."""
        probe = studio.emission_probe("Mask Probe", lambda graph, geometry: weathering.mask_socket(graph, source))
        return self.render(probe)[..., 0]


def weathered(name, modes, key_light=None, **state):
    return pw.make_weathered_material(
        name, modes=modes, key_light=key_light, water_roughness=WATER_ROUGHNESS, **STONE, **state
    )


def lobes(render_with, roughness):
    """White Lambert, white GGX at the stone's roughness and at the water's."""
    diffuse = render_with(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0, roughness=roughness))
    glossy = render_with(pw.make_base_material("G", base_color=(0, 0, 0), ks=1.0, roughness=roughness))
    water = render_with(pw.make_base_material("W", base_color=(0, 0, 0), ks=1.0, roughness=WATER_ROUGHNESS))
    return diffuse[..., :3], glossy[..., :3], water[..., :3]


def expected_image(weights, lobe_images):
    kd_w, ks_w, water_w = weights
    diffuse, glossy, water = lobe_images
    return kd_w * diffuse + np.asarray(ks_w)[..., None] * glossy + water_w * water


def model_weights(modes, n_dot_l, n_dot_v, **state):
    p = STONE
    return model.weathered_coefficients(
        p["base_color"], p["ks"], p["roughness"], p["porosity"], p["pore_depth_ratio"], n_dot_l, n_dot_v, modes, **state
    )


#: The layers beyond the paper (SPEC 6): the black crust and the wet darkening.
BEYOND_PAPER = (soiling.lay_crust, wet.darken_under_water)


@contextlib.contextmanager
def paper_modes(names):
    """Registers, for the block, each mode of ``names`` as the paper writes it: its own record
    without the layers beyond the paper, named "paper_<mode>". Yields those names."""
    records = [
        dataclasses.replace(
            weathering_modes.get(name),
            name=f"paper_{name}",
            layers=tuple(layer for layer in weathering_modes.get(name).layers if layer.apply not in BEYOND_PAPER),
        )
        for name in names
    ]
    for record in records:
        weathering_modes.register(record)
    try:
        yield tuple(record.name for record in records)
    finally:
        for record in records:
            weathering_modes.unregister(record.name)
