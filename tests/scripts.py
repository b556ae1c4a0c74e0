"""The repo's scripts that are not in a package (sample_blends/, node_groups/, ...), loaded as
modules for the tests with ``load_script``."""

import importlib.util
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent

#: Generated .blend files are saved by the oldest supported Blender line, so that every line opens them.
OLDEST_LINE = (4, 5)


def load_script(relative_path):
    """The script at ``relative_path`` (from the repository root), executed as a new module."""
    path = ROOT / relative_path
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
