"""Wet surfaces (SPEC 4, section 4.2 of the paper): water fills the pores where the rain map
is highest first, and a near-mirror water lobe of its own reflects the sky."""

from .base import FILL_WATER, FRONT_WIDTH, RAIN_MAP, TIME, Input, Layer, Mode, blend, filled_absorption, pore_fill

WET_LEVEL = Input(
    "wet_level", 1.0, 0.0, 1.0, "How far down the rain map the wet area reaches at t = 1 (lower it to dry)"
)
WATER_SPECULAR = Input("water_specular", 1.0, 0.0, 1.0, "k_s,water: the water lobe's weight (about 1)")


def wet_weights(kd, water_specular, pore, ap):
    """(k_d,wet, water-lobe weight): eq. (9), and eq. (8) less its k_s (1 - alpha G_p) part,
    which is k_s,poro and stays on the stone's own glossy lobe."""
    return kd * (1.0 - pore), water_specular * pore * (1.0 - ap)


def fill_with_water(xp, point):
    s = point.state
    water = pore_fill(xp, s["rain_map"], s["time"], s["wet_level"], s["front_width"])
    ap = filled_absorption(xp, point.ka, point.sp, water, point.theta_i, point.theta_r)
    kd_wet, water_lobe = wet_weights(point.kd, xp.channel(s["water_specular"]), point.pore, ap)
    point.kd_w = blend(point.kd_w, kd_wet, xp.channel(water))
    point.water_w = xp.channel(water) * water_lobe


MODE = Mode(
    name="wet",
    label="Wet",
    description="Rain fills the pores with water where the rain map is highest first",
    inputs=(TIME, FRONT_WIDTH, RAIN_MAP, WET_LEVEL, WATER_SPECULAR),
    layers=(Layer(FILL_WATER, fill_with_water),),
    catalog="Wet Surfaces",
    asset_summary="Wet surface: water fills the pores where the rain map is highest first",
    preview=dict(time=1.0, rain_map=1.0),
    water_lobe=True,
)
