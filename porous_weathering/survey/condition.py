"""The condition survey (docs/survey.md, docs/model.md §10): for each weathered object and age,
the true area in m² of every pattern its modes produce (``core.condition``), written as
``DIR/<name>.survey.csv`` (object, years, t, pattern, area_m2, share) and its paradata
``DIR/<name>.survey.json``, both renamed into place together (``atomic``), or neither.

A pair made from another .blend or other objects, or not by this extension, is never replaced
silently (``OverwriteRefused``, unless ``force``); a pair that would be written again as it is
is left alone and reported "unchanged"."""

import datetime
import hashlib
import math
import numbers
import os
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, fields

import bpy

import numpy as np

from ..common.options import check, comma_words, entries, option, to_argv
from ..common.progress import run_steps
from ..contracts import safe_file_name
from ..core import aging, condition, environments, solar
from ..core.patterns import CLEANING_LOSS, NO_VISIBLE_CHANGE
from ..maps import linking, sun
from ..publish.paradata import extension_version, json_value
from ..publish.textures import porous_node
from ..shading.material import metres_per_unit
from . import files, forecast, points, sheet, tally

#: The survey table's columns, in order (docs/survey.md).
COLUMNS = ("object", "years", "t", "pattern", "area_m2", "share")
SURVEY_VERSION = 1

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
        flag="--years",
        ui_default="10,25,50",
        metavar="Y,Y,...",
        tooltip="Comma-separated years of exposure, each an age t by the site's soiling law (aging.age_for_years)",
    )
    ages: tuple | None = option(
        None,
        label="Ages",
        flag="--ages",
        metavar="T,T,...",
        ui=False,
        tooltip="Comma-separated ages t in [0, 1], instead of years",
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
    north_angle: float | None = sun.north_angle_option(
        "for the forecast's faces and the drawings' views; unset (0 in the dialog): the north each object's sun map "
        "was baked with, else the scene's Sun Position north offset, else 0"
    )
    views: tuple = option(
        tuple(sheet.ELEVATIONS),
        label="Views",
        flag="--views",
        choices=sheet.VIEWS,
        metavar="VIEW,...",
        tooltip="Comma-separated views the drawings show: the elevations north, east, south and west (each side seen "
        "from where it faces) and the plan (from above)",
    )
    scale: int = option(
        sheet.PRINT_SCALE,
        label="Scale",
        flag="--scale",
        low=1,
        high=sheet.STANDARD_SCALES[-1],
        whole=True,
        metavar="N",
        tooltip="The drawings' print scale 1:N on A3 (1:50 for a building, 1:5 or 1:10 for a sculpture), or the next "
        "standard scale at which their views fit",
    )
    force: bool = option(
        False,
        label="Replace",
        flag="--force",
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
        if isinstance(self.views, str):  # a comma-separated text, as the years may be
            object.__setattr__(self, "views", comma_words(self.views))
        elif isinstance(self.views, list):
            object.__setattr__(self, "views", tuple(self.views))
        if self.name is not None and (not isinstance(self.name, str) or "/" in self.name or self.name.startswith(".")):
            raise ValueError(f"name (--name) must be a file name without a folder, not {self.name!r}")
        check(self)
        object.__setattr__(self, "scale", int(self.scale))  # a whole number (checked), as the sheet takes it

    def stages(self) -> tuple[tuple[float | None, float], ...]:
        """(years or None, t) of every age surveyed, in order."""
        if self.ages is not None:
            return tuple((None, age) for age in self.ages)
        carbon = environments.get(self.environment).elemental_carbon
        return tuple((years, aging.age_for_years(years, carbon)) for years in self.years)

    def north_of(self, obj: "bpy.types.Object") -> float:
        """North's angle from +Y, clockwise seen from above, in degrees, for ``obj``: the one
        given, else the site its sun map was baked at (docs/model.md §9.1), else the scene's."""
        if self.north_angle is not None:
            return float(self.north_angle)
        recorded = linking.recorded_settings(obj, "sun") or {}
        given = {field.name: recorded[field.name] for field in fields(sun.SunSettings) if field.name in recorded}
        return sun.site(sun.SunSettings(**given), sun.scene_of(obj))[1]

    def to_argv(self) -> list[str]:
        """The ``survey`` command-line words that give these options (for the Dask workers)."""
        return to_argv(option_entries(), lambda entry: getattr(self, entry.name))


def option_entries() -> list:
    """The survey options as front ends see them (``options.Entry``)."""
    return entries(SurveyOptions)


@dataclass(frozen=True)
class SurveyResult:
    csv: str  #: the survey table
    forecast: str  #: its companion, the forecast table
    paradata: str
    status: str  #: "written" or "unchanged"
    rows: tuple  #: the survey table's rows, as dicts of COLUMNS
    forecast_rows: tuple  #: the forecast table's rows, as dicts of forecast.COLUMNS
    drawings: tuple  #: the drawings' paths (none where matplotlib is missing)


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
    north_angle: float | None = None,
    views: Sequence[str] | str = tuple(sheet.ELEVATIONS),
    scale: int = sheet.PRINT_SCALE,
    force: bool = False,
    progress: Callable[[float, str], None] | None = None,
) -> SurveyResult:
    """Survey the weathered ``objects`` at ``years`` of exposure in ``environment`` (or at ``ages``
    t directly): the area in m² of each pattern, per object and age, in ``OUT/<name>.survey.csv``,
    the forecast per face and pattern in ``OUT/<name>.forecast.csv`` and the paradata in
    ``OUT/<name>.survey.json`` (docs/survey.md); ``north_angle`` is north's angle from the scene's
    +Y, clockwise seen from above, in degrees (None: each object's sun map's, else the scene's);
    the drawings show ``views`` (of sheet.VIEWS) at 1:``scale`` on A3, or the next standard scale
    at which they fit. ValueError before any work for bad input (negative years, ages outside [0, 1], an object
    without a Porous Weathering material), OSError before any work when ``out_dir`` could not take
    the files (``files.check_out_dir``); OverwriteRefused (a ValueError) when ``out_dir`` holds
    a survey of that name made from another .blend or other objects, unless ``force``."""
    options = SurveyOptions(
        years=years,
        ages=ages,
        environment=environment,
        out_dir=out_dir,
        name=name,
        north_angle=north_angle,
        views=views,
        scale=scale,
        force=force,
    )
    return run_steps(iter_survey(objects, options), progress)


def iter_survey(objects: Sequence["bpy.types.Object"], options: SurveyOptions) -> Iterator[Step]:
    """The Steps of a survey; the objects, the .blend and the output folder are checked at once,
    before anything starts (a generator: closing it early writes nothing)."""
    if not objects:
        raise ValueError("no objects to survey")
    for obj in objects:
        if obj.type != "MESH":
            raise ValueError(f"object '{obj.name}' has no mesh (its type is {obj.type}): only meshes can be surveyed")
        if not obj.material_slots:
            raise ValueError(f"object '{obj.name}' has no material: give it a Porous Weathering material (Make)")
        for index, slot in enumerate(obj.material_slots):
            if porous_node(slot.material) is None:
                what = f"material '{slot.material.name}'" if slot.material else "an empty slot"
                raise ValueError(f"object '{obj.name}', slot {index + 1} has {what}, not a Porous Weathering material")
    out_dir = os.path.abspath(bpy.path.abspath(options.out_dir))
    name = options.name or os.path.splitext(os.path.basename(bpy.data.filepath))[0] or "untitled"
    paths = files.output_paths(out_dir, name)
    files.check_out_dir(out_dir)
    if not options.force:
        files.refuse_overwrite(paths, [obj.name for obj in objects])
    return _steps(list(objects), options, out_dir, name, paths)


@dataclass
class _Surveyed:
    """What the survey found on one object: its surface, materials and patterns, and the tally
    at each surveyed age and at each age of the forecast."""

    obj: "bpy.types.Object"
    north_angle: float
    surface: points.Surface
    materials: dict
    patterns: tuple
    tallies: list
    forecast: list


def _steps(objects, options, out_dir, name, paths):
    stages = options.stages()
    carbon = environments.get(options.environment).elemental_carbon

    def clocks(years, t):
        """{clock input: value} at an age (docs/model.md §9.4): t, and the clocks counted in years,
        from the years asked for, or those after which the site reaches t."""
        return {**aging.ages_for_years(aging.years_for_age(t, carbon) if years is None else years, carbon), "time": t}

    total = len(objects) * (1 + len(stages) + len(forecast.FORECAST_AGES)) + 1
    done = 0
    # without matplotlib (Blender's own Python, until it is installed there) the tables are written
    # and the drawings left out, said in one line (docs/survey.md, "matplotlib in Blender")
    cannot_draw = sheet.cannot_draw()
    drawn = cannot_draw is None
    if cannot_draw:
        yield Step(0.0, f"no drawings: {cannot_draw}")
    surveyed = []
    for obj in objects:
        yield Step(done / total, f"{obj.name}: surface")
        found = points.surface(obj)
        if not found.areas_m2.sum() > 0.0:
            raise ValueError(f"object '{obj.name}': its mesh has no face of non-zero area (after its modifiers)")
        materials = {
            slot: points.material_of(obj, min(slot, len(obj.material_slots) - 1), found)
            for slot in sorted(set(found.slots.tolist()))
        }
        patterns = tally.union(materials.values())
        if patterns == (NO_VISIBLE_CHANGE,):
            warnings.warn(
                f"object '{obj.name}': its materials have no weathering mode, so it shows no visible change at any "
                "age; make its material with the modes to survey (the panel's Weathering switches, or modes=)",
                stacklevel=2,
            )
        north = options.north_of(obj)
        faces = condition.faces_of(found.normals, solar.site_to_scene(north)[:2, 1])
        done += 1
        tallies = []
        for years, t in stages:
            yield Step(done / total, f"{obj.name}: t = {t:.4g}")
            tallies.append(tally.tally(found, materials, patterns, clocks(years, t), faces, drawn=drawn))
            done += 1
        ahead, read = [], forecast.triangles(len(found.areas_m2))
        for t in forecast.FORECAST_AGES:
            yield Step(done / total, f"{obj.name}: forecast, t = {t:.4g}")
            ahead.append(
                tally.tally(
                    found, materials, patterns, clocks(None, t), faces, triangles=read, target=forecast.FORECAST_SAMPLES
                )
            )
            done += 1
        surveyed.append(_Surveyed(obj, north, found, materials, patterns, tallies, forecast.forecast(patterns, ahead)))
    yield Step(done / total, f"writing {os.path.basename(paths['csv'])}")
    created = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    rows, ahead_rows = _rows(surveyed, stages), _forecast_rows(surveyed, options)
    texts = {"csv": files.csv_text(COLUMNS, rows), "forecast": files.csv_text(forecast.COLUMNS, ahead_rows)}
    drawings = _drawings(surveyed, options, stages, out_dir, name, created)
    record = _paradata(options, stages, surveyed, created, drawn=bool(drawings))
    status = files.write_survey(
        out_dir, paths, texts, record, drawings, [item.obj.name for item in surveyed], options.force
    )
    result = SurveyResult(
        paths["csv"],
        paths["forecast"],
        paths["json"],
        status,
        tuple(rows),
        tuple(ahead_rows),
        tuple(path for group in drawings for path in group),
    )
    yield Step(1.0, f"{status} {paths['csv']}", result)


def _rows(surveyed, stages):
    rows = []
    for item in surveyed:
        for (years, t), found in zip(stages, item.tallies):
            whole = float(found.areas.sum())
            for pattern, area in zip(item.patterns, found.areas):
                rows.append(
                    dict(
                        object=item.obj.name,
                        years="" if years is None else f"{years:g}",
                        t=f"{t:.6g}",
                        pattern=pattern.name,
                        area_m2=f"{area:.6g}",
                        share=f"{area / whole:.6g}",
                    )
                )
    return rows


def _forecast_rows(surveyed, options):
    carbon = environments.get(options.environment).elemental_carbon

    def number(value):
        return "" if value is None else f"{value:.4g}"

    return [
        dict(
            object=item.obj.name,
            face=row.face,
            pattern=row.pattern,
            first_shows_years=number(forecast.years_of(row.first_shows_t, carbon)),
            first_shows_t=number(row.first_shows_t),
            cleaning_years=number(forecast.years_of(row.cleaning_t, carbon)),
            cleaning_t=number(row.cleaning_t),
        )
        for item in surveyed
        for row in item.forecast
    ]


def _paradata(options, stages, surveyed, created, drawn):
    site = environments.get(options.environment)
    every = {pattern.name: pattern for item in surveyed for pattern in item.patterns}
    return json_value(
        {
            "survey_version": SURVEY_VERSION,
            "kind": "condition survey (forecast)",
            "statement": STATEMENT,
            "created": created,
            "generator": {"extension": f"Porous Weathering {extension_version()}", "blender": bpy.app.version_string},
            "model": "docs/model.md §10: the numpy model at sample points, face on, ambient light",
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
            "forecast": {
                "ages": list(forecast.FORECAST_AGES),
                "shows_share": forecast.SHOWS_SHARE,
                "sample_points": forecast.FORECAST_SAMPLES,
                "faces": list(condition.FACES),
            },
            "patterns": [
                {
                    "name": pattern.name,
                    "nsd_iri": pattern.nsd_iri,
                    "rule": pattern.rule_text,
                    "colour_srgb": list(pattern.colour),
                    "hatch": pattern.hatch,
                }
                for pattern in sorted(every.values(), key=lambda pattern: pattern.precedence)
            ],
            "objects": [_object_record(item, stages) for item in surveyed],
            # as asked: a sheet whose views do not fit says the scale it is drawn at
            "drawings": {"views": list(options.views), "scale": options.scale} if drawn else None,
        },
        "the survey's paradata",
    )


def _object_record(item, stages):
    return {
        "name": item.obj.name,
        "north_angle_degrees": item.north_angle,  # from +Y, clockwise seen from above
        # the surface surveyed: its triangles' world corners in metres (float32)
        "geometry_sha256": hashlib.sha256(item.surface.triangles_m.astype(np.float32).tobytes()).hexdigest(),
        "triangles": len(item.surface.areas_m2),
        "area_m2": float(item.surface.areas_m2.sum()),
        "sample_points": int((item.surface.splits() ** 2).sum()),
        "materials": [
            {"slot": slot + 1, "material": material.name, "modes": list(material.modes), "inputs": material.sources}
            for slot, material in item.materials.items()
        ],
        "areas_m2": [
            {"years": years, "t": t, **{pattern.name: float(area) for pattern, area in zip(item.patterns, found.areas)}}
            for (years, t), found in zip(stages, item.tallies)
        ],
    }


# --- the drawings (survey/sheet.py) ------------------------------------------------------------------


def _drawings(surveyed, options, stages, out_dir, name, created):
    """{(svg path, png path): draw(svg, png)}: one sheet per object and age, none where
    matplotlib is missing (``sheet.cannot_draw``)."""
    if sheet.cannot_draw():
        return {}
    carbon = environments.get(options.environment).elemental_carbon
    north_of = {id(item): tuple(solar.site_to_scene(item.north_angle)[:2, 1]) for item in surveyed}
    frames = {}

    def frame_of(item, counted):
        """The views' geometry of ``item``'s sheets, made with its first sheet and kept for the
        others: every age samples the same points (``tally``), only their patterns differ."""
        if id(item) not in frames:
            frames.clear()  # one object's at a time
            triangles = points.small_triangles(item.surface, *counted.drawn_points, item.surface.splits())
            frames[id(item)] = sheet.make_frame(triangles, north_of[id(item)], options.views, options.scale)
        return frames[id(item)]

    found = {}
    for item in surveyed:
        shown = [pattern for pattern in item.patterns if pattern is not NO_VISIBLE_CHANGE]
        order = np.array([shown.index(p) if p in shown else -1 for p in item.patterns])
        ahead = tuple(
            (row.face, row.pattern, *(forecast.years_of(age, carbon) for age in (row.first_shows_t, row.cleaning_t)))
            for row in item.forecast
        )
        for (years, t), counted in zip(stages, item.tallies):
            label = f"{years:g}y" if years is not None else f"t{t:g}"
            stem = os.path.join(out_dir, f"{name}.{safe_file_name(item.obj.name)}.{label}")

            def draw(svg, png, item=item, counted=counted, years=years, t=t, shown=shown, order=order, ahead=ahead):
                """One sheet; its object's views are made when its first sheet is drawn."""
                frame = frame_of(item, counted)
                data = sheet.SheetData(
                    object_name=item.obj.name,
                    environment=options.environment,
                    years=years,
                    t=t,
                    date=created[:10],
                    triangles_m=None,
                    pattern_index=order[counted.drawn_patterns],
                    patterns=tuple((p.name, p.colour, p.hatch) for p in shown),
                    areas_m2=tuple(float(counted.areas[item.patterns.index(p)]) for p in shown),
                    north=north_of[id(item)],
                    scale=options.scale,
                    views=options.views,
                    forecast=ahead,
                )
                sheet.write_sheets(data, svg, png, frame)

            found[(stem + ".svg", stem + ".png")] = draw
    return found
