"""The bake operator: a thin modal wrapper over ``bake.iter_bake`` (one step per timer tick,
progress in the window manager's progress bar, Esc cancels between steps).  Its properties
are generated from the bake's option declarations and the map registry."""

import bpy

from . import bake, maps, options


class BakeMapsOperator:
    """Bake the weathering maps (rain exposure, edge/cavity mask, ...) of the selected meshes (Esc cancels)"""

    bl_idname = "porous_weathering.bake_maps"
    bl_label = "Bake Weathering Maps"
    bl_options = {"REGISTER", "UNDO"}

    _steps = None
    _timer = None

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
            values = {entry.dest: getattr(self, entry.dest) for entry in bake.option_entries() if entry.option.ui}
            values["maps"] = tuple(name for name in maps.names() if name in self.maps)
            values["out_dir"] = bpy.path.abspath(self.out_dir)
            chosen = bake.options_from_values(values)
            objects = [obj for obj in context.selected_objects if obj.type == "MESH"]
            self._steps = bake.iter_bake(objects, chosen)  # refuses bad objects or folders here
        except (ValueError, OSError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self._objects, self._options = objects, chosen
        self._outcomes = []
        context.window_manager.progress_begin(0, 1)
        if bpy.app.background or context.window is None:  # no event loop: run to the end
            return self._finish(context, self._run_all(context))
        self._timer = context.window_manager.event_timer_add(0.05, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._steps.close()  # undoes the unfinished object's new lightmap UV map
            self.report({"WARNING"}, f"Bake cancelled after {len(self._outcomes)} map(s)")
            return self._finish(context, {"CANCELLED"})
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            step = next(self._steps)
        except StopIteration:
            return self._finish(context, {"FINISHED"})
        except (ValueError, OSError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return self._finish(context, {"CANCELLED"})
        self._show(context, step)
        return {"RUNNING_MODAL"}

    def _run_all(self, context):
        try:
            for step in self._steps:
                self._show(context, step)
        except (ValueError, OSError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return {"FINISHED"}

    def _show(self, context, step):
        context.window_manager.progress_update((step.index + (step.outcome is not None)) / step.total)
        if step.outcome is not None:
            self._outcomes.append(step.outcome)
            self.report({"INFO"}, f"{step.object}: {step.map} {step.outcome.status} ({step.outcome.where})")

    def _finish(self, context, result):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        if result == {"FINISHED"} and self.target == "image":
            bake.link_images(self._objects, self._options)
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
