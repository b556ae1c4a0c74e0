"""The condition survey (docs/survey.md, docs/model.md §10): for each weathered object and age,
the true area in m² of every pattern its modes produce (``core.condition``), written as
``DIR/<name>.survey.csv`` (object, years, t, pattern, area_m2, share) and its paradata
``DIR/<name>.survey.json``, both renamed into place together (``atomic``), or neither.

A pair made from another .blend or other objects, or not by this extension, is never replaced
silently (``OverwriteRefused``, unless ``force``); a pair that would be written again as it is
is left alone and reported "unchanged"."""

import csv
import datetime
import io
import json
import math
import numbers
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import bpy

import numpy as np

from ..common import atomic
from ..common.options import check, entries, option
from ..core import aging, condition, environments
from ..core.patterns import CLEANING_LOSS
from ..maps.bake import _Digests
from ..maps.provenance import OverwriteRefused, Provenance
from ..publish.paradata import extension_version, json_value
from ..publish.textures import porous_node
from ..shading.material import metres_per_unit
from . import points

CSV_SUFFIX, JSON_SUFFIX = ".survey.csv", ".survey.json"
#: The CSV's columns, in order (docs/survey.md).
COLUMNS = ("object", "years", "t", "pattern", "area_m2", "share")
SURVEY_VERSION = 1
#: Sample points classified per call of the model (bounds the memory a scan takes).
CHUNK = 250_000

STATEMENT = (
    "A forecast of the visible weathering patterns of the objects, classified from a physically based model "
    "of porous stone (docs/model.md §10); it is not a record of their observed condition."
)


def parse_numbers(text: str, what: str) -> tuple[float, ...]:
    """'10,25,50' -> (10.0, 25.0, 50.0); ValueError naming a word that is not a number."""
    found = []
    for word in (part.strip() for part in str(text).split(",")):
        if word:
            try:
                found.append(float(word))
            except ValueError:
                raise ValueError(f"{what} must be numbers separated by commas, not {word!r}") from None
    return tuple(found)


def _numbers(value, what):
    if value is None:
        return None
    if isinstance(value, str):
        value = parse_numbers(value, what)
    if isinstance(value, numbers.Real):
        value = (value,)
    found = []
    for item in value:
        if not isinstance(item, numbers.Real) or isinstance(item, bool) or math.isnan(item):
            raise ValueError(f"{what} must be numbers, not {item!r}")
        found.append(float(item))
    return tuple(found)


@dataclass(frozen=True)
class SurveyOptions:
    """What to survey (frozen; checked on creation: ValueError naming the bad field). The
    declarations generate the survey operator's properties and the ``survey`` command's flags."""

    years: tuple | None = option(
        None,
        label="Years",
        ui_default="10,25,50",
        metavar="Y,Y,...",
        tooltip="Comma-separated years of exposure, each an age t by the site's soiling law (aging.age_for_years)",
    )
    ages: tuple | None = option(
        None, label="Ages", metavar="T,T,...", ui=False, tooltip="Comma-separated ages t in [0, 1], instead of years"
    )
    environment: str = option(
        environments.DEFAULT_ENVIRONMENT,
        label="Environment",
        flag="--environment",
        choices=tuple(environments.ENVIRONMENTS),
        tooltip="The site whose soot loading turns years into t (docs/presets.md, 'Environments')",
    )
    out_dir: str = option(
        ".",
        label="Folder",
        flag="--out",
        kind="path",
        ui_default="//survey/",
        metavar="DIR",
        tooltip="Folder of the survey's CSV and paradata (// is the .blend's folder)",
    )
    name: str | None = option(
        None,
        label="File Name",
        flag="--name",
        metavar="NAME",
        tooltip="Name of the survey's files, NAME.survey.csv and NAME.survey.json (default: the .blend's name)",
    )
    force: bool = option(
        False,
        label="Replace",
        tooltip="Replace a survey made from another .blend or other objects, or not by Porous Weathering",
    )

    def __post_init__(self):
        years, ages = _numbers(self.years, "years"), _numbers(self.ages, "ages")
        if (years is None) == (ages is None) or not (years or ages):
            raise ValueError("give the years (--years 10,25,50) or the ages (--ages 0.5,1), one of them")
        for item in years or ():
            if not (math.isfinite(item) and item >= 0.0):
                raise ValueError(f"years must be numbers >= 0, not {item:g}")
        for item in ages or ():
            if not 0.0 <= item <= 1.0:
                raise ValueError(f"ages must be numbers in [0, 1], not {item:g}")
        object.__setattr__(self, "years", None if years is None else tuple(sorted(set(years))))
        object.__setattr__(self, "ages", None if ages is None else tuple(sorted(set(ages))))
        if not isinstance(self.out_dir, (str, os.PathLike)):
            raise ValueError(f"out_dir must be a folder's path (a str or os.PathLike), not {self.out_dir!r}")
        object.__setattr__(self, "out_dir", os.fspath(self.out_dir))
        if self.name == "":
            object.__setattr__(self, "name", None)
        if self.name is not None and (not isinstance(self.name, str) or "/" in self.name or self.name.startswith(".")):
            raise ValueError(f"name (--name) must be a file name without a folder, not {self.name!r}")
        check(self)

    def stages(self) -> tuple[tuple[float | None, float], ...]:
        """(years or None, t) of every age surveyed, in order."""
        if self.ages is not None:
            return tuple((None, age) for age in self.ages)
        carbon = environments.get(self.environment).elemental_carbon
        return tuple((years, aging.age_for_years(years, carbon)) for years in self.years)


