"""Publish weathered states: PBR textures baked from the weathered materials, and one glTF 2.0
file per object set whose material variants (``KHR_materials_variants``) are the clean state and
each requested age, with a paradata sidecar (docs/export.md).

For every object, each state is baked on a copy of the object in a scratch scene: its own
non-overlapping UV map, or the lightmap ("PW Lightmap", made as the map bake makes it). Every
material slot's weathered material is copied in the ambient light mode (a web viewer lights
with its own environment) and an Emission probe wired to the group's outputs is baked with
Cycles (EMIT bakes are exact and cheap): "Diffuse Weight" (k_d), "Specular Weight" (k_s) with
the roughness m, and "Water Weight" for a wet state. The weights are then mapped to glTF's
metallic-roughness model with ``KHR_materials_specular`` (``pbr_from_weights``; the mapping and
its measured error are in docs/export.md) and written by Blender's own glTF exporter. The user's
objects, meshes, materials and scenes are left as they were; the .glb and its paradata are
written to temporary files in the output folder and renamed into place together at the end
(``atomic.move_into_place_together``), so a failed or cancelled export leaves no partial file
and never one of the pair without the other. The texture files live in a temporary folder
(``atomic.temporary_folder``) removed on success, error and interrupt. An existing pair made
from another .blend or object set, or not by this extension, is refused (``OverwriteRefused``)
unless ``force``.

This module holds the options, the states, the checks and the steps of the export; the mapping
is ``mapping``, the bakes ``textures``, the .glb ``gltf`` and its sidecar ``paradata``.
"""

import json
import numbers
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import Any

import bpy

import numpy as np

from ..blender import scratch_scene
from ..common import atomic
from ..common.options import check, entries, option
from ..common.progress import run_steps
from ..contracts import MODES_PROPERTY, TEMPORARY_PREFIX, safe_file_name
from ..core import modes as weathering_modes
from ..maps import bake, lightmap
from ..maps.provenance import OverwriteRefused  # noqa: F401  (raised here: docs/api.md)
from ..shading.material import object_metres_per_unit
from . import gltf, paradata, textures
from .gltf import GLTF_ADDON
from .mapping import pbr_from_weights
from .paradata import paradata_path
from .textures import BAKE_SAMPLES, DIFFUSE, SPECULAR, UNBAKED, WATER, Probe, porous_node

DEFAULT_AGES = (0.0, 0.5, 1.0)
#: Texture sizes: a power of two up to MAX_SIZE (delivery tiers 1024, 2048, 4096; never above 8192).
MIN_SIZE, MAX_SIZE = 16, 8192
#: Image formats Blender's glTF exporter writes itself (KTX2 needs an external gltfpack: docs/export.md).
IMAGE_FORMATS = ("png", "webp")
CLEAN, WET = "clean", "wet"
#: The prefix of the temporary folder of an export's texture files (``<prefix><pid>_...``).
FOLDER_PREFIX = TEMPORARY_PREFIX + "export_"
#: The longest label of a texture (``Textures``): "<object> <variant> base colour".
LONGEST_LABEL = "base colour"


def parse_ages(text: str) -> tuple[float, ...]:
    """'0,0.5,1' -> (0.0, 0.5, 1.0); ValueError naming a word that is not a number."""
    ages = []
    for word in (part.strip() for part in str(text).split(",")):
        if not word:
            continue
        try:
            ages.append(float(word))
        except ValueError:
            raise ValueError(f"ages must be numbers in [0, 1] separated by commas, not {word!r}") from None
    return tuple(ages)


def format_age(age: float) -> str:
    """The shortest text that reads back as ``age`` exactly: 0.5, 1, 0.1234561 (so that two
    ages give two names)."""
    text = repr(float(age))
    return text.removesuffix(".0")


def format_ages(ages: Sequence[float]) -> str:
    return ",".join(map(format_age, ages))


