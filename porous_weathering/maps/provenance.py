"""What a map was made from, and the refusal to replace a map made from something else (docs/cli.md,
"No map is replaced silently").

Every map records the .blend file, the object and the map it was made from (``Provenance``):
in the EXR header of an image map (``SOURCE_KEY``, ``OBJECT_KEY``, ``MAP_KEY``), as custom
properties of the mesh for an attribute. An image map made from another .blend or object, or an
image this extension did not write, is never replaced silently: ``refuse_overwrite`` raises
``OverwriteRefused``. The bake (``bake``) re-exports these names, where docs/api.md documents them.
"""

import os
from collections.abc import Mapping
from dataclasses import dataclass

import bpy

from ..common import imageio
from ..common.imageio import MAP_KEY, OBJECT_KEY, SOURCE_KEY


class OverwriteRefused(ValueError):
    """An image map would replace a file made from another .blend or object (or a file that
    is not a map): nothing of this bake was written, unless the check failed only as the map
    was about to be written (a file that appeared meanwhile), when the maps before it are kept."""


class ForeignInput(ValueError):
    """A map the bake would read (the run-off reads the rain) was made from another .blend or
    object: nothing was baked."""


@dataclass(frozen=True)
class Provenance:
    """What a map was made from: the .blend file (absolute path; "" when unsaved or not
    recorded), the object's exact name and the map ("" when not recorded)."""

    source: str = ""
    object: str = ""
    map: str = ""

    @classmethod
    def of(cls, obj: "bpy.types.Object", map_name: str) -> "Provenance":
        """The provenance a map of ``obj`` baked now gets."""
        return cls(os.path.abspath(bpy.data.filepath) if bpy.data.filepath else "", obj.name, map_name)

    @classmethod
    def from_header(cls, header: Mapping[str, str]) -> "Provenance":
        return cls(header.get(SOURCE_KEY, ""), header.get(OBJECT_KEY, ""), header.get(MAP_KEY, ""))

    def header(self) -> dict[str, str]:
        return {SOURCE_KEY: self.source, OBJECT_KEY: self.object, MAP_KEY: self.map}

    def yields_to(self, other: "Provenance") -> bool:
        """Whether a map made from this may be replaced by one made from ``other``: each field
        it records (an unsaved .blend or an older map records none) must be the same."""
        same_source = not self.source or self.source == other.source or _same_file(self.source, other.source)
        return same_source and self.object in ("", other.object) and self.map in ("", other.map)

    def __str__(self):
        return f"{self.source or 'an unsaved .blend'} (object '{self.object or '?'}')"


def _same_file(first, second):
    try:
        return bool(second) and os.path.samefile(first, second)
    except OSError:
        return False


def refuse_overwrite(path: str, wanted: Provenance) -> None:
    """Raise OverwriteRefused when the file at ``path`` may not be replaced by a map made from
    ``wanted``: it is a map made from another .blend, object or map, or an image that this
    extension did not write (a map painted by hand, say). A file that is no readable image (a
    broken map) holds nothing to keep, and is replaced."""
    header = imageio.image_header(path)
    if header is None:
        return
    if MAP_KEY not in header:
        raise OverwriteRefused(f"{path} is an image that Porous Weathering did not write")
    made = Provenance.from_header(header)
    if not made.yields_to(wanted):
        raise OverwriteRefused(f"{path} was made from {made}, not from {wanted}")
