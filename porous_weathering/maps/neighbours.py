"""The objects beside an object that its maps see: those that shelter it from the rain and the
sun (``rain``, ``sun``) and those it meets, whose corners with it the edge mask counts
(``edges``, ``contacts``): every renderable geometry object of its scenes, or of the bake's
occluder collection.
"""

from collections.abc import Sequence

import bpy

import numpy as np
from mathutils import Vector

from ..blender import scratch_scene


def default_occluders(
    target: bpy.types.Object, collection: bpy.types.Collection | None = None
) -> list[bpy.types.Object]:
    """The objects that can shelter ``target``: every renderable geometry object of its scenes,
    or only those of ``collection`` (a bpy Collection, children included)."""
    if collection is not None:
        candidates = collection.all_objects
    else:
        candidates = {o for scene in target.users_scene for o in scene.objects}
    geometry = scratch_scene.GEOMETRY_TYPES
    return [o for o in candidates if o.type in geometry and not o.hide_render and o != target]


def options_occluders(obj: bpy.types.Object, options) -> list[bpy.types.Object]:
    """``default_occluders`` of ``obj`` under a bake's ``options`` (``bake.BakeOptions``: its
    occluder collection, if it names one), as the rain, sun and edge records read them."""
    return default_occluders(obj, options.occluder_collection())


def occluders_digest(obj: bpy.types.Object, options, digests) -> list[tuple[str, str]]:
    """(name, ``digests(occluder)``) of each of ``options_occluders``, sorted: the part of a
    map's input hash that re-bakes it when an occluder changes."""
    return sorted((o.name, digests(o)) for o in options_occluders(obj, options))


def meeting(target: bpy.types.Object, candidates: Sequence[bpy.types.Object], reach: float) -> list[bpy.types.Object]:
    """The objects of ``candidates`` that ``target`` may meet: their world boxes (``world_box``) lie
    within ``reach`` of its own."""
    low, high = world_box(target)
    found = []
    for other in candidates:
        other_low, other_high = world_box(other)
        if other is not target and np.all(other_low <= high + reach) and np.all(low - reach <= other_high):
            found.append(other)
    return found


def world_box(obj: bpy.types.Object) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of the box of ``obj``'s bounding-box corners placed in the world."""
    corners = np.array([obj.matrix_world @ Vector(corner) for corner in obj.bound_box])
    return corners.min(axis=0), corners.max(axis=0)
