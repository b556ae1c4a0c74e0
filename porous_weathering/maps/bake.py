"""Baking the weathering maps (docs/model.md §5): the one pipeline behind the operator and the command line.

``iter_bake`` does the work one (object, map) step at a time, so that a caller can show
progress and stop between steps (the modal operator); ``bake_maps`` runs it to the end with
a progress callback and a cancel test. Every map is written whole or not at all, with its
values clamped to [0, 1] (a Monte Carlo estimate of 1 can come out a little above it):

- image maps go to ``OUT/<object>.<map>.exr`` (float, linear) through a temporary file
  (``image_path``: a name that is not a file name as it is gets a hash suffix);
- colour attributes (``pw_rain``, ``pw_edges``, per face corner) are replaced only once their
  values are baked;
- a new lightmap UV map is removed again when no map of its object could be written.

Each map records what it was made from: a hash of its inputs (geometry, transforms, UVs,
occluders, parameters), the .blend file and the object (``Provenance``), in the EXR header
(``pw:inputs``, ``pw:source``, ``pw:object``, ``pw:map``) or as the mesh's custom properties
``<attribute>_inputs``, ``<attribute>_source`` and ``<attribute>_object``. A map whose stored
hash and provenance match is reported "unchanged" and not baked again. An image map made from
another .blend or object is never replaced silently: the bake is refused (``OverwriteRefused``)
unless ``force``.
"""

import hashlib
import json
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from types import MappingProxyType
from typing import Any

import bpy

import numpy as np

from ..blender import scratch_scene
from ..blender.mesh_arrays import write_corner_attribute  # noqa: F401  (public)
from ..common import atomic, imageio
from ..common.imageio import (  # noqa: F401  (public: docs/api.md)
    HASH_KEY,
    MAP_KEY,
    OBJECT_KEY,
    SETTINGS_KEY,
    SOURCE_KEY,
    UV_MAP_KEY,
    image_path,
)
from ..common.options import Entry, check, check_value, comma_words, declared, entries, folder_path, option, to_argv
from ..contracts import map_image_property
from . import edges, lightmap, rain, scan_checks
from . import registry as maps
from .provenance import ForeignInput, OverwriteRefused, Provenance, refuse_overwrite  # noqa: F401  (public: docs/api.md)

TARGETS = ("image", "attribute")
DEFAULT_RESOLUTION = 512
#: Texels filled around every UV island (the bake's margin; the lightmap's islands lie
#: ``uv.padding_for(resolution)`` texels apart).
MARGIN = 4
#: Bumped when a change of the bake itself makes old maps stale (2: the input hash holds every
#: field of a map's settings, ``MapKind.inputs``; 3: the maps of an inside-out mesh and of an
#: object far from the world's origin mended, the edge mask's grid on its samples' centre; 4: the
#: sun map by its own shadow rays, exact where nothing shadows; 5: the edge mask with the corners
#: where parts meet, ``contacts``; 6: a surface split at its seams read whole, by the edge mask
#: and the run-off (``mesh_arrays.border_places``, ``open_edges``), and geometry duplicated in
#: place read as the part alone, ``contacts.repeats_another_part``; 7: only two borders on one
#: edge are a seam, so split blocks that touch face to face stay apart).
BAKE_VERSION = 7


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

    chosen = comma_words(text)
    if not chosen or set(chosen) - set(maps.names()):
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of {', '.join(maps.names())}, got {text!r}")
    return chosen


def _in_reading_order(chosen):
    """``chosen`` in its order, but for a map that reads another one chosen too (the run-off,
    the rain): that one comes first."""
    ordered = []
    for name in chosen:
        ordered += [read for read in maps.get(name).reads if read in chosen and read not in ordered]
        ordered += [name] if name not in ordered else []
    return tuple(ordered)


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
        metavar="MAP,...",
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
        "rain and sun, and hold the ground their rising damp comes up from; empty: every other object of the scene",
    )
    settings: Mapping[str, Any] = field(default_factory=dict)  #: map name -> its settings

    def __init__(self, **given):
        general = {name: given.pop(name, default) for name, _, default in declared(BakeOptions)}
        general["out_dir"] = folder_path("out_dir", general["out_dir"])
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
        general["maps"] = _in_reading_order(general["maps"])
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

    def to_argv(self) -> list[str]:
        """The ``bake`` command-line words that give these options (for the Dask workers)."""
        return to_argv(option_entries(), self.value)

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


#: The ``Step.map`` of an object's unwrap, the step before its image maps (docs/maps.md).
LIGHTMAP_STEP = "lightmap"


