"""Render timings with the fixed per-render cost taken out, for a machine shared with others.

A render's wall time is a fixed part (scene sync, BVH, shader compile, EXR round trip) plus a
part proportional to the samples.  Every material is rendered at two sample counts, in
interleaved rounds (each round renders every material at both counts back to back, so load
on the machine hits all of them alike); per round, the slope between the two counts is the
cost of one sample and its ratio to the baseline material's slope in the same round is the
overhead.  Medians over rounds are reported, with the range of the ratios.
"""

import statistics
import time

from porous_weathering.blender import render
from porous_weathering.samples import studio


def wall_and_cpu_seconds(run):
    """(wall, CPU) seconds of ``run()``. CPU time is this process's own, which the other jobs
    of a shared machine disturb less than the wall time."""
    wall, cpu = time.perf_counter(), time.process_time()
    run()
    return time.perf_counter() - wall, time.process_time() - cpu


def timed_render(scene):
    start = time.perf_counter()
    image = render.render_array(scene)
    return time.perf_counter() - start, image


def interleaved_rounds(scene, obj, materials, configure, sample_counts, rounds, warm_up=1):
    """{(name, samples): [seconds per round]} and {(name, samples): last image}.

    ``configure(scene, samples)`` sets the engine up; the first ``warm_up`` rounds (shader
    compiles, kernel loading, caches) are not kept.
    """
    times = {(name, samples): [] for name in materials for samples in sample_counts}
    images = {}
    for round_ in range(warm_up + rounds):
        for name, material in materials.items():
            studio.assign(obj, material)
            for samples in sample_counts:
                configure(scene, samples)
                seconds, images[name, samples] = timed_render(scene)
                if round_ >= warm_up:
                    times[name, samples].append(seconds)
    return times, images


def costs(times, names, sample_counts, baseline):
    """name -> dict: median fixed seconds, median ms per sample, median and range of the
    per-round ratio of its per-sample cost to ``baseline``'s."""
    low, high = sample_counts[0], sample_counts[-1]

    def slopes(name):
        return [(t_high - t_low) / (high - low) for t_low, t_high in zip(times[name, low], times[name, high])]

    base = slopes(baseline)
    result = {}
    for name in names:
        per_sample = slopes(name)
        ratios = [s / b if b > 0 else float("nan") for s, b in zip(per_sample, base)]
        fixed = [t - s * low for t, s in zip(times[name, low], per_sample)]
        result[name] = {
            "fixed s": statistics.median(fixed),
            "ms/sample": 1000 * statistics.median(per_sample),
            "ratio": statistics.median(ratios),
            "ratio range": (min(ratios), max(ratios)),
        }
    return result


def ratio_cell(cost):
    low, high = cost["ratio range"]
    return f"{cost['ratio']:.3f} ({low:.2f}–{high:.2f})"
