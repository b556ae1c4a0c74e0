"""The command line: ``python -m porous_weathering COMMAND ...`` (bpy module) and
``blender -b -c porous_weathering COMMAND ...`` (Blender's extension command), one parser.

Each command lives in its own module, which defines ``configure_parser(parser)`` and
``run(args) -> exit code``; it is imported only when that command runs. Every error is one line
on stderr; a usage error exits with 2. Standard output is line-buffered, so the lines of what
is done reach a log even when the run is killed.
"""

import argparse
import importlib
import sys

from ..common import process_end
from ..contracts import EXIT_OK, EXIT_SIGINT, EXIT_USAGE

#: command -> (module, relative to this package, so it works installed as bl_ext.*; help)
COMMANDS = {
    "bake": (".bake", "bake the weathering maps of .blend files (bake --help lists them)"),
    "demo": ("..samples.demo", "render the bundled sample scene and write pictures"),
    "export": (".export", "publish weathered states as glTF 2.0 with material variants and paradata"),
    "survey": (".survey", "the condition survey: the area of each weathering pattern per object and age"),
}


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2)."""

    def error(self, message):
        self.exit(2, f"error: {message} (see {self.prog} --help)\n")


class _Version(argparse.Action):
    """``--version``: the extension's version and the Blender it runs in, then exit 0 (a batch
    log records what made its maps). bpy is imported only when it is asked for."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        import bpy

        from ..publish.paradata import extension_version

        print(f"Porous Weathering {extension_version()} (Blender {bpy.app.version_string})")
        parser.exit(0)


def build_parser():
    parser = _Parser(
        prog="python -m porous_weathering",
        description="Porous Weathering: porous materials and their weathering in Blender.",
    )
    parser.add_argument("--version", action=_Version, help="print the extension's and Blender's versions and exit")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module_name, help_text) in COMMANDS.items():
        sub = commands.add_parser(name, help=help_text, description=help_text)
        sub.set_defaults(module_name=module_name)
        importlib.import_module(module_name, __package__).configure_parser(sub)
    return parser


def main(argv=None):
    """Parse ``argv`` (default: sys.argv[1:]) and run the command; returns its exit code."""
    from ..blender import compat  # bpy: every command's module imports it anyway

    # a signal ends the process at once (common.interrupts): Blender's session folder goes too
    process_end.remove_at_end(compat.session_folder)
    if hasattr(sys.stdout, "reconfigure"):
        sys.stdout.reconfigure(line_buffering=True)
    args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    return importlib.import_module(args.module_name, __package__).run(args)


def exit_with(argv=None):
    """Run ``main(argv)`` and end the process with its exit code, skipping bpy's exit-time
    cleanup (``compat.end_process``: bpy 4.5 can hang for ever in a static destructor at
    interpreter exit, seen after opening a .blend whose text block is registered as a module)."""
    from ..blender import compat

    try:
        code = main(argv)
    except SystemExit as error:  # argparse's --help and usage errors
        code = error.code if isinstance(error.code, int) else EXIT_USAGE if error.code else EXIT_OK
    except KeyboardInterrupt:  # before a command took the signals over (bake: interrupts.py)
        print("interrupted by SIGINT", file=sys.stderr)
        code = EXIT_SIGINT
    compat.end_process(code)


_command_handle = None


def register():
    """Make the same commands available as ``blender -c porous_weathering COMMAND ...``."""
    import bpy

    global _command_handle
    _command_handle = bpy.utils.register_cli_command("porous_weathering", main)


def unregister():
    import bpy

    global _command_handle
    if _command_handle is not None:
        bpy.utils.unregister_cli_command(_command_handle)
        _command_handle = None