@dataclass(frozen=True)
class ExportOptions:
    """What to export (frozen; checked on creation: ValueError naming the bad field). The
    declarations generate the export operator's properties and the ``export`` command's flags."""

    ages: tuple = option(
        DEFAULT_AGES,
        label="Ages",
        ui_default=format_ages(DEFAULT_AGES),
        metavar="T,T,...",
        tooltip="Comma-separated ages t in [0, 1], each a material variant besides the clean state (t = 0)",
    )
    wet: bool = option(
        False,
        label="Wet",
        tooltip="Add a 'wet' variant: the oldest age in the rain (the wet mode over the weathered material)",
    )
    size: int = option(
        2048,
        label="Texture Size",
        flag="--size",
        low=MIN_SIZE,
        high=MAX_SIZE,
        whole=True,
        unit="texels",
        metavar="N",
        tooltip="Width and height of every texture, a power of two: 1024, 2048, 4096 (delivery tiers), at most 8192",
    )
    image_format: str = option(
        IMAGE_FORMATS[0],
        label="Images",
        flag="--image-format",
        choices=IMAGE_FORMATS,
        tooltip="png: lossless; webp: smaller files (EXT_texture_webp, lossy)",
    )
    out_dir: str = option(
        ".",
        label="Folder",
        flag="--out",
        kind="path",
        ui_default="//export/",
        metavar="DIR",
        tooltip="Folder of the .glb and its paradata (// is the .blend's folder)",
    )
    name: str | None = option(
        None,
        label="File Name",
        flag="--name",
        metavar="NAME",
        tooltip="Name of the .glb and of its paradata sidecar (default: the .blend's name)",
    )
    force: bool = option(
        False,
        label="Replace",
        tooltip="Replace a .glb and paradata made from another .blend or other objects, or not by Porous Weathering",
    )
    #: recorded in the paradata: JSON values (NaN and infinities are written as null)
    notes: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        if isinstance(self.ages, (str, bytes, Mapping)) or not isinstance(self.ages, (Sequence, np.ndarray)):
            raise ValueError(f"ages must be a sequence of numbers in [0, 1], not {self.ages!r}")
        ages = tuple(self.ages)
        for age in ages:
            if not isinstance(age, numbers.Real) or isinstance(age, bool) or not 0.0 <= age <= 1.0:  # NaN fails
                raise ValueError(f"ages must be numbers in [0, 1], not {age!r}")
        object.__setattr__(self, "ages", tuple(sorted(set(map(float, ages)))))
        if not any(self.ages):  # the clean state alone: nothing weathered to publish
            raise ValueError(
                f"ages must hold an age in (0, 1], a weathered state besides the clean one, not "
                f"{format_ages(self.ages) or 'none'} (an age below 1e-308 reads as 0)"
            )
        if not isinstance(self.size, numbers.Integral) or isinstance(self.size, bool):  # numpy's are Integral
            raise ValueError(f"size must be a whole number of texels (an int), not {self.size!r}")
        object.__setattr__(self, "size", int(self.size))
        if not isinstance(self.out_dir, (str, os.PathLike)) or not isinstance(os.fspath(self.out_dir), str):
            raise ValueError(f"out_dir must be a folder's path (a str or os.PathLike), not {self.out_dir!r}")
        object.__setattr__(self, "out_dir", os.fspath(self.out_dir))
        if self.name == "":  # the operator's empty field: the default
            object.__setattr__(self, "name", None)
        if self.name is not None:
            check_file_name(self.name)
        check(self)
        if self.size & (self.size - 1):
            raise ValueError(f"texture size must be a power of two (1024, 2048, 4096, ...), not {self.size}")
        object.__setattr__(self, "notes", paradata.json_notes(self.notes))


def check_file_name(name: Any) -> None:
    """ValueError unless ``name`` can name the .glb and its paradata: a non-empty text without
    a folder, not hidden (a leading '.': '..' would give '...glb')."""
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"name (--name) must be a file name, not {name!r}")
    if os.sep in name or "/" in name or "\0" in name:
        raise ValueError(f"name (--name) {name!r} must not contain a folder")
    if name.startswith("."):
        raise ValueError(f"name (--name) {name!r} must not start with '.': the files would be hidden")


def option_entries() -> list:
    """The export options as front ends see them (``options.Entry``)."""
    return entries(ExportOptions)


@dataclass(frozen=True)
class State:
    """One material variant: its name, the age t it shows and whether it is wet."""

    name: str
    age: float
    wet: bool = False


def states(ages: Sequence[float], wet: bool) -> list[State]:
    """The variants: the clean state, each age above 0 (``t=0.5``), and ``wet`` (the oldest age)."""
    found = [State(CLEAN, 0.0)] + [State(f"t={format_age(age)}", age) for age in sorted(set(ages)) if age > 0.0]
    if wet:
        found.append(State(WET, max(ages), wet=True))
    return found


