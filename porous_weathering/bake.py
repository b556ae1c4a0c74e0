"""Baking the weathering maps (SPEC 5): the one pipeline behind the operator and the command line.

``iter_bake`` does the work one (object, map) step at a time, so that a caller can show
progress and stop between steps (the modal operator); ``bake_maps`` runs it to the end with
a progress callback and a cancel test. Every map is written whole or not at all:

- image maps go to ``OUT/<object>.<map>.exr`` (float, linear) through a temporary file;
- colour attributes (``pw_rain``, ``pw_edges``, per face corner) are replaced only once their
  values are baked;
- a new lightmap UV map is removed again when no map of its object could be written.

Each map carries a hash of its inputs (geometry, transforms, UVs, occluders, parameters): in
the EXR header (``pw:inputs``) or as the mesh's custom property ``<attribute>_inputs``. A map
whose stored hash matches is reported "unchanged" and not baked again.
"""

import hashlib
import json
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import bpy

import numpy as np

from . import imageio, maps, uv
from .imageio import HASH_KEY, MAP_KEY, UV_MAP_KEY  # noqa: F401  (public: docs/api.md)
from .mesh_arrays import write_corner_attribute  # noqa: F401  (public)
from .options import Entry, check, check_value, declared, entries, option, to_argv

TARGETS = ("image", "attribute")
DEFAULT_RESOLUTION = 512
#: Texels filled around every UV island (and packed between xatlas charts).
MARGIN = 4
#: Bumped when a change of the bake itself makes old maps stale.
BAKE_VERSION = 1
DEFAULT_EDGE_RADIUS = maps.edges.DEFAULT_EDGE_RADIUS


def __getattr__(name):
    """MAPS and ATTRIBUTES, read from the map registry when asked."""
    if name == "MAPS":
        return maps.names()
    if name == "ATTRIBUTES":
        return {kind.name: kind.attribute for kind in maps.all_kinds()}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class BakeCancelled(Exception):
    """The caller asked to stop; the maps finished before that are complete and kept."""


def _map_list(text):
    import argparse

    chosen = tuple(name.strip() for name in text.split(",") if name.strip())
    if not chosen or set(chosen) - set(maps.names()):
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of {', '.join(maps.names())}, got {text!r}")
    return chosen


@dataclass(frozen=True, init=False)
class BakeOptions:
    """What to bake: the general options below, and each map's settings (``settings``, by map
    name; also given and read as its ``options_field``, e.g. ``rain_settings``, or an alias
    such as ``edge_radius``).  Frozen; checked on creation: ValueError naming the bad field."""

    maps: tuple = option(
        (),
        label="Maps",
        flag="--maps",
        parse=_map_list,
        metavar="rain,edges",
        ui=False,
        tooltip="Comma-separated maps to bake (default: every map)",
    )
    target: str = option(
        "image",
        label="Target",
        flag="--target",
        choices=TARGETS,
        tooltip="image: EXR files on a lightmap UV map; attribute: per-corner colour attributes "
        "stored in the .blend (scans without UVs)",
    )
    resolution: int = option(
        DEFAULT_RESOLUTION,
        label="Resolution",
        flag="--resolution",
        low=8,
        high=16384,
        whole=True,
        unit="texels",
        metavar="N",
        tooltip="Width and height of the image maps",
    )
    out_dir: str = option(
        ".",
        label="Folder",
        flag="--out",
        kind="path",
        ui_default="//maps/",
        metavar="DIR",
        tooltip="Folder of the image maps (// is the .blend's folder)",
    )
    occluders: Any = option(
        None,
        label="Occluders",
        flag="--occluders",
        kind="collection",
        metavar="COLLECTION",
        tooltip="Collection whose objects (children included) shelter the baked objects from "
        "rain; empty: every other object of the scene",
    )
    settings: Mapping[str, Any] = field(default_factory=dict)  #: map name -> its settings

    def __init__(self, **given):
        general = {name: given.pop(name, default) for name, _, default in declared(BakeOptions)}
        settings = dict(given.pop("settings", None) or {})
        for kind in maps.all_kinds():
            settings[kind.name] = given.pop(kind.options_field, None) or settings.get(kind.name) or kind.settings()
            aliased = {name: given.pop(alias) for alias, name in kind.aliases.items() if alias in given}
            if aliased:
                settings[kind.name] = replace(settings[kind.name], **aliased)
        if given:
            raise TypeError(f"BakeOptions has no options {', '.join(sorted(given))}")
        general["maps"] = tuple(general["maps"]) if general["maps"] else maps.names()
        unknown = set(general["maps"]) - set(maps.names())
        if unknown:
            raise ValueError(f"maps must be some of {', '.join(maps.names())}, not {', '.join(general['maps'])}")
        for name, opt, _ in declared(BakeOptions):
            if name != "maps":
                check_value(opt.label.lower(), opt, general[name])
            object.__setattr__(self, name, general[name])
        for kind_settings in settings.values():  # a map's settings dataclass need not check itself
            check(kind_settings)
        object.__setattr__(self, "settings", MappingProxyType(settings))

    def __getattr__(self, name):
        settings = self.__dict__.get("settings", {})
        for kind in maps.all_kinds():
            if name == kind.options_field and kind.name in settings:
                return settings[kind.name]
            if name in kind.aliases and kind.name in settings:
                return getattr(settings[kind.name], kind.aliases[name])
        raise AttributeError(f"BakeOptions has no option {name!r}")

    def occluder_collection(self):
        """The collection whose objects shelter the baked ones, or None for every other object."""
        return occluder_collection(self.occluders)

    def to_argv(self, without=("maps",)) -> list[str]:
        """The ``bake`` command-line words that give these options but ``without`` (for the
        Dask workers, whose tasks name their maps themselves)."""
        return to_argv([entry for entry in option_entries() if entry.dest not in without], self.value)

    def value(self, entry: Entry):
        """The value of one option (a general one, or a field of a map's settings)."""
        return getattr(self.settings[entry.owner] if entry.owner else self, entry.name)


