"""The lit-sphere harness: a porous render checked pixel by pixel against model.py.

A porous pixel must equal k_d,poro * D + k_s,poro * G, where D and G are renders of a
white Lambert and a white GGX lobe of the same roughness under the same light, and the
weights come from model.py at that pixel's shading normal (read from a probe render).
"""

import numpy as np

import porous_weathering as pw
from porous_weathering import model, render, studio


class LitSphere:
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
