"""Efflorescence (docs/model.md §4, section 4.3 of the paper): salt fills the pores where a location
map (a height field from a photograph, or generated; without one, the water the stone absorbs,
docs/model.md §7.2) is highest first, and at the tide mark of rising damp, where the water drawn up
from the ground evaporates (docs/model.md §9.2; no damp map: the location map alone)."""

from ..patterns import NSD, Pattern, shown
from ..rising_damp import tide_mark
from .base import (
    DAMP_MAP,
    FILL_SALT,
    FRONT_WIDTH,
    TIME,
    Input,
    Layer,
    Mode,
    blend,
    filled_absorption,
    local_share,
    pore_fill,
)

EFFLORESCENCE_MAP = Input(
    "efflorescence_map",
    0.0,
    0.0,
    1.0,
    "Efflorescence location: salt fills the pores from the highest value down",
    mask=True,
    map="efflorescence",
    fallback_map="runoff",  # the absorbed water: salts come out where water soaks in (docs/model.md §7.2)
)
EFFLORESCENCE_LEVEL = Input(
    "efflorescence_level", 1.0, 0.0, 1.0, "How far down the location map the salt reaches at t = 1"
)
SALT_COLOR = Input("salt_color", (0.8, 0.8, 0.8), 0.0, 1.0, "k_d,efflo_salt: the salt's diffuse colour (about 0.8)")


def efflorescence_diffuse(xp, kd, salt_color, pore, ap, ks_poro):
    """k_d,efflo, eq. (11), k_d (1 - alpha G_p A_p) + k_d,salt alpha G_p (1 - A_p), capped at
    1 - k_s,poro: eq. (11) alone reflects more light than arrives on bright stone (k_d + k_s
    near 1), which must not happen.  Eq. (11) is a Mix by alpha G_p of k_d and
    (k_d + k_d,salt)(1 - A_p)."""
    return xp.minimum(xp.mix(pore, kd, (kd + salt_color) * (1.0 - ap)), 1.0 - ks_poro)


def salt_location(xp, efflorescence_map, damp_map):
    """Where salt fills the pores first: the location map or the tide mark of rising damp,
    max(location, 4 D (1 - D)) (docs/model.md §9.2); the location map bit for bit at D = 0."""
    return xp.maximum(efflorescence_map, tide_mark(xp, damp_map))


def fill_with_salt(xp, point):
    s = point.state
    location = salt_location(xp, s["efflorescence_map"], s["damp_map"])
    salt = local_share(xp, pore_fill(xp, location, s["time"], s["efflorescence_level"], s["front_width"]), point.spread)
    ap = filled_absorption(xp, point.ka, point.sp, salt, point.theta_i, point.theta_r)
    salty = efflorescence_diffuse(xp, point.kd, s["salt_color"], point.pore, ap, xp.channel(point.ks_w))
    point.kd_w = blend(xp, point.kd_w, salty, xp.channel(salt))
    point.notes["salt"] = salt


EFFLORESCENCE = Pattern(
    "efflorescence",
    NSD + "Efflorescence",
    (0.93, 0.55, 0.80),
    "cross",
    shown("salt"),
    20,
    "salt fills half the pores or more (fill >= 0.5)",
)


MODE = Mode(
    name="efflorescence",
    label="Efflorescence",
    description="Salt fills the pores where the location map is highest first",
    inputs=(TIME, FRONT_WIDTH, EFFLORESCENCE_MAP, DAMP_MAP, EFFLORESCENCE_LEVEL, SALT_COLOR),
    layers=(Layer(FILL_SALT, fill_with_salt),),
    catalog="Efflorescence",
    asset_summary="Efflorescence: salt fills the pores where the location map is highest first",
    preview=dict(time=1.0, efflorescence_map=1.0),
    order=30,
    patterns=(EFFLORESCENCE,),
)
