"""Materials: the shader node groups built from the maths of ``core`` (``nodes``), the porous
and weathered materials on them (``material``, ``weathering``), the stone presets
(``presets``) and the node-group asset library (``assets``).

May import: bpy, ``core``, ``common`` and ``blender``.
"""
