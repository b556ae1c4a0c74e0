"""The bake operator: a thin modal wrapper over ``bake.iter_bake`` (one step per timer tick,
progress in the window manager's progress bar and the status bar, Esc cancels between steps).
The unwrap runs in a child process and reports every tenth of a second, so the UI stays live
and Esc stops it at once; a Cycles bake holds the UI until it ends (Blender gives a script no
way to watch one). Its properties are generated from the bake's option declarations and the
map registry."""

import bpy

from ..maps import bake
from ..maps import registry as maps
from .steps import SteppedOperator, absolute_folder, generated_operator


class BakeMapsOperator(SteppedOperator):
    """Bake the weathering maps (rain exposure, edge/cavity mask, ...) of the selected meshes (Esc cancels)"""

    bl_idname = "porous_weathering.bake_maps"
    bl_label = "Bake Weathering Maps"
    bl_options = {"REGISTER", "UNDO"}

    select_message = "Select the mesh objects to bake"
    entries = staticmethod(bake.option_entries)

    def make_steps(self, values, meshes):
        values["maps"] = tuple(name for name in maps.names() if name in self.maps)
        # attribute maps need no folder: an unsaved .blend bakes them
        values["out_dir"] = absolute_folder(self.out_dir) if self.target == "image" else self.out_dir
        self._outcomes = []
        return bake.iter_bake(meshes, bake.options_from_values(values))  # refuses bad objects or folders here

    def _cancelled_message(self):
        return f"Bake cancelled after {len(self._outcomes)} map(s)"

    def _show(self, context, step):
        context.window_manager.progress_update(step.fraction)
        if context.workspace is not None:
            context.workspace.status_text_set(f"Baking {step.message}  (Esc cancels)")
        if step.outcome is not None:
            self._outcomes.append(step.outcome)
            self.report({"INFO"}, f"{step.object}: {step.map} {step.outcome.status} ({step.outcome.where})")

    def _finish(self, context, result):
        super()._finish(context, result)
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        if self.target == "image":  # what was baked before an error or Esc is linked too
            bake.link_outcomes(self._outcomes)
        return result


def operator_class():
    """The bake operator, with one property per bake option and a map set of every registered
    map (generated at registration, so a map registered before it is offered too)."""
    map_items = [(kind.name, kind.label, kind.description) for kind in maps.all_kinds()]
    chosen_maps = bpy.props.EnumProperty(
        name="Maps",
        options={"ENUM_FLAG"},
        default=set(maps.names()),
        items=map_items,
        description="Which maps to bake: the weathering modes read them (rain exposure, edge/cavity mask, ...)",
    )
    return generated_operator("PW_OT_bake_maps", BakeMapsOperator, {"maps": chosen_maps})
