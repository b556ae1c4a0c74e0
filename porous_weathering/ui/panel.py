"""The panel, drawn in two places (the material properties and the 3D viewport's sidebar): the
scene's settings, the object's maps and the buttons of the operators. Drawing only: the maps
listed and the Make-map buttons are derived from the map registry (``linking.known_maps``,
``registry.made_kinds``), what the buttons do is in ``operators``, ``bake_operator``,
``export_operator`` and ``survey_operator``."""

import bpy

from ..core import aging, stones
from ..core import modes as weathering_modes
from ..maps import registry as maps
from ..maps.linking import discover_maps, known_maps, missing_maps
from . import bake_operator as ops_bake
from . import export_operator as ops_export
from . import operators
from . import survey_operator as ops_survey
from .settings import ASHLAR, active_material, scene_sun, time_socket, variation_socket


def draw_panel(layout: "bpy.types.UILayout", context: "bpy.types.Context") -> None:
    settings = context.scene.porous_weathering
    obj = context.active_object
    layout.use_property_split = True
    layout.use_property_decorate = False

    col = layout.column(heading="Material")
    col.prop(settings, "source")
    if settings.preset() is not None:
        col.prop(settings, "variation", slider=True)
        col.prop(settings, "masonry")
        if settings.masonry == ASHLAR:
            for name in stones.ASHLAR_LENGTHS:
                col.prop(settings, name)
    col.prop(settings, "environment")
    col.prop(settings, "key_light")
    if settings.key_light is None:
        sun = scene_sun(context.scene)
        if sun is None:
            col.label(text="No sun: ambient mode (sky lighting)", icon="INFO")
        else:
            col.label(text=f"Make uses the sun '{sun.name}' (the scene's strongest)", icon="LIGHT_SUN")
    switches = col.column(heading="Weathering", align=True)
    for mode in weathering_modes.names():
        switches.prop(settings, mode)
    for item in weathering_modes.inputs_of(settings.modes()):
        if item.panel:
            col.prop(settings, item.name, slider=True)
    if obj is not None:
        labels = {kind.name: kind.label for kind in known_maps()}
        for map_name in missing_maps(obj, settings.modes()):
            col.label(text=f"Needs the {labels[map_name]} map: make it below first", icon="ERROR")
    col.operator(operators.PW_OT_make_material.bl_idname, icon="MATERIAL")

    col = layout.column(heading="Measured")
    col.prop(settings, "measured_space")
    for name in ("clean", "soiled", "crust"):
        col.prop(settings, f"measured_{name}")
    col.operator(operators.PW_OT_make_from_colorimetry.bl_idname, icon="EYEDROPPER")

    col = layout.column(heading="Maps")
    have = discover_maps(obj) if obj is not None else {}
    for kind in known_maps():
        where = have.get(kind.name)
        text = (
            "not made yet"
            if where is None
            else ("image " + where.name if hasattr(where, "name") else "attribute " + where)
        )
        col.label(text=f"{kind.label}: {text}")
    bake_button = col.operator(ops_bake.BakeMapsOperator.bl_idname, icon="RENDER_STILL")
    bake_button.maps = set(maps.names())
    for make_map in operators.make_map_operators():
        col.operator(make_map.bl_idname, icon="IMAGE_DATA")

    variation = variation_socket(active_material(context))
    if variation is not None:  # the made material's own stone, varied live
        col = layout.column(heading="Its Stone")
        col.prop(variation, "default_value", text="Variation", slider=True)

    col = layout.column(heading="Age")
    socket = time_socket(active_material(context))
    if socket is None:
        col.label(text="Make a weathered material to age it", icon="INFO")
    else:
        row = col.row()
        row.use_property_decorate = True
        row.prop(socket, "default_value", text="Time", slider=True)
        col.prop(settings, "years")
        col.label(
            text=f"at {settings.elemental_carbon():g} µg/m³ of soot: t = 1 after "
            f"{aging.years_for_full_age(settings.elemental_carbon()):.0f} years"
        )
    col.operator(operators.PW_OT_keyframe_aging.bl_idname, icon="KEY_HLT")
    if settings.years > 0.0:
        years_button = col.operator(
            operators.PW_OT_keyframe_aging.bl_idname, text=f"Keyframe {settings.years:g} Years", icon="KEY_HLT"
        )
        years_button.years = settings.years

    col = layout.column(heading="Publish")
    col.operator(ops_export.ExportVariantsOperator.bl_idname, icon="EXPORT")
    col.operator(ops_survey.ConditionSurveyOperator.bl_idname, icon="SPREADSHEET")


class PanelBody:
    """What both panels draw (one draw, two places)."""

    bl_label = "Porous Weathering"

    def draw(self, context):
        draw_panel(self.layout, context)


class PW_PT_material(PanelBody, bpy.types.Panel):
    """Porous Weathering: make, bake and age porous materials"""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"


class PW_PT_sidebar(PanelBody, bpy.types.Panel):
    """Porous Weathering in the 3D viewport's sidebar: make, bake and age porous materials"""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Weathering"
