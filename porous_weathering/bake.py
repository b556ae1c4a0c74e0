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
import math
import os
import sys
from dataclasses import asdict, dataclass, field, replace

import bpy
import numpy as np

from . import distributed, imageio, rain, uv

MAPS = ("rain", "edges")
TARGETS = ("image", "attribute")
ATTRIBUTES = {"rain": rain.RAIN_ATTRIBUTE, "edges": "pw_edges"}
HASH_KEY = "pw:inputs"
#: The EXR header field naming the UV map an image map was baked on (weathered materials read
#: the image through it, weathering.image_uv_map).
UV_MAP_KEY = "pw:uv_map"
DEFAULT_RESOLUTION = 512
#: Texels filled around every UV island (and packed between xatlas charts).
MARGIN = 4
#: Bumped when a change of the bake itself makes old maps stale.
BAKE_VERSION = 1
#: Scene units over which the curvature of an attribute edge map is smoothed: a brick's arris.
DEFAULT_EDGE_RADIUS = 0.05


class BakeCancelled(Exception):
    """The caller asked to stop; the maps finished before that are complete and kept."""


@dataclass(frozen=True)
class BakeOptions:
    maps: tuple = MAPS  # every map unless asked for fewer
    target: str = "image"
    resolution: int = DEFAULT_RESOLUTION
    rain_settings: rain.RainSettings = field(default_factory=rain.RainSettings)
    out_dir: str = "."
    occluders: object = None  # a bpy Collection, or None for every other object of the scene
    edge_radius: float = DEFAULT_EDGE_RADIUS

    def __post_init__(self):
        unknown = set(self.maps) - set(MAPS)
        if not self.maps or unknown:
            raise ValueError(f"maps must be some of {', '.join(MAPS)}, not {', '.join(self.maps) or 'none'}")
        if self.target not in TARGETS:
            raise ValueError(f"target must be one of {', '.join(TARGETS)}, not {self.target!r}")
        if not (self.resolution == int(self.resolution) and 8 <= self.resolution <= 16384):
            raise ValueError(f"resolution must be a whole number of texels from 8 to 16384, not {self.resolution}")
        if not (math.isfinite(self.edge_radius) and self.edge_radius > 0.0):
            raise ValueError(f"edge radius must be a positive number of scene units, not {self.edge_radius}")


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


def image_path(out_dir, object_name, map_name):
    safe = object_name.replace(os.sep, "_").replace(os.altsep or os.sep, "_")
    return os.path.join(out_dir, f"{safe}.{map_name}.exr")


def check_targets(objects, options=BakeOptions()):
    """Raise ValueError naming the first object that cannot be baked with ``options``, before
    anything is written."""
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
            raise ValueError(f"object '{obj.name}' is linked from the library {library.filepath}: "
                             "make it local before baking")
        if options.target == "attribute":
            owners.setdefault(obj.data.name, []).append(obj.name)
            if "edges" in options.maps:
                _check_vertices_kept(obj)
    shared = next((names for names in owners.values() if len(names) > 1), None)
    if shared:  # one mesh holds one attribute: each object would overwrite the others' map
        raise ValueError(f"objects {', '.join(repr(n) for n in shared)} share one mesh, which can hold only "
                         "one colour-attribute map: bake them to images, or make their meshes single-user")


def _check_vertices_kept(obj):
    """The edge attribute is per vertex of the mesh: modifiers must not change the vertex count."""
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    if len(evaluated.data.vertices) != len(obj.data.vertices):
        raise ValueError(f"object '{obj.name}': its modifiers change the vertex count, so the edge attribute "
                         "cannot follow its mesh; apply the modifiers or bake edges to an image")


def check_writable_folder(folder):
    """Create ``folder`` if needed; raise OSError saying why it cannot take the maps."""
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        raise OSError(f"cannot create the output folder {folder}: {error.strerror}") from error
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OSError(f"the output folder {folder} is not writable")


def bake_maps(objects, options=BakeOptions(), *, dry_run=False, progress=None, cancelled=None):
    """Bake ``options.maps`` of ``objects``; returns the list of Outcomes.

    ``progress(fraction, message)`` is called before and after each step; ``cancelled()``
    is asked before each step and stops the bake with BakeCancelled when true.
    """
    outcomes = []
    for step in iter_bake(objects, options, dry_run=dry_run):
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


def iter_bake(objects, options=BakeOptions(), *, dry_run=False):
    """The Steps of the bake, as a generator (see the module docstring). The objects and the
    output folder are checked at once, so a refusal comes before anything starts. Closing the
    generator early (cancel) undoes the lightmap UV map of the object in progress if none of
    its maps was written."""
    check_targets(objects, options)
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
        raise ValueError(f"mesh '{mesh.name}': its UV map '{uv.LIGHTMAP_UV}' overlaps or leaves [0, 1]; "
                         f"remove or rename it to let the bake make a new one")
    return uv.LIGHTMAP_UV, uv.lightmap_uvs(mesh, options.resolution, padding=MARGIN)


