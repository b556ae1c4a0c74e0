"""The panel's operators: Add Porous Material, Make Porous Material (the stone, light and modes
of the scene's settings, wired to the object's maps: ``linking.weathered_material_for``), Make
Efflorescence Map (the Make-map operator of the map registry's efflorescence record, a map that
is made, not baked) and Keyframe Aging. Thin: each calls the public functions of the layers below."""

import inspect
import warnings

import bpy

from ..blender import scratch_scene
from ..core import model
from ..maps import efflorescence_map, linking
from ..maps import registry as maps
from ..maps.provenance import OverwriteRefused
from ..shading import material, presets, weathering
from . import bake_operator as ops_bake
from .settings import active_material, aging_targets, clock_sockets, key_light, time_socket


class NeedsMaterialObject:
    """Operators that give the active object a material: poll for one that can have them."""

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type not in scratch_scene.GEOMETRY_TYPES:
            cls.poll_message_set("Select an object that can have materials")
            return False
        return True


def material_targets(context: "bpy.types.Context") -> "list[bpy.types.Object]":
    """What Make gives a material: the active object, then every other selected object that can
    have materials (as Bake, Export and the survey take the selected meshes), each its own; an
    object whose mesh an earlier one shares has it through that mesh's slot."""
    targets, meshes = [], set()
    for obj in (context.active_object, *context.selected_objects):
        if obj.type in scratch_scene.GEOMETRY_TYPES and obj.data.name_full not in meshes:
            targets.append(obj)
            meshes.add(obj.data.name_full)
    return targets


class PW_OT_add_porous_material(NeedsMaterialObject, bpy.types.Operator):
    """Give the active object a new porous material (docs/model.md §2), lit by the scene's key light or ambient"""

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


def _keyword_default(function, name):
    return inspect.signature(function).parameters[name].default


