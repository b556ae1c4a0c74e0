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
"""

import datetime
import hashlib
import json
import numbers
import os
import shutil
import tempfile
import tomllib
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from typing import Any

import bpy

import numpy as np
from numpy.typing import ArrayLike

from ..blender import compat, render, scratch_scene
from ..common import imageio, interrupts
from ..common.imageio import HASH_KEY, OBJECT_KEY, SOURCE_KEY
from ..common.options import check, entries, option
from ..contracts import (
    GROUP_NODE,
    LIGHT_MODE_PROPERTY,
    MANIFEST,
    MODES_PROPERTY,
    TEMPORARY_PREFIX,
    safe_file_name,
    socket_name,
)
from ..core import model
from ..core import modes as weathering_modes
from ..core.modes.wet import WET_LEVEL
from ..core.shader_math import Graph
from ..maps import bake, lightmap
from ..shading import nodes

DEFAULT_AGES = (0.0, 0.5, 1.0)
#: Texture sizes: a power of two up to MAX_SIZE (delivery tiers 1024, 2048, 4096; never above 8192).
MIN_SIZE, MAX_SIZE = 16, 8192
#: Image formats Blender's glTF exporter writes itself (KTX2 needs an external gltfpack: docs/export.md).
IMAGE_FORMATS = ("png", "webp")
#: WebP quality (Blender's exporter re-encodes every texture; 100 would be lossless and large).
WEBP_QUALITY = 90
#: glTF's dielectric F0 at specular 1 (IOR 1.5). A specular colour factor of 1 / F0 makes
#: F0 = F90 = specularFactor: a reflectance without Fresnel rise, as the porous glossy lobe.
DIELECTRIC_F0 = 0.04
SPECULAR_COLOR_FACTOR = 1.0 / DIELECTRIC_F0
CLEAN, WET = "clean", "wet"
#: Samples per texel of the EMIT bakes (an Emission closure bakes exactly; more only averages a texel).
BAKE_SAMPLES = 1
#: What a texel holds before a bake: texels it still holds afterwards are outside every UV island.
UNBAKED = -1.0
PARADATA_SUFFIX = ".paradata.json"
PARADATA_VERSION = 1
GLTF_ADDON = "io_scene_gltf2"
#: The three probes: the group output(s) each bakes (see _Probe).
DIFFUSE, SPECULAR, WATER = "diffuse", "specular", "water"


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


# --- the mapping ----------------------------------------------------------------------------


def pbr_from_weights(
    kd: np.ndarray, ks: np.ndarray, water: np.ndarray, m: ArrayLike, water_roughness: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The glTF material of the porous weights (docs/export.md, "The mapping"), per texel:
    ``(base colour (..., 3), specular S (...), roughness (...))`` for metallic 0, a specular
    colour factor of 1 / 0.04 and a specular factor S (so F0 = F90 = S).

    ``kd`` (..., 3) is k_d, ``ks`` (...) k_s, ``water`` (..., 3) the water lobe's weight, ``m``
    the stone's roughness and ``water_roughness`` the water lobe's (Blender's and glTF's
    roughness are both perceptual: alpha = roughness²). One glossy lobe carries both:
    S = k_s + mean(water), of alpha the mean of the two alphas weighted by the lobes' weights
    squared; the base colour is k_d / (1 - S), as glTF weights the diffuse by 1 - F."""
    dtype = np.result_type(np.asarray(kd).dtype, np.float32)  # float32 textures stay float32
    kd = np.clip(np.asarray(kd, dtype=dtype), 0.0, 1.0)
    ks = np.clip(np.asarray(ks, dtype=dtype), 0.0, 1.0)
    water = np.clip(np.asarray(water, dtype=dtype), 0.0, 1.0).mean(axis=-1)
    specular = np.minimum(ks + water, 1.0)
    tiny = np.finfo(dtype).tiny
    base = np.minimum(kd / np.maximum(1.0 - specular, tiny)[..., None], 1.0)
    alpha_stone = np.clip(np.asarray(m, dtype=dtype), 0.0, 1.0) ** 2
    alpha_water = np.clip(np.asarray(water_roughness, dtype=dtype), 0.0, 1.0) ** 2
    # each lobe's error grows with its weight: weighted by the weights squared, the heavier lobe sets the shape
    squares = ks**2 + water**2
    alpha = np.where(
        squares > 0.0, (ks**2 * alpha_stone + water**2 * alpha_water) / np.maximum(squares, tiny), alpha_stone
    )
    return base, specular, np.sqrt(alpha)


