"""Operators and panels: thin wrappers over the package's plain functions."""

import warnings

import bpy

from . import maps, material, model, ops_bake, presets, scratch_scene, weathering
from . import modes as weathering_modes


class NeedsMaterialObject:
    """Operators that give the active object a material: poll for one that can have them."""

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type not in scratch_scene.GEOMETRY_TYPES:
            cls.poll_message_set("Select an object that can have materials")
            return False
        return True


class PW_OT_add_porous_material(NeedsMaterialObject, bpy.types.Operator):
    """Give the active object a new porous material (SPEC 2), lit by the scene's key light or ambient"""

    bl_idname = "porous_weathering.add_porous_material"
    bl_label = "Add Porous Material"
    bl_options = {"REGISTER", "UNDO"}

    key_light: bpy.props.StringProperty(
        name="Key Light",
        description="Light whose direction the pore shadowing follows; empty for ambient (environment) lighting",
    )

    def execute(self, context):
        obj = context.active_object
        linked = next((block for block in (obj, obj.data) if block.library is not None), None)
        if linked is not None:  # a material slot added to linked data is gone once the file is saved
            what = f"object '{obj.name}'" + ("" if linked is obj else f": its data '{linked.name}'")
            self.report(
                {"ERROR"},
                f"{what} is linked from the library {linked.library.filepath}, where a new "
                "material would not be saved; make it local first",
            )
            return {"CANCELLED"}
        try:
            mat = material.make_porous_material(f"{obj.name} Porous", key_light=self.key_light or None)
        except ValueError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        try:
            obj.data.materials.append(mat)
        except RuntimeError as error:  # data that cannot take a material: leave no orphan behind
            bpy.data.materials.remove(mat)
            self.report({"ERROR"}, f"object '{obj.name}': {error}")
            return {"CANCELLED"}
        obj.active_material_index = len(obj.material_slots) - 1
        return {"FINISHED"}


# --- the artist's panel --------------------------------------------------------------------

FROM_MATERIAL = "FROM_MATERIAL"


def _is_light(_settings, obj):
    return obj.type == "LIGHT"


class SettingsBase:
    """Porous Weathering choices of a scene: what the panel's Make button builds"""

    def modes(self):
        return tuple(mode for mode in weathering_modes.names() if getattr(self, mode))


def settings_class():
    """The scene's settings: the stone, the key light and one switch per registered mode."""
    properties = {
        "source": bpy.props.EnumProperty(
            name="Stone",
            description="Porous stone to start from",
            default="LIMESTONE",
            items=[(key, preset.label, preset.description) for key, preset in presets.PRESETS.items()]
            + [
                (
                    FROM_MATERIAL,
                    "Object's Own Material",
                    "Keep the base colour and roughness images of the object's current material",
                )
            ],
        ),
        "key_light": bpy.props.PointerProperty(
            name="Key Light",
            type=bpy.types.Object,
            poll=_is_light,
            description="Light whose direction the pores follow exactly; empty: ambient mode, for scenes lit by a sky",
        ),
    }
    for mode in map(weathering_modes.get, weathering_modes.names()):
        properties[mode.name] = bpy.props.BoolProperty(name=mode.label, description=mode.description)
    return type(
        "PW_Settings",
        (SettingsBase, bpy.types.PropertyGroup),
        {"__annotations__": properties, "__doc__": SettingsBase.__doc__},
    )


def baked_maps(obj):
    """{map name: source} of the maps baked for ``obj``: an Image or a colour attribute name."""
    found = {}
    for kind in maps.all_kinds():
        image = bpy.data.images.get(obj.get(f"pw_{kind.name}_image", ""))
        if image is not None:
            found[kind.name] = image
        elif obj.type == "MESH" and kind.attribute in obj.data.attributes:
            found[kind.name] = kind.attribute
    return found


def missing_maps(obj, modes):
    """The baked maps that ``modes`` read and ``obj`` lacks, sorted."""
    have = baked_maps(obj)
    wanted = {item.map for item in weathering_modes.inputs_of(modes) if item.map in maps.names()}
    return sorted(wanted - set(have))


def map_inputs(obj, modes):
    """{weathering input: source} of ``obj``'s baked maps, for each mask input ``modes`` read."""
    have = baked_maps(obj)
    return {item.name: have[item.map] for item in weathering_modes.inputs_of(modes) if item.map in have}


