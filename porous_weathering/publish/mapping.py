"""The PBR mapping (docs/export.md, "The mapping"): the porous weights of a texel as glTF's
metallic-roughness material with ``KHR_materials_specular`` (``pbr_from_weights``), the sRGB
transfer function of the base colour textures, and the 8-bit codes a texture file holds.

Plain numpy, no bpy: importable (and testable) outside Blender.
"""

import numpy as np
from numpy.typing import ArrayLike

from ..core.colorimetry import linear_to_srgb  # noqa: F401  (the base colour textures' transfer function)

#: glTF's dielectric F0 at specular 1 (IOR 1.5). A specular colour factor of 1 / F0 makes
#: F0 = F90 = specularFactor: a reflectance without Fresnel rise, as the porous glossy lobe.
DIELECTRIC_F0 = 0.04
SPECULAR_COLOR_FACTOR = 1.0 / DIELECTRIC_F0


def pbr_from_weights(
    kd: np.ndarray, ks: np.ndarray, water: np.ndarray, m: ArrayLike, water_roughness: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The glTF material of the porous weights (docs/export.md, "The mapping"), per texel:
    ``(base colour (..., 3), specular S (...), roughness (...))`` for metallic 0, a specular
    colour factor of 1 / 0.04 and a specular factor S (so F0 = F90 = S).

    ``kd`` (..., 3) is k_d, ``ks`` (...) k_s, ``water`` (..., 3) the water lobe's weight, ``m``
    the stone's roughness and ``water_roughness`` the water lobe's (Blender's and glTF's
    roughness are both perceptual: alpha = roughness²). One glossy lobe carries both:
    S = k_s + mean(water), of alpha the mean of the two alphas weighted by the lobes' weights
    squared; the base colour is k_d / (1 - S), as glTF weights the diffuse by 1 - F."""
    dtype = np.result_type(np.asarray(kd).dtype, np.float32)  # float32 textures stay float32
    kd = np.clip(np.asarray(kd, dtype=dtype), 0.0, 1.0)
    ks = np.clip(np.asarray(ks, dtype=dtype), 0.0, 1.0)
    water = np.clip(np.asarray(water, dtype=dtype), 0.0, 1.0).mean(axis=-1)
    specular = np.minimum(ks + water, 1.0)
    tiny = np.finfo(dtype).tiny
    base = np.minimum(kd / np.maximum(1.0 - specular, tiny)[..., None], 1.0)
    alpha_stone = np.clip(np.asarray(m, dtype=dtype), 0.0, 1.0) ** 2
    alpha_water = np.clip(np.asarray(water_roughness, dtype=dtype), 0.0, 1.0) ** 2
    # each lobe's error grows with its weight: weighted by the weights squared, the heavier lobe sets the shape
    squares = ks**2 + water**2
    alpha = np.where(
        squares > 0.0, (ks**2 * alpha_stone + water**2 * alpha_water) / np.maximum(squares, tiny), alpha_stone
    )
    return base, specular, np.sqrt(alpha)


def texel_codes(values: np.ndarray, covered: np.ndarray) -> np.ndarray:
    """8-bit codes (H, W, C) of values in [0, 1]; texels outside the UV islands take the
    covered texels' mean (no seam colour bleeds into mipmaps, and the file compresses well)."""
    codes = np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)
    if not covered.all():
        codes[~covered] = np.round(codes[covered].mean(axis=0)).astype(np.uint8)
    return codes


def is_uniform(codes: np.ndarray, covered: np.ndarray) -> bool:
    """Whether every covered texel has the same code, within one step (the bake's rounding)."""
    inside = codes[covered].astype(np.int16)
    return bool((inside.max(axis=0) - inside.min(axis=0)).max() <= 1)
