"""The paradata of an export (docs/export.md, "Paradata"): what the .glb is, what it was made
from and how (the versions of the extension, Blender and its glTF add-on), the .glb's sha256,
written as a JSON sidecar beside it; and the refusal to replace a pair made from something else
(``refuse_overwrite``)."""

import datetime
import hashlib
import importlib.metadata
import json
import math
import numbers
import os
import tomllib
from collections.abc import Mapping, Sequence
from typing import Any

import bpy

from ..common import imageio
from ..common.imageio import HASH_KEY, OBJECT_KEY, SOURCE_KEY
from ..contracts import LIGHT_MODE_PROPERTY, MANIFEST
from ..maps import bake
from ..maps.provenance import OverwriteRefused, Provenance
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


def json_notes(notes: Any) -> dict:
    """The ``notes`` of an export as the paradata records them (``json_value``); ValueError
    naming ``notes`` when they are not a mapping of JSON values."""
    if not isinstance(notes, Mapping):
        raise ValueError(f"notes must be a mapping of names to JSON values, not {notes!r}")
    return json_value(notes, "notes")


def json_value(value: Any, where: str) -> Any:
    """``value`` made of what JSON holds: text, booleans, None, finite numbers (NaN and the
    infinities, which JSON has not, become None: null), lists and mappings with text keys;
    ValueError naming ``where`` for anything else (a set, an object)."""
    if value is None or isinstance(value, (str, bool)):
        return value
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, Mapping):
        for key in value:
            if not isinstance(key, str):
                raise ValueError(f"{where} must have text keys, not {key!r}")
        return {key: json_value(item, f"{where}[{key!r}]") for key, item in value.items()}
    if isinstance(value, Sequence) and not isinstance(value, (bytes, bytearray)):
        return [json_value(item, f"{where}[{index}]") for index, item in enumerate(value)]
    raise ValueError(f"{where} must hold JSON values (text, numbers, lists, mappings), not {value!r}")


def refuse_overwrite(path: str, objects: Sequence[str]) -> None:
    """Raise OverwriteRefused when the .glb ``path`` or its paradata may not be replaced by an
    export of the objects named ``objects`` from the open .blend: a pair made from another
    .blend or of other objects, a .glb changed since it was written (its sha256 is not its
    paradata's), or files this extension did not write (no paradata of its own, or not files)."""
    sidecar = paradata_path(path)
    there = [where for where in (path, sidecar) if os.path.lexists(where)]
    if not there:
        return
    for where in there:
        if os.path.islink(where) or not os.path.isfile(where):
            raise OverwriteRefused(f"{where} is not a file that Porous Weathering wrote")
    record = _read_paradata(sidecar)
    if record is None:
        raise OverwriteRefused(f"{there[0]} was not written by Porous Weathering (no paradata of its own beside it)")
    made, wanted = record["source"]["blend_file"], os.path.abspath(bpy.data.filepath)
    if not Provenance(made).yields_to(Provenance(wanted)):
        raise OverwriteRefused(f"{there[0]} was made from {made}, not from {wanted}")
    made_objects = sorted(str(item.get("name")) for item in record["objects"])
    if made_objects != sorted(objects):
        raise OverwriteRefused(
            f"{there[0]} holds the objects {', '.join(made_objects)}, not {', '.join(sorted(objects))}"
        )
    if os.path.exists(path) and record["export"].get("sha256") != sha256(path):
        raise OverwriteRefused(f"{path} was changed since Porous Weathering wrote it (its sha256 is not as recorded)")


def _read_paradata(path):
    """The paradata at ``path`` when it is one this extension wrote, else None."""
    try:
        with open(path, encoding="utf-8") as stream:
            record = json.load(stream)
        generator = record["generator"]["extension"]
        source, objects, export = record["source"]["blend_file"], record["objects"], record["export"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    mine = str(generator).startswith("Porous Weathering ")
    shaped = isinstance(source, str) and isinstance(objects, list) and isinstance(export, dict)
    return record if mine and shaped and all(isinstance(item, dict) for item in objects) else None


def sha256(path: str) -> str:
    """The sha256 of the file ``path``, in hexadecimal."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def extension_version() -> str:
    """The extension's version, from its blender_manifest.toml (beside this package), else from
    the installed distribution (``pip install .``: docs/packaging.md), else "unknown"."""
    try:
        with open(MANIFEST, "rb") as stream:
            return str(tomllib.load(stream)["version"])
    except (OSError, KeyError, tomllib.TOMLDecodeError):
        pass
    try:
        return importlib.metadata.version("porous-weathering")
    except importlib.metadata.PackageNotFoundError:
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