def option_entries() -> list:
    """The survey options as front ends see them (``options.Entry``)."""
    return entries(SurveyOptions)


@dataclass(frozen=True)
class SurveyResult:
    csv: str
    paradata: str
    status: str  #: "written" or "unchanged"
    rows: tuple  #: the CSV's rows, as dicts of COLUMNS


@dataclass(frozen=True)
class Step:
    fraction: float
    message: str
    result: SurveyResult | None = None


def condition_survey(
    objects: Sequence["bpy.types.Object"],
    years: Sequence[float] | str | None = None,
    ages: Sequence[float] | str | None = None,
    *,
    out_dir: str,
    environment: str = environments.DEFAULT_ENVIRONMENT,
    name: str | None = None,
    force: bool = False,
    progress: Callable[[float, str], None] | None = None,
) -> SurveyResult:
    """Survey the weathered ``objects`` at ``years`` of exposure in ``environment`` (or at ``ages``
    t directly): the area in m² of each pattern, per object and age, in ``OUT/<name>.survey.csv``
    and its paradata ``OUT/<name>.survey.json`` (docs/survey.md). ValueError before any work for
    bad input (negative years, ages outside [0, 1], an object without a Porous Weathering
    material); OverwriteRefused (a ValueError) when ``out_dir`` holds a survey of that name made
    from another .blend or other objects, unless ``force``."""
    options = SurveyOptions(years=years, ages=ages, environment=environment, out_dir=out_dir, name=name, force=force)
    result = None
    for step in iter_survey(objects, options):
        if progress is not None:
            progress(step.fraction, step.message)
        result = step.result or result
    return result


def output_paths(out_dir: str, name: str) -> tuple[str, str]:
    return os.path.join(out_dir, name + CSV_SUFFIX), os.path.join(out_dir, name + JSON_SUFFIX)


def iter_survey(objects: Sequence["bpy.types.Object"], options: SurveyOptions) -> Iterator[Step]:
    """The Steps of a survey; the objects, the .blend and the output folder are checked at once,
    before anything starts (a generator: closing it early writes nothing)."""
    if not objects:
        raise ValueError("no objects to survey")
    for obj in objects:
        if obj.type != "MESH":
            raise ValueError(f"object '{obj.name}' has no mesh (its type is {obj.type}): only meshes can be surveyed")
        if not obj.material_slots or not any(slot.material for slot in obj.material_slots):
            raise ValueError(f"object '{obj.name}' has no material: give it a Porous Weathering material (Make)")
        for index in range(len(obj.material_slots)):
            material = obj.material_slots[index].material
            if porous_node(material) is None:
                what = f"material '{material.name}'" if material else "an empty slot"
                raise ValueError(f"object '{obj.name}', slot {index + 1} has {what}, not a Porous Weathering material")
    out_dir = os.path.abspath(bpy.path.abspath(options.out_dir))
    name = options.name or os.path.splitext(os.path.basename(bpy.data.filepath))[0] or "untitled"
    paths = output_paths(out_dir, name)
    if not options.force:
        refuse_overwrite(paths, [obj.name for obj in objects])
    return _steps(list(objects), options, out_dir, paths)