class PW_OT_make_material(NeedsMaterialObject, bpy.types.Operator):
    """Give the active object a porous material from the chosen stone, light and weathering modes, wired to its maps"""

    bl_idname = "porous_weathering.make_material"
    bl_label = "Make Porous Material"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        settings = context.scene.porous_weathering
        obj = context.active_object
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", model.PorousInputWarning)
                new = build_material(obj, settings)
        except ValueError as error:
            self.report({"ERROR"}, f"object '{obj.name}': {error}")
            return {"CANCELLED"}
        for warning in caught:
            self.report({"WARNING"}, str(warning.message))
        for map_name in missing_maps(obj, settings.modes()):
            self.report(
                {"WARNING"},
                f"object '{obj.name}' has no {maps.get(map_name).label} map: its input stays "
                "constant until you bake it (Bake Weathering Maps) and Make again",
            )
        if obj.material_slots:
            obj.material_slots[obj.active_material_index].material = new
        else:
            obj.data.materials.append(new)
        return {"FINISHED"}


def build_material(obj, settings):
    """The material the panel's Make button gives ``obj`` (see PW_OT_make_material)."""
    if settings.source == FROM_MATERIAL:
        textures = material.principled_textures(obj.active_material)
        params = {"base_color": textures.get("Base Color", (0.8, 0.8, 0.8))}
        name = f"{obj.active_material.name if obj.active_material else obj.name} Porous"
    else:
        preset = presets.PRESETS[settings.source]
        textures = {}
        params = preset.material_params()
        name = f"{obj.name} {preset.label}"
    modes = settings.modes()
    if modes:
        new = weathering.make_weathered_material(
            name, modes=modes, key_light=settings.key_light, **params, **map_inputs(obj, modes)
        )
    else:
        new = material.make_porous_material(name, key_light=settings.key_light, **params)
    if "Roughness" in textures:
        material.connect_roughness_image(new, textures["Roughness"])
    return new


def _active_material(context):
    """The material the panel shows: the Properties editor's, else the active object's."""
    obj = context.active_object
    return getattr(context, "material", None) or (obj.active_material if obj is not None else None)


def _time_socket(mat):
    group = mat.node_tree.nodes.get("Porous") if mat and mat.node_tree else None
    return group.inputs.get("Time") if group is not None else None


class PW_OT_keyframe_aging(bpy.types.Operator):
    """Animate the active material from new (time 0, first frame) to fully weathered (time 1, last frame)"""

    bl_idname = "porous_weathering.keyframe_aging"
    bl_label = "Keyframe Aging"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if _time_socket(_active_material(context)) is None:
            cls.poll_message_set("Make a weathered material first: a porous-only material does not age")
            return False
        return True

    def execute(self, context):
        scene = context.scene
        weathering.animate_weathering(_active_material(context), scene.frame_start, scene.frame_end)
        return {"FINISHED"}


def draw_panel(layout, context):
    settings = context.scene.porous_weathering
    obj = context.active_object
    layout.use_property_split = True
    layout.use_property_decorate = False

    col = layout.column(heading="Material")
    col.prop(settings, "source")
    col.prop(settings, "key_light")
    if settings.key_light is None:
        col.label(text="No key light: ambient mode (sky lighting)", icon="INFO")
    switches = col.column(heading="Weathering", align=True)
    for mode in weathering_modes.names():
        switches.prop(settings, mode)
    if obj is not None:
        for map_name in missing_maps(obj, settings.modes()):
            col.label(text=f"Needs the {maps.get(map_name).label} map: bake it below first", icon="ERROR")
    col.operator(PW_OT_make_material.bl_idname, icon="MATERIAL")

    col = layout.column(heading="Maps")
    have = baked_maps(obj) if obj is not None else {}
    for kind in maps.all_kinds():
        where = have.get(kind.name)
        text = (
            "not baked"
            if where is None
            else ("image " + where.name if hasattr(where, "name") else "attribute " + where)
        )
        col.label(text=f"{kind.label}: {text}")
    bake_button = col.operator(ops_bake.BakeMapsOperator.bl_idname, icon="RENDER_STILL")
    bake_button.maps = set(maps.names())

    col = layout.column(heading="Age")
    socket = _time_socket(_active_material(context))
    if socket is None:
        col.label(text="Make a weathered material to age it", icon="INFO")
    else:
        row = col.row()
        row.use_property_decorate = True
        row.prop(socket, "default_value", text="Time", slider=True)
    col.operator(PW_OT_keyframe_aging.bl_idname, icon="KEY_HLT")


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


def classes():
    """The add-on's classes, the generated ones made from the registries as they are now."""
    return (
        settings_class(),
        PW_OT_add_porous_material,
        PW_OT_make_material,
        PW_OT_keyframe_aging,
        ops_bake.operator_class(),
        PW_PT_material,
        PW_PT_sidebar,
    )


#: The classes registered last (made again by each register(), from the registries as they are).
CLASSES = classes()


def register():
    global CLASSES
    CLASSES = classes()
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.porous_weathering = bpy.props.PointerProperty(type=CLASSES[0])


def unregister():
    del bpy.types.Scene.porous_weathering
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
