"""The ``survey`` command (``cli.entry``): the condition survey of the weathered objects of
.blend files (``survey.condition``), each into its own files, on this machine or on a Dask
cluster as ``bake`` runs its files (``batch``, ``distributed``); its options generated from the
survey's option declarations, as the Condition Survey operator's properties are.

Exit codes (docs/cli.md): 0 every survey written or unchanged; 1 a file failed (it could not be
opened, a write failed), the others done; 2 bad arguments or input (nothing written); 3 a file
was refused: ``--out`` holds a survey of its name made from another .blend or other objects, or
not by the extension (``--force`` replaces it); 130 / 143 interrupted by SIGINT / SIGTERM.
"""

import os
import sys
import warnings

from ..blender import blend_file
from ..common import interrupts, options
from ..common.progress import ProgressBar
from ..contracts import EXIT_USAGE, batch_exit_code
from ..maps.provenance import OverwriteRefused
from ..survey import condition
from . import batch, distributed, selection
from .selection import one_line

FORCE_HINT = "survey into another --out or --name, or add --force to replace it"
#: Options the parser takes by hand: one of the years or the ages, and a switch.
BY_HAND = ("years", "ages", "force")


def configure_parser(parser):
    parser.usage = "%(prog)s FILE.blend [FILE.blend ...] (--years Y,Y,... | --ages T,T,...) [options]"
    parser.description = (
        "Classify every point of the weathered objects of .blend files, at each age, into the patterns the model "
        "produces (black crust, soiling, efflorescence, moist area, no visible change) and write their true "
        "areas in m² to OUT/<name>.survey.csv with its paradata OUT/<name>.survey.json, <name> being each "
        ".blend's. Exit codes: 0 written or unchanged, 1 a file failed, 2 bad arguments or input (nothing "
        "written), 3 a file was refused (OUT holds a survey made from another .blend or other objects: --force "
        "replaces it), 130/143 interrupted."
    )
    parser.add_argument(
        "files",
        nargs="*",
        metavar="FILE.blend",
        help=".blend files whose objects to survey, each into its own files; a word ending in .blend that "
        "names an existing file is a file, even after --objects",
    )
    selection.add_arguments(
        parser,
        objects_help="survey these objects (default: every mesh object whose materials are all Porous Weathering ones)",
        collection_help="survey the mesh objects of this collection",
    )
    declared = {entry.dest: entry.option for entry in condition.option_entries()}
    ages = parser.add_mutually_exclusive_group(required=True)
    for dest in ("years", "ages"):
        ages.add_argument(declared[dest].flag, dest=dest, metavar=declared[dest].metavar, help=declared[dest].tooltip)
    parser.add_argument(
        declared["force"].flag, action="store_true", help=f"{declared['force'].tooltip} (default: refuse, exit 3)"
    )
    options.add_arguments(parser, [entry for entry in condition.option_entries() if entry.dest not in BY_HAND])
    distributed.add_arguments(parser, "survey")


def run(args):
    """The ``survey`` command; returns the exit code."""
    try:
        args.files, args.objects = batch.files_and_objects("survey", args.files, args.objects)
        if args.name and len(args.files) > 1:
            raise ValueError(
                f"--name names the files of one survey, and {len(args.files)} .blend files were given: "
                "leave --name out (each survey is named after its .blend) or survey one file"
            )
        values = options.argument_values(args, condition.option_entries())
        chosen = condition.SurveyOptions(**{**values, "out_dir": os.path.abspath(args.out_dir)})
        batch.check_paths(args.files)
        _check_files(args, chosen)
    except (ValueError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    if args.workers or args.scheduler:
        words = selection.to_argv(args) + chosen.to_argv()
        return distributed.run(
            args, "survey", words, _survey_names, "the surveys finished so far are whole, the others wrote nothing"
        )
    return _survey_serially(args, chosen)


def _check_files(args, chosen):
    """Open every file once before any work and check it as its survey will: ValueError (exit
    2) naming the first file whose objects cannot be surveyed. A file Blender cannot open fails
    later, as its survey, and one refused (``--out`` holds another's survey) is refused then."""
    for path in args.files:
        try:
            blend_file.open_blend(os.path.abspath(path))
        except RuntimeError:
            continue
        try:
            with warnings.catch_warnings():  # said again as the file is surveyed
                warnings.simplefilter("ignore")
                objects = selection.weathered_objects(args, "survey")
                condition.iter_survey(objects, chosen)  # its checks; its steps are not run
        except OverwriteRefused:
            continue
        except ValueError as error:
            raise ValueError(f"{path}: {one_line(error)}") from None


def _survey_names(cluster, files):
    """The name of each file's survey (the .blend's, as ``condition.iter_survey`` names it):
    files of the same name write the same survey (``distributed.clash_groups``)."""
    return [[os.path.splitext(os.path.basename(path))[0]] for path in files]


def _survey_serially(args, chosen):
    codes = []
    words = "the surveys finished before are whole, the one in progress wrote nothing"
    with interrupts.exit_on_signals(lambda signal_name: f"interrupted by {signal_name}: {words}"):
        for path in map(os.path.abspath, args.files):
            bar = ProgressBar(os.path.basename(path))
            codes.append(batch.run_file(bar, FORCE_HINT, _survey_file, path, args, chosen, bar))
            bar.finish()
    return batch_exit_code(codes)


def _survey_file(path, args, chosen, bar):
    """Survey one file; its outcome lines go to stdout once its files are in place."""
    blend_file.open_blend(path)
    result = None
    for step in condition.iter_survey(selection.weathered_objects(args, "survey"), chosen):
        bar(step.fraction, step.message)
        result = step.result or result
    for where in (result.csv, result.forecast, result.paradata, *result.drawings):
        bar.print(f"{result.status:9} {where}")
