"""The paradata of an export (docs/export.md, "Paradata"): what the .glb is, what it was made
from and how (the versions of the extension, Blender and its glTF add-on), the .glb's sha256,
written as a JSON sidecar beside it."""

import datetime
import hashlib
import os
import tomllib

import bpy

from ..common import imageio
from ..common.imageio import HASH_KEY, OBJECT_KEY, SOURCE_KEY
from ..contracts import LIGHT_MODE_PROPERTY, MANIFEST
from ..maps import bake
from .gltf import GLTF_ADDON
from .textures import porous_node

PARADATA_SUFFIX = ".paradata.json"
PARADATA_VERSION = 1

#: What the paradata says the export is (London Charter, principles 4.1 and 4.6: a
#: visualisation must say what it is, what it is based on and how it was made).
STATEMENT = (
    "A computer-generated visualisation of hypothetical weathering states (soiling, wetting, salt "
    "efflorescence) of the objects, made with a physically based model of porous stone; it is not a "
    "survey and does not record the objects' observed condition."
)


def paradata_path(path: str) -> str:
    """The paradata sidecar of the .glb ``path``: ``OUT/<name>.paradata.json``."""
    return os.path.splitext(path)[0] + PARADATA_SUFFIX


def paradata(slots, options, variants, uv_maps, file_name) -> dict:
    """The paradata of an export (docs/export.md, "Paradata"): ``slots`` {object: [Slot]},
    the ``ExportOptions``, the variants (``State``), {object name: (UV map, made by the
    export)} and the .glb's file name. The .glb's sha256 is added once it is written."""
    digests = bake._Digests()
    return {
        "paradata_version": PARADATA_VERSION,
        "kind": "visualisation",
        "statement": STATEMENT,
        "practice": "The London Charter for the Computer-based Visualisation of Cultural Heritage, 2.1 (2009)",
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "generator": {
            "extension": f"Porous Weathering {extension_version()}",
            "blender": bpy.app.version_string,
            "gltf_exporter": ".".join(map(str, gltf_addon_version())),
        },
        "source": {"blend_file": os.path.abspath(bpy.data.filepath)},
        "export": {
            "file": file_name,
            "texture_size": options.size,
            "image_format": options.image_format,
            "light_mode": "ambient (the weights of an environment-lit material, seen face on)",
            "mapping": "docs/export.md: base colour k_d / (1 - S), specular F0 = F90 = S = k_s + water, "
            "roughness from the lobes' alphas",
        },
        "variants": [{"name": state.name, "age": state.age, "wet": state.wet} for state in variants],
        "objects": [
            {
                "name": obj.name,
                "geometry_sha256": digests(obj),
                "vertices": len(obj.data.vertices),
                "faces": len(obj.data.polygons),
                "uv_map": {"name": uv_maps[obj.name][0], "made_by_export": uv_maps[obj.name][1]},
                "materials": [_material_paradata(obj, slot) for slot in object_slots],
            }
            for obj, object_slots in slots.items()
        ],
        "notes": options.notes,
    }


def sha256(path: str) -> str:
    """The sha256 of the file ``path``, in hexadecimal."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def extension_version() -> str:
    """The extension's version, from its blender_manifest.toml (beside this package)."""
    manifest = MANIFEST
    try:
        with open(manifest, "rb") as stream:
            return str(tomllib.load(stream)["version"])
    except (OSError, KeyError, tomllib.TOMLDecodeError):
        return "unknown"


def gltf_addon_version() -> tuple:
    """The version of Blender's glTF add-on (its bl_info), or ("unknown",)."""
    import addon_utils

    module = next((mod for mod in addon_utils.modules() if mod.__name__ == GLTF_ADDON), None)
    return addon_utils.module_bl_info(module)["version"] if module else ("unknown",)


def _material_paradata(obj, slot):
    """The stone, the weathering inputs and the maps of a slot's weathered material."""
    group = porous_node(slot.material)
    values, maps = {}, {}
    for socket in group.inputs:
        if socket.is_linked:
            maps[socket.name] = _map_paradata(obj, socket.links[0].from_node)
        elif hasattr(socket, "default_value"):
            value = socket.default_value
            values[socket.name] = round(float(value), 6) if isinstance(value, float) else [round(v, 6) for v in value]
    return {
        "slot": slot.index + 1,
        "material": slot.material.name,
        "modes": list(slot.modes),
        "light_mode_of_the_material": slot.material.get(LIGHT_MODE_PROPERTY, "unknown"),
        "inputs": values,
        "maps": maps,
    }


def _map_paradata(obj, node):
    """What feeds a linked input: a baked colour attribute (its input hash and source) or an
    image (its file and, for a baked map, its header's input hash and source)."""
    if node.type == "ATTRIBUTE":
        name = node.attribute_name
        mesh = obj.data
        return {
            "attribute": name,
            "inputs_sha256": mesh.get(f"{name}_inputs"),
            "baked_from": mesh.get(f"{name}_source"),
            "baked_object": mesh.get(f"{name}_object"),
        }
    if node.type == "TEX_IMAGE" and node.image is not None:
        path = bpy.path.abspath(node.image.filepath, library=node.image.library) if node.image.filepath else ""
        header = imageio.read_metadata(path) if path else {}
        return {
            "image": node.image.name,
            "file": path,
            "inputs_sha256": header.get(HASH_KEY),
            "baked_from": header.get(SOURCE_KEY),
            "baked_object": header.get(OBJECT_KEY),
        }
    return {"node": node.bl_idname}