@dataclass(frozen=True)
class Step:
    """Progress of ``iter_bake``: step ``index`` of ``total`` starts (outcome None) or ended.
    A long step (the unwrap, ``map`` LIGHTMAP_STEP) also reports how far it got (``part``,
    0 to 1) and what it does (``stage``)."""

    index: int
    total: int
    object: str
    map: str
    outcome: Outcome = None
    part: float = 0.0
    stage: str = ""

    @property
    def fraction(self) -> float:
        """How much of the bake is done as the step starts (or goes on), or once it ended."""
        return (self.index + (1.0 if self.outcome is not None else self.part)) / self.total

    @property
    def message(self) -> str:
        """The progress line: "<object>: <map>", with its stage, and its status once it ended."""
        stage = f": {self.stage}" if self.stage else ""
        return f"{self.object}: {self.map}{stage}" + (f" {self.outcome.status}" if self.outcome else "")


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
        if not has_faces(obj):
            raise ValueError(
                f"object '{obj.name}': its modifiers ({', '.join(m.name for m in obj.modifiers)}) leave no face: "
                "nothing to bake on; change or disable them"
            )
        if edges.surface_box(obj) is None:  # every default length is a fraction of the surface's size
            raise ValueError(f"object '{obj.name}' has no face of non-zero area: nothing to bake on")
        library = obj.library or obj.data.library
        if library is not None:  # UV maps and attributes added to library data are lost on save
            raise ValueError(
                f"object '{obj.name}' is linked from the library {library.filepath}: make it local before baking"
            )
        if options.target == "image":
            _check_uvs_kept(obj)
            for name in options.maps:
                try:
                    imageio.check_file_name(image_path(options.out_dir, obj.name, name))
                except ValueError as error:
                    raise ValueError(f"object '{obj.name}': {error}: rename the object") from None
        if options.target == "attribute":
            owners.setdefault(obj.data.name, []).append(obj.name)
            _check_corners_kept(obj)
        for name in options.maps:
            for read in maps.get(name).reads:
                if read not in options.maps:
                    _check_read(obj, name, read, options)
    shared = next((names for names in owners.values() if len(names) > 1), None)
    if shared:  # one mesh holds one attribute: each object would overwrite the others' map
        raise ValueError(
            f"objects {', '.join(repr(n) for n in shared)} share one mesh, which can hold only "
            "one colour-attribute map: bake them to images, or make their meshes single-user"
        )


def _check_read(obj, name, read, options):
    """The ``read`` map that ``obj``'s ``name`` map reads, baked before, must be ``obj``'s, from
    this .blend (ForeignInput) and of this run's settings (ValueError naming the first that
    differs): else the map would be made from something else than its header says."""
    stored = _stored(obj, read, options)
    both = f"bake both (--maps {read},{name})"
    if stored.get(HASH_KEY) is None:
        raise ValueError(
            f"object '{obj.name}': the {name} map reads the {read} map, which is neither baked "
            f"for it nor asked for: {both}"
        )
    made, wanted = Provenance.from_header(stored), Provenance.of(obj, read)
    if not made.yields_to(wanted):
        raise ForeignInput(
            f"object '{obj.name}': the {name} map would read the {read} map made from {made}, not from {wanted}: "
            f"{both}, or bake into another --out"
        )
    if SETTINGS_KEY not in stored:  # made before maps recorded their settings, or by hand: no clash
        return
    settings = json.loads(stored[SETTINGS_KEY])
    ours = json.loads(_settings_json(options, read))
    read_options = {entry.name: entry.option for entry in option_entries() if entry.owner == read}
    differing = [
        field
        for field, value in ours.items()
        if settings.get(field) != value and not (field in read_options and read_options[field].estimate)
    ]
    if differing:
        said = ", ".join(
            f"{read_options[field].flag or field} {ours[field]} (the map's: {settings.get(field, 'unknown')})"
            for field in differing
        )
        raise ValueError(
            f"object '{obj.name}': the {read} map the {name} map reads was baked with other settings: {said}; {both}"
        )


def _settings_json(options, map_name):
    """The settings of ``map_name`` in this run, as the JSON its map stores (``SETTINGS_KEY``)."""
    return json.dumps(asdict(options.settings[map_name]), sort_keys=True)


def has_faces(obj: "bpy.types.Object") -> bool:
    """Whether the mesh ``obj`` has faces, and still has some after its modifiers (a Mask or a
    Boolean can remove them all)."""
    if not obj.data.polygons:
        return False
    return bool(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.polygons)


