"""The command line, ``python -m porous_weathering COMMAND`` and ``blender -c porous_weathering
COMMAND``: the parser and entry (``entry``), the ``bake``, ``export`` and ``survey`` commands
(``bake``, ``export``, ``survey``), what they take to choose objects and how they word an error
(``selection``: ``--objects``, ``--collection``), what the commands of several files share
(``batch``: ``bake``, ``survey``), and their runs on a Dask cluster: the client
(``distributed``: its options, scheduling, the combined exit code) and what runs on a worker
(``dask_worker``, which imports no bpy; its bake processes do). Exit codes are
``contracts.EXIT_*`` (docs/cli.md).
Thin: every command calls the public functions of the layers below.

May import: every layer below it (``core``, ``common``, ``blender``, ``shading``, ``maps``,
``publish``, ``survey``) and ``samples`` for the ``demo`` command; not ``ui``.
"""
