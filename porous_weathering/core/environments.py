"""Environments: site presets that set the weathering inputs which depend on where the stone
stands (a city street, a suburb, the countryside, the coast), and the site's typical soot loading,
which maps years to the weathering time (``aging``).  Every value and its source:
docs/presets.md, "Environments".

``make_weathered_material(..., environment="URBAN")`` (the default) takes these values for the inputs
its modes use; explicit inputs win; ``environment=None`` is the plain API defaults.
"""

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from . import modes as weathering_modes
from .arguments import choice
from .modes.soiling import CRUST_DEFAULT, POLLUTION_COLOR

#: The environment a heritage team in a city gets: the panel's and make_weathered_material's default.
DEFAULT_ENVIRONMENT = "URBAN"


@dataclass(frozen=True)
class Environment:
    label: str
    description: str
    #: Typical annual mean elemental-carbon (soot) concentration, µg/m³: how fast t grows with years.
    elemental_carbon: float
    #: How much of the stone's black crust forms here (x the stone's ``crust``; gypsum needs SO2).
    crust_factor: float
    #: {weathering input: value} the site sets, of any mode (names checked against the mode
    #: registry), besides the crust, which is a share of the stone's.
    values: Mapping[str, Any]

    def __post_init__(self):
        unknown = sorted(set(self.values) - set(weathering_modes.inputs()))
        if unknown:
            raise ValueError(f"environment {self.label!r}: {unknown} are no weathering inputs")
        object.__setattr__(self, "values", MappingProxyType({**EVERYWHERE, **self.values}))

    def weathering(self, crust: float = CRUST_DEFAULT) -> dict:
        """{input: value} this site sets, with ``crust`` the stone's (the API default 0.8)."""
        return {**self.values, "crust": round(crust * self.crust_factor, 4)}


#: What every site sets alike: the carbon in the pores and the crust is soot everywhere.
EVERYWHERE = {POLLUTION_COLOR.name: POLLUTION_COLOR.default}


#: Every site's deposit colour (linear RGB) has the lightness that makes the limestone preset's
#: sheltered grey area lose 30% of its reflectance at t = 1 (aging.LOSS_AT_FULL_AGE).
ENVIRONMENTS = {
    "URBAN": Environment(
        "Urban (polluted)",
        "A city street: traffic soot, sulphur for black crusts, salts",
        elemental_carbon=2.0,
        crust_factor=1.0,
        values=dict(
            deposit_color=(0.257, 0.249, 0.231),
            streaks=0.5,
            efflorescence_level=1.0,
            biological_level=0.4,
            lichen_density=0.0,
        ),
    ),
    "SUBURBAN": Environment(
        "Suburban",
        "A suburb or a small town: less traffic, thinner crusts",
        elemental_carbon=1.0,
        crust_factor=0.6,
        values=dict(
            deposit_color=(0.261, 0.248, 0.225),
            streaks=0.4,
            efflorescence_level=0.8,
            biological_level=0.7,
            lichen_density=50.0,
        ),
    ),
    "RURAL": Environment(
        "Rural",
        "The countryside: little soot, brownish mineral and organic dust, crusts rare",
        elemental_carbon=0.3,
        crust_factor=0.25,
        values=dict(
            deposit_color=(0.274, 0.246, 0.205),
            streaks=0.25,
            efflorescence_level=0.6,
            biological_level=1.0,
            lichen_density=200.0,
        ),
    ),
    "COASTAL": Environment(
        "Coastal (marine)",
        "By the sea: clean marine air, sea salt for efflorescence, crusts rare",
        elemental_carbon=0.3,
        crust_factor=0.25,
        values=dict(
            deposit_color=(0.256, 0.249, 0.236),
            streaks=0.35,
            efflorescence_level=1.0,
            biological_level=1.0,
            lichen_density=200.0,
        ),
    ),
}


def get(name: str) -> Environment:
    """The environment ``name`` (a key of ENVIRONMENTS); ValueError naming the known ones."""
    return ENVIRONMENTS[choice("environment", name, (*ENVIRONMENTS, None))]


def weathering_inputs(name: str | None, modes: Iterable[str], crust: float = CRUST_DEFAULT) -> dict:
    """{input: value} the environment ``name`` sets among the inputs ``modes`` use ({} for None)."""
    if name is None:
        return {}
    used = {item.name for item in weathering_modes.inputs_of(modes)}
    return {key: value for key, value in get(name).weathering(crust).items() if key in used}