@dataclass(frozen=True)
class Step:
    """Progress of ``iter_export``: ``stage`` ("lightmap", "bake", "textures", "write") of
    ``message`` starts at ``fraction``; the last step carries the ``result``."""

    fraction: float
    stage: str
    message: str
    result: "ExportResult | None" = None


@dataclass(frozen=True)
class ExportResult:
    path: str  #: the .glb
    paradata: str  #: its paradata sidecar (JSON)
    variants: tuple  #: variant names, in order
    objects: tuple  #: object names


# --- checks ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Slot:
    """A material slot of an exported object: its weathered material, the modes its bake
    material has (the material's, plus the modes with the water lobe for a wet variant)."""

    index: int
    material: "bpy.types.Material"
    modes: tuple


def _check_objects(objects: Sequence["bpy.types.Object"], options: ExportOptions) -> dict:
    """{object: [Slot]} of the objects to export; ValueError naming the first that cannot be
    exported, before anything is made or written."""
    if not bpy.data.filepath:
        raise ValueError("the .blend file is not saved: save it first (the paradata names the file it comes from)")
    if GLTF_ADDON not in bpy.context.preferences.addons:
        raise ValueError(f"Blender's glTF 2.0 add-on ({GLTF_ADDON}) is not enabled: enable it in the Preferences")
    if not objects:
        raise ValueError("no objects to export")
    for obj in objects:
        if obj.type != "MESH":
            raise ValueError(f"object '{obj.name}' has no mesh (its type is {obj.type}): only meshes can be exported")
    found = {}
    for obj, surface in surfaces_after_modifiers(objects).items():
        modifiers = ", ".join(modifier.name for modifier in obj.modifiers)
        if not surface.faces:
            what = f"its modifiers ({modifiers}) leave no faces" if modifiers else "its mesh has no faces"
            raise ValueError(f"object '{obj.name}': {what}: nothing to export")
        if not surface.keeps_uvs:  # the textures are baked on a UV map of the mesh, which they drop
            raise ValueError(
                f"object '{obj.name}': its modifiers ({modifiers}) leave no UV map, which the textures need: "
                "apply them, or turn off the ones that drop the UVs (Remesh)"
            )
        slots = [_slot(obj, index, slot.material, options.wet) for index, slot in enumerate(obj.material_slots)]
        if not slots:
            raise ValueError(f"object '{obj.name}' has no material: give it a Porous Weathering material (Make)")
        found[obj] = slots
    return found


@dataclass(frozen=True)
class Surface:
    """What an object's modifiers leave of its mesh: its face count, and whether a UV map of
    the mesh reaches the evaluated surface (Remesh, for one, drops every UV map)."""

    faces: int
    keeps_uvs: bool


def surfaces_after_modifiers(objects: Sequence["bpy.types.Object"]) -> dict:
    """{mesh object: Surface}, read before anything else is done: a mesh without modifiers is
    its own surface; one with modifiers is evaluated as a copy that has a UV map of its own,
    in a scratch scene (nothing of the user's is evaluated or changed)."""
    found = {obj: Surface(len(obj.data.polygons), True) for obj in objects if not obj.modifiers}
    modified = [obj for obj in objects if obj.modifiers]
    if modified:
        with scratch_scene.Ledger() as made:
            scene = scratch_scene.temporary_scene(made, "PW Export Check")
            copies = {}
            for obj in modified:
                copy = made.add(obj.copy())
                copy.data = made.add(obj.data.copy())
                copy.data.uv_layers.new(name="PW Check")
                copy.parent = None
                scene.collection.objects.link(copy)
                copies[obj] = copy
            with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
                depsgraph = bpy.context.evaluated_depsgraph_get()
            for obj, copy in copies.items():
                evaluated = copy.evaluated_get(depsgraph).data
                found[obj] = Surface(len(evaluated.polygons), len(evaluated.uv_layers) > 0)
    return {obj: found[obj] for obj in objects}