def _bake_one(obj, map_name, options, uv_map, inputs, dry_run):
    mesh = obj.data
    if options.target == "image":
        where = image_path(options.out_dir, obj.name, map_name)
        stored = imageio.read_metadata(where).get(HASH_KEY)
    else:
        where = ATTRIBUTES[map_name]
        stored = mesh.get(f"{where}_inputs") if where in mesh.color_attributes else None
    if stored == inputs:
        return Outcome(obj.name, map_name, "unchanged", where)
    if dry_run:
        return Outcome(obj.name, map_name, "planned", where)

    if options.target == "image":
        pixels = _bake_image(obj, map_name, options, uv_map)
        imageio.write_image(where, pixels, metadata={HASH_KEY: inputs, "pw:map": map_name, UV_MAP_KEY: uv_map})
    elif map_name == "rain":
        occluders = rain.default_occluders(obj, options.occluders)
        write_corner_attribute(mesh, where, rain.bake_rain_corners(obj, options.rain_settings, occluders))
    else:
        _edges().write_curvature_attribute(obj, options.edge_radius)
    if options.target == "attribute":
        mesh[f"{where}_inputs"] = inputs
    return Outcome(obj.name, map_name, "written", where)


def _bake_image(obj, map_name, options, uv_map):
    if map_name == "rain":
        occluders = rain.default_occluders(obj, options.occluders)
        return rain.bake_rain_image(obj, uv_map, options.resolution, options.rain_settings, occluders, margin=MARGIN)
    return _edges().edge_mask_image(obj, uv_map, options.resolution, margin=MARGIN)


def _edges():
    from . import edges  # only an edge bake needs it

    return edges


def write_corner_attribute(mesh, name, values):
    """Replace the colour attribute ``name`` of ``mesh`` by grey per-corner ``values``."""
    rgba = np.ones((len(mesh.loops), 4), dtype=np.float32)
    rgba[:, :3] = np.asarray(values, dtype=np.float32)[:, None]
    if name in mesh.color_attributes:
        mesh.color_attributes.remove(mesh.color_attributes[name])
    mesh.color_attributes.new(name, "FLOAT_COLOR", "CORNER").data.foreach_set("color", rgba.reshape(-1))


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
        inputs.update(resolution=options.resolution, margin=MARGIN,
                      uvs=hashlib.sha256(np.ascontiguousarray(uvs, dtype=np.float32).tobytes()).hexdigest())
    if map_name == "edges" and options.target == "attribute":
        inputs.update(edge_radius=options.edge_radius)
    if map_name == "rain":
        occluders = rain.default_occluders(obj, options.occluders)
        inputs.update(rain=asdict(options.rain_settings), occluders=sorted((o.name, digests(o)) for o in occluders))
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


# --- the command line (porous_weathering/cli.py) -------------------------------------------


def configure_parser(parser):
    parser.description = (
        "Bake rain-exposure and edge/cavity maps of the mesh objects of .blend files. Image maps are "
        "written as OUT/<object>.rain.exr and OUT/<object>.edges.exr (float, linear); attribute maps are "
        "the colour attributes pw_rain and pw_edges. Maps whose inputs did not change since they were "
        "written are skipped. Exit code 0 only when every requested map was written (or is up to date).")
    parser.add_argument("files", nargs="+", metavar="FILE.blend", help=".blend files to bake")
    parser.add_argument("--objects", nargs="+", metavar="NAME", default=(),
                        help="bake only these objects (default: every mesh object of the file)")
    parser.add_argument("--collection", metavar="NAME",
                        help="bake only the mesh objects of this collection (children included)")
    parser.add_argument("--maps", default=",".join(MAPS), type=_map_list, metavar="rain,edges",
                        help="comma-separated maps to bake: rain, edges (default: both)")
    parser.add_argument("--target", choices=TARGETS, default="image",
                        help="image: EXR files on a lightmap UV map; attribute: per-corner colour attributes "
                             "stored in the .blend (needs --save) (default: image)")
    parser.add_argument("--resolution", type=int, default=DEFAULT_RESOLUTION, metavar="N",
                        help=f"image maps are N x N texels (default: {DEFAULT_RESOLUTION})")
    parser.add_argument("--samples", type=int, default=rain.DEFAULT_SAMPLES, metavar="N",
                        help=f"rain samples per texel or corner (default: {rain.DEFAULT_SAMPLES}; docs/maps.md)")
    parser.add_argument("--rain-cone", type=float, default=rain.RainSettings.cone, metavar="DEG",
                        help=f"half-angle of the cone of rain directions (default: {rain.RainSettings.cone:g})")
    parser.add_argument("--wind-azimuth", type=float, default=0.0, metavar="DEG",
                        help="side the rain is driven from, degrees from +X towards +Y (default: 0)")
    parser.add_argument("--wind-tilt", type=float, default=0.0, metavar="DEG",
                        help="lean of the mean rain direction from the vertical (default: 0, vertical rain)")
    parser.add_argument("--edge-radius", type=float, default=DEFAULT_EDGE_RADIUS, metavar="M",
                        help="scene units over which the curvature of attribute edge maps (--maps edges --target "
                             f"attribute) is smoothed (default: {DEFAULT_EDGE_RADIUS:g}; docs/maps.md)")
    parser.add_argument("--occluders", metavar="COLLECTION",
                        help="only the objects of this collection (children included) shelter the baked objects "
                             "from rain (default: every other object of the scene)")
    parser.add_argument("--out", default=".", metavar="DIR", help="folder of the image maps (default: .)")
    parser.add_argument("--save", action="store_true",
                        help="store the maps in the .blend (attributes, or images linked by relative path, "
                             "and the lightmap UV map) and save it")
    parser.add_argument("--dry-run", action="store_true", help="check the inputs and list what would be baked; "
                                                               "write nothing")
    distributed.add_arguments(parser)