def _steps(objects, options, out_dir, paths):
    stages = options.stages()
    total = len(objects) * (1 + len(stages)) + 1
    done = 0
    digests = _Digests()
    rows, records, seen = [], [], {}
    for obj in objects:
        yield Step(done / total, f"{obj.name}: surface")
        found = points.surface(obj)
        if not len(found.areas_m2) or not found.areas_m2.sum() > 0.0:
            raise ValueError(f"object '{obj.name}': its mesh has no face of non-zero area (after its modifiers)")
        slots = sorted(set(found.slots.tolist()))
        materials = {
            slot: points.material_of(obj, min(slot, len(obj.material_slots) - 1), found) for slot in slots
        }
        patterns = _union(materials.values())
        seen.update((pattern.name, pattern) for pattern in patterns)
        done += 1
        areas = []
        for years, t in stages:
            yield Step(done / total, f"{obj.name}: t = {t:.4g}")
            per_pattern = pattern_areas(found, materials, patterns, t)
            areas.append(per_pattern)
            total_area = float(per_pattern.sum())
            for pattern, area in zip(patterns, per_pattern):
                rows.append(
                    dict(
                        object=obj.name,
                        years="" if years is None else f"{years:g}",
                        t=f"{t:.6g}",
                        pattern=pattern.name,
                        area_m2=f"{area:.6g}",
                        share=f"{area / total_area:.6g}",
                    )
                )
            done += 1
        records.append(_object_record(obj, found, materials, patterns, stages, areas, digests))
    yield Step(done / total, f"writing {os.path.basename(paths[0])}")
    record = _paradata(options, stages, records, sorted(seen.values(), key=lambda pattern: pattern.precedence))
    status = write_pair(out_dir, paths, _csv_text(rows), record, [obj.name for obj in objects], options.force)
    yield Step(1.0, f"{status} {paths[0]}", SurveyResult(paths[0], paths[1], status, tuple(rows)))


def _union(materials):
    found = {}
    for material in materials:
        for pattern in condition.survey_patterns(material.modes):
            found.setdefault(pattern.name, pattern)
    return tuple(sorted(found.values(), key=lambda pattern: pattern.precedence))


