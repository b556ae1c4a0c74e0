"""Time in years: the weathering time t from years of exposure at an elemental-carbon concentration,
by a published soiling law of surfaces sheltered from rain (docs/weathering.md, "Time in years"),
and the biological clock beside it (``ages_for_years``, docs/model.md §9.4).

t = 1 is defined in reflectance terms: the sheltered (grey) surface has lost
``LOSS_AT_FULL_AGE`` (30%) of its reflectance, the loss Pio, Ramos & Duarte (1998) take as calling
for cleaning.  The model's grey area darkens linearly in t, so t is the loss over 30%.
"""

import math

from . import modes
from .arguments import choice, real_number
from .modes import Input

#: Reflectance loss of a sheltered surface at t = 1 (Pio et al. 1998: 30% calls for cleaning).
LOSS_AT_FULL_AGE = 0.30

#: The calibration: Pio et al. 1998 measured the 30% loss in 5.5-8.8 years in Oporto's city centre;
#: we take the geometric mean of the range, 6.96 years, at an elemental-carbon concentration of
#: 5 µg/m³ (our judgement of that street-level site's; docs/weathering.md).
REFERENCE_YEARS = math.sqrt(5.5 * 8.8)
REFERENCE_ELEMENTAL_CARBON = 5.0

#: The soiling laws: reflectance loss as a function of the dose (µg/m³ x years) over the dose of t = 1.
LAWS = ("sqrt", "exponential")


def reflectance_loss(dose_ratio: float, law: str = "sqrt") -> float:
    """The fraction of its reflectance a sheltered surface has lost at ``dose_ratio`` times the
    dose of t = 1: "sqrt", 0.3 sqrt(ratio) (Beloin & Haynie 1975; Pio et al. 1998), or
    "exponential", 1 - 0.7^ratio (R = R0 exp(-k dose), the form Grossi & Brimblecombe review),
    both 30% at ratio 1."""
    if choice("soiling law", law, LAWS) == "sqrt":
        return LOSS_AT_FULL_AGE * math.sqrt(dose_ratio)
    return 1.0 - (1.0 - LOSS_AT_FULL_AGE) ** dose_ratio


def age_for_years(years: float, elemental_carbon: float, law: str = "sqrt", mode: str | None = None) -> float:
    """t in [0, 1] after ``years`` of exposure at ``elemental_carbon`` µg/m³ (annual mean), by the
    soiling ``law`` of rain-sheltered surfaces ("sqrt" or "exponential"): the reflectance loss
    over the 30% of t = 1, capped at 1 (the model's fully weathered state; the stone goes on
    darkening).  With ``mode``, the value of that mode's clock instead (docs/model.md §9.4): t for
    the modes that run on it, the years themselves for ``"biological"``.  ValueError for negative
    years, a concentration not above 0, an unknown law or an unknown mode."""
    if not (math.isfinite(real_number("years", years)) and years >= 0.0):
        raise ValueError(f"years must be a number >= 0, not {years!r}")
    if not (math.isfinite(real_number("elemental_carbon", elemental_carbon)) and elemental_carbon > 0.0):
        raise ValueError(f"elemental_carbon must be a concentration > 0 µg/m³, not {elemental_carbon!r}")
    clocks = [item for item in modes.inputs_of(modes.checked(mode)) if item.clock] if mode is not None else []
    ratio = years * elemental_carbon / (REFERENCE_YEARS * REFERENCE_ELEMENTAL_CARBON)  # inf past 1e308: t = 1
    t = min(reflectance_loss(ratio, law) / LOSS_AT_FULL_AGE, 1.0)
    return _clock_value(clocks[0], years, t) if clocks else t


def _clock_value(clock: Input, years: float, t: float) -> float:
    """What ``clock`` reads after ``years`` whose soiling age is ``t``."""
    return t if clock.clock == "age" else min(float(years), clock.high)


def years_for_full_age(elemental_carbon: float) -> float:
    """The years to t = 1 (30% loss) at ``elemental_carbon`` µg/m³: the same dose as the calibration."""
    return REFERENCE_YEARS * REFERENCE_ELEMENTAL_CARBON / elemental_carbon


def years_for_age(age: float, elemental_carbon: float, law: str = "sqrt") -> float:
    """The years of exposure at ``elemental_carbon`` µg/m³ after which t reaches ``age`` in [0, 1]:
    ``age_for_years`` inverted (the dose whose reflectance loss is ``age`` x 30%)."""
    loss = LOSS_AT_FULL_AGE * min(max(real_number("age", age), 0.0), 1.0)
    if choice("soiling law", law, LAWS) == "sqrt":
        ratio = (loss / LOSS_AT_FULL_AGE) ** 2
    else:
        ratio = math.log1p(-loss) / math.log1p(-LOSS_AT_FULL_AGE) if loss else 0.0
    return ratio * years_for_full_age(elemental_carbon)


def ages_for_years(years: float, elemental_carbon: float, law: str = "sqrt") -> dict:
    """{clock input: value} after ``years`` at a site (docs/model.md §9.4), for every mode's clock
    (``Input.clock``): "age", the soiling's t (``age_for_years``: soot accumulates with the dose,
    years x concentration); "years", the years themselves, capped at the input's range (life's
    pace is set by water and light, not by soot; a site's air sets how much life there is, its
    level and lichen density). ValueError as ``age_for_years``."""
    t = age_for_years(years, elemental_carbon, law)
    return {item.name: _clock_value(item, years, t) for item in modes.inputs().values() if item.clock}