def _check_uvs_kept(obj):
    """Image maps are baked on the evaluated surface through a UV map of the mesh: modifiers
    that drop the UV maps (Remesh, ...) leave none to bake through. A mesh without UV maps gets
    one for the test, removed again."""
    if not obj.modifiers:
        return
    mesh = obj.data
    added = None if mesh.uv_layers else mesh.uv_layers.new(name=lightmap.LIGHTMAP_UV)
    try:
        kept = bool(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.uv_layers)
    finally:
        if added is not None:
            mesh.uv_layers.remove(added)
    if not kept:
        raise ValueError(
            f"object '{obj.name}': its modifiers ({', '.join(m.name for m in obj.modifiers)}) drop its UV maps, "
            "so image maps cannot be baked through one; apply them, or bake to attributes (--target attribute)"
        )


def _check_corners_kept(obj):
    """Attribute maps are values of the mesh's vertices and corners, which the render reads
    after the modifiers: these must keep them (a Displace does; a Subdivision, Array or Bevel
    does not)."""
    if not obj.modifiers:
        return
    with scratch_scene.rendered(obj) as seen:
        scratch_scene.check_corners_kept(obj, seen)


def check_writable_folder(folder: str) -> None:
    """Create ``folder`` if needed; raise OSError saying why it cannot take the maps."""
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        raise OSError(f"cannot create the output folder {folder}: {error.strerror or error}") from error
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OSError(f"the output folder {folder} is not writable")
    with atomic.temporary_file(folder, ".exr"):  # what the maps need (root writes through modes, not into /proc)
        pass


def bake_maps(
    objects: Sequence["bpy.types.Object"],
    options: BakeOptions | None = None,
    *,
    dry_run: bool = False,
    force: bool = False,
    progress: Callable[[float, str], None] | None = None,
    cancelled: Callable[[], bool] | None = None,
) -> list["Outcome"]:
    """Bake ``options.maps`` of ``objects``; returns the list of Outcomes (see ``iter_bake``).

    ``progress(fraction, message)`` is called before and after each step (and as the unwrap
    goes on); ``cancelled()`` is asked before each map and stops the bake with BakeCancelled
    when true (to stop within an unwrap, close ``iter_bake``'s generator).
    """
    outcomes = []
    for step in iter_bake(objects, options or BakeOptions(), dry_run=dry_run, force=force):
        if step.outcome is not None:
            outcomes.append(step.outcome)
        elif step.map != LIGHTMAP_STEP and cancelled is not None and cancelled():
            raise BakeCancelled(f"bake cancelled before {step.message}")
        if progress is not None:
            progress(step.fraction, step.message)
    return outcomes


def iter_bake(
    objects: Sequence["bpy.types.Object"],
    options: BakeOptions | None = None,
    *,
    dry_run: bool = False,
    force: bool = False,
) -> Iterator["Step"]:
    """The Steps of the bake, as a generator (see the module docstring). The objects, the
    output folder and the image files the bake would replace are checked at once, so a refusal
    comes before anything starts: OverwriteRefused when a map file was made from another .blend
    or object (or is not a map), unless ``force``. For image maps each object's unwrap is a
    step of its own before its maps (``LIGHTMAP_STEP``, reporting as it goes: ``Step.part``,
    ``Step.stage``). Closing the generator early (cancel) stops an unwrap at once, and undoes
    the lightmap UV map of the object in progress if none of its maps was written."""
    options = options or BakeOptions()
    check_targets(objects, options)
    options.occluder_collection()  # refuses an unknown collection name up front
    if options.target == "image":
        if not dry_run:
            check_writable_folder(options.out_dir)
        if not force:
            for obj in objects:
                for map_name in options.maps:
                    refuse_overwrite(image_path(options.out_dir, obj.name, map_name), Provenance.of(obj, map_name))
    return _steps(objects, options, dry_run, force)


def _steps(objects, options, dry_run, force):
    digests = _Digests()
    unwraps = options.target == "image"  # each object's unwrap is a step before its maps
    per_object = len(options.maps) + unwraps
    total = len(objects) * per_object
    for number, obj in enumerate(objects):
        scan_checks.warn(obj, rain=rain.MAP.name in options.maps)
        undo = None
        if unwraps:
            uv_map, uvs, undo = yield from _unwrap(obj, options, number * per_object, total, dry_run)
        written = False
        try:
            for offset, map_name in enumerate(options.maps):
                index = number * per_object + unwraps + offset
                yield Step(index, total, obj.name, map_name)
                inputs = _inputs_hash(obj, map_name, options, uvs if unwraps else None, digests)
                outcome = _bake_one(obj, map_name, options, uv_map if unwraps else None, inputs, dry_run, force)
                written = written or outcome.status == "written"
                yield Step(index, total, obj.name, map_name, outcome)
        except BaseException:
            if undo is not None and not written:
                undo()
            raise


