"""The ``survey`` command (``cli.entry``): the condition survey of the weathered objects of a
.blend (``survey.condition``), its options generated from the survey's option declarations, as
the Condition Survey operator's properties are.

Exit codes (docs/cli.md): 0 written or unchanged; 1 the survey failed (the file could not be
opened, a write failed); 2 bad arguments or input (nothing written); 3 refused: ``--out`` holds
a survey of that name made from another .blend or other objects, or not by the extension
(``--force`` replaces it); 130 / 143 interrupted by SIGINT / SIGTERM (nothing written).
"""

import os
import sys

import bpy

from ..common import interrupts, options
from ..common.progress import ProgressBar
from ..contracts import EXIT_FAILED, EXIT_OK, EXIT_REFUSED, EXIT_USAGE
from ..maps.provenance import OverwriteRefused
from ..publish.textures import porous_node
from ..survey import condition
from . import selection
from .selection import one_line

FORCE_HINT = "survey into another --out or --name, or add --force to replace it"


def configure_parser(parser):
    parser.description = (
        "Classify every point of the weathered objects of a .blend, at each age, into the patterns the model "
        "produces (black crust, soiling, efflorescence, moist area, no visible change) and write their true "
        "areas in m² to OUT/<name>.survey.csv with its paradata OUT/<name>.survey.json. Exit codes: 0 written "
        "or unchanged, 1 the survey failed, 2 bad arguments or input (nothing written), 3 refused (OUT holds a "
        "survey made from another .blend or other objects: --force replaces it), 130/143 interrupted."
    )
    parser.add_argument("file", metavar="FILE.blend", help="the .blend file whose objects to survey")
    selection.add_arguments(
        parser,
        objects_help="survey these objects (default: every mesh object whose materials are all Porous Weathering ones)",
        collection_help="survey the mesh objects of this collection",
    )
    declared = {entry.dest: entry.option for entry in condition.option_entries()}
    ages = parser.add_mutually_exclusive_group(required=True)
    for dest in ("years", "ages"):
        ages.add_argument(f"--{dest}", metavar=declared[dest].metavar, help=declared[dest].tooltip)
    parser.add_argument("--force", action="store_true", help=f"{declared['force'].tooltip} (default: refuse, exit 3)")
    options.add_arguments(parser, [entry for entry in condition.option_entries() if entry.option.flag])


def run(args):
    """The ``survey`` command; returns the exit code."""
    path = os.path.abspath(args.file)
    try:
        chosen = condition.SurveyOptions(
            years=args.years,
            ages=args.ages,
            environment=args.environment,
            out_dir=os.path.abspath(args.out_dir),
            name=args.name,
            force=args.force,
        )
        if not os.path.isfile(path):
            raise FileNotFoundError(f"no such .blend file: {args.file}")
    except (ValueError, OSError) as error:
        return _error(error, EXIT_USAGE)
    try:
        bpy.ops.wm.open_mainfile(filepath=path, load_ui=False, use_scripts=False)  # never run a file's code
    except RuntimeError as error:
        return _error(f"{path}: {one_line(error)}", EXIT_FAILED)
    try:
        steps = condition.iter_survey(_chosen_objects(args), chosen)  # checks everything before it starts
    except OverwriteRefused as error:
        return _error(f"{path}: {one_line(error)}; {FORCE_HINT}", EXIT_REFUSED)
    except (ValueError, OSError) as error:
        return _error(f"{path}: {one_line(error)}", EXIT_USAGE)
    bar = ProgressBar(os.path.basename(path))
    result = None
    with interrupts.exit_on_signals(lambda signal_name: f"interrupted by {signal_name}: nothing was written"):
        try:
            for step in steps:
                bar(step.fraction, step.message)
                result = step.result or result
        except OverwriteRefused as error:
            bar.finish()
            return _error(f"{path}: {one_line(error)}; {FORCE_HINT}", EXIT_REFUSED)
        except ValueError as error:
            bar.finish()
            return _error(f"{path}: {one_line(error)}", EXIT_USAGE)
        except (OSError, RuntimeError) as error:
            bar.finish()
            return _error(f"{path}: {one_line(error)}", EXIT_FAILED)
    bar.finish()
    for path in (result.csv, result.forecast, result.paradata, *result.drawings):
        print(f"{result.status:9} {path}")
    return EXIT_OK


def _error(error, code):
    print(f"error: {error}", file=sys.stderr)
    return code


def _chosen_objects(args):
    """--objects or --collection as the bake command takes them, else every mesh object of the
    scene whose materials are all Porous Weathering ones."""
    if selection.chosen(args):
        return selection.chosen_objects(args)
    objects = sorted(
        (
            obj
            for obj in bpy.context.scene.objects
            if obj.type == "MESH"
            and obj.material_slots
            and all(porous_node(slot.material) for slot in obj.material_slots)
        ),
        key=lambda obj: obj.name,
    )
    if not objects:
        raise ValueError("no mesh objects with Porous Weathering materials to survey (give --objects)")
    return objects
