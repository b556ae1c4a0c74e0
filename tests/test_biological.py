"""The biological mode's model (docs/model.md §9.3, §9.4), in numpy: level 0 is the material without
life bit for bit; the algal film greens first (b* before a*) and darkens later; the lichens' cover
follows the Boolean model where it applies; north faces green more than south ones, washed sunny
tops least, and a city far less than the country.  The render is checked per pixel in
tests/test_weathering_render.py."""

import math

import numpy as np
import pytest

from benchmarks.lichen_cover import cover, limestone_spread, voronoi_seeds
from porous_weathering.core import aging, colorimetry, environments, model
from porous_weathering.core.backends import NumpyOps
from porous_weathering.core.modes import biological
from porous_weathering.shading.presets import PRESETS

XP = NumpyOps(colour=False)
LIMESTONE = PRESETS["LIMESTONE"]
STONE = (
    LIMESTONE.linear_base_color()[:3],
    LIMESTONE.ks,
    LIMESTONE.roughness,
    LIMESTONE.porosity,
    LIMESTONE.pore_depth_ratio,
)

#: Faces of a cube in the open at 50° N (docs/model.md §9.1's sun exposures): the top under rain, walls
#: that rain wets a little (wind-driven), none with run-off or rising damp.
FACES = {
    "north": dict(sun_map=0.02, rain_map=0.1),
    "south": dict(sun_map=0.46, rain_map=0.1),
    "top": dict(sun_map=0.51, rain_map=1.0),
}


def seen(years, environment=None, fields=None, **inputs):
    """The linear RGB a colorimeter reads (diffuse plus glossy weight, face on, ambient light) after
    ``years`` in ``environment`` (its inputs; None: the plain defaults)."""
    site = environments.weathering_inputs(environment, ("biological",)) if environment else {}
    kd_w, ks_w, _ = model.weathered_coefficients(
        *STONE,
        None,
        1.0,
        ("biological",),
        fields=fields,
        **{**site, "biological_years": years, "runoff_map": 0.0, **inputs},
    )
    return kd_w + np.asarray(ks_w)[..., None]


def lab(rgb):
    return colorimetry.linear_to_lab(rgb)


def test_the_colours_are_those_documented():
    for item, documented in (
        (biological.ALGAE_COLOR, (52, -12, 30)),
        (biological.BIOFILM_COLOR, (30, -4, 8)),
        (biological.LICHEN_COLOR, (65, 15, 55)),
        (biological.LICHEN_GREY_COLOR, (65, -3, 12)),
    ):
        assert lab(item.default) == pytest.approx(documented, abs=0.3), item.name


def test_level_zero_and_year_zero_are_the_material_without_life_bit_for_bit():
    rng = np.random.default_rng(3)
    shape = (500,)
    n_dot_l, n_dot_v = rng.random(shape), rng.random(shape)
    maps = {name: rng.random(shape) for name in ("rain_map", "runoff_map", "damp_map", "sun_map")}
    seeds = {biological.LICHEN_SEEDS: tuple(rng.random((6, *shape)) * np.array((0.8, 1.0, 1.0) * 2)[:, None])}
    clean = model.porous_coefficients(*STONE, n_dot_l, n_dot_v)
    for state in (dict(biological_level=0.0, biological_years=40.0), dict(biological_years=0.0)):
        kd_w, ks_w, water = model.weathered_coefficients(
            *STONE, n_dot_l, n_dot_v, ("biological",), fields=seeds, **maps, **state
        )
        assert np.array_equal(kd_w, clean[0]) and np.array_equal(ks_w, clean[1]) and not water.any()
    aged = model.weathered_coefficients(*STONE, n_dot_l, n_dot_v, ("biological",), fields=seeds, **maps)
    assert np.abs(aged[0] - clean[0]).max() == 0.0  # the defaults: years 0
    grown = model.weathered_coefficients(
        *STONE, n_dot_l, n_dot_v, ("biological",), fields=seeds, biological_years=20.0, **maps
    )
    assert np.abs(grown[0] - clean[0]).max() > 0.05  # the comparison can tell them apart


