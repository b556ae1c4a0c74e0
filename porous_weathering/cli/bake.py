"""The ``bake`` command (``cli.entry``): its options are generated from the bake's
option declarations (``bake.option_entries``), so the command line, the operator and the
Dask workers offer the same options with the same defaults and checks.

Exit codes (docs/cli.md): 0 every requested map written or up to date; 1 a file failed; 2 bad
arguments (nothing baked); 3 a file was refused because it would replace maps made from another
.blend or object (``--force`` replaces them); 130 / 143 interrupted by SIGINT / SIGTERM.
"""

import os
import sys
import warnings
from dataclasses import dataclass

import bpy

from ..blender import blend_file, compat
from ..common import atomic, interrupts, options
from ..common.progress import ProgressBar
from ..contracts import EXIT_REFUSED, EXIT_USAGE, batch_exit_code
from ..maps import registry as maps
from ..maps.bake import (
    BakeOptions,
    ForeignInput,
    OverwriteRefused,
    Provenance,
    changes_the_file,
    check_targets,
    check_writable_folder,
    image_path,
    iter_bake,
    link_outcomes,
    option_entries,
    options_from_values,
)
from . import batch, distributed, selection
from .selection import one_line

FORCE_HINT = "bake into another --out, or add --force to replace it"


def configure_parser(parser):
    files = ", ".join(f"OUT/<object>{kind.image_suffix}" for kind in maps.all_kinds())
    attributes = ", ".join(kind.attribute for kind in maps.all_kinds())
    parser.usage = "%(prog)s FILE.blend [FILE.blend ...] [options]"  # FILE.blend may also come after --objects
    parser.description = (
        f"Bake the weathering maps ({', '.join(maps.names())}) of the mesh objects of .blend files. Image maps "
        f"are written as {files} (float, linear); attribute maps are the colour attributes {attributes}, "
        "stored in the .blend (needs --save). Maps whose inputs did not change since they were written are "
        "skipped; a map file made from another .blend or object is not replaced without --force. Exit codes: "
        "0 every requested map was written or is up to date, 1 a file failed, 2 bad arguments, 3 a file was "
        "refused (it would replace maps made from another .blend or object), 130/143 interrupted."
    )
    parser.add_argument(
        "files",
        nargs="*",
        metavar="FILE.blend",
        help=".blend files to bake; a word ending in .blend that names an existing file is a file, even "
        "after --objects",
    )
    selection.add_arguments(
        parser,
        objects_help="bake only these objects (default: every mesh object of the file)",
        collection_help="bake only the mesh objects of this collection (children included)",
    )
    options.add_arguments(parser, option_entries())
    parser.add_argument(
        "--save",
        action="store_true",
        help="store the maps in the .blend (attributes, or images linked by relative path, "
        "and the lightmap UV map) and save it",
    )
    parser.add_argument(
        "--allow-downgrade",
        action="store_true",
        help="--save also a .blend saved by a newer Blender than this one, in this one's older format "
        "(default: refuse it, exit 2)",
    )
    parser.add_argument(
        "--dry-run", action="store_true", help="check the inputs and list what would be baked; write nothing"
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace image maps made from another .blend or object (default: refuse that file, exit 3)",
    )
    distributed.add_arguments(parser, "bake")


