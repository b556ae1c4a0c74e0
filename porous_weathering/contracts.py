"""Every name that users, their files and their scripts rely on, in one place: the group node
and its sockets, the properties and attributes the extension writes, the files it makes, the
folders it ships and the exit codes of its commands (docs/api.md, docs/cli.md).

Changing a value here breaks users' .blend files, scripts or pipelines: don't, unless the
change is announced. Imports nothing of the package (every layer may import it) and no bpy.
"""

import hashlib
import os

# --- the material -----------------------------------------------------------------------------

#: The name (and label) of the group node of every Porous Weathering material.
GROUP_NODE = "Porous"
#: Material properties: the light mode ("SUN", "POINT", "AMBIENT"), the weathering modes
#: ("soiling,wet"), the preset it was made from, and the key light's name.
LIGHT_MODE_PROPERTY = "pw_light_mode"
MODES_PROPERTY = "pw_modes"
PRESET_PROPERTY = "pw_preset"
KEY_LIGHT_PROPERTY = "pw_key_light"
#: The name (and label) of the node of a material's stone structure (docs/model.md §8), and the
#: material property naming its stone (a preset key).
STONE_NODE = "Stone"
STONE_PROPERTY = "pw_stone"
#: The integer face attribute naming each face's block, where the blocks are the mesh's own
#: (``presets.MeshBlocks``, ``presets.mark_blocks``: docs/model.md §8.5).
BLOCK_ATTRIBUTE = "pw_block"
#: Node-group property: the builder version a group was built by (groups of another are rebuilt).
BUILD_VERSION_PROPERTY = "pw_build_version"


def socket_name(input_name: str) -> str:
    """The group socket of a weathering input: 'rain_map' -> 'Rain Map'."""
    return input_name.replace("_", " ").title()


# --- maps -------------------------------------------------------------------------------------


def map_attribute(map_name: str) -> str:
    """The colour attribute a map is baked into (attribute target): 'rain' -> 'pw_rain'."""
    return f"pw_{map_name}"


def map_image_property(map_name: str) -> str:
    """The object property naming the Image of a map: 'rain' -> 'pw_rain_image'."""
    return f"pw_{map_name}_image"


#: Characters that a file name cannot hold on some system (Windows refuses the most), as "_".
_TO_FILE_NAME = str.maketrans(dict.fromkeys([*map(chr, range(32)), *'<>:"/\\|?*'], "_"))


def safe_file_name(name: str) -> str:
    """``name`` as a file name any system holds: a name that cannot be one as it is has its
    unsafe characters replaced by "_" and gets "-" and the first 8 hex digits of the sha256 of
    its exact (UTF-8) text, so that names that read alike stay apart ("Wall/1" gives
    ``Wall_1-<hash>``, "Wall_1" ``Wall_1``)."""
    safe = name.translate(_TO_FILE_NAME)
    if safe != name:
        safe += "-" + hashlib.sha256(name.encode()).hexdigest()[:8]
    return safe


def map_file_name(object_name: str, map_name: str) -> str:
    """``<object>.<map>.exr``, the object's name made safe: 'Wall/1' -> 'Wall_1-<hash>.rain.exr'."""
    return f"{safe_file_name(object_name)}.{map_name}.exr"


#: Prefix of every temporary file and folder the extension makes.
TEMPORARY_PREFIX = "pw_"

# --- the extension's folders ------------------------------------------------------------------

#: The folder holding blender_manifest.toml: the repository's root, or the installed extension.
EXTENSION_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MANIFEST = os.path.join(EXTENSION_ROOT, "blender_manifest.toml")
#: The node-group asset library (built by node_groups/build_assets.py).
NODE_GROUPS_DIR = os.path.join(EXTENSION_ROOT, "node_groups")
#: The sample scenes the demo renders (shipped in the extension's zip).
SAMPLES_DIR = os.path.join(EXTENSION_ROOT, "sample_blends")

# --- exit codes of the commands (docs/cli.md) -------------------------------------------------

EXIT_OK = 0
#: A file or object failed (the others were done).
EXIT_FAILED = 1
#: Bad input (usage, options, files): nothing was done.
EXIT_USAGE = 2
#: A file made by another .blend, object or tool would have been replaced: refused.
EXIT_REFUSED = 3
#: Stopped by SIGINT / SIGTERM (128 + the signal), with nothing half-written.
EXIT_SIGINT = 130
EXIT_SIGTERM = 143


def batch_exit_code(codes) -> int:
    """The exit code of a command over several files, from each file's: 1 when one failed, else
    3 when one was refused, else 0 (docs/cli.md); the serial run and a Dask run say the same."""
    others = set(codes) - {EXIT_OK}
    return EXIT_FAILED if others - {EXIT_REFUSED} else EXIT_REFUSED if others else EXIT_OK