def test_green_first_then_dark():
    """On a damp north face b* moves perceptibly (0.59: Sanmartín et al. 2012) before a* does, and
    the film keeps darkening long after it has greened (ΔL* between 2 and 20 years)."""
    clean = lab(seen(0.0, **FACES["north"]))
    years = np.linspace(0.0, 2.0, 2001)
    change = lab(np.stack([seen(y, **FACES["north"]) for y in years])) - clean
    first_b = years[np.argmax(np.abs(change[:, 2]) >= 0.59)]
    first_a = years[np.argmax(np.abs(change[:, 1]) >= 0.59)]
    assert change[-1, 2] > 0.59 and change[-1, 1] < -0.59  # both do move: yellower, then greener
    assert 0.0 < first_b < first_a < 1.0  # b* first; visible within the first year
    ab_at_2, ab_at_20 = (lab(seen(y, **FACES["north"])) for y in (2.0, 20.0))
    assert ab_at_20[0] < ab_at_2[0] - 5.0  # darker by far at 20 years
    assert np.hypot(*(ab_at_20[1:] - clean[1:])) < np.hypot(*(ab_at_2[1:] - clean[1:]))  # greyer: dark biofilm


def test_north_greener_than_south_and_washed_tops_least_in_the_country():
    """RURAL at 50° N after 20 years: north differs from south by ΔE*ab >= 3.2 (clearly visible:
    Sanmartín et al. 2012), with a lower a*; the washed, sunny top carries the least algae."""
    faces = {name: lab(seen(20.0, "RURAL", **face)) for name, face in FACES.items()}
    assert np.linalg.norm(faces["north"] - faces["south"]) >= 3.2
    assert faces["north"][1] < faces["south"][1]
    site = environments.weathering_inputs("RURAL", ("biological",))
    biomass = {
        name: biological.algal_biomass(
            XP, model.weathering_state("biological", dict(site, biological_years=20.0, **face)), 1.0
        )
        for name, face in FACES.items()
    }
    assert biomass["top"] < biomass["south"] < biomass["north"]


def test_life_is_at_most_half_as_strong_in_the_city():
    """The colour change life makes on a north face after 20 years: URBAN at most half RURAL's."""
    clean = lab(seen(0.0, **FACES["north"]))
    change = {site: np.linalg.norm(lab(seen(20.0, site, **FACES["north"])) - clean) for site in ("URBAN", "RURAL")}
    assert change["URBAN"] <= 0.5 * change["RURAL"]
    assert change["RURAL"] > 3.2


def test_lichen_cover_follows_the_boolean_model():
    """Seeds one per cell, drawn in numpy as Blender's Voronoi draws them, each thallus its own size
    and seen from the two nearest seeds: at full suitability the mean cover is 1 - exp(-lambda pi r^2)
    within 0.03 up to lambda pi r^2 = 4 (the crowded radius; 0.035 with this smaller draw's scatter);
    where only a share L of the seeds establish, within 0.03 while the cover stays under 0.3
    (docs/model.md §9.3), beyond which the cover stays under the law's."""
    seeds = voronoi_seeds(cells=200, points=50_000)
    for u in (0.05, 0.2, 0.5, 1.0, 2.0, 4.0):
        assert cover(seeds, u) == pytest.approx(1.0 - math.exp(-u), abs=0.035), u
    for u in (0.1, 0.3, 1.0):
        assert cover(seeds, u, 0.5) == pytest.approx(1.0 - math.exp(-0.5 * u), abs=0.03), u
    assert cover(seeds, 4.0, 0.5) < 1.0 - math.exp(-2.0) - 0.1
    # without the crowded radius the one-seed-per-cell cover is far above the law at u = 1
    assert np.mean(seeds[0] < math.sqrt(1.0 / math.pi)) > (1.0 - math.exp(-1.0)) + 0.08