def run(args):
    """The ``bake`` command; returns the exit code (0: every requested map was written)."""
    try:
        args.files, args.objects = batch.files_and_objects("bake", args.files, args.objects)
        values = vars(args)
        values["out_dir"] = os.path.abspath(args.out_dir)
        bake_options = options_from_values(values)
        if bake_options.target == "attribute" and not (args.save or args.dry_run):
            raise ValueError("--target attribute stores the maps in the .blend: add --save")
        batch.check_paths(args.files)
        written_to = bake_options.out_dir if bake_options.target == "image" and not args.dry_run else None
        with atomic.folders_undone_on_error(written_to):  # a refusal leaves no folder made for it
            if written_to is not None:
                check_writable_folder(written_to)
            _check_files(args, bake_options)
    except ForeignInput as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_REFUSED
    except (ValueError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    if args.workers or args.scheduler:
        switches = {"--force": args.force, "--dry-run": args.dry_run, "--save": args.save}
        switches["--allow-downgrade"] = args.allow_downgrade
        words = selection.to_argv(args) + bake_options.to_argv() + [flag for flag, on in switches.items() if on]
        return distributed.run(
            args,
            "bake",
            words,
            _mesh_names if bake_options.target == "image" else None,
            "maps finished so far are complete, no .blend file was saved after the interrupt",
        )
    return _bake_serially(args, bake_options)


def _mesh_names(cluster, files):
    """The names of each file's mesh objects: only image maps of objects of the same name can
    clash (``distributed.clash_groups``)."""
    return cluster.mesh_names(files)


def _check_files(args, bake_options):
    """Open every file once before any work and check it as its bake will: ValueError (exit 2)
    naming the first file whose objects cannot be baked with these options, or that ``--save``
    would write in an older format than it has (saved by a newer Blender); ForeignInput (exit 3)
    for a map the bake would read that another .blend or object made. A file Blender cannot open
    fails later, as the bake's."""
    for path in args.files:
        try:
            blend_file.open_blend(os.path.abspath(path))
        except RuntimeError:
            continue
        newer = compat.newer_file_version()
        if args.save and not args.allow_downgrade and newer:
            raise ValueError(
                f"{path} was saved by {newer}, newer than this {compat.running_version()}: --save would "
                "rewrite it in the older format and lose what the newer one stores; bake it with "
                f"{newer} or newer, or add --allow-downgrade"
            )
        with warnings.catch_warnings():  # said again as the file is baked
            warnings.simplefilter("ignore")
            try:
                check_targets(_objects_to_bake(args), bake_options)
                bake_options.occluder_collection()
            except ValueError as error:
                raise type(error)(f"{path}: {error}") from None


def _objects_to_bake(args):
    """The objects of the open file that the command bakes: those named, or else those with faces."""
    objects = selection.chosen_objects(args)
    return objects if args.objects else selection.without_faceless(objects)


@dataclass
class _Run:
    """Where the serial run is, for the messages (and the last words of an interrupt)."""

    save: bool
    file: str = ""
    saved: bool = False
    bar: ProgressBar | None = None

    def last_words(self, signal_name):
        words = f"interrupted by {signal_name}: the maps finished before are whole, the map in progress was discarded"
        if self.save and self.file and not self.saved:
            words += f"; {self.file} was not saved"
        return words


def _bake_serially(args, bake_options):
    run = _Run(save=args.save and not args.dry_run)
    codes = []
    claimed = {}  # image path -> Provenance of the file of this run that makes it
    with interrupts.exit_on_signals(run.last_words):
        for path in map(os.path.abspath, args.files):
            run.file, run.saved, run.bar = path, False, ProgressBar(os.path.basename(path))
            codes.append(batch.run_file(run.bar, FORCE_HINT, _bake_file, path, args, bake_options, claimed, run))
            run.bar.finish()
    return batch_exit_code(codes)


def _bake_file(path, args, bake_options: BakeOptions, claimed, run: _Run):
    """Bake one file; its outcome lines go to stdout as its maps finish (attribute maps once the
    .blend is saved, as they exist only in it)."""
    blend_file.open_blend(path)
    objects = _objects_to_bake(args)  # objects nobody named: one without faces to bake on is left out
    if bake_options.target == "image" and not args.force:
        _refuse_claimed(objects, bake_options, claimed)
    stored_in_blend = bake_options.target == "attribute" and run.save
    unsaved, outcomes, layout = [], [], _layout(objects)
    try:
        for step in iter_bake(objects, bake_options, dry_run=args.dry_run, force=args.force):
            outcome = step.outcome
            run.bar(step.fraction, step.message)
            if outcome is None:
                continue
            outcomes.append(outcome)
            line = f"{outcome.status:9} {outcome.object}.{outcome.map} -> {outcome.where}"
            if bake_options.target == "image":
                claimed[outcome.where] = Provenance.of(bpy.data.objects[outcome.object], outcome.map)
            if stored_in_blend and outcome.status == "written":
                unsaved.append(line)
            else:
                run.bar.print(line)
    except Exception:
        if run.save and any(outcome.status == "written" for outcome in outcomes):  # keep what was baked
            _save(path, outcomes, bake_options, unsaved, run)
        raise
    if run.save and (changes_the_file(outcomes) or _layout(objects) != layout):
        _save(path, outcomes, bake_options, unsaved, run)
    elif run.save:  # every map up to date and linked: saving again would only turn the backup over
        run.saved = True
        run.bar.print(f"unchanged {path}")


def _layout(objects):
    """What a bake adds to the objects besides its maps: their UV maps and modifiers (a lightmap
    laid out again, whose maps may be found unchanged)."""
    return [(tuple(obj.data.uv_layers.keys()), tuple(obj.modifiers.keys())) for obj in objects]


def _refuse_claimed(objects, bake_options, claimed):
    """Refuse a file whose image maps an earlier file of this run makes (a dry run included)."""
    for obj in objects:
        for map_name in bake_options.maps:
            where = image_path(bake_options.out_dir, obj.name, map_name)
            wanted = Provenance.of(obj, map_name)
            if where in claimed and not claimed[where].yields_to(wanted):
                raise OverwriteRefused(f"{where} is made in this run from {claimed[where]}, not from {wanted}")


def _save(path, outcomes, bake_options, unsaved, run):
    if bake_options.target == "image":
        link_outcomes(outcomes)
    try:
        with atomic.uncut():  # Blender writes FILE.blend@ and renames it: never cut in between
            bpy.ops.wm.save_mainfile(filepath=path)
            run.saved = True
    except RuntimeError as error:
        lost = (
            f"the {len(unsaved)} attribute map(s) baked into it were NOT saved"
            if bake_options.target == "attribute"
            else "the image maps are written, but not linked into it"
        )
        raise RuntimeError(f"cannot save it ({one_line(error)}): {lost}") from error
    for line in unsaved:
        run.bar.print(line)
    run.bar.print(f"saved     {path}")