def option_entries() -> list[Entry]:
    """Every bake option as the front ends see it: the general ones, then each map's settings."""
    return entries(BakeOptions) + [item for kind in maps.all_kinds() for item in entries(kind.settings, kind.name)]


def options_from_values(values: Mapping[str, Any]) -> BakeOptions:
    """BakeOptions from front-end values keyed by Entry.dest (argparse's namespace, the
    operator's properties); entries without a value keep their defaults."""
    general, settings = {}, {}
    for entry in option_entries():
        if entry.dest not in values:
            continue
        if entry.owner is None:
            general[entry.name] = values[entry.dest]
        else:
            settings.setdefault(entry.owner, {})[entry.name] = values[entry.dest]
    return BakeOptions(
        **general, settings={name: maps.get(name).settings(**fields_) for name, fields_ in settings.items()}
    )


@dataclass(frozen=True)
class Outcome:
    object: str
    map: str
    status: str  # "written", "unchanged" (stored hash matches) or "planned" (dry run)
    where: str  # the image path or the attribute name


@dataclass(frozen=True)
class Step:
    """Progress of ``iter_bake``: step ``index`` of ``total`` starts (outcome None) or ended."""

    index: int
    total: int
    object: str
    map: str
    outcome: Outcome = None


def image_path(out_dir: str, object_name: str, map_name: str) -> str:
    safe = object_name.replace(os.sep, "_").replace(os.altsep or os.sep, "_")
    return os.path.join(out_dir, f"{safe}.{map_name}.exr")


def check_targets(objects: Sequence["bpy.types.Object"], options: BakeOptions | None = None) -> None:
    """Raise ValueError naming the first object that cannot be baked with ``options``, before
    anything is written."""
    options = options or BakeOptions()
    if not objects:
        raise ValueError("no objects to bake")
    owners = {}
    for obj in objects:
        if obj.type != "MESH":
            raise ValueError(f"object '{obj.name}' has no mesh (its type is {obj.type}): only meshes can be baked")
        if not obj.data.polygons:
            raise ValueError(f"object '{obj.name}' has a mesh without faces: nothing to bake on")
        library = obj.library or obj.data.library
        if library is not None:  # UV maps and attributes added to library data are lost on save
            raise ValueError(
                f"object '{obj.name}' is linked from the library {library.filepath}: make it local before baking"
            )
        if options.target == "attribute":
            owners.setdefault(obj.data.name, []).append(obj.name)
            if maps.EDGES.name in options.maps:
                _check_vertices_kept(obj)
    shared = next((names for names in owners.values() if len(names) > 1), None)
    if shared:  # one mesh holds one attribute: each object would overwrite the others' map
        raise ValueError(
            f"objects {', '.join(repr(n) for n in shared)} share one mesh, which can hold only "
            "one colour-attribute map: bake them to images, or make their meshes single-user"
        )


