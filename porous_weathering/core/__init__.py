"""The maths, written once: the porous BRDF post-process (``porous``), the weathering modes
(``modes``: one module per mode and their registry), the two backends that evaluate them
(``backends``: numpy arrays and shader-node expressions, ``shader_math``) and the numpy model
(``model``), the ground truth the renders are checked against (docs/model.md), the sun's
year at a site (``solar``, the sun map's model) and cross products fast on millions of
vectors (``vectors``).

May import: numpy and the standard library; nothing else of this package, and never bpy.
"""
