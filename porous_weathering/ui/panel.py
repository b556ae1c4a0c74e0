"""Operators and panels: thin wrappers over the package's plain functions."""

import inspect
import warnings
from dataclasses import dataclass

import bpy

from ..blender import scratch_scene
from ..contracts import GROUP_NODE, map_image_property
from ..core import model
from ..core import modes as weathering_modes
from ..core.modes.efflorescence import EFFLORESCENCE_MAP
from ..maps import bake, efflorescence_map
from ..maps import registry as maps
from ..shading import material, presets, weathering
from . import bake_operator as ops_bake
from . import export_operator as ops_export


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
DEFAULT_SOURCE = "LIMESTONE"


def _is_light(_settings, obj):
    return obj.type == "LIGHT"


def panel_inputs() -> list[weathering_modes.Input]:
    """The weathering inputs the panel shows (``Input.panel``), each once, in socket order."""
    return [item for item in weathering_modes.inputs().values() if item.panel]


def source_weathering(source: str) -> dict:
    """{panel input: value} a stone source sets: a preset's own values, else the API defaults."""
    preset = presets.PRESETS.get(source)
    return preset.panel_weathering() if preset else {item.name: item.default for item in panel_inputs()}


def _apply_source(settings, _context):
    """Picking a stone sets the panel's weathering inputs to that stone's values."""
    for name, value in source_weathering(settings.source).items():
        setattr(settings, name, value)


class SettingsBase:
    """Porous Weathering choices of a scene: what the panel's Make button builds"""

    def modes(self):
        return tuple(mode for mode in weathering_modes.names() if getattr(self, mode))

    def weathering_values(self, modes) -> dict:
        """{input: value} of the panel's weathering inputs that ``modes`` use."""
        return {item.name: getattr(self, item.name) for item in weathering_modes.inputs_of(modes) if item.panel}


def settings_class():
    """The scene's settings: the stone, the key light, one switch per registered mode and one
    slider per weathering input the registry marks for the panel (defaults: the default stone's)."""
    properties = {
        "source": bpy.props.EnumProperty(
            name="Stone",
            description="Porous stone to start from; picking one also sets its weathering values below",
            default=DEFAULT_SOURCE,
            items=[(key, preset.label, preset.description) for key, preset in presets.PRESETS.items()]
            + [
                (
                    FROM_MATERIAL,
                    "Object's Own Material",
                    "Keep the base colour and roughness images of the object's current material",
                )
            ],
            update=_apply_source,
        ),
        "key_light": bpy.props.PointerProperty(
            name="Key Light",
            type=bpy.types.Object,
            poll=_is_light,
            description="Light whose direction the pores follow exactly; empty: the scene's strongest sun, "
            "or ambient mode (for scenes lit by a sky) when it has none",
        ),
    }
    for mode in map(weathering_modes.get, weathering_modes.names()):
        properties[mode.name] = bpy.props.BoolProperty(name=mode.label, description=mode.description)
    defaults = source_weathering(DEFAULT_SOURCE)
    for item in panel_inputs():
        properties[item.name] = bpy.props.FloatProperty(
            name=item.socket,
            description=item.tooltip,
            default=defaults[item.name],
            min=item.low,
            max=item.high,
            subtype="FACTOR",
        )
    return type(
        "PW_Settings",
        (SettingsBase, bpy.types.PropertyGroup),
        {"__annotations__": properties, "__doc__": SettingsBase.__doc__},
    )


def scene_sun(scene: "bpy.types.Scene") -> "bpy.types.Object | None":
    """The sun Make wires when the Key Light field is empty: the scene's strongest sun that
    renders (not hidden from renders, strength above 0), the first by name among equals; None
    without one (ambient mode: point, spot and area lights are never picked for the artist)."""
    suns = [
        obj
        for obj in scene.objects
        if obj.type == "LIGHT" and obj.data.type == "SUN" and not obj.hide_render and obj.data.energy > 0.0
    ]
    return max(sorted(suns, key=lambda obj: obj.name), key=lambda obj: obj.data.energy, default=None)


