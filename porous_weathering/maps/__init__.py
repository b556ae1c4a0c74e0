"""The maps: their registry (``registry``: it finds the ``MAP`` record of each map's module,
re-exported here as ``porous_weathering.maps``), the one bake pipeline behind the operator, the
command line and Dask (``bake``) and what a map was made from (``provenance``), the direct-light
bake of the rain and the points of both sky maps (``sky_bake``), the objects beside one that its
maps see (``neighbours``), Embree's rays (``shadow_rays``), each map's bake (``rain``; ``sun``;
``runoff`` over its numpy flow, ``runoff_flow``; ``edges``, the bpy side of the edge mask over
its numpy maths, ``curvature``, and the corners where parts meet, ``contacts``), the lightmap UVs
image maps are baked on (``lightmap``, over its check, ``lightmap_check``, and its unwrap, the
child process ``lightmap_child``), the checks made on scans (``scan_checks``), the efflorescence
location maps (``efflorescence_map``) and how an object's maps are found and wired into its
weathered material (``linking``).

``curvature``, ``runoff_flow``, ``lightmap_check`` and ``lightmap_child`` import no bpy (numpy,
and xatlas for the unwrap), and neither does importing this package: the registry's names load
on first use; ``lightmap_check`` imports nothing of this package and
``lightmap_child`` only it, so the unwrap runs as a plain script in a child process.

May import: bpy, numpy, xatlas, embreex, ``core``, ``common``, ``blender`` and ``shading`` (``linking``
builds the materials the maps feed).
"""

import importlib

__all__ = [
    "MadeMap",
    "MapKind",
    "all_kinds",
    "discover",
    "feeding",
    "get",
    "made_kinds",
    "modules",
    "names",
    "register",
    "register_made",
    "unregister",
]


def __getattr__(name):
    if name in __all__:
        return getattr(importlib.import_module(".registry", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
