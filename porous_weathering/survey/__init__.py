"""The condition survey: the drawings of the condition maps (``sheet``).

May import: the standard library, numpy, matplotlib and ``common``; never bpy.
"""