def key_light(scene: "bpy.types.Scene", settings) -> "bpy.types.Object | None":
    """The panel's Key Light, else the scene's sun (scene_sun)."""
    return settings.key_light or scene_sun(scene)


@dataclass(frozen=True)
class PanelMap:
    """A map the panel lists and Make connects: baked by Bake Weathering Maps, or made by a
    button of its own."""

    name: str  #: as mode inputs name it (Input.map)
    label: str
    attribute: str | None  #: the colour attribute it may be baked into
    button: str  #: the label of the button that makes it


def panel_maps() -> list[PanelMap]:
    """Every map the panel knows: the baked ones (maps registry), then the efflorescence map."""
    bake_label = ops_bake.BakeMapsOperator.bl_label
    baked = [PanelMap(kind.name, kind.label, kind.attribute, bake_label) for kind in maps.all_kinds()]
    return [*baked, PanelMap(EFFLORESCENCE_MAP.map, "Efflorescence", None, PW_OT_make_efflorescence_map.bl_label)]


def object_maps(obj):
    """{map name: source} of the maps made for ``obj``: an Image (named in its ``pw_<map>_image``
    property) or a colour attribute name."""
    found = {}
    for known in panel_maps():
        image = bpy.data.images.get(obj.get(map_image_property(known.name), ""))
        if image is not None:
            found[known.name] = image
        elif obj.type == "MESH" and known.attribute and known.attribute in obj.data.attributes:
            found[known.name] = known.attribute
    return found


def missing_maps(obj, modes):
    """The maps that ``modes`` read and ``obj`` lacks, sorted."""
    wanted = {item.map for item in weathering_modes.inputs_of(modes) if item.map}
    return sorted(wanted - set(object_maps(obj)))


def map_inputs(obj, modes):
    """{weathering input: source} of ``obj``'s maps, for each mask input ``modes`` read."""
    have = object_maps(obj)
    return {item.name: have[item.map] for item in weathering_modes.inputs_of(modes) if item.map in have}


def _keyword_default(function, name):
    return inspect.signature(function).parameters[name].default