def test_lichen_cover_on_a_stone_stays_near_the_boolean_model():
    """On the limestone each point's thalli reach by its uptake (docs/model.md §9.3, REACH_SPREAD):
    the mean cover stays within 0.03 of the Boolean law up to lambda pi r^2 = 2 (0.035 with this
    smaller draw's scatter), a little below it as the thalli crowd (Jensen's inequality)."""
    seeds = voronoi_seeds(cells=200, points=50_000)
    spread = limestone_spread(len(seeds[0]))
    for u in (0.2, 0.5, 1.0, 2.0):
        assert cover(seeds, u, spread=spread) == pytest.approx(1.0 - math.exp(-u), abs=0.035), u
    assert cover(seeds, 2.0, spread=spread) < cover(seeds, 2.0) - 0.01


def test_each_thallus_grows_to_its_own_size():
    """A thallus's radius is the crowded r(years) times its seed's own factor, uniform over 0.48-1.44
    and of mean square 1 (docs/model.md §9.3): read from the cover around established seeds of every
    size draw, the radii span that range and their mean square is the crowded radius's square."""
    state = model.weathering_state(
        "biological",
        dict(sun_map=0.5, rain_map=1.0, runoff_map=0.0, biological_years=21.5, lichen_growth=10.0, lichen_density=1.0),
    )
    radius = float(biological.lichen_radius(XP, state))  # 0.1 m, against a rim of 0.3 mm; the cells are 1 m
    crowded = radius / math.sqrt(1.0 + biological.CROWDING * math.pi * radius**2)
    distances = np.linspace(0.0, 0.25, 50_001)  # metres = cells here
    sizes = np.linspace(0.0, 1.0, 101)
    far = np.full((101, 1), 1e9)
    seeds = (distances[None, :], np.zeros((101, 1)), sizes[:, None], far, np.ones((101, 1)), sizes[:, None])
    inside = biological.lichen_cover(XP, state, seeds) > 0.5
    drawn = (distances[inside.sum(axis=1) - 1] + 0.5 * biological.LICHEN_RIM) / crowded  # where its rim is half way
    assert drawn[0] == pytest.approx(0.4804, abs=2e-4) and drawn[-1] == pytest.approx(1.4412, abs=2e-4)
    assert np.all(np.diff(drawn) > 0.0)
    assert np.mean(drawn**2) == pytest.approx(1.0, abs=0.01)


def test_a_thallus_reaches_past_a_nearer_seed():
    """A point nearer to a seed that has not established, or whose thallus is small, is still in the
    second nearest seed's thallus when within its radius (docs/model.md §9.3: the thalli stay round,
    not cut at their cells' edges); the nearest seed's thallus lies over the other's."""
    state = model.weathering_state(
        "biological", dict(sun_map=0.5, rain_map=1.0, runoff_map=0.0, biological_years=21.5, lichen_growth=10.0)
    )
    one = np.ones(1)
    unestablished_near = (0.01 * one, 0.99 * one, 0.5 * one, 0.02 * one, 0.5 * one, 0.5 * one)
    assert biological.lichen_cover(XP, state, unestablished_near) == pytest.approx(1.0)
    first, second = biological.thalli_covers(
        XP, state, (0.01 * one, 0.5 * one, 0.5 * one, 0.02 * one, 0.0 * one, 0.5 * one)
    )
    assert first == pytest.approx(1.0) and second == pytest.approx(1.0)


