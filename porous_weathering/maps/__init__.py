"""The baked maps: their registry (``registry``: one ``MapKind`` record per map, re-exported here
as ``porous_weathering.maps``), the one bake pipeline behind the operator, the command line and
Dask (``bake``) and what a map was made from (``provenance``), each map's bake (``rain``;
``runoff`` over its numpy flow, ``runoff_flow``; ``edges``, the bpy side of the edge mask over
its numpy maths, ``curvature``), the lightmap UVs image maps are baked on (``lightmap``, over
its check, ``lightmap_check``, and its unwrap, the child process ``lightmap_child``), the checks
made on scans (``scan_checks``), the efflorescence location maps (``efflorescence_map``) and how
an object's maps are found and wired into its weathered material (``linking``).

``curvature``, ``runoff_flow``, ``lightmap_check`` and ``lightmap_child`` import no bpy (numpy,
and xatlas for the unwrap); ``lightmap_check`` imports nothing of this package and
``lightmap_child`` only it, so the unwrap runs as a plain script in a child process.

May import: bpy, numpy, xatlas, ``core``, ``common``, ``blender`` and ``shading`` (``linking``
builds the materials the maps feed).
"""

from .registry import MadeMap, MapKind, all_kinds, feeding, get, made_kinds, names, register, register_made, unregister

__all__ = [
    "MadeMap",
    "MapKind",
    "all_kinds",
    "feeding",
    "get",
    "made_kinds",
    "names",
    "register",
    "register_made",
    "unregister",
]
