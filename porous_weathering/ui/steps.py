"""What the bake, export and survey operators share: running a generator of steps modally (one
step per timer tick, progress in the window manager's progress bar, Esc closes the generator
between steps), or to its end where there is no event loop (background, no window); starting it
with the refusals reported in one line; and the operator class generated from option entries."""

import warnings

import bpy

from ..common import options
from ..maps.provenance import OverwriteRefused


def absolute_folder(path: str) -> str:
    """An operator's folder as the file system knows it: "//" is the .blend's folder (the
    defaults "//maps/", "//export/"); ValueError, one line, when the .blend is not saved yet."""
    if path.startswith("//") and not bpy.data.filepath:
        raise ValueError(
            f"the folder {path!r} is beside the .blend ('//'), which is not saved yet: save it first, "
            "or choose an absolute folder"
        )
    return bpy.path.abspath(path)


class SteppedOperator:
    """Mixin: an operator on the selected meshes whose dialog shows its options (``entries``,
    declared once) and whose Run starts the steps ``make_steps(values, meshes)`` returns;
    subclasses say what a step shows (``_show``) and what Esc reports (``_cancelled_message``),
    and may wrap ``_finish``."""

    _steps = None
    _timer = None
    #: What the greyed-out button says while no mesh is selected.
    select_message = "Select the mesh objects"

    @staticmethod
    def entries() -> list:
        """The option entries the dialog shows (``options.option`` declarations)."""
        raise NotImplementedError

    def make_steps(self, values: dict, meshes: list):
        """The steps for the dialog's ``values`` on ``meshes``; ValueError or OSError (one line)
        before any work."""
        raise NotImplementedError

    @classmethod
    def poll(cls, context):
        if not any(obj.type == "MESH" for obj in context.selected_objects):
            cls.poll_message_set(cls.select_message)
            return False
        return True

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        meshes = [obj for obj in context.selected_objects if obj.type == "MESH"]
        return self.start_steps(context, lambda: self.make_steps(options.operator_values(self, self.entries()), meshes))

    def start_steps(self, context, make_steps):
        """Start the steps ``make_steps()`` returns; it checks the options, objects and folder
        first: a refusal or a bad value is one report, and nothing starts."""
        try:
            self._steps = make_steps()
        except OverwriteRefused as error:
            replace = ", or tick Replace" if hasattr(self, "force") else ""
            self.report({"ERROR"}, f"{error}: choose another folder or file name{replace}")
            return {"CANCELLED"}
        except (ValueError, OSError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return self.start(context)

    def start(self, context):
        context.window_manager.progress_begin(0, 1)
        if bpy.app.background or context.window is None:  # no event loop: run to the end
            return self._finish(context, self._run_all(context))
        self._timer = context.window_manager.event_timer_add(0.05, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._steps.close()  # the generator undoes what its unfinished step made
            self.report({"WARNING"}, self._cancelled_message())
            return self._finish(context, {"CANCELLED"})
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            step = self._next_step()
        except StopIteration:
            return self._finish(context, {"FINISHED"})
        except Exception as error:
            self._report_error(error)
            return self._finish(context, {"CANCELLED"})
        self._show(context, step)
        return {"RUNNING_MODAL"}

    def _run_all(self, context):
        try:
            while True:
                self._show(context, self._next_step())
        except StopIteration:
            return {"FINISHED"}
        except Exception as error:
            self._report_error(error)
            return {"CANCELLED"}

    def _report_error(self, error):
        """An error of a step, in one line; one that is not a refusal or a failure the step
        expects is a bug, said as one (what the steps before it made is kept all the same)."""
        if isinstance(error, (ValueError, OSError, RuntimeError)):
            self.report({"ERROR"}, str(error))
        else:
            self.report({"ERROR"}, f"{type(error).__name__}: {error} (a bug: please report it)")

    def _next_step(self):
        """The next Step; the warnings its work gave meanwhile (a scan set up wrongly, a material
        with no weathering mode, ...) are reported as warnings of the operator."""
        given = []
        try:
            with warnings.catch_warnings(record=True) as given:
                warnings.simplefilter("always", UserWarning)
                return next(self._steps)
        finally:
            for warning in given:
                if issubclass(warning.category, UserWarning):
                    self.report({"WARNING"}, str(warning.message))
                else:  # not meant for the user: shown where it would have been
                    warnings.showwarning(warning.message, warning.category, warning.filename, warning.lineno)

    def _finish(self, context, result):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        return result


def generated_operator(name: str, base: type, extra: dict | None = None) -> type:
    """The operator ``name`` of the mixin ``base``, with one property per option entry of
    ``base.entries()`` (the options declared once: ``options.option``) and the ``extra``
    properties, made at registration."""
    properties = {**(extra or {}), **options.operator_properties(bpy.props, base.entries())}
    return type(name, (base, bpy.types.Operator), {"__annotations__": properties, "__doc__": base.__doc__})
