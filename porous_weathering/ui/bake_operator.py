"""The bake operator: a thin modal wrapper over ``bake.iter_bake`` (one step per timer tick,
progress in the window manager's progress bar and the status bar, Esc cancels between steps).
The unwrap runs in a child process and reports every tenth of a second, so the UI stays live
and Esc stops it at once; a Cycles bake holds the UI until it ends (Blender gives a script no
way to watch one). Its properties are generated from the bake's option declarations and the
map registry."""

import warnings

import bpy

from ..common import options
from ..maps import bake
from ..maps import registry as maps
from .steps import SteppedOperator, absolute_folder


class BakeMapsOperator(SteppedOperator):
    """Bake the weathering maps (rain exposure, edge/cavity mask, ...) of the selected meshes (Esc cancels)"""

    bl_idname = "porous_weathering.bake_maps"
    bl_label = "Bake Weathering Maps"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if not any(obj.type == "MESH" for obj in context.selected_objects):
            cls.poll_message_set("Select the mesh objects to bake")
            return False
        return True

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        try:
            values = options.operator_values(self, bake.option_entries())
            values["maps"] = tuple(name for name in maps.names() if name in self.maps)
            # attribute maps need no folder: an unsaved .blend bakes them
            values["out_dir"] = absolute_folder(self.out_dir) if self.target == "image" else self.out_dir
            chosen = bake.options_from_values(values)
            objects = [obj for obj in context.selected_objects if obj.type == "MESH"]
            self._steps = bake.iter_bake(objects, chosen)  # refuses bad objects or folders here
        except (ValueError, OSError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self._objects, self._options = objects, chosen
        self._outcomes = []
        return self.start(context)

    def _cancelled_message(self):
        return f"Bake cancelled after {len(self._outcomes)} map(s)"

    def _next_step(self):
        """The next Step; the warnings the bake gave meanwhile (a scan set up wrongly, ...) are
        reported as warnings of the operator."""
        given = []
        try:
            with warnings.catch_warnings(record=True) as given:
                warnings.simplefilter("always", UserWarning)
                return super()._next_step()
        finally:
            for warning in given:
                if issubclass(warning.category, UserWarning):
                    self.report({"WARNING"}, str(warning.message))
                else:  # not meant for the user: shown where it would have been
                    warnings.showwarning(warning.message, warning.category, warning.filename, warning.lineno)

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
    properties = {
        "maps": bpy.props.EnumProperty(
            name="Maps",
            options={"ENUM_FLAG"},
            default=set(maps.names()),
            items=map_items,
            description="Which maps to bake: the weathering modes read them (rain exposure, edge/cavity mask, ...)",
        ),
        **options.operator_properties(bpy.props, bake.option_entries()),
    }
    return type(
        "PW_OT_bake_maps",
        (BakeMapsOperator, bpy.types.Operator),
        {"__annotations__": properties, "__doc__": BakeMapsOperator.__doc__},
    )


_registered = None


def register():
    """Register the bake operator alone (the add-on registers it through ui.register)."""
    global _registered
    _registered = operator_class()
    bpy.utils.register_class(_registered)


def unregister():
    bpy.utils.unregister_class(_registered)