def linear_to_srgb(values: ArrayLike) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of linear values in [0, 1]."""
    values = np.clip(np.asarray(values, dtype=np.result_type(np.asarray(values).dtype, np.float32)), 0.0, 1.0)
    return np.where(values <= 0.0031308, values * 12.92, 1.055 * np.power(values, 1.0 / 2.4) - 0.055)


# --- checks ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Slot:
    """A material slot of an exported object: its weathered material, the modes its bake
    material has (the material's, plus wet for a wet variant) and its group node."""

    index: int
    material: "bpy.types.Material"
    modes: tuple


def porous_node(material: "bpy.types.Material | None") -> "bpy.types.ShaderNodeGroup | None":
    """The "Porous" group node of a Porous Weathering material, or None."""
    tree = material.node_tree if material is not None else None
    node = tree.nodes.get(GROUP_NODE) if tree is not None else None
    if node is None or node.type != "GROUP" or node.node_tree is None:
        return None
    return node if {"Diffuse Weight", "Specular Weight"} <= set(node.outputs.keys()) else None


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
    if wet and model.WET not in modes:
        rain = porous_node(material).inputs.get(socket_name("rain_map"))
        if rain is None or not (rain.is_linked or rain.default_value > 0.0):
            raise ValueError(
                f"{where}: material '{material.name}' has no rain map, which the wet variant needs "
                "(bake the rain map and Make the material again)"
            )
        modes = tuple(mode for mode in weathering_modes.names() if mode in {*modes, model.WET})
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
        paradata = _paradata(slots, options, variants, scratch.uv_maps, os.path.basename(path))
        scratch.write(path, variants, paradata)
    result = ExportResult(path, paradata_path(path), tuple(v.name for v in variants), tuple(o.name for o in slots))
    yield Step(1.0, "write", f"wrote {path}", result)


def paradata_path(path: str) -> str:
    return os.path.splitext(path)[0] + PARADATA_SUFFIX


def _passes(state):
    return (DIFFUSE, SPECULAR, WATER) if state.wet else (DIFFUSE, SPECULAR)


class _Scratch:
    """The scratch scene of one export: copies of the objects with their bake materials, the
    textures and the PBR materials; everything it made is removed when it closes."""

    def __init__(self, name, size):
        self.name, self.size = name, size
        self.margin = lightmap.padding_for(size)
        self.made = {kind: [] for kind in ("objects", "meshes", "materials", "images")}
        self.copies = {}  # copy -> (original, [bake material per slot], bake image, {variant: material})
        self.uv_maps = {}  # original name -> (UV map baked on, whether the export made it)
        self.textures = {}  # original name -> _Textures

    def __enter__(self):
        self.scene = bpy.data.scenes.new(f"{self.name} (Porous Weathering)")  # the glTF scene's name
        render.use_cycles(self.scene, samples=BAKE_SAMPLES)
        self.folder = tempfile.mkdtemp(prefix=TEMPORARY_PREFIX + "export_")
        return self

    def __exit__(self, *exc):
        for kind in ("objects", "meshes", "materials", "images"):
            collection = getattr(bpy.data, kind)
            for block in self.made[kind]:
                collection.remove(block)
        bpy.data.scenes.remove(self.scene)
        shutil.rmtree(self.folder, ignore_errors=True)
        return False

    # the copy and its UV map

    def copy(self, obj, slots):
        for done in self.copies:  # alone in the scene, the copy bakes without syncing the others
            if done.name in self.scene.collection.objects:
                self.scene.collection.objects.unlink(done)
        materials = [_bake_material(slot, f"PW Export {obj.name} {slot.index}") for slot in slots]
        self.made["materials"] += materials
        copy = scratch_scene.placed_copy(obj, self.scene, materials[0], own_mesh=True)
        self.made["objects"].append(copy)
        self.made["meshes"].append(copy.data)
        copy.data.materials.clear()
        for material in materials:
            copy.data.materials.append(material)
        for slot in copy.material_slots:
            slot.link = "DATA"
        try:
            name, made = _bake_uv_map(copy.data, self.size)
        except ValueError as error:  # the copy's mesh has a name of its own: say the user's
            raise ValueError(f"object '{obj.name}': {error}") from None
        self.uv_maps[obj.name] = (name, made)
        copy.data.uv_layers.active = copy.data.uv_layers[name]  # the bake's target; textures read active_render
        image = bpy.data.images.new(f"PW Export {obj.name}", self.size, self.size, alpha=True, float_buffer=True)
        self.made["images"].append(image)
        for material in materials:
            _Probe.of(material).image.image = image
        self.copies[copy] = (obj, materials, image, {})
        return copy

    # baking

    def set_state(self, copy, state):
        for material in self.copies[copy][1]:
            _Probe.of(material).set_state(state)

    def bake(self, copy, pass_name):
        """The pass's probe baked on the copy's UV map: float32 (size, size, 3), top row first,
        UNBAKED outside the UV islands and their margin."""
        _, materials, image, _ = self.copies[copy]
        for material in materials:
            _Probe.of(material).show(pass_name)
        image.pixels.foreach_set(np.full(self.size * self.size * 4, UNBAKED, dtype=np.float32))
        with bpy.context.temp_override(**scratch_scene.only_selected(copy)):
            bpy.ops.object.bake(
                type="EMIT",
                target="IMAGE_TEXTURES",
                margin=self.margin,
                margin_type="EXTEND",
                use_clear=False,
                use_selected_to_active=False,
            )
        pixels = np.empty(self.size * self.size * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(self.size, self.size, 4)[::-1, :, :3].copy()  # Blender stores the bottom row first

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
        textures = self.textures.setdefault(obj.name, _Textures(self, obj.name))
        materials[state.name] = _pbr_material(
            f"{obj.name} {state.name}",
            textures.colour(f"{state.name} base colour", base, covered),
            textures.scalar(f"{state.name} roughness", roughness, covered),
            textures.specular(f"{state.name} specular", s, covered),
        )
        self.made["materials"].append(materials[state.name])

    # writing

    def write(self, path, variants, paradata):
        """The copies, each with its variant materials, as one .glb at ``path`` and the
        paradata beside it, both renamed into place together."""
        folder = os.path.dirname(path)
        for copy in self.copies:
            if copy.name not in self.scene.collection.objects:
                self.scene.collection.objects.link(copy)
        with ExitStack() as stack:
            stack.enter_context(_variants_declared([state.name for state in variants]))
            for copy, (obj, _, _, materials) in self.copies.items():
                _finish_copy(copy, self.uv_maps[obj.name][0], [materials[state.name] for state in variants])
            stack.enter_context(_borrowed_names(self.copies))
            glb = stack.enter_context(interrupts.temporary_file(folder, ".glb"))
            sidecar = stack.enter_context(interrupts.temporary_file(folder, ".json"))
            self.scene["porous_weathering"] = {
                "kind": "visualisation",
                "paradata": os.path.basename(paradata_path(path)),
                "generator": paradata["generator"]["extension"],
            }
            _export_gltf(self.scene, glb, paradata["export"]["image_format"])
            paradata["export"]["sha256"] = _sha256(glb)
            with open(sidecar, "w", encoding="utf-8") as stream:
                json.dump(paradata, stream, indent=2, ensure_ascii=False)
                stream.write("\n")
            with interrupts.uncut():
                interrupts.move_into_place(glb, path)
                interrupts.move_into_place(sidecar, paradata_path(path))


def _bake_uv_map(mesh, size):
    """(the UV map of ``mesh`` to bake on, whether it was made now): one that can hold a bake
    at ``size``², else a new lightmap (as the map bake makes it)."""
    existing = lightmap.find_bakeable_uv_map(mesh, size)
    if existing is not None:
        return existing, False
    if lightmap.LIGHTMAP_UV in mesh.uv_layers:
        raise ValueError(
            f"its UV map '{lightmap.LIGHTMAP_UV}' cannot hold textures of {size}²; remove or rename it to let the "
            "export make a new one"
        )
    lightmap.add_uv_map(mesh, lightmap.LIGHTMAP_UV, lightmap.lightmap_uvs(mesh, size))
    return lightmap.LIGHTMAP_UV, True


# --- the bake materials ---------------------------------------------------------------------


def _bake_material(slot, name):
    """A copy of the slot's weathered material in the ambient mode (and with the wet mode when
    the slot needs it), whose output is an Emission probe (_Probe) and whose active node is an
    Image Texture (the bake's target)."""
    material = slot.material.copy()
    material.name = name
    tree = material.node_tree
    tree.animation_data_clear()  # the key light's drivers and any keyframed age
    old = tree.nodes[GROUP_NODE]
    group = tree.nodes.new("ShaderNodeGroup")
    group.node_tree = nodes.weathered_group(slot.modes, nodes.AMBIENT)
    for socket in old.inputs:
        target = group.inputs.get(socket.name)
        if target is None:  # the key light's direction or position
            continue
        if socket.is_linked:
            tree.links.new(socket.links[0].from_socket, target)
        else:
            target.default_value = socket.default_value
    own_water_level = old.inputs[WET_LEVEL.socket].default_value if WET_LEVEL.socket in old.inputs else 1.0
    tree.nodes.remove(old)
    group.name = group.label = GROUP_NODE
    _keep_only_what_feeds(tree, group)
    _Probe.build(material, group, own_water_level)
    return material


def _keep_only_what_feeds(tree, node):
    """Remove every node of ``tree`` that does not feed ``node`` (the old output, the drivers)."""
    keep, todo = {node.name}, [node]
    while todo:
        for socket in todo.pop().inputs:
            for link in socket.links:
                if link.from_node.name not in keep:
                    keep.add(link.from_node.name)
                    todo.append(link.from_node)
    for name in [n.name for n in tree.nodes if n.name not in keep]:
        tree.nodes.remove(tree.nodes[name])


class _Probe:
    """The probe of a bake material: an Emission shader showing one pass (DIFFUSE: the Diffuse
    Weight; SPECULAR: (Specular Weight, m, water roughness); WATER: the Water Weight), and the
    state inputs (time, wet level)."""

    def __init__(self, material):
        self.material = material
        self.tree = material.node_tree
        self.group = self.tree.nodes[GROUP_NODE]
        self.emission = self.tree.nodes["PW Probe"]
        self.specular = self.tree.nodes["PW Specular"]
        self.image = self.tree.nodes["PW Target"]

    @classmethod
    def of(cls, material):
        return cls(material)

    @classmethod
    def build(cls, material, group, own_water_level):
        tree = material.node_tree
        graph = Graph(tree)
        channels = {"Red": group.outputs["Specular Weight"]}
        for channel, input_socket in (("Green", "Roughness"), ("Blue", "Water Roughness")):
            source = group.inputs.get(input_socket)
            if source is None:
                channels[channel] = 0.0
            elif source.is_linked:
                channels[channel] = source.links[0].from_socket
            else:
                channels[channel] = source.default_value
        specular = graph.node("ShaderNodeCombineColor", channels)
        specular.name = "PW Specular"
        emission = graph.node("ShaderNodeEmission", {"Color": group.outputs["Diffuse Weight"], "Strength": 1.0})
        emission.name = "PW Probe"
        output = graph.node("ShaderNodeOutputMaterial", {"Surface": emission.outputs[0]})
        output.is_active_output = True
        target = graph.node("ShaderNodeTexImage", depth=0)
        target.name = "PW Target"
        tree.nodes.active = target
        material["pw_export_wet_level"] = own_water_level

    def show(self, pass_name):
        source = {
            DIFFUSE: self.group.outputs["Diffuse Weight"],
            SPECULAR: self.specular.outputs[0],
            WATER: self.group.outputs.get("Water Weight"),
        }[pass_name]
        colour = self.emission.inputs["Color"]
        if source is None:  # a slot without the water lobe: no water
            for link in colour.links:
                self.tree.links.remove(link)
            colour.default_value = (0.0, 0.0, 0.0, 1.0)
        else:
            self.tree.links.new(source, colour)

    def set_state(self, state):
        inputs = self.group.inputs
        if socket_name("time") in inputs:
            inputs[socket_name("time")].default_value = state.age
        if WET_LEVEL.socket in inputs:
            wet_level = self.material["pw_export_wet_level"] if state.wet else 0.0
            inputs[WET_LEVEL.socket].default_value = wet_level


# --- textures and PBR materials -------------------------------------------------------------


class _Textures:
    """The textures of one object: 8-bit PNG files in the scratch folder, loaded as Images; a
    texture whose covered texels (some, always: make_material checks) are all the same code is
    a factor instead, and identical textures are one Image."""

    def __init__(self, scratch, object_name):
        self.scratch, self.object_name = scratch, object_name
        self.folder = tempfile.mkdtemp(dir=scratch.folder)
        self.images = {}  # sha256 of the codes -> Image

    def colour(self, label, linear, covered):
        """A base colour: ("factor", linear RGB) or ("texture", sRGB Image)."""
        codes = _codes(linear_to_srgb(linear), covered)
        if _uniform(codes, covered):
            return ("factor", tuple(float(v) for v in linear[covered].mean(axis=0)))
        return ("texture", self._image(label, codes, "sRGB"))

    def scalar(self, label, values, covered):
        """A roughness: ("factor", value) or ("texture", Non-Color Image, grey)."""
        codes = _codes(values[..., None], covered)
        if _uniform(codes, covered):
            return ("factor", float(values[covered].mean()))
        return ("texture", self._image(label, codes[..., 0], "Non-Color"))

    def specular(self, label, values, covered):
        """The specular factor S: ("factor", S) or ("texture", S_max, Non-Color Image whose
        alpha is S / S_max, read as glTF reads specularTexture)."""
        top = float(values[covered].max())
        codes = _codes((values / top if top > 0.0 else values)[..., None], covered)
        if top == 0.0 or _uniform(codes, covered):
            return ("factor", float(values[covered].mean()))
        rgba = np.repeat(codes, 4, axis=-1)
        return ("texture", top, self._image(label, rgba, "Non-Color"))

    def _image(self, label, codes, colorspace):
        key = hashlib.sha256(codes.tobytes() + str(codes.shape).encode() + colorspace.encode()).hexdigest()
        if key not in self.images:
            # the exporter names a glTF image after its file: "<object> <label>", in a folder per object
            path = os.path.join(self.folder, safe_file_name(f"{self.object_name} {label}") + ".png")
            _write_png(path, codes)
            image = bpy.data.images.load(path)
            image.name = f"{self.object_name} {label}"
            image.colorspace_settings.name = colorspace
            self.scratch.made["images"].append(image)
            self.images[key] = image
        return self.images[key]


def _codes(values, covered):
    """8-bit codes (H, W, C) of values in [0, 1]; texels outside the UV islands take the
    covered texels' mean (no seam colour bleeds into mipmaps, and the file compresses well)."""
    codes = np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)
    if not covered.all():
        codes[~covered] = np.round(codes[covered].mean(axis=0)).astype(np.uint8)
    return codes


def _uniform(codes, covered):
    """Whether every covered texel has the same code, within one step (the bake's rounding)."""
    inside = codes[covered].astype(np.int16)
    return bool((inside.max(axis=0) - inside.min(axis=0)).max() <= 1)


def _write_png(path, codes):
    import OpenImageIO as oiio

    codes = np.ascontiguousarray(codes if codes.ndim == 3 else codes[..., None])
    height, width, channels = codes.shape
    output = oiio.ImageOutput.create(path)
    if output is None or not output.open(path, oiio.ImageSpec(width, height, channels, oiio.UINT8)):
        raise OSError(f"cannot write the texture {path}: {oiio.geterror()}")
    written = output.write_image(codes)
    output.close()
    if not written:
        raise OSError(f"cannot write the texture {path}: {oiio.geterror()}")


def _pbr_material(name, base, roughness, specular):
    """A Principled BSDF material built as Blender's glTF importer builds one: what the
    exporter writes back as baseColor, metallicRoughness and KHR_materials_specular."""
    material = compat.new_material(name)
    tree = material.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    principled = graph.node("ShaderNodeBsdfPrincipled", depth=3)
    graph.node("ShaderNodeOutputMaterial", {"Surface": principled.outputs["BSDF"]}, depth=4)
    inputs = principled.inputs
    inputs["Metallic"].default_value = 0.0
    inputs["IOR"].default_value = 1.5
    inputs["Specular Tint"].default_value = (SPECULAR_COLOR_FACTOR,) * 3 + (1.0,)
    if base[0] == "factor":
        inputs["Base Color"].default_value = (*base[1], 1.0)
    else:
        graph.connect(_texture(graph, base[1]).outputs["Color"], inputs["Base Color"])
    if roughness[0] == "factor":
        inputs["Roughness"].default_value = roughness[1]
    else:
        channels = graph.node("ShaderNodeSeparateColor", {"Color": _texture(graph, roughness[1]).outputs["Color"]})
        graph.connect(channels.outputs["Green"], inputs["Roughness"])
    # glTF specular (F0 = F90 = S) is Blender's Specular IOR Level S / 2 (the importer's mapping)
    if specular[0] == "factor":
        inputs["Specular IOR Level"].default_value = 0.5 * specular[1]
    else:
        alpha = _texture(graph, specular[2]).outputs["Alpha"]
        level = graph.node("ShaderNodeMath", {0: alpha, 1: 0.5 * specular[1]}, operation="MULTIPLY")
        graph.connect(level.outputs[0], inputs["Specular IOR Level"])
    return material


def _texture(graph, image):
    return graph.node("ShaderNodeTexImage", depth=0, image=image, interpolation="Linear", extension="EXTEND")


# --- writing the glTF -----------------------------------------------------------------------


def _finish_copy(copy, uv_map, variant_materials):
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
def _variants_declared(names):
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


@contextmanager
def _borrowed_names(copies):
    """Give each copy (and its mesh) the name of the object (and mesh) it copies, for the
    export only: the .glb's nodes and meshes carry the user's names. A local original steps
    aside under a temporary name meanwhile (a linked one keeps its name: a local copy may share it)."""
    originals, stand_ins, seen = [], [], set()  # (block, its own name)
    try:
        for copy, (obj, *_rest) in copies.items():
            for original, stand_in in ((obj, copy), (obj.data, copy.data)):
                if original.as_pointer() in seen:  # a mesh that two objects share: its first copy has the name
                    continue
                seen.add(original.as_pointer())
                name = original.name
                if original.library is None:
                    originals.append((original, name))
                    original.name = f"{name} (PW exporting)"
                stand_ins.append((stand_in, stand_in.name))
                stand_in.name = name
        yield
    finally:
        for block, name in stand_ins:
            block.name = name
        for block, name in originals:
            block.name = name


def _export_gltf(scene, path, image_format):
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
    try:
        with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
            result = bpy.ops.export_scene.gltf(**settings)
    finally:
        if window is not None:  # the exporter leaves the window showing the scene it exported
            window.scene = shown
    if result != {"FINISHED"} or not os.path.getsize(path):
        raise RuntimeError(f"Blender's glTF exporter did not write {path}")


def _sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# --- paradata -------------------------------------------------------------------------------

#: What the paradata says the export is (London Charter, principles 4.1 and 4.6: a
#: visualisation must say what it is, what it is based on and how it was made).
STATEMENT = (
    "A computer-generated visualisation of hypothetical weathering states (soiling, wetting, salt "
    "efflorescence) of the objects, made with a physically based model of porous stone; it is not a "
    "survey and does not record the objects' observed condition."
)


def _paradata(slots, options, variants, uv_maps, file_name) -> dict:
    """The paradata of an export (docs/export.md, "Paradata")."""
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
            "gltf_exporter": ".".join(map(str, _gltf_addon_version())),
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


def extension_version() -> str:
    """The extension's version, from its blender_manifest.toml (beside this package)."""
    manifest = MANIFEST
    try:
        with open(manifest, "rb") as stream:
            return str(tomllib.load(stream)["version"])
    except (OSError, KeyError, tomllib.TOMLDecodeError):
        return "unknown"


def _gltf_addon_version():
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
