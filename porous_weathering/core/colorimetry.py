"""Colour as conservation surveys measure it: sRGB and CIE L*a*b* (D65) against the linear RGB the
shaders take, the CIEDE2000 colour difference, and the inverse of the soiling model
(docs/model.md §4.1, §6.1): the stone, deposit and pollution colours and the crust coverage that
reproduce a measured clean, grey-soiled and black-crusted stone at t = 1, face on, under ambient
light (docs/presets.md, "From measured colours")."""

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from . import model

#: Linear sRGB (Rec. 709 primaries) to CIE XYZ, D65 white (IEC 61966-2-1).
RGB_TO_XYZ = np.array(
    [
        [0.4124564, 0.3575761, 0.1804375],
        [0.2126729, 0.7151522, 0.0721750],
        [0.0193339, 0.1191920, 0.9503041],
    ]
)
#: The D65 white point's XYZ: the white that RGB (1, 1, 1) maps to.
D65_WHITE = RGB_TO_XYZ.sum(axis=1)
_EPSILON, _KAPPA = 216.0 / 24389.0, 24389.0 / 27.0  # CIE's exact constants of L*


def srgb_to_linear(values: ArrayLike) -> np.ndarray:
    """The inverse sRGB transfer function (IEC 61966-2-1) of encoded values in [0, 1]."""
    values = np.asarray(values, dtype=np.float64)
    return np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(values: ArrayLike) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of linear values in [0, 1]."""
    values = np.clip(np.asarray(values, dtype=np.result_type(np.asarray(values).dtype, np.float32)), 0.0, 1.0)
    return np.where(values <= 0.0031308, values * 12.92, 1.055 * np.power(values, 1.0 / 2.4) - 0.055)


def linear_to_lab(rgb: ArrayLike) -> np.ndarray:
    """CIE L*a*b* (D65) of linear sRGB colours (last axis RGB)."""
    xyz = np.asarray(rgb, dtype=np.float64) @ RGB_TO_XYZ.T / D65_WHITE
    f = np.where(xyz > _EPSILON, np.cbrt(xyz), (_KAPPA * xyz + 16.0) / 116.0)
    return np.stack([116.0 * f[..., 1] - 16.0, 500.0 * (f[..., 0] - f[..., 1]), 200.0 * (f[..., 1] - f[..., 2])], -1)


def lab_to_linear(lab: ArrayLike) -> np.ndarray:
    """Linear sRGB of CIE L*a*b* (D65) colours; outside the sRGB gamut some channel is < 0 or > 1."""
    lab = np.asarray(lab, dtype=np.float64)
    fy = (lab[..., 0] + 16.0) / 116.0
    f = np.stack([fy + lab[..., 1] / 500.0, fy, fy - lab[..., 2] / 200.0], -1)
    xyz = np.where(f**3 > _EPSILON, f**3, (116.0 * f - 16.0) / _KAPPA) * D65_WHITE
    return xyz @ np.linalg.inv(RGB_TO_XYZ).T


#: 180° for the mean hue's case split, with room for rounding: hues exactly opposite (Sharma et al.'s
#: pairs 13-15) must not fall either side of it by the last bit of a float, which varies by platform.
_HALF_TURN = 180.0 + 1e-9


def delta_e_2000(lab1: ArrayLike, lab2: ArrayLike) -> np.ndarray:
    """CIEDE2000 colour difference (k_L = k_C = k_H = 1), as Sharma, Wu & Dalal write it ("The
    CIEDE2000 color-difference formula: implementation notes, supplementary test data, and
    mathematical observations", Color Res. Appl. 30(1), 21-30, 2005); tests/test_colorimetry.py
    holds it to their 34 test pairs."""
    L1, a1, b1 = np.moveaxis(np.asarray(lab1, dtype=np.float64), -1, 0)
    L2, a2, b2 = np.moveaxis(np.asarray(lab2, dtype=np.float64), -1, 0)
    c_mean7 = ((np.hypot(a1, b1) + np.hypot(a2, b2)) / 2.0) ** 7
    g = 0.5 * (1.0 - np.sqrt(c_mean7 / (c_mean7 + 25.0**7)))
    a1, a2 = a1 * (1.0 + g), a2 * (1.0 + g)
    c1, c2 = np.hypot(a1, b1), np.hypot(a2, b2)
    h1, h2 = np.degrees(np.arctan2(b1, a1)) % 360.0, np.degrees(np.arctan2(b2, a2)) % 360.0
    chromatic = c1 * c2 != 0.0  # a neutral colour has no hue: its hue difference is 0
    dh = np.where(chromatic, (h2 - h1 + 180.0) % 360.0 - 180.0, 0.0)
    dL, dC = L2 - L1, c2 - c1
    dH = 2.0 * np.sqrt(c1 * c2) * np.sin(np.radians(dh / 2.0))
    L_mean, c_mean = (L1 + L2) / 2.0, (c1 + c2) / 2.0
    h_sum = h1 + h2
    h_mean = np.where(
        np.abs(h1 - h2) <= _HALF_TURN, h_sum / 2.0, np.where(h_sum < 360.0, h_sum + 360.0, h_sum - 360.0) / 2.0
    )
    h_mean = np.where(chromatic, h_mean, h_sum)
    t = (
        1.0
        - 0.17 * np.cos(np.radians(h_mean - 30.0))
        + 0.24 * np.cos(np.radians(2.0 * h_mean))
        + 0.32 * np.cos(np.radians(3.0 * h_mean + 6.0))
        - 0.20 * np.cos(np.radians(4.0 * h_mean - 63.0))
    )
    s_l = 1.0 + 0.015 * (L_mean - 50.0) ** 2 / np.sqrt(20.0 + (L_mean - 50.0) ** 2)
    s_c = 1.0 + 0.045 * c_mean
    s_h = 1.0 + 0.015 * c_mean * t
    c_mean7 = c_mean**7
    r_t = (
        -2.0
        * np.sqrt(c_mean7 / (c_mean7 + 25.0**7))
        * np.sin(np.radians(60.0 * np.exp(-(((h_mean - 275.0) / 25.0) ** 2))))
    )
    return np.sqrt((dL / s_l) ** 2 + (dC / s_c) ** 2 + (dH / s_h) ** 2 + r_t * (dC / s_c) * (dH / s_h))


# === The soiling model inverted ====================================================================

#: The three points a survey measures, as the soiling model's masks set them at t = 1: the clean
#: stone where rain washes it, the grey deposit where it is sheltered off the edges (C = 0: no carbon),
#: the black crust where it is sheltered at the highest edge mask (C = 1: pores full, crust complete).
SURVEY_POINTS = {
    "clean": dict(rain_map=1.0, edge_map=0.0),
    "soiled": dict(rain_map=0.0, edge_map=0.0),
    "crust": dict(rain_map=0.0, edge_map=1.0),
}

#: The inputs the inversion holds at their defaults: the fronts and levels say where and when, not
#: what colour; no run-off (no streaks).
_FIXED = dict(time=1.0, soiling_level=1.0, runoff_map=0.0)


def appearance(stone: Mapping, point: str, **inputs) -> np.ndarray:
    """The linear RGB a colorimeter would read on the soiling model's ``point`` (``SURVEY_POINTS``)
    of ``stone`` (kd, ks, m, alpha, sp) at t = 1, face on (N.V = 1), in ambient light: the diffuse
    weight plus the glossy weight (a white surrounding, specular included as a d/8 instrument
    measures it)."""
    kd_w, ks_w, _ = model.weathered_coefficients(
        stone["kd"],
        stone["ks"],
        stone["m"],
        stone["alpha"],
        stone["sp"],
        None,
        1.0,
        (model.SOILING,),
        **{**_FIXED, **SURVEY_POINTS[point], **inputs},
    )
    return kd_w + np.asarray(ks_w)[..., None]


def _affine(colour_of, target):
    """x in [0, 1]^3 with colour_of(x) = target, for a colour affine in x per channel."""
    at0, at1 = colour_of(np.zeros(3)), colour_of(np.ones(3))
    return (target - at0) / (at1 - at0)


def invert(
    clean: ArrayLike, soiled: ArrayLike, crust: ArrayLike, stone: Mapping, crust_coverage: float
) -> dict[str, np.ndarray | float]:
    """{"kd", "deposit_color", "pollution_color", "crust"}: what makes the model (``appearance``)
    give the linear RGB colours ``clean``, ``soiled`` and ``crust``, for a stone of ``stone``'s
    ks, m, alpha, sp.  The crust covers ``crust_coverage`` of the black point unless the crust is
    too dark for it (then more, up to 1).  ValueError, saying which colour, when no
    setting reproduces them."""
    clean, soiled, crust = (np.asarray(colour, dtype=np.float64) for colour in (clean, soiled, crust))
    lightness = {
        name: linear_to_lab(colour)[0] for name, colour in (("clean", clean), ("soiled", soiled), ("crust", crust))
    }
    if not lightness["crust"] < lightness["soiled"] < lightness["clean"]:
        raise ValueError(
            "the colours must darken from the clean stone to the soiled one to the crust: L* "
            + ", ".join(f"{name} {value:.1f}" for name, value in lightness.items())
        )
    kd = _clean_albedo(clean, stone)
    stone = {**stone, "kd": kd}
    deposit = _affine(lambda x: appearance(stone, "soiled", deposit_color=x), soiled)
    if np.any(deposit < -1e-9) or np.any(deposit > 1.0 + 1e-9):
        reach = [linear_to_lab(appearance(stone, "soiled", deposit_color=np.full(3, v)))[0] for v in (0.0, 1.0)]
        raise ValueError(
            f"the soiled stone (L* {linear_to_lab(soiled)[0]:.1f}) is out of what a grey deposit makes of this "
            f"stone at t = 1 (L* {reach[0]:.1f} to {reach[1]:.1f}): measure the grey, sheltered stone, not the crust"
        )
    stone_inputs = dict(deposit_color=np.clip(deposit, 0.0, 1.0))

    def pollution_at(coverage):
        return _affine(lambda x: appearance(stone, "crust", **stone_inputs, pollution_color=x, crust=coverage), crust)

    coverage = float(np.clip(crust_coverage, 0.0, 1.0))
    if pollution_at(coverage).min() < 0.0:  # darker than this coverage allows: more crust (1 reaches black)
        coverage = _bisect(lambda c: pollution_at(c).min() >= 0.0, coverage, 1.0)
    if pollution_at(coverage).max() > 1.0 + 1e-9:
        raise ValueError(
            f"the crust (L* {linear_to_lab(crust)[0]:.1f}) is lighter than a crust can make this stone under its "
            "grey deposit: measure the black crust where it is thickest"
        )
    pollution = np.clip(pollution_at(coverage), 0.0, 1.0)
    return dict(kd=kd, deposit_color=stone_inputs["deposit_color"], pollution_color=pollution, crust=coverage)


def _clean_albedo(clean, stone):
    """k_d whose clean porous colour (washed, t = 1) is ``clean``: bisection per channel (the colour
    rises with k_d in every channel); ValueError if ``clean`` is out of what k_d in [0, 1 - k_s] gives."""
    low, high = np.zeros(3), np.full(3, 1.0 - float(stone["ks"]))
    reach = [appearance({**stone, "kd": kd}, "clean") for kd in (low, high)]
    if np.any(clean < reach[0] - 1e-9) or np.any(clean > reach[1] + 1e-9):
        raise ValueError(
            f"the clean stone (L* {linear_to_lab(clean)[0]:.1f}) is out of what this stone's k_s and pores give "
            f"(L* {linear_to_lab(reach[0])[0]:.1f} to {linear_to_lab(reach[1])[0]:.1f} per channel)"
        )
    for _ in range(60):
        middle = (low + high) / 2.0
        below = appearance({**stone, "kd": middle}, "clean") < clean
        low, high = np.where(below, middle, low), np.where(below, high, middle)
    return (low + high) / 2.0


def _bisect(holds, failing: float, passing: float) -> float:
    """The value nearest ``failing`` on the way to ``passing`` at which ``holds`` becomes true."""
    for _ in range(60):
        middle = (failing + passing) / 2.0
        failing, passing = (failing, middle) if holds(middle) else (middle, passing)
    return passing


def measured_linear(colour: Sequence[float] | str, space: str) -> np.ndarray:
    """A measured colour as linear RGB: a "#RRGGBB" string is sRGB; a tuple of three floats is
    CIE L*a*b* (D65) for ``space="lab"`` or sRGB in [0, 1] for ``space="srgb"``.  ValueError for a
    colour outside the sRGB gamut or a malformed value."""
    if isinstance(colour, str):
        text = colour.removeprefix("#")
        if len(text) != 6:
            raise ValueError(f"colour {colour!r}: a hex colour is '#RRGGBB'")
        try:
            colour, space = [int(text[i : i + 2], 16) / 255.0 for i in (0, 2, 4)], "srgb"
        except ValueError:
            raise ValueError(f"colour {colour!r}: a hex colour is '#RRGGBB'") from None
    values = np.asarray(colour, dtype=np.float64)
    if values.shape != (3,) or not np.isfinite(values).all():
        raise ValueError(f"colour {colour!r}: give three finite numbers (L*, a*, b*) or an sRGB triple")
    if space == "srgb":
        if values.min() < 0.0 or values.max() > 1.0:
            raise ValueError(f"sRGB colour {colour!r}: components are in [0, 1] (divide 0-255 values by 255)")
        return srgb_to_linear(values)
    if space != "lab":
        raise ValueError(f"space {space!r}: 'lab' (CIE L*a*b*, D65) or 'srgb'")
    if not 0.0 <= values[0] <= 100.0:
        raise ValueError(f"L*a*b* colour {colour!r}: L* is in [0, 100]")
    linear = lab_to_linear(values)
    if linear.min() < -1e-3 or linear.max() > 1.0 + 1e-3:
        raise ValueError(f"L*a*b* colour {colour!r} is outside the sRGB gamut the shaders render")
    return np.clip(linear, 0.0, 1.0)
