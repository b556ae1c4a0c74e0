"""The ``bake`` command (porous_weathering/cli.py): its options are generated from the bake's
option declarations (``bake.option_entries``), so the command line, the operator and the
Dask workers offer the same options with the same defaults and checks."""

import os
import sys

import bpy

from . import distributed, maps, options
from .bake import (
    BakeOptions,
    bake_maps,
    check_writable_folder,
    image_path,
    link_images,
    option_entries,
    options_from_values,
)
from .progress import ProgressBar


def configure_parser(parser):
    files = ", ".join(f"OUT/<object>{kind.image_suffix}" for kind in maps.all_kinds())
    attributes = ", ".join(kind.attribute for kind in maps.all_kinds())
    parser.description = (
        f"Bake the weathering maps ({', '.join(maps.names())}) of the mesh objects of .blend files. Image maps "
        f"are written as {files} (float, linear); attribute maps are the colour attributes {attributes}, "
        "stored in the .blend (needs --save). Maps whose inputs did not change since they were written are "
        "skipped. Exit code 0 only when every requested map was written (or is up to date)."
    )
    parser.add_argument("files", nargs="+", metavar="FILE.blend", help=".blend files to bake")
    parser.add_argument(
        "--objects",
        nargs="+",
        metavar="NAME",
        default=(),
        help="bake only these objects (default: every mesh object of the file)",
    )
    parser.add_argument(
        "--collection", metavar="NAME", help="bake only the mesh objects of this collection (children included)"
    )
    options.add_arguments(parser, option_entries())
    parser.add_argument(
        "--save",
        action="store_true",
        help="store the maps in the .blend (attributes, or images linked by relative path, "
        "and the lightmap UV map) and save it",
    )
    parser.add_argument(
        "--dry-run", action="store_true", help="check the inputs and list what would be baked; write nothing"
    )
    distributed.add_arguments(parser)


def run(args):
    """The ``bake`` command; returns the exit code (0: every requested map was written)."""
    try:
        values = vars(args)
        values["out_dir"] = os.path.abspath(args.out_dir)
        bake_options = options_from_values(values)
        if bake_options.target == "attribute" and not (args.save or args.dry_run):
            raise ValueError("--target attribute stores the maps in the .blend: add --save")
        missing = [path for path in args.files if not os.path.isfile(path)]
        if missing:
            raise FileNotFoundError(f"no such .blend file: {', '.join(missing)}")
        if bake_options.target == "image" and not args.dry_run:
            check_writable_folder(bake_options.out_dir)
    except (ValueError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if args.workers or args.scheduler:
        return distributed.run(args, bake_options.target, bake_options.maps, bake_options.to_argv())

    failures = 0
    written_paths = set()
    for path in args.files:
        try:
            failures += _bake_file(os.path.abspath(path), args, bake_options, written_paths)
        except KeyboardInterrupt:
            print(f"\ninterrupted: maps finished so far are complete; {path} was not saved", file=sys.stderr)
            return 130
        except (ValueError, OSError, RuntimeError) as error:
            print(f"\nerror: {path}: {error}", file=sys.stderr)
            failures += 1
    return 0 if failures == 0 else 1


def _bake_file(path, args, bake_options: BakeOptions, written_paths):
    """Bake one file; returns the number of failures."""
    bpy.ops.wm.open_mainfile(filepath=path, load_ui=False, use_scripts=False)  # never run a file's code
    objects = _chosen_objects(args)
    if bake_options.target == "image":
        clashes = {image_path(bake_options.out_dir, o.name, m) for o in objects for m in bake_options.maps}
        clashes &= written_paths
        if clashes:
            raise ValueError(f"another file already wrote {', '.join(sorted(clashes))}: bake it into another --out")
    bar = ProgressBar(os.path.basename(path))
    outcomes = bake_maps(objects, bake_options, dry_run=args.dry_run, progress=bar)
    bar.finish()
    for outcome in outcomes:
        print(f"{outcome.status:9} {outcome.object}.{outcome.map} -> {outcome.where}")
        written_paths.add(outcome.where)
    if args.save and not args.dry_run:
        if bake_options.target == "image":
            link_images(objects, bake_options)
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
