"""The baked maps: their registry (``registry``: one ``MapKind`` record per map, re-exported
here as ``porous_weathering.maps``), the one bake pipeline behind the operator, the command line
and Dask (``bake``), each map's bake (``rain``, ``edges``), the lightmap UVs image maps are
baked on (``lightmap``), the checks made on scans (``scan_checks``) and the efflorescence
location maps (``efflorescence_map``).

May import: bpy, numpy, xatlas, ``core``, ``common`` and ``blender``.
"""

from .registry import MapKind, all_kinds, feeding, get, names, register, unregister

__all__ = ["MapKind", "all_kinds", "feeding", "get", "names", "register", "unregister"]
