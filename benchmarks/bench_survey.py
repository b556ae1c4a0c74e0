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
    steps = {}  # message: (wall clock, this process's CPU time) when the step began

    def progress(fraction, message):
        steps[message] = (time.perf_counter(), time.process_time())

    start = (time.perf_counter(), time.process_time())
    with tempfile.TemporaryDirectory() as out:
        result = survey.condition_survey([obj], ages=args.ages, out_dir=out, name="scan", progress=progress)
    end = (time.perf_counter(), time.process_time())
    # on a machine shared with other jobs the CPU time is near what the survey takes alone
    print(f"{len(obj.data.polygons)} triangles, built in {built:.1f} s; survey of {args.ages}: ", end="")
    print(f"{end[0] - start[0]:.1f} s ({end[1] - start[1]:.1f} s of CPU)")
    marks = sorted(steps.items(), key=lambda item: item[1])
    forecast = [at for message, at in marks if message.startswith("Scan: forecast")]
    shown = [item for item in marks if not item[0].startswith("Scan: forecast")]
    if forecast:
        shown.append((f"forecast ({len(forecast)} ages)", forecast[0]))
        shown.sort(key=lambda item: item[1])
    for (message, at), (_, following) in zip(shown, [*shown[1:], ("end", end)]):
        print(f"  {message:40} {following[0] - at[0]:6.2f} s ({following[1] - at[1]:.2f} s of CPU)")
    print(f"  rows: {len(result.rows)}; load: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
