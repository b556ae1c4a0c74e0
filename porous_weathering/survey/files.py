"""The survey's files (docs/survey.md): ``<name>.survey.csv`` (a row per object, age and pattern),
its companion ``<name>.forecast.csv``, the paradata ``<name>.survey.json`` and the drawings, all
written to temporary files and renamed into place together (``atomic``), or none of them. A set
made from another .blend or other objects, or not by this extension, is never replaced silently
(``OverwriteRefused``); a set that would be written again as it is is left alone: "unchanged"."""

import contextlib
import csv
import io
import json
import os
from collections.abc import Callable, Sequence

import bpy

from ..common import atomic
from ..maps.provenance import OverwriteRefused, Provenance

CSV_SUFFIX, FORECAST_SUFFIX, JSON_SUFFIX = ".survey.csv", ".forecast.csv", ".survey.json"


def output_paths(out_dir: str, name: str) -> dict[str, str]:
    """{"csv", "forecast", "json"}: the paths of a survey's tables and paradata."""
    return {
        key: os.path.join(out_dir, name + suffix)
        for key, suffix in (("csv", CSV_SUFFIX), ("forecast", FORECAST_SUFFIX), ("json", JSON_SUFFIX))
    }


def check_out_dir(out_dir: str) -> None:
    """OSError, before any work, when the survey could not be written to ``out_dir``: a file in
    its place or on its way, or its nearest existing folder not writable. Nothing is made here:
    the folder is made as the survey is written (``write_survey``), not for a survey that fails
    or finds its files unchanged."""
    there = out_dir
    while not os.path.lexists(there) and os.path.dirname(there) != there:
        there = os.path.dirname(there)
    if not os.path.isdir(there):
        on_its_way = "" if there == out_dir else f" on its way, {there},"
        raise OSError(f"the output folder {out_dir} (--out) cannot be made: a file{on_its_way} is in its place")
    if not os.access(there, os.W_OK | os.X_OK):
        raise OSError(f"the output folder {out_dir} (--out) cannot take the files: {there} is not writable")


def csv_text(columns: Sequence[str], rows: Sequence[dict]) -> str:
    stream = io.StringIO()
    writer = csv.DictWriter(stream, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return stream.getvalue()


def _read_record(path):
    """The survey paradata at ``path`` when this extension wrote it, else None."""
    try:
        with open(path, encoding="utf-8") as stream:
            record = json.load(stream)
        mine = str(record["generator"]["extension"]).startswith("Porous Weathering ")
        return record if mine and isinstance(record["objects"], list) and "survey_version" in record else None
    except (OSError, ValueError, KeyError, TypeError):
        return None


def refuse_overwrite(paths: dict[str, str], objects: Sequence[str]) -> None:
    """OverwriteRefused when the survey at ``paths`` may not be replaced by a survey of
    ``objects`` from the open .blend: made from another .blend or of other objects, or not
    written by this extension."""
    there = [where for where in paths.values() if os.path.lexists(where)]
    if not there:
        return
    for where in there:
        if os.path.islink(where) or not os.path.isfile(where):
            raise OverwriteRefused(f"{where} is not a file that Porous Weathering wrote")
    record = _read_record(paths["json"])
    if record is None:
        raise OverwriteRefused(f"{there[0]} was not written by Porous Weathering (no survey paradata of its own)")
    made, wanted = record["source"]["blend_file"], os.path.abspath(bpy.data.filepath) if bpy.data.filepath else ""
    if not Provenance(made).yields_to(Provenance(wanted)):
        raise OverwriteRefused(f"{there[0]} was made from {made}, not from {wanted or 'an unsaved .blend'}")
    made_objects = sorted(str(item.get("name")) for item in record["objects"])
    if made_objects != sorted(objects):
        raise OverwriteRefused(f"{there[0]} surveys {', '.join(made_objects)}, not {', '.join(sorted(objects))}")


def _unchanged(paths, texts, record, drawings):
    """Whether the files at ``paths`` hold ``texts`` and ``record`` already (but for its date),
    and the ``drawings`` are there."""
    for key, text in texts.items():
        try:
            with open(paths[key], encoding="utf-8") as stream:
                if stream.read() != text:
                    return False
        except OSError:
            return False
    there = _read_record(paths["json"])
    same = there is not None and {**there, "created": ""} == {**record, "created": ""}
    return same and all(os.path.isfile(path) for group in drawings for path in group)


def write_survey(
    out_dir: str,
    paths: dict[str, str],
    texts: dict[str, str],
    record: dict,
    drawings: dict[tuple[str, ...], Callable[..., None]],
    objects: Sequence[str],
    force: bool,
) -> str:
    """Write the ``texts`` ({path key: text}), the paradata ``record`` and the ``drawings``
    ({(path, ...): draw(temporary path, ...)}) into place together: "written", or "unchanged" (nothing
    written) when they are there already."""
    if _unchanged(paths, texts, record, drawings):
        return "unchanged"
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as error:
        raise OSError(f"the output folder {out_dir} (--out) cannot be made: {error.strerror}") from None
    with contextlib.ExitStack() as stack:
        moves = []
        for key, text in texts.items():
            temporary = stack.enter_context(atomic.temporary_file(out_dir, os.path.splitext(paths[key])[1]))
            with open(temporary, "w", encoding="utf-8", newline="") as stream:
                stream.write(text)
            moves.append((temporary, paths[key]))
        sidecar = stack.enter_context(atomic.temporary_file(out_dir, ".json"))
        with open(sidecar, "w", encoding="utf-8") as stream:
            json.dump(record, stream, indent=2, ensure_ascii=False, allow_nan=False)
            stream.write("\n")
        moves.append((sidecar, paths["json"]))
        for group, draw in drawings.items():
            temporaries = [
                stack.enter_context(atomic.temporary_file(out_dir, os.path.splitext(path)[1])) for path in group
            ]
            draw(*temporaries)
            moves += zip(temporaries, group)
        if not force:
            refuse_overwrite(paths, objects)  # a survey that appeared meanwhile
        atomic.move_into_place_together(moves)
    return "written"
