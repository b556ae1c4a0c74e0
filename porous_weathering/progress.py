"""A one-line text progress bar on stderr, shared by the serial and the Dask bakes (no bpy)."""

import sys


class ProgressBar:
    """A one-line text progress bar on stderr: ``progress(fraction, message)``."""

    WIDTH = 30

    def __init__(self, label, stream=None):
        self.label, self.stream = label, stream or sys.stderr

    def __call__(self, fraction, message):
        filled = int(round(fraction * self.WIDTH))
        self.stream.write(
            f"\r{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {fraction:4.0%} {message:40.40}"
        )
        self.stream.flush()

    def finish(self):
        self.stream.write("\n")
