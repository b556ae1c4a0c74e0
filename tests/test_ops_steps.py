"""The modal stepping the bake and export operators share (ops_steps.SteppedOperator), driven
with stand-in events and window manager: a timer tick runs one step, Esc closes the generator
(whose clean-up runs) and cancels, the end finishes, an error cancels with one report."""

from types import SimpleNamespace

import pytest

from porous_weathering.ui import steps as ops_steps
from porous_weathering.ui.steps import SteppedOperator


class WindowManager:
    def __init__(self):
        self.calls = []

    def progress_begin(self, low, high):
        self.calls.append("begin")

    def progress_end(self):
        self.calls.append("end")

    def event_timer_add(self, step, window):
        self.calls.append("timer")
        return "timer"

    def event_timer_remove(self, timer):
        self.calls.append("timer removed")

    def modal_handler_add(self, operator):
        self.calls.append("modal")


class Stepper(SteppedOperator):
    def __init__(self, steps):
        self._steps, self.reports, self.shown = steps, [], []

    def report(self, kind, message):
        self.reports.append((set(kind), message))

    def _show(self, context, step):
        self.shown.append(step)

    def _cancelled_message(self):
        return f"cancelled after {len(self.shown)}"


def steps(cleaned, fail_at=None):
    try:
        for index in range(3):
            if index == fail_at:
                raise ValueError("bad step")
            yield index
    finally:
        cleaned.append(True)


@pytest.fixture
def context(monkeypatch):
    """A window with an event loop (these tests run in background Blender, which has none)."""
    monkeypatch.setattr(ops_steps, "bpy", SimpleNamespace(app=SimpleNamespace(background=False)))
    return SimpleNamespace(window_manager=WindowManager(), window="window")


TIMER, ESC, MOUSE = (SimpleNamespace(type=kind) for kind in ("TIMER", "ESC", "MOUSEMOVE"))


def test_a_timer_tick_runs_one_step_and_the_end_finishes(context):
    cleaned = []
    operator = Stepper(steps(cleaned))
    assert operator.start(context) == {"RUNNING_MODAL"}
    assert operator.modal(context, MOUSE) == {"PASS_THROUGH"} and operator.shown == []
    assert [operator.modal(context, TIMER) for _ in range(3)] == [{"RUNNING_MODAL"}] * 3
    assert operator.shown == [0, 1, 2]
    assert operator.modal(context, TIMER) == {"FINISHED"} and cleaned == [True]
    assert context.window_manager.calls == ["begin", "timer", "modal", "timer removed", "end"]


def test_esc_closes_the_steps_and_cancels(context):
    cleaned = []
    operator = Stepper(steps(cleaned))
    operator.start(context)
    operator.modal(context, TIMER)
    assert operator.modal(context, ESC) == {"CANCELLED"}
    assert cleaned == [True] and operator.shown == [0]
    assert operator.reports == [({"WARNING"}, "cancelled after 1")]
    assert context.window_manager.calls[-2:] == ["timer removed", "end"]


def test_an_error_cancels_with_one_report(context):
    cleaned = []
    operator = Stepper(steps(cleaned, fail_at=1))
    operator.start(context)
    assert operator.modal(context, TIMER) == {"RUNNING_MODAL"}
    assert operator.modal(context, TIMER) == {"CANCELLED"}
    assert operator.reports == [({"ERROR"}, "bad step")] and context.window_manager.calls[-1] == "end"


def test_without_a_window_it_runs_to_the_end(context):
    context.window = None
    cleaned = []
    operator = Stepper(steps(cleaned))
    assert operator.start(context) == {"FINISHED"}
    assert operator.shown == [0, 1, 2] and cleaned == [True]
    assert context.window_manager.calls == ["begin", "end"]