class PW_OT_make_efflorescence_map(bpy.types.Operator):
    """Make the active mesh's efflorescence map (brick joints or a photograph) beside the .blend; Make connects it"""

    bl_idname = "porous_weathering.make_efflorescence_map"
    bl_label = "Make Efflorescence Map"
    bl_options = {"REGISTER", "UNDO"}

    source: bpy.props.EnumProperty(
        name="From",
        description="Where the salt goes first",
        items=[
            ("BRICK_JOINTS", "Brick Joints", "Generated: along the mortar joints of a running bond on the UV map"),
            ("PHOTO", "Photograph", "A photograph of efflorescence: its brightness, denoised and normalised"),
        ],
    )
    photo: bpy.props.StringProperty(
        name="Photograph", subtype="FILE_PATH", description="Image file of the efflorescence (From: Photograph)"
    )
    resolution: bpy.props.IntProperty(
        name="Resolution", default=512, min=16, max=8192, description="Width and height of the map, in pixels"
    )
    rows: bpy.props.IntProperty(
        name="Courses",
        default=_keyword_default(efflorescence_map.brick_joint_map, "rows"),
        min=1,
        max=4096,
        description="Brick courses over the UV map's height (From: Brick Joints)",
    )
    bricks_per_row: bpy.props.IntProperty(
        name="Bricks per Course",
        default=_keyword_default(efflorescence_map.brick_joint_map, "bricks_per_row"),
        min=1,
        max=4096,
        description="Bricks over the UV map's width (From: Brick Joints)",
    )

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != "MESH":
            cls.poll_message_set("Select the mesh whose efflorescence map to make")
            return False
        return True

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        obj = context.active_object
        try:
            if not obj.data.uv_layers:
                raise ValueError("has no UV map to read an efflorescence map through: unwrap it first")
            path = efflorescence_map.default_path(obj.name)
            if self.source == "PHOTO":
                if not self.photo:
                    raise ValueError("choose the photograph to make the efflorescence map from")
                height = efflorescence_map.photo_map(bpy.path.abspath(self.photo), size=self.resolution)
            else:
                height = efflorescence_map.brick_joint_map(
                    self.resolution, rows=self.rows, bricks_per_row=self.bricks_per_row
                )
            image = bake.link_image(obj, EFFLORESCENCE_MAP.map, efflorescence_map.save_map(height, path))
        except (ValueError, OSError) as error:
            self.report({"ERROR"}, f"object '{obj.name}': {error}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"{obj.name}: efflorescence map written to {image.filepath}")
        return {"FINISHED"}


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
                new = build_material(obj, settings, key_light(context.scene, settings))
        except ValueError as error:
            self.report({"ERROR"}, f"object '{obj.name}': {error}")
            return {"CANCELLED"}
        for warning in caught:
            self.report({"WARNING"}, str(warning.message))
        known = {item.name: item for item in panel_maps()}
        for map_name in missing_maps(obj, settings.modes()):
            self.report(
                {"WARNING"},
                f"object '{obj.name}' has no {known[map_name].label} map: its input stays "
                f"constant until you make it ({known[map_name].button}) and Make again",
            )
        if obj.material_slots:
            obj.material_slots[obj.active_material_index].material = new
        else:
            obj.data.materials.append(new)
        return {"FINISHED"}


def build_material(obj, settings, light):
    """The material the panel's Make button gives ``obj``, lit by ``light`` (see PW_OT_make_material)."""
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
            name,
            modes=modes,
            key_light=light,
            **params,
            **settings.weathering_values(modes),
            **map_inputs(obj, modes),
        )
    else:
        new = material.make_porous_material(name, key_light=light, **params)
    if "Roughness" in textures:
        material.connect_roughness_image(new, textures["Roughness"])
    return new


def _active_material(context):
    """The material the panel shows: the Properties editor's, else the active object's."""
    obj = context.active_object
    return getattr(context, "material", None) or (obj.active_material if obj is not None else None)


def _time_socket(mat):
    group = mat.node_tree.nodes.get(GROUP_NODE) if mat and mat.node_tree else None
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
        labels = {item.name: item.label for item in panel_maps()}
        for map_name in missing_maps(obj, settings.modes()):
            col.label(text=f"Needs the {labels[map_name]} map: make it below first", icon="ERROR")
    col.operator(PW_OT_make_material.bl_idname, icon="MATERIAL")

    col = layout.column(heading="Maps")
    have = object_maps(obj) if obj is not None else {}
    for known in panel_maps():
        where = have.get(known.name)
        text = (
            "not made yet"
            if where is None
            else ("image " + where.name if hasattr(where, "name") else "attribute " + where)
        )
        col.label(text=f"{known.label}: {text}")
    bake_button = col.operator(ops_bake.BakeMapsOperator.bl_idname, icon="RENDER_STILL")
    bake_button.maps = set(maps.names())
    col.operator(PW_OT_make_efflorescence_map.bl_idname, icon="IMAGE_DATA")

    col = layout.column(heading="Age")
    socket = _time_socket(_active_material(context))
    if socket is None:
        col.label(text="Make a weathered material to age it", icon="INFO")
    else:
        row = col.row()
        row.use_property_decorate = True
        row.prop(socket, "default_value", text="Time", slider=True)
    col.operator(PW_OT_keyframe_aging.bl_idname, icon="KEY_HLT")

    col = layout.column(heading="Publish")
    col.operator(ops_export.ExportVariantsOperator.bl_idname, icon="EXPORT")


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
        PW_OT_make_efflorescence_map,
        PW_OT_keyframe_aging,
        ops_bake.operator_class(),
        ops_export.operator_class(),
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
