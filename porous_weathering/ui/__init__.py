"""The artist's front end: the scene's settings (``settings``), the panel that draws them
(``panel``), its operators (``operators``: add porous material, make material, make
efflorescence map, keyframe aging), the bake, export and condition survey operators
(``bake_operator``, ``export_operator``, ``survey_operator``) and what they share (``steps``:
the selection's poll, the dialog of their declared options, the modal stepping). Thin: every operator calls
the public functions of the layers below. ``register``/``unregister`` register every ui class,
in one place.

May import: bpy and every layer below it (``core``, ``common``, ``blender``, ``shading``,
``maps``, ``publish``, ``survey``); not ``cli`` or ``samples``.
"""

import bpy

from . import bake_operator, export_operator, operators, panel, settings, survey_operator


def classes() -> tuple[type, ...]:
    """The add-on's classes, the generated ones made from the registries as they are now: the
    settings first, then the operators (one Make-map operator per map made, not baked), then the
    panels."""
    return (
        settings.settings_class(),
        operators.PW_OT_add_porous_material,
        operators.PW_OT_make_material,
        operators.PW_OT_make_from_colorimetry,
        *operators.make_map_operators(),
        operators.PW_OT_keyframe_aging,
        bake_operator.operator_class(),
        export_operator.operator_class(),
        survey_operator.operator_class(),
        panel.PW_PT_material,
        panel.PW_PT_sidebar,
    )


#: The classes registered last (made again by each register(), from the registries as they are).
CLASSES = classes()


def register() -> None:
    global CLASSES
    CLASSES = classes()
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.porous_weathering = bpy.props.PointerProperty(type=CLASSES[0])


def unregister() -> None:
    del bpy.types.Scene.porous_weathering
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