def _unwrap(obj, options, index, total, dry_run):
    """The unwrap step of ``obj``: its Steps while it runs (in a child process, stopped when this
    generator is closed), on the mesh its modifiers make (``lightmap.anchor``); returns (the UV
    map to bake on, its UVs at the corners of the mesh the render sees, the function undoing a
    new lightmap or None). A dry run lays out no new lightmap."""
    undo = None
    with scratch_scene.rendered(obj, lightmap.anchor(obj)) as made_on:
        ours = obj.modifiers.get(lightmap.LIGHTMAP_MODIFIER)
        unwrap = lightmap.iter_lightmap(made_on.mesh, options.resolution, replaceable=ours is not None)
        try:
            while True:
                try:
                    part, stage = next(unwrap)
                except StopIteration as done:
                    unwrapped = done.value
                    break
                yield Step(index, total, obj.name, LIGHTMAP_STEP, part=part, stage=stage)
        except lightmap.LightmapError as error:
            raise ValueError(f"object '{obj.name}': cannot make a lightmap: {error}") from error
        finally:
            unwrap.close()
        if unwrapped.uvs is not None and not dry_run:
            undo = lightmap.lay_out(obj, made_on, unwrapped.uvs)
    made = "new" if unwrapped.uvs is not None else "reused"
    stage = f"'{unwrapped.name}' ({made}, {unwrapped.report.utilisation:.0%} used)"
    try:
        yield Step(index, total, obj.name, LIGHTMAP_STEP, part=1.0, stage=stage)
        if dry_run and unwrapped.uvs is not None:
            return unwrapped.name, unwrapped.uvs, None
        with scratch_scene.rendered(obj) as seen:
            return unwrapped.name, lightmap.corner_uvs(seen.mesh, unwrapped.name), undo
    except BaseException:
        if undo is not None:
            undo()
        raise


def _bake_one(obj, map_name, options, uv_map, inputs, dry_run, force):
    kind = maps.get(map_name)
    mesh = obj.data
    made = Provenance.of(obj, map_name)
    if options.target == "image":
        where = image_path(options.out_dir, obj.name, map_name)
        header = imageio.read_metadata(where)
        unchanged = header.get(HASH_KEY) == inputs and Provenance.from_header(header) == made
    else:
        where = kind.attribute
        unchanged = where in mesh.color_attributes and mesh.get(f"{where}_inputs") == inputs
    if unchanged:
        return Outcome(obj.name, map_name, "unchanged", where)
    if dry_run:
        return Outcome(obj.name, map_name, "planned", where)

    try:  # NaN or an infinity in a map is a bug: refused, the old map kept
        if options.target == "image":
            pixels = kind.bake_image(obj, uv_map, options, MARGIN)
            imageio.check_finite(pixels, where)  # before the clip, which keeps NaN and makes inf 1
            if not force:  # the file as it is now: another run may have written it meanwhile
                refuse_overwrite(where, made)
            settings = _settings_json(options, map_name)
            metadata = {HASH_KEY: inputs, UV_MAP_KEY: uv_map, SETTINGS_KEY: settings, **made.header()}
            imageio.write_image(where, np.clip(pixels, 0.0, 1.0), metadata=metadata)
        else:
            kind.bake_attribute(obj, options)
    except imageio.NonFiniteMap as error:
        raise imageio.NonFiniteMap(f"object '{obj.name}', {kind.label.lower()} map: {error}") from None
    if options.target == "attribute":
        _clamp_attribute(mesh.color_attributes[where])
        mesh[f"{where}_inputs"] = inputs
        mesh[f"{where}_source"] = made.source
        mesh[f"{where}_object"] = made.object
        mesh[f"{where}_settings"] = _settings_json(options, map_name)
    return Outcome(obj.name, map_name, "written", where)