def _map_list(text):
    import argparse

    maps = tuple(name.strip() for name in text.split(",") if name.strip())
    if not maps or set(maps) - set(MAPS):
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of {', '.join(MAPS)}, got {text!r}")
    return maps


def run(args):
    """The ``bake`` command; returns the exit code (0: every requested map was written)."""
    try:
        options = BakeOptions(maps=args.maps, target=args.target, resolution=args.resolution,
                              out_dir=os.path.abspath(args.out), edge_radius=args.edge_radius,
                              rain_settings=rain.RainSettings(cone=args.rain_cone, wind_azimuth=args.wind_azimuth,
                                                     wind_tilt=args.wind_tilt, samples=args.samples))
        if args.target == "attribute" and not (args.save or args.dry_run):
            raise ValueError("--target attribute stores the maps in the .blend: add --save")
        missing = [path for path in args.files if not os.path.isfile(path)]
        if missing:
            raise FileNotFoundError(f"no such .blend file: {', '.join(missing)}")
        if args.target == "image" and not args.dry_run:
            check_writable_folder(options.out_dir)
    except (ValueError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if args.workers or args.scheduler:
        return distributed.run(args, options)

    failures = 0
    written_paths = set()
    for path in args.files:
        try:
            failures += _bake_file(os.path.abspath(path), args, options, written_paths)
        except KeyboardInterrupt:
            print(f"\ninterrupted: maps finished so far are complete; {path} was not saved", file=sys.stderr)
            return 130
        except (ValueError, OSError, RuntimeError) as error:
            print(f"\nerror: {path}: {error}", file=sys.stderr)
            failures += 1
    return 0 if failures == 0 else 1


def _bake_file(path, args, options, written_paths):
    """Bake one file; returns the number of failures."""
    bpy.ops.wm.open_mainfile(filepath=path, load_ui=False, use_scripts=False)  # never run a file's code
    objects = _chosen_objects(args)
    options = replace(options, occluders=occluder_collection(args.occluders))
    if options.target == "image":
        clashes = {image_path(options.out_dir, o.name, m) for o in objects for m in options.maps} & written_paths
        if clashes:
            raise ValueError(f"another file already wrote {', '.join(sorted(clashes))}: bake it into another --out")
    bar = ProgressBar(os.path.basename(path))
    outcomes = bake_maps(objects, options, dry_run=args.dry_run, progress=bar)
    bar.finish()
    for outcome in outcomes:
        print(f"{outcome.status:9} {outcome.object}.{outcome.map} -> {outcome.where}")
        written_paths.add(outcome.where)
    if args.save and not args.dry_run:
        if options.target == "image":
            link_images(objects, options)
        bpy.ops.wm.save_mainfile(filepath=path)  # Blender writes FILE.blend@ and renames it: atomic
        print(f"saved     {path}")
    return 0


def _chosen_objects(args):
    if args.objects:
        missing = [name for name in args.objects if name not in bpy.data.objects]
        if missing:
            raise ValueError(f"no object named {', '.join(missing)}")
        return [bpy.data.objects[name] for name in args.objects]
    if args.collection:
        if args.collection not in bpy.data.collections:
            raise ValueError(f"no collection named {args.collection}")
        candidates = bpy.data.collections[args.collection].all_objects
    else:
        candidates = bpy.context.scene.objects
    objects = sorted((o for o in candidates if o.type == "MESH"), key=lambda o: o.name)
    if not objects:
        raise ValueError("no mesh objects to bake")
    return objects


def occluder_collection(name):
    """The collection whose objects are the rain occluders, or None (every other object) for no name."""
    if not name:
        return None
    if name not in bpy.data.collections:
        raise ValueError(f"no collection named '{name}' to take the occluders from")
    return bpy.data.collections[name]


def link_images(objects, options):
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


class ProgressBar:
    """A one-line text progress bar on stderr: ``progress(fraction, message)``."""

    WIDTH = 30

    def __init__(self, label, stream=sys.stderr):
        self.label, self.stream = label, stream

    def __call__(self, fraction, message):
        filled = int(round(fraction * self.WIDTH))
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {fraction:4.0%} {message:40.40}")
        self.stream.flush()

    def finish(self):
        self.stream.write("\n")
