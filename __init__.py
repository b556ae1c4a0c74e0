# The extension's entry point: Blender loads the folder holding blender_manifest.toml as a
# package, and the code lives in the porous_weathering package beside this file.
from .porous_weathering import register, unregister  # noqa: F401
