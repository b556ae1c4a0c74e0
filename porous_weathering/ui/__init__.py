"""The artist's front end: the panel, its settings and operators (``panel``), the bake and export
operators (``bake_operator``, ``export_operator``) and the modal stepping they share
(``steps``). Thin: every operator calls the public functions of the layers below.

May import: bpy and every layer below it (``core``, ``common``, ``blender``, ``shading``,
``maps``, ``publish``); not ``cli`` or ``samples``.
"""
