"""The Condition Survey operator: a thin modal wrapper over ``survey.condition.iter_survey`` (one
step per timer tick, progress in the window manager's progress bar, Esc cancels between steps and
writes nothing). Its properties are generated from the survey's option declarations."""

from ..common import options
from ..survey import condition
from .steps import SteppedOperator, absolute_folder, generated_operator


class ConditionSurveyOperator(SteppedOperator):
    """Survey the selected meshes: each weathering pattern's area in m² at each age, and its forecast (Esc cancels)"""

    bl_idname = "porous_weathering.condition_survey"
    bl_label = "Condition Survey"
    bl_options = {"REGISTER", "UNDO"}  # as every operator here; the survey changes nothing in the file

    @classmethod
    def poll(cls, context):
        if not any(obj.type == "MESH" for obj in context.selected_objects):
            cls.poll_message_set("Select the weathered mesh objects to survey")
            return False
        return True

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        def steps():
            values = options.operator_values(self, condition.option_entries())
            values["out_dir"] = absolute_folder(values["out_dir"])
            chosen = condition.SurveyOptions(**values)
            objects = [obj for obj in context.selected_objects if obj.type == "MESH"]
            return condition.iter_survey(objects, chosen)  # refuses bad objects or folders here

        return self.start_steps(context, steps)

    def _cancelled_message(self):
        return "Condition survey cancelled: nothing was written"

    def _show(self, context, step):
        context.window_manager.progress_update(step.fraction)
        if step.result is not None:
            self.report({"INFO"}, f"Survey {step.result.status}: {step.result.csv}")


def operator_class():
    """The survey operator, with one property per survey option (generated at registration)."""
    return generated_operator("PW_OT_condition_survey", ConditionSurveyOperator, condition.option_entries())