def _clamp_attribute(attribute):
    colours = np.empty(len(attribute.data) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", colours)
    clamped = np.clip(colours, 0.0, 1.0)
    if not np.array_equal(clamped, colours):
        attribute.data.foreach_set("color", clamped)


# --- the input hash -------------------------------------------------------------------------


class _Digests:
    """Per-object geometry digests of one bake run (occluders are shared between targets)."""

    def __init__(self):
        self._cache = {}

    def __call__(self, obj):
        if obj.name not in self._cache:
            with scratch_scene.rendered(obj) as seen:
                self._cache[obj.name] = _geometry_digest(seen.mesh, seen.matrix_world)
        return self._cache[obj.name]


def _geometry_digest(mesh, matrix):
    """sha256 of a mesh as rendered: world-space vertex positions and face corners."""
    positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", positions)
    corners = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    sizes = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", sizes)
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
    kind = maps.get(map_name)
    inputs.update(kind.inputs(obj, options, digests))
    inputs.update(reads={read: _stored_hash(obj, read, options) for read in kind.reads})
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


def _stored_hash(obj, map_name, options):
    """The input hash stored with ``obj``'s baked ``map_name`` of the bake's target, or None."""
    return _stored(obj, map_name, options).get(HASH_KEY)


def _stored(obj, map_name, options):
    """What ``obj``'s baked ``map_name`` of the bake's target records (its EXR header's fields, or
    the same read from the mesh's properties); {} when it is not baked."""
    if options.target == "image":
        return imageio.read_metadata(image_path(options.out_dir, obj.name, map_name))
    attribute = maps.get(map_name).attribute
    if attribute not in obj.data.color_attributes:
        return {}
    recorded = {HASH_KEY: "inputs", SOURCE_KEY: "source", OBJECT_KEY: "object", SETTINGS_KEY: "settings"}
    stored = {key: obj.data.get(f"{attribute}_{suffix}") for key, suffix in recorded.items()}
    return {key: value for key, value in stored.items() if value is not None} | {MAP_KEY: map_name}


# --- linking the maps into the .blend ----------------------------------------------------------


def occluder_collection(name: str | bpy.types.Collection | None) -> bpy.types.Collection | None:
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
            link_image(obj, map_name, image_path(options.out_dir, obj.name, map_name))


def _image_maps(outcomes: Sequence[Outcome]) -> list[Outcome]:
    """The image maps ``outcomes`` wrote or found up to date."""
    return [o for o in outcomes if o.status in ("written", "unchanged") and o.where.endswith(".exr")]


def link_outcomes(outcomes: Sequence[Outcome]) -> None:
    """Point each object at the image maps ``outcomes`` wrote or found up to date (those of a
    bake that stopped part-way included), as ``link_images`` does."""
    for outcome in _image_maps(outcomes):
        link_image(bpy.data.objects[outcome.object], outcome.map, outcome.where)


def changes_the_file(outcomes: Sequence[Outcome]) -> bool:
    """Whether storing ``outcomes`` in the .blend changes it: a map written (an attribute, or an
    image's lightmap and header), or an image map its object does not point at yet
    (``link_outcomes`` would link it). A bake that found every map up to date and linked has
    nothing to save."""
    if any(outcome.status == "written" for outcome in outcomes):
        return True
    return any(_linked(bpy.data.objects[o.object], o.map, o.where) is None for o in _image_maps(outcomes))


def _linked(obj: "bpy.types.Object", map_name: str, path: str) -> "bpy.types.Image | None":
    """The Image ``obj`` is pointed at for ``map_name`` if it reads the file ``path``, else None."""
    image = bpy.data.images.get(obj.get(map_image_property(map_name), ""))
    return image if image is not None and image.packed_file is None and _reads(image, path) else None


def link_image(obj: "bpy.types.Object", map_name: str, path: str) -> "bpy.types.Image":
    """Point ``obj`` at the map image file ``path`` (also the panel's efflorescence map): an Image
    (relative path, Non-Color, reloaded) named in the object's custom property ``pw_<map>_image``.
    That Image is the one the property already names if it reads ``path``, else a new one
    (named after the file, with Blender's ".001" if a user's image has that name): an Image of
    the user's is never changed."""
    image = _linked(obj, map_name, path) or bpy.data.images.load(path, check_existing=False)
    image.filepath = bpy.path.relpath(path)
    image.colorspace_settings.name = "Non-Color"
    image.use_fake_user = True  # an image nothing uses yet is not saved otherwise
    image.reload()
    obj[map_image_property(map_name)] = image.name
    return image


def _reads(image, path):
    """Whether ``image`` is read from the file ``path``."""
    return bool(image.filepath) and os.path.abspath(bpy.path.abspath(image.filepath)) == os.path.abspath(path)
