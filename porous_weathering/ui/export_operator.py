"""The export operator: a thin modal wrapper over ``export.iter_export`` (one step per timer
tick, progress in the window manager's progress bar, Esc cancels between steps and leaves
nothing behind). Its properties are generated from the export's option declarations."""

import bpy

from ..publish import export
from .steps import SteppedOperator, absolute_folder, generated_operator


class ExportVariantsOperator(SteppedOperator):
    """Publish the selected meshes' weathered states as glTF 2.0 with material variants and paradata (Esc cancels)"""

    bl_idname = "porous_weathering.export_variants"
    bl_label = "Export Weathered States (glTF)"
    bl_options = {"REGISTER", "UNDO"}  # it may add a lightmap UV map to the meshes

    select_message = "Select the mesh objects to export"
    entries = staticmethod(export.option_entries)

    @classmethod
    def poll(cls, context):
        if not super().poll(context):
            return False
        if not bpy.data.filepath:
            cls.poll_message_set("Save the .blend first: the paradata names the file it comes from")
            return False
        return True

    def make_steps(self, values, meshes):
        values["ages"] = export.parse_ages(values["ages"])
        values["out_dir"] = absolute_folder(values["out_dir"])
        return export.iter_export(meshes, export.ExportOptions(**values))  # refuses bad objects or folders here

    def _cancelled_message(self):
        return "Export cancelled: nothing was written"

    def _show(self, context, step):
        context.window_manager.progress_update(step.fraction)
        if step.result is not None:
            self.report({"INFO"}, f"Wrote {step.result.path} (variants {', '.join(step.result.variants)})")


def operator_class():
    """The export operator, with one property per export option (generated at registration)."""
    return generated_operator("PW_OT_export_variants", ExportVariantsOperator)
