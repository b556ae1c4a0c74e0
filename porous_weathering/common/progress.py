"""A one-line text progress bar on stderr, shared by the serial and the Dask bakes, and the loop
that runs a command's steps to its result (no bpy)."""

import sys
from collections.abc import Callable, Iterable
from typing import Any


def run_steps(steps: Iterable[Any], progress: Callable[[float, str], None] | None = None) -> Any:
    """Run ``steps`` (each with ``fraction``, ``message`` and ``result``) to the end, calling
    ``progress(fraction, message)`` as each starts; the last result a step carried, or None."""
    result = None
    for step in steps:
        if progress is not None:
            progress(step.fraction, step.message)
        result = step.result or result
    return result


class ProgressBar:
    """A one-line text progress bar on stderr: ``progress(fraction, message)``."""

    WIDTH = 30

    def __init__(self, label, stream=None):
        self.label, self.stream = label, stream or sys.stderr
        self._drawn = ""  # the bar's line as drawn, until it is ended

    def __call__(self, fraction, message):
        filled = int(round(fraction * self.WIDTH))
        self._drawn = f"{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {fraction:4.0%} {message:40.40}"
        self.stream.write(f"\r{self._drawn}")
        self.stream.flush()

    def print(self, line, file=None):
        """Print ``line`` (to stdout) in the bar's place, and draw the bar again after it."""
        if self._drawn:
            self.stream.write(f"\r{' ' * len(self._drawn)}\r")
            self.stream.flush()
        print(line, file=file or sys.stdout, flush=True)
        if self._drawn:
            self.stream.write(self._drawn)
            self.stream.flush()

    def finish(self):
        """End the bar's line, if one is drawn, so that what follows starts a line of its own."""
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = ""
