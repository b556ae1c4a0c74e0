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
written to temporary files in the output folder and renamed into place at the end, so a failed
or cancelled export leaves no partial file.

This module holds the options, the states, the checks and the steps of the export; the mapping
is ``mapping``, the bakes ``textures``, the .glb ``gltf`` and its sidecar ``paradata``.
"""

import json
import numbers
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import Any

import bpy

import numpy as np

from ..blender import scratch_scene
from ..common import atomic
from ..common.options import check, entries, option
from ..contracts import MODES_PROPERTY, TEMPORARY_PREFIX
from ..core import modes as weathering_modes
from ..maps import bake, lightmap
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


def format_ages(ages: Sequence[float]) -> str:
    return ",".join(f"{age:g}" for age in ages)


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
    notes: Mapping[str, Any] = field(default_factory=dict)  #: recorded as they are in the paradata

    def __post_init__(self):
        ages = tuple(self.ages)
        for age in ages:
            if not isinstance(age, numbers.Real) or isinstance(age, bool) or not 0.0 <= age <= 1.0:  # NaN fails
                raise ValueError(f"ages must be numbers in [0, 1], not {age!r}")
        object.__setattr__(self, "ages", tuple(sorted(set(map(float, ages)))))
        check(self)
        if self.size & (self.size - 1):
            raise ValueError(f"texture size must be a power of two (1024, 2048, 4096, ...), not {self.size}")
        if self.name and (os.sep in self.name or "/" in self.name):
            raise ValueError(f"the file name {self.name!r} must not contain a folder")
        if self.wet and not any(self.ages):
            raise ValueError("the wet variant shows the oldest age in the rain: give an age above 0")
        object.__setattr__(self, "notes", dict(self.notes))


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
    found = [State(CLEAN, 0.0)] + [State(f"t={age:g}", age) for age in sorted(set(ages)) if age > 0.0]
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
    found = {}
    for obj in objects:
        if obj.type != "MESH":
            raise ValueError(f"object '{obj.name}' has no mesh (its type is {obj.type}): only meshes can be exported")
        if not obj.data.polygons:
            raise ValueError(f"object '{obj.name}' has a mesh without faces: nothing to export")
        slots = [_slot(obj, index, slot.material, options.wet) for index, slot in enumerate(obj.material_slots)]
        if not slots:
            raise ValueError(f"object '{obj.name}' has no material: give it a Porous Weathering material (Make)")
        found[obj] = slots
    return found


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
    progress: Callable[[float, str], None] | None = None,
) -> ExportResult:
    """Bake the clean state, each age of ``ages`` (and a wet state) of ``objects`` to PBR
    textures of ``size``² and write ``OUT/<name>.glb`` (glTF 2.0, one material variant per
    state) and its paradata ``OUT/<name>.paradata.json`` (see the module docstring).

    ``name`` defaults to the .blend's name; ``notes`` (JSON values) go into the paradata as
    they are, e.g. who made it and from which survey; ``progress(fraction, message)`` is called
    as each step starts. Raises ValueError before anything is written when an object cannot be
    exported (not a mesh, no Porous Weathering material, ...), the .blend is not saved or an
    option is out of range; nothing is left in ``out_dir`` when the export fails."""
    options = ExportOptions(
        ages=tuple(ages),
        wet=wet,
        size=size,
        image_format=image_format,
        out_dir=out_dir,
        name=name,
        notes=notes or {},
    )
    result = None
    for step in iter_export(objects, options):
        if progress is not None:
            progress(step.fraction, step.message)
        result = step.result or result
    return result


def iter_export(objects: Sequence["bpy.types.Object"], options: ExportOptions) -> Iterator[Step]:
    """The Steps of the export, as a generator (the operator's loop); the objects, the .blend
    and the output folder are checked at once, before anything starts. Closing the generator
    early (cancel) removes everything it made; the output files are written by the last step."""
    slots = _check_objects(objects, options)
    out_dir = os.path.abspath(bpy.path.abspath(options.out_dir))
    bake.check_writable_folder(out_dir)
    return _steps(slots, options, output_path(out_dir, options.name or default_name()))


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
        scratch.write(path, variants, record)
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
            stack.push(self.made)
            # the glTF scene's name
            self.scene = scratch_scene.temporary_scene(
                self.made, f"{self.name} (Porous Weathering)", samples=BAKE_SAMPLES
            )
            self.folder = self.made.folder(prefix=TEMPORARY_PREFIX + "export_")
            stack.pop_all()
        return self

    def __exit__(self, *exc):
        return self.made.__exit__(*exc)

    # the copy and its UV map

    def copy(self, obj, slots):
        for done in self.copies:  # alone in the scene, the copy bakes without syncing the others
            if done.name in self.scene.collection.objects:
                self.scene.collection.objects.unlink(done)
        materials = [
            self.made.add(textures.bake_material(slot, f"PW Export {obj.name} {slot.index}")) for slot in slots
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

    def write(self, path, variants, record):
        """The copies, each with its variant materials, as one .glb at ``path`` and the
        paradata ``record`` beside it, both renamed into place together."""
        folder = os.path.dirname(path)
        for copy in self.copies:
            if copy.name not in self.scene.collection.objects:
                self.scene.collection.objects.link(copy)
        with ExitStack() as stack:
            stack.enter_context(gltf.variants_declared([state.name for state in variants]))
            for copy, (obj, _, _, materials) in self.copies.items():
                gltf.finish_copy(copy, self.uv_maps[obj.name][0], [materials[state.name] for state in variants])
            stack.enter_context(gltf.borrowed_names(self.copies))
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
                json.dump(record, stream, indent=2, ensure_ascii=False)
                stream.write("\n")
            with atomic.uncut():
                atomic.move_into_place(glb, path)
                atomic.move_into_place(sidecar, paradata_path(path))
