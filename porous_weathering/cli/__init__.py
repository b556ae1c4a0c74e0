"""The command line, ``python -m porous_weathering COMMAND`` and ``blender -c porous_weathering
COMMAND``: the parser and entry (``entry``), the ``bake`` and ``export`` commands (``bake``,
``export``) and batch bakes on a Dask cluster (``distributed``, whose workers import no bpy).
Thin: every command calls the public functions of the layers below.

May import: every layer below it (``core``, ``common``, ``blender``, ``shading``, ``maps``,
``publish``) and ``samples`` for the ``demo`` command; not ``ui``.
"""