def _check_vertices_kept(obj):
    """The edge attribute is per vertex of the mesh: modifiers must not change the vertex count."""
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    if len(evaluated.data.vertices) != len(obj.data.vertices):
        raise ValueError(
            f"object '{obj.name}': its modifiers change the vertex count, so the edge attribute "
            "cannot follow its mesh; apply the modifiers or bake edges to an image"
        )


def check_writable_folder(folder):
    """Create ``folder`` if needed; raise OSError saying why it cannot take the maps."""
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        raise OSError(f"cannot create the output folder {folder}: {error.strerror}") from error
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OSError(f"the output folder {folder} is not writable")


def bake_maps(
    objects: Sequence["bpy.types.Object"],
    options: BakeOptions | None = None,
    *,
    dry_run: bool = False,
    progress: Callable[[float, str], None] | None = None,
    cancelled: Callable[[], bool] | None = None,
) -> list["Outcome"]:
    """Bake ``options.maps`` of ``objects``; returns the list of Outcomes.

    ``progress(fraction, message)`` is called before and after each step; ``cancelled()``
    is asked before each step and stops the bake with BakeCancelled when true.
    """
    outcomes = []
    for step in iter_bake(objects, options or BakeOptions(), dry_run=dry_run):
        if step.outcome is None:
            if cancelled is not None and cancelled():
                raise BakeCancelled(f"bake cancelled before {step.object}: {step.map}")
            message = f"{step.object}: {step.map}"
        else:
            outcomes.append(step.outcome)
            message = f"{step.object}: {step.map} {step.outcome.status}"
        if progress is not None:
            progress((step.index + (step.outcome is not None)) / step.total, message)
    return outcomes


def iter_bake(
    objects: Sequence["bpy.types.Object"], options: BakeOptions | None = None, *, dry_run: bool = False
) -> Iterator["Step"]:
    """The Steps of the bake, as a generator (see the module docstring). The objects and the
    output folder are checked at once, so a refusal comes before anything starts. Closing the
    generator early (cancel) undoes the lightmap UV map of the object in progress if none of
    its maps was written."""
    options = options or BakeOptions()
    check_targets(objects, options)
    options.occluder_collection()  # refuses an unknown collection name up front
    if options.target == "image" and not dry_run:
        check_writable_folder(options.out_dir)
    return _steps(objects, options, dry_run)


def _steps(objects, options, dry_run):
    digests = _Digests()
    total = len(objects) * len(options.maps)
    for number, obj in enumerate(objects):
        mesh = obj.data
        uv_map, new_uvs = _uv_map_for(mesh, options) if options.target == "image" else (None, None)
        added_uv_map = new_uvs is not None and not dry_run
        if added_uv_map:
            uv.add_uv_map(mesh, uv_map, new_uvs)
        written = False
        try:
            for offset, map_name in enumerate(options.maps):
                index = number * len(options.maps) + offset
                yield Step(index, total, obj.name, map_name)
                uvs = new_uvs if new_uvs is not None else (uv.corner_uvs(mesh, uv_map) if uv_map else None)
                inputs = _inputs_hash(obj, map_name, options, uvs, digests)
                outcome = _bake_one(obj, map_name, options, uv_map, inputs, dry_run)
                written = written or outcome.status == "written"
                yield Step(index, total, obj.name, map_name, outcome)
        except BaseException:
            if added_uv_map and not written:
                mesh.uv_layers.remove(mesh.uv_layers[uv_map])
            raise


