"""Publishing weathered states: PBR textures baked from the weathered materials, one glTF 2.0
file with a material variant per state, and its paradata (``export``).

May import: bpy, ``core``, ``common``, ``blender``, ``shading`` and ``maps``.
"""
