"""The Condition Survey operator: a thin modal wrapper over ``survey.condition.iter_survey`` (one
step per timer tick, progress in the window manager's progress bar, Esc cancels between steps and
writes nothing). Its properties are generated from the survey's option declarations."""

from ..survey import condition
from .steps import SteppedOperator, absolute_folder, generated_operator


class ConditionSurveyOperator(SteppedOperator):
    """Survey the selected meshes: each weathering pattern's area in m² at each age, and its forecast (Esc cancels)"""

    bl_idname = "porous_weathering.condition_survey"
    bl_label = "Condition Survey"
    bl_options = {"REGISTER", "UNDO"}  # as every operator here; the survey changes nothing in the file

    select_message = "Select the weathered mesh objects to survey"
    entries = staticmethod(condition.option_entries)

    def make_steps(self, values, meshes):
        values["out_dir"] = absolute_folder(values["out_dir"])
        return condition.iter_survey(meshes, condition.SurveyOptions(**values))  # refuses bad objects or folders here

    def _cancelled_message(self):
        return "Condition survey cancelled: nothing was written"

    def _show(self, context, step):
        context.window_manager.progress_update(step.fraction)
        if step.result is not None:
            self.report({"INFO"}, f"Survey {step.result.status}: {step.result.csv}")


def operator_class():
    """The survey operator, with one property per survey option (generated at registration)."""
    return generated_operator("PW_OT_condition_survey", ConditionSurveyOperator)
