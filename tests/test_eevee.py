"""One EEVEE scene: the same porous group, rasterised (docs/model.md §2 in EEVEE's own lobes)."""

import numpy as np
import pytest

from benchmarks.scenes import porous_material
from helpers import LitSphere

pytestmark = pytest.mark.eevee

#: EEVEE's lobes differ from Cycles' (shadow maps, LTC glossy), but it weights its closures
#: linearly: a porous pixel is k_d,poro D + k_s,poro G of EEVEE's own white-lobe renders.
TOLERANCE = 0.01


def test_eevee_porous_sphere_matches_model(fresh_scene):
    params = dict(kd=(0.62, 0.55, 0.45), ks=0.2, m=0.4, alpha=0.35, sp=2.5)
    sphere = LitSphere(fresh_scene, size=32, samples=1, eevee=True)
    image = sphere.render(porous_material(params, sphere.sun))
    expected, mask = sphere.expected(**params)
    assert mask.sum() > 100 and np.isfinite(image).all()
    error = np.abs(image[..., :3] - expected)[mask]
    assert error.max() <= TOLERANCE * expected[mask].max(), error.max()
