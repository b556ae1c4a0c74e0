"""docs/survey.md's figures: the main job's limestone façade (samples/demo.py, its maps baked as the
demo bakes them) soiled, surveyed at the years given in its environment; prints the survey's time
and tables (the totals over the façade's objects per age and pattern, and the forecast per face);
with ``--images DIR``, renders the façade at each age by the survey's clocks and writes each
condition map beside its render there (``demo.render_facade_survey``, as ``demo --docs`` does in
docs/images).

    .venv-5.2/bin/python benchmarks/survey_facade.py [--years 10,25,50] [--bake-samples 32]
        [--out /tmp/pw-survey] [--images docs/images]
"""

import argparse
import collections
import os
import subprocess
import sys
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--years", default="10,25,50")
    parser.add_argument("--bake-samples", type=int, default=32)
    parser.add_argument("--out", default="/tmp/pw-survey")
    parser.add_argument("--images", default=None, help="write the renders and condition maps here")
    parser.add_argument("--size", type=int, default=540)
    parser.add_argument("--samples", type=int, default=4)
    args = parser.parse_args()
    sys.path.insert(0, ROOT)
    from porous_weathering.samples import demo
    from porous_weathering.survey.condition import parse_numbers

    started = time.perf_counter()
    facade = demo.Sample(demo.FACADE, map_dir=args.out, bake_samples=args.bake_samples)
    baked = time.perf_counter()
    result = demo.survey_facade(facade, parse_numbers(args.years, "years"), args.out)
    surveyed = time.perf_counter()
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"bake {baked - started:.1f} s, survey {surveyed - baked:.1f} s ({load})")
    if args.images:
        facade.use_cycles(args.size, args.samples)
        for path in demo.render_facade_survey(facade, result, args.out, args.images):
            print("wrote", path)
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