def classify_samples(found, materials, patterns, t):
    """(triangle indices, pattern index, area m²) of every sample point of ``found`` at age ``t``."""
    splits = found.splits()
    names = [pattern.name for pattern in patterns]
    for k in np.unique(splits):
        bary = points.barycentric_centroids(int(k))
        for slot, material in materials.items():
            chosen = np.flatnonzero((splits == k) & (found.slots == slot))
            local = np.array([names.index(p.name) for p in condition.survey_patterns(material.modes)])
            step = max(1, CHUNK // len(bary))
            for start in range(0, len(chosen), step):
                triangles = chosen[start : start + step]
                inputs = {key: read(triangles, bary) for key, read in material.readers.items()}
                inputs["time"] = np.full((len(triangles), len(bary)), t)
                stone = {key: inputs.pop(key) for key in points.STONE_INPUTS}
                index = condition.classify(
                    stone["kd"], stone["ks"], stone["m"], stone["alpha"], stone["sp"], material.modes, **inputs
                )
                weights = np.broadcast_to((found.areas_m2[triangles] / len(bary))[:, None], index.shape)
                yield triangles, local[index], weights


def pattern_areas(found, materials, patterns, t) -> np.ndarray:
    """The area in m² of each of ``patterns`` on ``found`` at age ``t``."""
    areas = np.zeros(len(patterns))
    for _, index, weights in classify_samples(found, materials, patterns, t):
        areas += np.bincount(index.ravel(), weights.ravel(), minlength=len(patterns))
    return areas


def _object_record(obj, found, materials, patterns, stages, areas, digests):
    return {
        "name": obj.name,
        "geometry_sha256": digests(obj),
        "triangles": len(found.areas_m2),
        "area_m2": float(found.areas_m2.sum()),
        "sample_points": int((found.splits() ** 2).sum()),
        "materials": [
            {"slot": slot + 1, "material": material.name, "modes": list(material.modes), "inputs": material.sources}
            for slot, material in materials.items()
        ],
        "patterns": [pattern.name for pattern in patterns],
        "areas_m2": [
            {"years": years, "t": t, **{pattern.name: float(area) for pattern, area in zip(patterns, row)}}
            for (years, t), row in zip(stages, areas)
        ],
    }


def _paradata(options, stages, records, every):
    site = environments.get(options.environment)
    return json_value(
        {
            "survey_version": SURVEY_VERSION,
            "kind": "condition survey (forecast)",
            "statement": STATEMENT,
            "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "generator": {"extension": f"Porous Weathering {extension_version()}", "blender": bpy.app.version_string},
            "model": "docs/model.md §10 (numpy model, face on, ambient light)",
            "source": {"blend_file": os.path.abspath(bpy.data.filepath) if bpy.data.filepath else ""},
            "unit_scale_m": metres_per_unit(),
            "environment": {
                "name": options.environment,
                "elemental_carbon_ug_m3": site.elemental_carbon,
                "law": "sqrt",
                "years_to_t_1": aging.years_for_full_age(site.elemental_carbon),
            },
            "cleaning_threshold_loss": CLEANING_LOSS,
            "ages": [{"years": years, "t": t} for years, t in stages],
            "patterns": [
                {
                    "name": pattern.name,
                    "nsd_iri": pattern.nsd_iri,
                    "rule": pattern.rule_text,
                    "colour_srgb": list(pattern.colour),
                    "hatch": pattern.hatch,
                }
                for pattern in every
            ],
            "objects": records,
        },
        "the survey's paradata",
    )


def _csv_text(rows):
    stream = io.StringIO()
    writer = csv.DictWriter(stream, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return stream.getvalue()


# --- the files ------------------------------------------------------------------------------------


def _read_record(path):
    try:
        with open(path, encoding="utf-8") as stream:
            record = json.load(stream)
        mine = str(record["generator"]["extension"]).startswith("Porous Weathering ")
        return record if mine and isinstance(record["objects"], list) and "survey_version" in record else None
    except (OSError, ValueError, KeyError, TypeError):
        return None


def refuse_overwrite(paths: tuple[str, str], objects: Sequence[str]) -> None:
    """OverwriteRefused when the survey pair at ``paths`` may not be replaced by a survey of
    ``objects`` from the open .blend: made from another .blend or of other objects, or not
    written by this extension."""
    there = [where for where in paths if os.path.lexists(where)]
    if not there:
        return
    for where in there:
        if os.path.islink(where) or not os.path.isfile(where):
            raise OverwriteRefused(f"{where} is not a file that Porous Weathering wrote")
    record = _read_record(paths[1])
    if record is None:
        raise OverwriteRefused(f"{there[0]} was not written by Porous Weathering (no survey paradata of its own)")
    made, wanted = record["source"]["blend_file"], os.path.abspath(bpy.data.filepath) if bpy.data.filepath else ""
    if not Provenance(made).yields_to(Provenance(wanted)):
        raise OverwriteRefused(f"{there[0]} was made from {made}, not from {wanted or 'an unsaved .blend'}")
    made_objects = sorted(str(item.get("name")) for item in record["objects"])
    if made_objects != sorted(objects):
        raise OverwriteRefused(f"{there[0]} surveys {', '.join(made_objects)}, not {', '.join(sorted(objects))}")


def _same(paths, text, record):
    """Whether the pair at ``paths`` holds ``text`` and ``record`` already (but for its date)."""
    try:
        with open(paths[0], encoding="utf-8") as stream:
            same_csv = stream.read() == text
    except OSError:
        return False
    there = _read_record(paths[1])
    return same_csv and there is not None and {**there, "created": ""} == {**record, "created": ""}


def write_pair(out_dir, paths, text, record, objects, force) -> str:
    """Write the CSV and its paradata into place together: "written", or "unchanged" (nothing
    written) when the pair there holds them already."""
    if _same(paths, text, record):
        return "unchanged"
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as error:
        raise OSError(f"the output folder {out_dir} (--out) cannot be made: {error.strerror}") from None
    with atomic.temporary_file(out_dir, ".csv") as table, atomic.temporary_file(out_dir, ".json") as sidecar:
        with open(table, "w", encoding="utf-8", newline="") as stream:
            stream.write(text)
        with open(sidecar, "w", encoding="utf-8") as stream:
            json.dump(record, stream, indent=2, ensure_ascii=False, allow_nan=False)
            stream.write("\n")
        if not force:
            refuse_overwrite(paths, objects)  # a pair that appeared meanwhile
        atomic.move_into_place_together([(table, paths[0]), (sidecar, paths[1])])
    return "written"
