"""Writing the glTF: the copies made what the .glb holds (``finish_copy``), the material
variants declared to Blender's glTF add-on (``variants_declared``), the user's names lent to the
copies (``borrowed_names``), and the add-on's exporter itself (``export_gltf``)."""

import os
from contextlib import contextmanager

import bpy

import numpy as np

from ..common import atomic, held_output

GLTF_ADDON = "io_scene_gltf2"
#: The add-on's lines nobody asked for: on the PyPI bpy wheel, which lacks the Draco and
#: meshoptimizer libraries a Blender install has, "ERROR" though the export asks for neither
#: compression (on 4.5's, which has Draco, "INFO Draco mesh compression is available"); and its
#: log of the export's steps ("01:45:46 | INFO: Starting glTF 2.0 export", "... Primitives
#: created: 1"), among the command's lines of the files written. Its warnings and errors pass.
ADDON_NOTES = (
    b"ERROR Draco is not available",
    b"ERROR MeshOptimizer is not available",
    b"INFO Draco mesh compression is available",
    b" | INFO: ",
)
#: WebP quality (Blender's exporter re-encodes every texture; 100 would be lossless and large).
WEBP_QUALITY = 90


def finish_copy(copy: "bpy.types.Object", uv_map: str, variant_materials: list) -> None:
    """Make a copy what the .glb holds: only the UV map the textures are on, no custom
    properties, one material slot showing the clean state, and the other variants declared
    for that slot (the glTF add-on's ``gltf2_variant_mesh_data``)."""
    mesh = copy.data
    # by name, looked up again each time: removing one invalidates the others' references
    for name in [layer.name for layer in mesh.uv_layers if layer.name != uv_map]:
        mesh.uv_layers.remove(mesh.uv_layers[name])
    for name in [attribute.name for attribute in mesh.color_attributes]:  # the masks, in the textures now
        mesh.color_attributes.remove(mesh.color_attributes[name])
    for block in (copy, mesh):
        for key in list(block.keys()):
            del block[key]
    mesh.materials.clear()
    mesh.materials.append(variant_materials[0])
    mesh.polygons.foreach_set("material_index", np.zeros(len(mesh.polygons), dtype=np.int32))
    copy.material_slots[0].link = "DATA"
    for index, material in enumerate(variant_materials):
        declared = mesh.gltf2_variant_mesh_data.add()
        declared.material_slot_index = 0
        declared.material = material
        declared.variants.add().variant.variant_idx = index


@contextmanager
def variants_declared(names):
    """The glTF add-on's variants, for the export only: its preference that enables them on,
    and the variant list (which the add-on reads from the first scene, ``bpy.data.scenes[0]``:
    no scene may be renamed meanwhile) holding ``names``; both are given back afterwards."""
    preferences = bpy.context.preferences.addons[GLTF_ADDON].preferences
    enabled = preferences.KHR_materials_variants_ui
    if not enabled:  # set only when off: setting it registers the add-on's classes again
        preferences.KHR_materials_variants_ui = True
    first = bpy.data.scenes[0]
    declared = first.gltf2_KHR_materials_variants_variants
    kept = [(item.name, item.variant_idx) for item in declared]
    active = first.gltf2_active_variant
    try:
        declared.clear()
        for index, name in enumerate(names):
            item = declared.add()
            item.variant_idx = index
            item.name = name
        yield
    finally:
        declared.clear()
        for name, index in kept:
            item = declared.add()
            item.variant_idx = index
            item.name = name
        first.gltf2_active_variant = active
        if not enabled:
            preferences.KHR_materials_variants_ui = False


#: The ``bpy.data`` collection of each kind of datablock ``borrowed_names`` names.
_COLLECTIONS = {"OBJECT": "objects", "MESH": "meshes", "MATERIAL": "materials"}


@contextmanager
def borrowed_names(wanted):
    """Give each datablock of ``wanted`` ((block, name) pairs: the copies, their meshes, the
    PBR materials) its name for the export only, so the .glb carries the user's names and never
    Blender's ".001" of a clash. A local datablock of that kind holding the name (the user's
    object, or a material "Cube clean" of an earlier export re-imported) steps aside under a
    temporary name meanwhile, and has its name back afterwards (a linked one keeps its name: a
    local block may share it). A name wanted twice (a mesh two objects share) goes to the first."""
    holders, stand_ins, given = [], [], set()  # (block, its own name)
    try:
        for block, name in wanted:
            kind = _COLLECTIONS[block.id_type]
            if (kind, name) in given:
                continue
            given.add((kind, name))
            holder = getattr(bpy.data, kind).get((name, None))
            if holder is not None and holder != block:
                holders.append((holder, name))
                holder.name = f"{name} (PW exporting)"
            stand_ins.append((block, block.name))
            block.name = name
        yield
    finally:
        for block, name in stand_ins:
            block.name = name
        for block, name in holders:
            block.name = name


def export_gltf(scene: "bpy.types.Scene", path: str, image_format: str) -> None:
    """Blender's glTF exporter on ``scene`` alone, to ``path`` (.glb)."""
    window = bpy.context.window
    shown = window.scene if window is not None else None
    settings = dict(
        filepath=path,
        export_format="GLB",
        use_active_scene=True,
        use_selection=False,
        export_apply=True,
        export_extras=True,
        export_materials="EXPORT",
        export_image_format="WEBP" if image_format == "webp" else "AUTO",
        export_cameras=False,
        export_lights=False,
        export_animations=False,
        export_skins=False,
        export_morph=False,
    )
    if image_format == "webp":
        settings["export_image_quality"] = WEBP_QUALITY
    # uncut: an interrupt waits for the exporter (seconds), so that the output is given back first
    # its output held: a failure is one line, not the add-on's traceback (Blender prints a
    # failed operator's traceback to stdout itself)
    with atomic.uncut(), held_output.held(ADDON_NOTES, shown_on_error=False):
        try:
            with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
                result = bpy.ops.export_scene.gltf(**settings)
        except RuntimeError as error:  # the add-on's traceback: its last line says what went wrong
            raise RuntimeError(f"Blender's glTF exporter could not write {path}: {_reason(error)}") from None
        finally:
            if window is not None:  # the exporter leaves the window showing the scene it exported
                window.scene = shown
    if result != {"FINISHED"} or not os.path.getsize(path):
        raise RuntimeError(f"Blender's glTF exporter did not write {path}")


def _reason(error):
    """The last line of an exception raised by a Python operator (Blender puts the whole
    traceback in the message, then "Location: ..."), without the exception's type."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip() and not line.startswith("Location:")]
    last = lines[-1] if lines else "no reason given"
    kind, colon, text = last.partition(": ")
    return text if colon and kind.replace(".", "").isidentifier() and kind[:1].isupper() else last