def test_a_thallus_is_grey_or_orange_as_far_as_the_sun_reaches_it():
    """A point inside an established thallus shows the lichen's colour alone (docs/model.md §9.3):
    a seed of the orange species (its value below ORANGE_SHARE x L) is the orange where a quarter
    of full sun or more reaches it, the grey where none does, and their mix at the light between;
    any other seed is grey in the sun too; on a north face every thallus is near the grey."""
    sun, grey = (np.asarray(item.default) for item in (biological.LICHEN_COLOR, biological.LICHEN_GREY_COLOR))

    def thallus(seed_value, **inputs):
        """The colour at an established seed's own place (distance 0), the point wet (L = light)."""
        inside = {biological.LICHEN_SEEDS: (np.zeros(1), np.full(1, seed_value), np.full(1, 0.5)) * 2}
        return seen(50.0, fields=inside, rain_map=1.0, biological_level=1.0, **inputs)[0]

    for sun_map, light in ((0.1, 0.4), (0.25, 1.0), (0.46, 1.0)):
        assert thallus(0.0, sun_map=sun_map) == pytest.approx(grey + (sun - grey) * light, abs=1e-6), sun_map
        # established (below L = light) but above the orange species' share of it: grey
        assert thallus(0.5 * light, sun_map=sun_map) == pytest.approx(grey, abs=1e-6), sun_map
    assert np.linalg.norm(lab(thallus(0.0, sun_map=0.0)) - lab(grey)) > 5.0  # no light: no thallus at all
    north, south = (
        lab(
            seen(50.0, fields={biological.LICHEN_SEEDS: (np.zeros(1), np.zeros(1), np.full(1, 0.5)) * 2}, **FACES[face])
        )[0]
        for face in ("north", "south")
    )
    assert north[1] < 0.0 < south[1] - 10.0


def test_a_third_of_the_thalli_are_orange():
    """Over many seeds of a wet, sunlit wall, the established thalli of the orange species are
    ORANGE_SHARE of them, wherever L puts the establishment."""
    values = np.random.default_rng(5).random(200_000)
    sun, grey = (np.asarray(item.default) for item in (biological.LICHEN_COLOR, biological.LICHEN_GREY_COLOR))
    for sun_map in (0.3, 0.5):  # L = 1 (wet, full light), and a share of that on a drier face
        for rain_map in (1.0, 0.0):
            state = model.weathering_state(
                "biological", dict(sun_map=sun_map, rain_map=rain_map, runoff_map=0.0, biological_years=50.0)
            )
            light = biological.lichen_light(XP, state)
            suitability = biological.lichen_suitability(XP, state, light)
            colour = biological.lichen_colour(NumpyOps(), state, values, suitability, light)  # RGB last
            at_seed = (np.zeros_like(values), values, np.full_like(values, 0.5))
            established = biological.lichen_cover(XP, state, at_seed * 2) > 0.5
            orange = np.abs(colour[:, 0] - sun[0]) < np.abs(colour[:, 0] - grey[0])
            assert orange[established].mean() == pytest.approx(biological.ORANGE_SHARE, abs=0.02), (sun_map, rain_map)
            assert not orange[~established].any()


def test_the_lichens_establish_at_the_stones_share():
    """On a stone (docs/model.md §8.7, §9.3) the share of seeds that establish is taken at the point's
    share: the receptive part (uptake +1) takes more thalli, the resistant part (-1) fewer, about the
    plain stone's share (a symmetric field keeps the mean); the film's biomass is not sorted (its
    pace is the receptivity's, §8.3, and r = 1 here)."""
    z_p = np.array([0.2, -0.2, 0.0])  # uptake +1, -1 and 0 at the gain G = 8
    seeds = {biological.LICHEN_SEEDS: (np.zeros((2, 3)), np.array([[0.6] * 3, [0.2] * 3]), np.full((2, 3), 0.5)) * 2}
    point = model.weathered_point(
        *STONE, None, 1.0, ("biological",), field=z_p, variation=1.0, fields=seeds,
        biological_years=20.0, biological_level=0.5, rain_map=1.0, runoff_map=0.0, sun_map=0.5,
    )  # fmt: skip
    # L = 0.5: a seed of value 0.6 establishes only where receptive, one of 0.2 not where resistant
    assert point.notes["lichen"] == pytest.approx(np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 1.0]]))
    assert np.ptp(point.notes["biomass"]) == 0.0