class PW_OT_make_efflorescence_map(bpy.types.Operator):
    """Make the active mesh's efflorescence map (brick joints or a photograph) beside the .blend, or let it follow
    the absorbed water (the run-off map); Make connects it"""

    bl_idname = "porous_weathering.make_efflorescence_map"
    bl_label = "Make Efflorescence Map"
    bl_options = {"REGISTER", "UNDO"}

    source: bpy.props.EnumProperty(
        name="From",
        description="Where the salt goes first",
        items=[
            ("BRICK_JOINTS", "Brick Joints", "Generated: along the mortar joints of a running bond on the UV map"),
            ("PHOTO", "Photograph", "A photograph of efflorescence: its brightness, denoised and normalised"),
            (
                "ABSORBED_WATER",
                "Absorbed Water",
                "The baked run-off map: salt first where most water soaks in (no file is written; a map made "
                "before stays on disk)",
            ),
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
    replace: bpy.props.BoolProperty(
        name="Replace",
        description="Replace the map file even if it was made from another .blend or object, or not by "
        "Porous Weathering (default: refuse)",
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
        if self.source == "ABSORBED_WATER":
            try:
                followed = linking.follow_fallback(obj, efflorescence_map.MAP_NAME)
            except ValueError as error:
                self.report({"ERROR"}, f"object '{obj.name}': {error}")
                return {"CANCELLED"}
            self.report({"INFO"}, f"{obj.name}: efflorescence follows the {followed} map; Make connects it")
            return {"FINISHED"}
        photo = (bpy.path.abspath(self.photo) if self.photo else "") if self.source == "PHOTO" else None
        try:
            image = efflorescence_map.MAP.make(
                obj,
                photo=photo,
                size=self.resolution,
                rows=self.rows,
                bricks_per_row=self.bricks_per_row,
                force=self.replace,
            )
        except OverwriteRefused as error:
            self.report({"ERROR"}, f"object '{obj.name}': {error}; set Replace to replace it")
            return {"CANCELLED"}
        except (ValueError, OSError) as error:
            self.report({"ERROR"}, f"object '{obj.name}': {error}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"{obj.name}: efflorescence map written to {image.filepath}")
        return {"FINISHED"}


#: The Make-map operator of each map that is made, not baked (``registry.made_kinds``).
MAKE_MAP_OPERATORS = {efflorescence_map.MAP.name: PW_OT_make_efflorescence_map}


def make_map_operators() -> list[type]:
    """The Make-map operators of the made maps, in the registry's order; KeyError naming a made
    map that has none."""
    missing = [kind.name for kind in maps.made_kinds() if kind.name not in MAKE_MAP_OPERATORS]
    if missing:
        raise KeyError(f"no Make-map operator for the made map(s) {', '.join(missing)}")
    return [MAKE_MAP_OPERATORS[kind.name] for kind in maps.made_kinds()]


def map_button(map_name: str) -> str:
    """The label of the button that makes the map ``map_name``: its Make-map operator's, else
    (a baked map) Bake Weathering Maps."""
    made = MAKE_MAP_OPERATORS.get(map_name)
    return made.bl_label if made is not None else ops_bake.BakeMapsOperator.bl_label


class MakeMaterial(NeedsMaterialObject):
    """What the two Make operators share: the scene's stone, environment, light and modes, wired to the
    object's maps; ``measured_values``/``measured_stone`` say what measured colours add."""

    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        settings = context.scene.porous_weathering
        modes = settings.modes()
        made = []  # (object, its new material, its blocks, the warnings)
        chosen = dict(  # what every object's material is made of: the panel's, found once
            preset=settings.preset(),
            key_light=key_light(context.scene, settings),
            values={**settings.weathering_values(modes), **self.measured_values(settings, modes)},
            environment=settings.environment,
            stone=self.measured_stone(settings),
            variation=settings.variation,
        )
        try:
            for obj in material_targets(context):
                masonry, blocks = settings.masonry_for(obj)
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always", model.PorousInputWarning)
                    new = linking.weathered_material_for(obj, modes, masonry=masonry, **chosen)
                made.append((obj, new, blocks, caught))
        except ValueError as error:  # nothing is given to any object: the materials made so far go
            for _, new, _, _ in made:
                bpy.data.materials.remove(new)
            self.report({"ERROR"}, f"object '{obj.name}': {error}")
            return {"CANCELLED"}
        labels = {kind.name: kind.label for kind in linking.known_maps()}
        for obj, new, blocks, caught in made:
            if blocks is not None:
                presets.write_blocks(obj, blocks)
            for warning in caught:
                self.report({"WARNING"}, str(warning.message))
            for map_name in linking.missing_maps(obj, modes):
                self.report(
                    {"WARNING"},
                    f"object '{obj.name}' has no {labels[map_name]} map: its input stays "
                    f"constant until you make it ({map_button(map_name)}) and Make again",
                )
            if obj.material_slots:
                obj.material_slots[obj.active_material_index].material = new
            else:
                obj.data.materials.append(new)
        return {"FINISHED"}

    def measured_values(self, settings, modes) -> dict:
        """Weathering inputs from measured colours: none for the plain Make."""
        return {}

    def measured_stone(self, settings) -> dict:
        """Material keywords from measured colours: none for the plain Make."""
        return {}


class PW_OT_make_material(MakeMaterial, bpy.types.Operator):
    """Give the selected objects each a porous material of the chosen stone, light and modes, wired to its maps"""

    bl_idname = "porous_weathering.make_material"
    bl_label = "Make Porous Material"


class PW_OT_make_from_colorimetry(MakeMaterial, bpy.types.Operator):
    """Make Porous Material whose clean stone, grey deposit and black crust are the measured colours at t = 1"""

    bl_idname = "porous_weathering.make_from_colorimetry"
    bl_label = "Make from Measured Colours"

    def execute(self, context):
        try:
            self._found = context.scene.porous_weathering.measured()
        except ValueError as error:
            self.report({"ERROR"}, f"measured colours: {error}")
            return {"CANCELLED"}
        return super().execute(context)

    def measured_values(self, settings, modes) -> dict:
        used = set(model.inputs_of(modes))
        return {name: value for name, value in self._found.items() if name in used}

    def measured_stone(self, settings) -> dict:
        return {name: value for name, value in self._found.items() if name not in model.WEATHERING_INPUTS}


class PW_OT_keyframe_aging(bpy.types.Operator):
    """Animate the selected objects' materials from new (time 0, first frame) to weathered (1, last) or over years"""

    bl_idname = "porous_weathering.keyframe_aging"
    bl_label = "Keyframe Aging"
    bl_options = {"REGISTER", "UNDO"}

    years: bpy.props.FloatProperty(
        name="Years",
        description="Years the frame range spans, Time following the soiling law at the environment's soot "
        "concentration; 0: Time from 0 to 1",
        default=0.0,
        min=0.0,
    )

    @classmethod
    def poll(cls, context):
        if not clock_sockets(active_material(context)):
            cls.poll_message_set("Make a weathered material first: a porous-only material does not age")
            return False
        return True

    def execute(self, context):
        scene = context.scene
        aged = aging_targets(context)
        in_years = [mat.name for mat in aged if time_socket(mat) is None]
        if self.years == 0.0 and in_years:
            self.report({"ERROR"}, f"material '{in_years[0]}' ages in years (its modes have no Time): give Years")
            return {"CANCELLED"}
        try:
            for mat in aged:
                if self.years == 0.0:
                    weathering.animate_weathering(mat, scene.frame_start, scene.frame_end)
                else:
                    weathering.animate_years(
                        mat,
                        scene.frame_start,
                        scene.frame_end,
                        self.years,
                        scene.porous_weathering.elemental_carbon(),
                    )
        except ValueError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return {"FINISHED"}
