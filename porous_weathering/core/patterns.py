"""The patterns of a condition survey (docs/model.md §10): what a point of the surface looks like
at an age, named as the ICOMOS-ISCS glossary names it, each one ``Pattern`` record with its rule.

A mode brings its own patterns (``Mode.patterns``); a rule reads a ``Reading`` of the numpy model
at the points: the notes the mode's layers leave (``Point.notes``) and the loss of visible
reflectance against the clean stone. ``NO_VISIBLE_CHANGE`` is where no rule holds. No bpy.
"""

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

#: The Natural Stone Damage Ontology (w3id.org/nsd): each pattern's class is this IRI + its name.
NSD = "https://w3id.org/nsd#"

#: The cleaning threshold: 30% of the visible reflectance lost (Pio et al. 1998; t = 1, core/aging.py).
CLEANING_LOSS = 0.30

#: Share of a point a layer must cover or fill (crust, salt, water) for the point to show it.
VISIBLE_SHARE = 0.5


@dataclass(frozen=True)
class Reading:
    """What the rules read at the points: the notes of the modes' layers ({name: array}) and
    the fraction of the clean stone's visible reflectance lost (1 - Y / Y_clean)."""

    notes: dict
    loss: Any


@dataclass(frozen=True)
class Pattern:
    """One pattern: its glossary name, its ontology IRI (None: no damage class), its colour on a
    drawing (sRGB) and hatch code, the rule (Reading -> bool per point; docs/model.md §10 says
    each in words), and its precedence: a point takes the holding pattern of least precedence."""

    name: str
    nsd_iri: str | None
    colour: tuple[float, float, float]
    hatch: str
    rule: Callable[[Reading], Any]
    precedence: int
    rule_text: str  #: the rule in words, as docs/model.md §10 tables it


def shown(note: str, share: float = VISIBLE_SHARE) -> Callable[[Reading], Any]:
    """The rule 'the layer noted ``note`` covers or fills at least ``share`` of the point'."""
    return lambda reading: reading.notes[note] >= share


def darkened(reading: Reading) -> Any:
    """The rule of soiling: the visible reflectance has fallen by the cleaning threshold or more."""
    return reading.loss >= CLEANING_LOSS


NO_VISIBLE_CHANGE = Pattern(
    "no visible change",
    None,
    (1.0, 1.0, 1.0),
    "none",
    lambda reading: True,
    1000,
    "no other rule holds",
)
