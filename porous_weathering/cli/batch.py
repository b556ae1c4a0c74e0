"""What the commands that take several .blend files share (``bake``, ``survey``): the files
given (a word ending in .blend after ``--objects`` too), checked before any work; each file's
run, whose error is one line on stderr and never stops the other files. The exit code over the
files is ``contracts.batch_exit_code``; the same files on a Dask cluster are ``distributed``."""

import os
import sys
import warnings
from collections.abc import Callable

from ..common.progress import ProgressBar
from ..contracts import EXIT_FAILED, EXIT_OK, EXIT_REFUSED
from ..maps.provenance import OverwriteRefused
from .selection import one_line


def files_and_objects(command: str, files: list[str], objects: list[str]) -> tuple[list[str], list[str]]:
    """(files, object names): ``--objects`` takes every word up to the next option, so a word
    ending in .blend that names an existing file is taken back as a file. ValueError when no
    file is given."""
    taken = [word for word in objects if word.endswith(".blend") and os.path.isfile(word)]
    names = [word for word in objects if word not in taken]
    if objects and not names:
        raise ValueError("--objects needs at least one object name")
    files = [*files, *taken]
    if not files:
        raise ValueError(f"no .blend file given (usage: {command} FILE.blend [FILE.blend ...] [options])")
    return files, names


def check_paths(files: list[str]) -> None:
    """ValueError for a folder given as a file, FileNotFoundError naming every missing file."""
    for path in files:
        if os.path.isdir(path):
            raise ValueError(f"{path} is a folder, not a .blend file")
    missing = [path for path in files if not os.path.isfile(path)]
    if missing:
        raise FileNotFoundError(f"no such .blend file: {', '.join(missing)}")


def run_file(bar: ProgressBar, force_hint: str, work: Callable[..., None], path: str, *arguments) -> int:
    """``work(path, *arguments)``, one file of a batch; its exit code. A warning is one line on
    stderr above ``bar``; an error one line below it as it stopped, ``force_hint`` after a refusal
    (``OverwriteRefused``)."""

    def fail(line):
        bar.finish()
        print(line, file=sys.stderr)

    # a warning (a scan that looks set up wrongly, ...) is one line, above the progress bar
    warnings.showwarning = lambda message, *_: bar.print(f"warning: {message}", file=sys.stderr)
    try:
        work(path, *arguments)
    except OverwriteRefused as error:
        fail(f"error: {path}: {one_line(error)}; {force_hint}")
        return EXIT_REFUSED
    except (ValueError, OSError, RuntimeError) as error:
        fail(f"error: {path}: {one_line(error)}")
        return EXIT_FAILED
    except Exception as error:  # a bug: said in one line, and the other files go on
        fail(f"error: {path}: {type(error).__name__}: {one_line(error)} (a bug: please report it)")
        return EXIT_FAILED
    return EXIT_OK
