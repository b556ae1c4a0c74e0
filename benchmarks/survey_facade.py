"""docs/survey.md's figures: the main job's limestone façade (samples/demo.py, its maps baked as the
demo bakes them) soiled, surveyed at 10, 25 and 50 years in its environment; prints the survey's
tables (the totals over the façade's objects per age and pattern, and the forecast per face).

    .venv-5.2/bin/python benchmarks/survey_facade.py [--bake-samples 16] [--out /tmp/pw-survey]
"""

import argparse
import collections
import os
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bake-samples", type=int, default=16)
    parser.add_argument("--out", default="/tmp/pw-survey")
    args = parser.parse_args()
    sys.path.insert(0, ROOT)
    from porous_weathering import survey
    from porous_weathering.core import model
    from porous_weathering.samples import demo

    facade = demo.Sample(demo.FACADE, map_dir=args.out, bake_samples=args.bake_samples)
    facade.show(model.SOILING, 0.0)
    result = survey.condition_survey(
        facade.objects, years=(10, 25, 50), environment=facade.recipe.environment, out_dir=args.out, name="facade"
    )
    totals = collections.defaultdict(float)
    for row in result.rows:
        totals[(row["years"], row["t"], row["pattern"])] += float(row["area_m2"])
    print(f"environment {facade.recipe.environment}; objects {', '.join(obj.name for obj in facade.objects)}")
    print("| years | t | pattern | area m² |")
    for (years, t, pattern), area in totals.items():
        print(f"| {years} | {t} | {pattern} | {area:.2f} |")
    faces = collections.defaultdict(list)
    for row in result.forecast_rows:
        faces[(row["face"], row["pattern"])].append(row)
    print("| face | pattern | objects | first shows (years) | cleaning (years) |")
    for (face, pattern), rows in sorted(faces.items()):
        first = min(float(row["first_shows_years"]) for row in rows)
        cleaning = [float(row["cleaning_years"]) for row in rows if row["cleaning_years"]]
        print(f"| {face} | {pattern} | {len(rows)} | {first:.1f} | {min(cleaning):.1f} |" if cleaning else
              f"| {face} | {pattern} | {len(rows)} | {first:.1f} | — |")  # fmt: skip
    print(result.csv)


if __name__ == "__main__":
    main()