def _check_names(slots, variants, name, out_dir):
    """ValueError before any work when a name the export makes does not fit: the .glb's and
    its paradata's file names in ``out_dir``, each object's texture files (in the system's
    temporary folder: the .glb names its images after them) and its materials (Blender's
    longest name: a longer one would be cut, and two variants could clash)."""
    check_file_name(name)
    longest = len(os.fsencode(name + paradata.PARADATA_SUFFIX))
    if longest > _name_max(out_dir):
        raise ValueError(
            f"name (--name) {name!r} is too long: '{name}{paradata.PARADATA_SUFFIX}' is {longest} bytes, "
            f"at most {_name_max(out_dir)} fit a file name in {out_dir}"
        )
    id_max = bpy.types.ID.bl_rna.properties["name"].length_max - 1  # bytes, without the closing NUL
    file_max = _name_max(tempfile.gettempdir())
    longest_variant = max((state.name for state in variants), key=len)
    for obj in slots:
        material = f"{obj.name} {longest_variant}"
        texture = safe_file_name(f"{material} {LONGEST_LABEL}") + ".png"
        for what, length, most in (
            (material, len(material.encode()), id_max),
            (texture, len(texture.encode()), file_max),
        ):
            if length > most:
                raise ValueError(
                    f"object '{obj.name}': its name is too long for the export's materials and textures "
                    f"('{what}' is {length} bytes, at most {most}): rename the object"
                )


def _name_max(folder):
    """The longest file name (bytes) ``folder``'s file system takes."""
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        return 255


def _check_folder(out_dir):
    """Create ``out_dir`` if needed and write a file in it (a file system such as /proc or a
    full disk refuses what ``os.access`` allows): OSError saying why it cannot take the files."""
    try:
        bake.check_writable_folder(out_dir)
        with atomic.temporary_file(out_dir, ".glb") as probe, open(probe, "wb") as stream:
            stream.write(b"glTF")
    except OSError as error:
        reason = getattr(error.__cause__, "strerror", None) or error.strerror or str(error)
        raise OSError(f"the output folder {out_dir} (--out) cannot take the files: {reason}") from None


def _slot(obj, index, material, wet):
    where = f"object '{obj.name}', slot {index + 1}"
    if porous_node(material) is None:
        what = f"material '{material.name}'" if material else "an empty slot"
        raise ValueError(f"{where} has {what}, not a Porous Weathering material: Make one first")
    modes = tuple(mode for mode in (material.get(MODES_PROPERTY) or "").split(",") if mode)
    if wet and not weathering_modes.has_water_lobe(modes):  # the wet state adds the modes with the water lobe
        water = textures.water_modes()
        group = porous_node(material)
        masks = [item for item in weathering_modes.inputs_of(water) if item.mask]

        def fed(item):
            source = group.inputs.get(item.socket)
            return source is not None and (source.is_linked or source.default_value > 0.0)

        if masks and not any(fed(item) for item in masks):  # the water needs a map of where it is
            first = masks[0]
            raise ValueError(
                f"{where}: material '{material.name}' has no {first.socket.lower()}, which the wet variant needs "
                f"(bake the {first.map} map and Make the material again)"
            )
        modes = tuple(mode for mode in weathering_modes.names() if mode in {*modes, *water})
    return Slot(index, material, modes)


def output_path(out_dir: str, name: str) -> str:
    """``OUT/<name>.glb``; its paradata is ``OUT/<name>.paradata.json``."""
    return os.path.join(out_dir, f"{name}.glb")


def default_name() -> str:
    """The .blend file's name without its extension."""
    return os.path.splitext(os.path.basename(bpy.data.filepath))[0]


# --- the export -----------------------------------------------------------------------------


def export_variants(
    objects: Sequence["bpy.types.Object"],
    ages: Sequence[float],
    *,
    wet: bool = False,
    size: int = 2048,
    out_dir: str,
    image_format: str = "png",
    name: str | None = None,
    notes: Mapping[str, Any] | None = None,
    force: bool = False,
    progress: Callable[[float, str], None] | None = None,
) -> ExportResult:
    """Bake the clean state, each age of ``ages`` (and a wet state) of ``objects`` to PBR
    textures of ``size``² and write ``OUT/<name>.glb`` (glTF 2.0, one material variant per
    state) and its paradata ``OUT/<name>.paradata.json`` (see the module docstring).

    ``name`` defaults to the .blend's name; ``notes`` (JSON values; NaN and infinities become
    null) go into the paradata, e.g. who made it and from which survey; ``progress(fraction,
    message)`` is called as each step starts. Raises ValueError before anything is written when
    an object cannot be exported (not a mesh, no faces or no UV map after its modifiers, no
    Porous Weathering material, ...), the .blend is not saved or an option is out of range or
    of the wrong type, and OverwriteRefused (a ValueError) when ``out_dir`` holds a pair of that
    name made from another .blend or other objects, or not by this extension, unless ``force``;
    nothing is left in ``out_dir`` when the export fails."""
    options = ExportOptions(
        ages=ages,
        wet=wet,
        size=size,
        image_format=image_format,
        out_dir=out_dir,
        name=name,
        notes={} if notes is None else notes,
        force=force,
    )
    return run_steps(iter_export(objects, options), progress)


