"""The toy map of the registry tests, written as a map is: this one module in maps/ (the ``toys``
fixture puts this folder on that package's path), its settings, its two bake functions and its
one ``MapKind`` record, ``MAP`` (docs/architecture.md, "Add a map")."""

import dataclasses

import numpy as np

from ..blender import mesh_arrays
from ..common.options import option
from ..contracts import map_attribute
from .registry import MapKind


@dataclasses.dataclass(frozen=True)
class ToySettings:
    level: float = option(
        0.75, label="Toy Level", flag="--toy-level", low=0.0, high=1.0, tooltip="The value the toy map is baked to"
    )


def toy_image(obj, uv_map, options, margin):
    return np.full((options.resolution, options.resolution), options.toy_settings.level, np.float32)


def toy_attribute(obj, options):
    values = np.full(len(obj.data.loops), options.toy_settings.level)
    mesh_arrays.write_corner_attribute(obj.data, map_attribute("toy"), values)


MAP = MapKind(
    "toy",
    "Toy Map",
    "Toy map of the registry tests",
    attribute=map_attribute("toy"),
    settings=ToySettings,
    options_field="toy_settings",
    bake_image=toy_image,
    bake_attribute=toy_attribute,
)
