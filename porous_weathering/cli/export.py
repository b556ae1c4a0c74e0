"""The ``export`` command (``cli.entry``): the weathered states of objects of a .blend
as one glTF 2.0 file with material variants and its paradata (``export.iter_export``). Its
options are generated from the export's option declarations (``export.option_entries``), as the
export operator's properties are.

Exit codes (docs/export.md): 0 written; 1 the export failed (the file could not be opened, a
bake or the write failed); 2 bad arguments or input (nothing written); 3 refused: ``--out``
holds a pair of that name made from another .blend or other objects, or not by the extension
(``--force`` replaces it); 130 / 143 interrupted by SIGINT / SIGTERM (nothing written).
"""

import os
import sys

from ..blender import blend_file
from ..common import interrupts, options
from ..common.progress import ProgressBar
from ..contracts import EXIT_FAILED, EXIT_OK, EXIT_REFUSED, EXIT_USAGE
from ..publish import export
from . import selection
from .selection import one_line


def configure_parser(parser):
    parser.description = (
        "Bake the clean state and each age of the weathered materials of objects of a .blend to PBR textures, "
        "and write them as one glTF 2.0 file (OUT/<name>.glb) whose material variants (KHR_materials_variants) "
        "are the states, with its paradata (OUT/<name>.paradata.json). Exit codes: 0 written, 1 the export "
        "failed, 2 bad arguments or input (nothing written), 3 refused (OUT holds a pair made from another "
        ".blend or other objects: --force replaces it), 130/143 interrupted (nothing written)."
    )
    parser.add_argument("file", metavar="FILE.blend", help="the .blend file whose objects to export")
    selection.add_arguments(
        parser,
        objects_help="export these objects (default: every mesh object whose materials are all Porous Weathering ones)",
        collection_help="export the mesh objects of this collection",
    )
    declared = {entry.dest: entry.option for entry in export.option_entries()}
    parser.add_argument(
        "--ages",
        metavar=declared["ages"].metavar,
        help=f"{declared['ages'].tooltip} (default: {export.format_ages(export.DEFAULT_AGES)})",
    )
    parser.add_argument("--wet", action="store_true", help=declared["wet"].tooltip)
    parser.add_argument("--force", action="store_true", help=f"{declared['force'].tooltip} (default: refuse, exit 3)")
    options.add_arguments(parser, [entry for entry in export.option_entries() if entry.option.flag])
    parser.add_argument(
        "--note",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a line of the paradata's notes, e.g. --note author='A. Conservator' --note survey='scan 2024-05' "
        "(repeatable)",
    )


def run(args):
    """The ``export`` command; returns the exit code."""
    path = os.path.abspath(args.file)
    try:
        chosen = export.ExportOptions(
            ages=export.parse_ages(args.ages) if args.ages is not None else export.DEFAULT_AGES,
            wet=args.wet,
            size=args.size,
            image_format=args.image_format,
            out_dir=os.path.abspath(args.out_dir),
            name=args.name,
            notes=_notes(args.note),
            force=args.force,
        )
        if not os.path.isfile(path):
            raise FileNotFoundError(f"no such .blend file: {args.file}")
    except (ValueError, OSError) as error:
        return _error(error, EXIT_USAGE)
    try:
        blend_file.open_blend(path)
    except RuntimeError as error:
        return _error(f"{path}: {one_line(error)}", EXIT_FAILED)
    try:
        steps = export.iter_export(_chosen_objects(args), chosen)  # checks everything before it starts
    except export.OverwriteRefused as error:
        return _error(f"{path}: {one_line(error)}; {FORCE_HINT}", EXIT_REFUSED)
    except (ValueError, OSError) as error:
        return _error(f"{path}: {one_line(error)}", EXIT_USAGE)
    bar = ProgressBar(os.path.basename(path))
    result = None
    last_words = lambda signal_name: f"interrupted by {signal_name}: nothing was written"
    with interrupts.exit_on_signals(last_words):
        try:
            for step in steps:
                bar(step.fraction, step.message)
                result = step.result or result
        except export.OverwriteRefused as error:  # a pair that appeared meanwhile
            bar.finish()
            return _error(f"{path}: {one_line(error)}; {FORCE_HINT}", EXIT_REFUSED)
        except ValueError as error:  # bad input found on the way (a mesh that cannot get a lightmap)
            bar.finish()
            return _error(f"{path}: {one_line(error)}", EXIT_USAGE)
        except (OSError, RuntimeError) as error:
            bar.finish()
            return _error(f"{path}: {one_line(error)}", EXIT_FAILED)
    bar.finish()
    print(f"wrote     {result.path} (variants {', '.join(result.variants)})")
    print(f"wrote     {result.paradata}")
    return EXIT_OK


FORCE_HINT = "export into another --out or --name, or add --force to replace it"


def _error(error, code):
    print(f"error: {error}", file=sys.stderr)
    return code


def _notes(words):
    notes = {}
    for word in words:
        key, equals, value = word.partition("=")
        if not equals or not key.strip():
            raise ValueError(f"--note takes KEY=VALUE, not {word!r}")
        notes[key.strip()] = value
    return notes


def _chosen_objects(args):
    """The objects ``args`` choose (``selection.weathered_objects``), but for the meshes nobody
    named that have no faces (after their modifiers), skipped with a warning."""
    objects = selection.weathered_objects(args, "export")
    if selection.chosen(args):
        return objects
    kept = []
    for obj, surface in export.surfaces_after_modifiers(objects).items():
        if surface.faces:
            kept.append(obj)
        else:
            print(f"warning: object '{obj.name}' has no faces (after its modifiers): skipped", file=sys.stderr)
    if not kept:
        raise ValueError("no mesh objects with faces and Porous Weathering materials to export")
    return kept