def iter_export(objects: Sequence["bpy.types.Object"], options: ExportOptions) -> Iterator[Step]:
    """The Steps of the export, as a generator (the operator's loop); the objects, the .blend
    and the output folder are checked at once, before anything starts. Closing the generator
    early (cancel) removes everything it made; the output files are written by the last step.
    A texture folder that a killed export left in the temporary folder is removed here."""
    slots = _check_objects(objects, options)
    out_dir = os.path.abspath(bpy.path.abspath(options.out_dir))
    name = options.name or default_name()
    _check_names(slots, states(options.ages, options.wet), name, out_dir)
    _check_folder(out_dir)
    path = output_path(out_dir, name)
    if not options.force:
        paradata.refuse_overwrite(path, [obj.name for obj in slots])
    atomic.remove_stale_folders(FOLDER_PREFIX)
    return _steps(slots, options, path)


def _steps(slots, options, path):
    variants = states(options.ages, options.wet)
    passes = [_passes(state) for state in variants]
    total = len(slots) * (1 + len(variants) + sum(map(len, passes))) + 1
    done = 0

    def step(stage, message):
        return Step(done / total, stage, message)

    with _Scratch(os.path.splitext(os.path.basename(path))[0], options.size) as scratch:
        for obj, object_slots in slots.items():
            yield step("lightmap", f"{obj.name}: UV map")
            copy = scratch.copy(obj, object_slots)
            done += 1
            for state, state_passes in zip(variants, passes):
                scratch.set_state(copy, state)
                weights = {}
                for pass_name in state_passes:
                    yield step("bake", f"{obj.name}: {state.name} {pass_name}")
                    weights[pass_name] = scratch.bake(copy, pass_name)
                    done += 1
                yield step("textures", f"{obj.name}: {state.name} textures")
                scratch.make_material(copy, state, weights)
                done += 1
        yield step("write", f"writing {os.path.basename(path)}")
        record = paradata.paradata(slots, options, variants, scratch.uv_maps, os.path.basename(path))
        scratch.write(path, variants, record, options.force)
    result = ExportResult(path, paradata_path(path), tuple(v.name for v in variants), tuple(o.name for o in slots))
    yield Step(1.0, "write", f"wrote {path}", result)


def _passes(state):
    return (DIFFUSE, SPECULAR, WATER) if state.wet else (DIFFUSE, SPECULAR)


