"""What talks to Blender but knows nothing of stone: the differences between the Blender lines
(``compat``), a .blend opened as the commands open it (``blend_file``), a mesh's data as numpy
arrays (``mesh_arrays``), temporary scenes for bakes (``scratch_scene``) and deterministic headless
renders into numpy arrays (``render``).

May import: bpy, numpy, ``core`` and ``common``.
"""
