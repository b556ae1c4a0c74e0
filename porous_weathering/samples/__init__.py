"""The bundled sample scenes and the main job: the scene kit that builds small lit scenes for
checks and pictures (``studio``) and the ``demo`` command that bakes and renders the samples of
``sample_blends/`` (shipped in the extension's zip beside this package).

May import: bpy and every layer below ``ui`` (``core``, ``common``, ``blender``, ``shading``,
``maps``, ``publish``, ``survey``).
"""