def _uv_map_for(mesh, options):
    """(name of the UV map to bake on, per-corner UVs to add as that map or None)."""
    existing = uv.find_bakeable_uv_map(mesh, options.resolution)
    if existing is not None:
        return existing, None
    if uv.LIGHTMAP_UV in mesh.uv_layers:
        raise ValueError(
            f"mesh '{mesh.name}': its UV map '{uv.LIGHTMAP_UV}' overlaps or leaves [0, 1]; "
            f"remove or rename it to let the bake make a new one"
        )
    return uv.LIGHTMAP_UV, uv.lightmap_uvs(mesh, options.resolution, padding=MARGIN)


def _bake_one(obj, map_name, options, uv_map, inputs, dry_run):
    kind = maps.get(map_name)
    mesh = obj.data
    if options.target == "image":
        where = image_path(options.out_dir, obj.name, map_name)
        stored = imageio.read_metadata(where).get(HASH_KEY)
    else:
        where = kind.attribute
        stored = mesh.get(f"{where}_inputs") if where in mesh.color_attributes else None
    if stored == inputs:
        return Outcome(obj.name, map_name, "unchanged", where)
    if dry_run:
        return Outcome(obj.name, map_name, "planned", where)

    if options.target == "image":
        pixels = kind.bake_image(obj, uv_map, options, MARGIN)
        imageio.write_image(where, pixels, metadata={HASH_KEY: inputs, MAP_KEY: map_name, UV_MAP_KEY: uv_map})
    else:
        kind.bake_attribute(obj, options)
        mesh[f"{where}_inputs"] = inputs
    return Outcome(obj.name, map_name, "written", where)


# --- the input hash -------------------------------------------------------------------------


class _Digests:
    """Per-object geometry digests of one bake run (occluders are shared between targets)."""

    def __init__(self):
        self.depsgraph = bpy.context.evaluated_depsgraph_get()
        self._cache = {}

    def __call__(self, obj):
        if obj.name not in self._cache:
            self._cache[obj.name] = _geometry_digest(obj.evaluated_get(self.depsgraph))
        return self._cache[obj.name]


def _geometry_digest(evaluated):
    """sha256 of the evaluated mesh: world-space vertex positions and face corners."""
    mesh = evaluated.to_mesh()
    try:
        positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", positions)
        corners = np.empty(len(mesh.loops), dtype=np.int32)
        mesh.loops.foreach_get("vertex_index", corners)
        sizes = np.empty(len(mesh.polygons), dtype=np.int32)
        mesh.polygons.foreach_get("loop_total", sizes)
    finally:
        evaluated.to_mesh_clear()
    matrix = np.array(evaluated.matrix_world, dtype=np.float64)
    world = positions.reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    digest = hashlib.sha256()
    for array in (world.astype(np.float32), corners, sizes):
        digest.update(array.tobytes())
    return digest.hexdigest()


def _inputs_hash(obj, map_name, options, uvs, digests):
    inputs = {"version": BAKE_VERSION, "map": map_name, "target": options.target, "object": digests(obj)}
    if options.target == "image":
        inputs.update(
            resolution=options.resolution,
            margin=MARGIN,
            uvs=hashlib.sha256(np.ascontiguousarray(uvs, dtype=np.float32).tobytes()).hexdigest(),
        )
    inputs.update(maps.get(map_name).hash_inputs(obj, options, digests))
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


# --- linking the maps into the .blend ----------------------------------------------------------


def occluder_collection(name):
    """The collection whose objects are the rain occluders (given, or named), or None (every
    other object) for none."""
    if not name:
        return None
    if isinstance(name, bpy.types.Collection):
        return name
    if name not in bpy.data.collections:
        raise ValueError(f"no collection named '{name}' to take the occluders from")
    return bpy.data.collections[name]


def link_images(objects: Sequence["bpy.types.Object"], options: BakeOptions) -> None:
    """Point each object at its image maps: an Image per map (relative path, Non-Color) named in
    the object's custom property ``pw_<map>_image``."""
    for obj in objects:
        for map_name in options.maps:
            path = image_path(options.out_dir, obj.name, map_name)
            name = os.path.basename(path)
            image = bpy.data.images.get(name) or bpy.data.images.load(path, check_existing=True)
            image.name = name
            image.filepath = bpy.path.relpath(path)
            image.colorspace_settings.name = "Non-Color"
            image.use_fake_user = True  # an image nothing uses yet is not saved otherwise
            image.reload()
            obj[f"pw_{map_name}_image"] = image.name
