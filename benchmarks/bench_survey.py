"""The condition survey's time on a scan-sized mesh: a heightfield of ``--triangles`` triangles
(bench_scale.heightfield) under the three modes, its masks colour attributes, surveyed at four
ages (the issue's target: 2M triangles, four ages, at most 60 s), its forecast included.

    .venv-5.2/bin/python benchmarks/bench_survey.py [--triangles 2000000] [--ages 0.25,0.5,0.75,1]
"""

import argparse
import os
import sys
import tempfile
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=2_000_000)
    parser.add_argument("--ages", default="0.25,0.5,0.75,1")
    args = parser.parse_args()
    sys.path.insert(0, ROOT)
    import bpy

    import numpy as np

    import porous_weathering as pw
    from benchmarks.bench_scale import heightfield
    from porous_weathering import survey

    bpy.ops.wm.read_factory_settings(use_empty=True)
    start = time.perf_counter()
    obj = heightfield("Scan", args.triangles)
    positions = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", positions)
    x, y = positions.reshape(-1, 3)[:, :2].T / 4.0
    for name, values in (("rain", x), ("edges", y), ("salt", (x + y) / 2)):
        attribute = obj.data.color_attributes.new(name, "FLOAT_COLOR", "POINT")
        attribute.data.foreach_set("color", np.column_stack([values, values, values, np.ones_like(x)]).ravel())
    material = pw.make_weathered_material(
        "Scan", modes=("soiling", "wet", "efflorescence"), rain_map="rain", edge_map="edges", efflorescence_map="salt"
    )
    obj.data.materials.append(material)
    built = time.perf_counter() - start
    steps = {}
    last = [time.perf_counter()]

    def progress(fraction, message):
        now = time.perf_counter()
        steps[message] = now
        last[0] = now

    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        result = survey.condition_survey([obj], ages=args.ages, out_dir=out, name="scan", progress=progress)
    total = time.perf_counter() - start
    marks = sorted(steps.items(), key=lambda item: item[1])
    print(f"{len(obj.data.polygons)} triangles, built in {built:.1f} s; survey of {args.ages}: {total:.1f} s")
    for (message, at), (_, following) in zip(marks, [*marks[1:], ("end", start + total)]):
        if not message.startswith("Scan: forecast"):
            print(f"  {message:40} {following - at:6.2f} s")
    forecast = [at for message, at in marks if message.startswith("Scan: forecast")]
    print(f"  forecast ({len(forecast)} ages) {marks[-1][1] - forecast[0]:6.2f} s" if forecast else "")
    print(f"  rows: {len(result.rows)}; load: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