class _Scratch:
    """The scratch scene of one export: copies of the objects with their bake materials, the
    textures and the PBR materials; everything it made is in its ledger, removed when it closes."""

    def __init__(self, name, size):
        self.name, self.size = name, size
        self.margin = lightmap.padding_for(size)
        self.made = scratch_scene.Ledger()
        self.copies = {}  # copy -> (original, [bake material per slot], bake image, {variant: material})
        self.uv_maps = {}  # original name -> (UV map baked on, whether the export made it)
        self.textures = {}  # original name -> Textures

    def __enter__(self):
        with ExitStack() as stack:  # a failure here removes what was made already
            self.folder = stack.enter_context(atomic.temporary_folder(FOLDER_PREFIX))
            stack.push(self.made)  # closed first: its images read the folder's files
            # the glTF scene's name
            self.scene = scratch_scene.temporary_scene(
                self.made, f"{self.name} (Porous Weathering)", samples=BAKE_SAMPLES
            )
            self.closing = stack.pop_all()
        return self

    def __exit__(self, *exc):
        return self.closing.__exit__(*exc)

    # the copy and its UV map

    def copy(self, obj, slots):
        for done in self.copies:  # alone in the scene, the copy bakes without syncing the others
            if done.name in self.scene.collection.objects:
                self.scene.collection.objects.unlink(done)
        unit = object_metres_per_unit(obj)
        materials = [
            self.made.add(textures.bake_material(slot, f"PW Export {obj.name} {slot.index}", unit)) for slot in slots
        ]
        copy = scratch_scene.placed_copy(obj, self.scene, materials[0], own_mesh=True, ledger=self.made)
        copy.data.materials.clear()
        for material in materials:
            copy.data.materials.append(material)
        for slot in copy.material_slots:
            slot.link = "DATA"
        try:
            name, made = textures.bake_uv_map(copy.data, self.size)
        except ValueError as error:  # the copy's mesh has a name of its own: say the user's
            raise ValueError(f"object '{obj.name}': {error}") from None
        self.uv_maps[obj.name] = (name, made)
        copy.data.uv_layers.active = copy.data.uv_layers[name]  # the bake's target; textures read active_render
        image = self.made.add(
            bpy.data.images.new(f"PW Export {obj.name}", self.size, self.size, alpha=True, float_buffer=True)
        )
        for material in materials:
            Probe(material).image.image = image
        self.copies[copy] = (obj, materials, image, {})
        return copy

    # baking

    def set_state(self, copy, state):
        for material in self.copies[copy][1]:
            Probe(material).set_state(state)

    def bake(self, copy, pass_name):
        """The pass's probe baked on the copy's UV map: float32 (size, size, 3), top row first,
        UNBAKED outside the UV islands and their margin."""
        _, materials, image, _ = self.copies[copy]
        for material in materials:
            Probe(material).show(pass_name)
        return scratch_scene.emit_bake(copy, image, fill=UNBAKED, margin=self.margin)[:, :, :3].copy()

    # textures and PBR materials

    def make_material(self, copy, state, weights):
        """The PBR material of ``state`` on the copy, from its baked ``weights`` (pass -> pixels)."""
        obj, _, _, materials = self.copies[copy]
        covered = weights[SPECULAR][..., 0] > UNBAKED / 2
        if not covered.any():
            raise ValueError(f"object '{obj.name}': its UV map covers no texel of a {self.size}² texture")
        water = weights.get(WATER, np.zeros_like(weights[DIFFUSE]))
        specular = weights[SPECULAR]
        base, s, roughness = pbr_from_weights(
            weights[DIFFUSE], specular[..., 0], water, specular[..., 1], specular[..., 2]
        )
        if obj.name not in self.textures:
            self.textures[obj.name] = textures.Textures(self.made, self.folder, obj.name)
        found = self.textures[obj.name]
        materials[state.name] = self.made.add(
            textures.pbr_material(
                f"{obj.name} {state.name}",
                found.colour(f"{state.name} base colour", base, covered),
                found.scalar(f"{state.name} roughness", roughness, covered),
                found.specular(f"{state.name} specular", s, covered),
            )
        )

    # writing

    def write(self, path, variants, record, force):
        """The copies, each with its variant materials, as one .glb at ``path`` and the
        paradata ``record`` beside it, both renamed into place together (unless ``force``,
        after the pair there is checked again: it may have appeared meanwhile)."""
        folder = os.path.dirname(path)
        objects = [obj.name for obj, *_ in self.copies.values()]  # before the copies borrow the names
        for copy in self.copies:
            if copy.name not in self.scene.collection.objects:
                self.scene.collection.objects.link(copy)
        with ExitStack() as stack:
            stack.enter_context(gltf.variants_declared([state.name for state in variants]))
            for copy, (obj, _, _, materials) in self.copies.items():
                gltf.finish_copy(copy, self.uv_maps[obj.name][0], [materials[state.name] for state in variants])
            stack.enter_context(gltf.borrowed_names(self._names(variants)))
            glb = stack.enter_context(atomic.temporary_file(folder, ".glb"))
            sidecar = stack.enter_context(atomic.temporary_file(folder, ".json"))
            self.scene["porous_weathering"] = {
                "kind": "visualisation",
                "paradata": os.path.basename(paradata_path(path)),
                "generator": record["generator"]["extension"],
            }
            gltf.export_gltf(self.scene, glb, record["export"]["image_format"])
            record["export"]["sha256"] = paradata.sha256(glb)
            with open(sidecar, "w", encoding="utf-8") as stream:
                written = paradata.json_value(record, "the paradata")  # a NaN input of a material: null
                json.dump(written, stream, indent=2, ensure_ascii=False, allow_nan=False)
                stream.write("\n")
            if not force:
                paradata.refuse_overwrite(path, objects)
            atomic.move_into_place_together([(glb, path), (sidecar, paradata_path(path))])

    def _names(self, variants):
        """(datablock, name) of what the .glb names: each copy and its mesh take the user's
        object's and mesh's names, each PBR material ``<object> <variant>``."""
        names = []
        for copy, (obj, _, _, materials) in self.copies.items():
            names += [(copy, obj.name), (copy.data, obj.data.name)]
            names += [(materials[state.name], f"{obj.name} {state.name}") for state in variants]
        return names
