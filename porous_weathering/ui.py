"""Operators and panels: thin wrappers over the package's plain functions."""

import bpy

from . import material, nodes


class PW_OT_add_porous_material(bpy.types.Operator):
    """Give the active object a new porous material (SPEC 2), lit by the scene's key light or ambient"""

    bl_idname = "porous_weathering.add_porous_material"
    bl_label = "Add Porous Material"
    bl_options = {"REGISTER", "UNDO"}

    key_light: bpy.props.StringProperty(
        name="Key Light",
        description="Light whose direction the pore shadowing follows; empty for ambient (environment) lighting",
    )

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type not in {"MESH", "CURVE", "SURFACE", "META", "FONT"}:
            cls.poll_message_set("Select an object that can have materials")
            return False
        return True

    def execute(self, context):
        obj = context.active_object
        try:
            mat = material.make_porous_material(f"{obj.name} Porous", key_light=self.key_light or None)
        except ValueError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        obj.data.materials.append(mat)
        obj.active_material_index = len(obj.material_slots) - 1
        return {"FINISHED"}


class PW_PT_material(bpy.types.Panel):
    """Porous Weathering controls for the active material"""

    bl_label = "Porous Weathering"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    def draw(self, context):
        layout = self.layout
        layout.operator(PW_OT_add_porous_material.bl_idname, icon="MATERIAL")
        mat = context.material
        if mat is None or "pw_light_mode" not in mat:
            layout.label(text="Not a porous material")
            return
        layout.label(text=f"Light mode: {mat['pw_light_mode'].title()}")
        group = mat.node_tree.nodes.get("Porous")
        if group is not None:
            for name in nodes.PORE_INPUTS:
                socket = group.inputs[name]
                if not socket.is_linked:
                    layout.prop(socket, "default_value", text=name)


CLASSES = (PW_OT_add_porous_material, PW_PT_material)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