def test_a_thallus_reaches_further_over_receptive_stone():
    """On a stone a thallus reaches r sqrt(1 + REACH_SPREAD s) at a point of uptake s (docs/model.md
    §9.3): further where receptive (+1), less far where resistant (-1), r at s = 0, so that its
    margin follows the stone; the area it reaches over a symmetric field is that of r."""
    state = dict(biological_years=21.5, lichen_growth=10.0, lichen_density=1.0, rain_map=1.0, runoff_map=0.0)
    full = model.weathering_state("biological", dict(state, sun_map=0.5))
    radius = float(biological.lichen_radius(XP, full))
    reach = radius / math.sqrt(1.0 + biological.CROWDING * math.pi * radius**2) * biological.size_factor(0.5)
    z_p = np.array([0.2, 0.0, -0.2])  # uptake +1, 0 and -1 at the gain G = 8

    def covered(distance):
        """Whether a point at ``distance`` (metres = cells here) of an established seed is covered."""
        seed = (np.full((1, 3), distance), np.zeros((1, 3)), np.full((1, 3), 0.5))
        point = model.weathered_point(
            *STONE, None, 1.0, ("biological",), field=z_p, variation=1.0,
            fields={biological.LICHEN_SEEDS: seed + biological.NO_SEEDS[3:]}, sun_map=0.5, **state,
        )  # fmt: skip
        return point.notes["lichen"][0] > 0.5

    factors = np.sqrt(1.0 + biological.REACH_SPREAD * np.array([1.0, 0.0, -1.0]))  # 1.14, 1, 0.84
    for factor, expected in zip(factors, ([True, False, False], [True, True, False], [True, True, True])):
        assert list(covered(reach * factor - 1e-3)) == expected, factor
    assert list(covered(reach * factors[0] + 1e-3)) == [False] * 3
    assert np.mean(factors[[0, 2]] ** 2) == pytest.approx(1.0)  # the area of r over s = +-1


def test_receptive_stone_holds_more_film():
    """The film's biomass is r times the plain stone's once grown (docs/model.md §9.3: receptive
    stone holds more, as it holds more water), and never above 1; r = 1 is the plain stone's."""
    state = model.weathering_state("biological", dict(biological_years=20.0, rain_map=1.0, runoff_map=0.0, sun_map=0.0))
    plain = biological.algal_biomass(XP, state, 1.0)  # wet and dark: 1 * (1 - exp(-20))
    receptivity = np.array([0.8, 1.0, 1.25, 3.0])
    held = biological.algal_biomass(XP, state, receptivity)
    assert held[:3] == pytest.approx(receptivity[:3] * plain, rel=1e-6) and held[3] == 1.0


def test_lichens_grow_at_their_rate_after_the_lag():
    state = model.weathering_state("biological", dict(biological_years=21.5, lichen_growth=2.0))
    assert float(biological.lichen_radius(XP, state)) == pytest.approx(0.020)  # 20 years x 1 mm
    no_lichens_in_city = environments.ENVIRONMENTS["URBAN"].weathering()["lichen_density"]
    assert no_lichens_in_city == 0.0


def test_the_clocks_come_from_years_at_a_site():
    ages = aging.ages_for_years(20.0, 0.3)
    assert ages == dict(time=aging.age_for_years(20.0, 0.3), biological_years=20.0)
    assert aging.ages_for_years(1e6, 0.3)["biological_years"] == biological.BIOLOGICAL_YEARS.high
    with pytest.raises(ValueError, match="years"):
        aging.ages_for_years(-1.0, 0.3)


def test_age_for_years_reads_each_modes_clock():
    soiling_age = aging.age_for_years(20.0, 0.3)
    assert soiling_age < 1.0  # not capped: the two clocks must differ below
    for mode in ("soiling", "wet", "efflorescence"):
        assert aging.age_for_years(20.0, 0.3, mode=mode) == soiling_age
    assert aging.age_for_years(20.0, 0.3, mode="biological") == 20.0
    assert aging.age_for_years(1e6, 0.3, mode="biological") == biological.BIOLOGICAL_YEARS.high
    with pytest.raises(ValueError, match="unknown weathering modes"):
        aging.age_for_years(20.0, 0.3, mode="moss")
