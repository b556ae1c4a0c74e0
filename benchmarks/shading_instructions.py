"""Shading cost counted in executed instructions: the noise-free twin of shading.py (docs/benchmarks.md,
"Builds 5 and 6, counted in instructions").

On a shared machine render times scatter by ±20–40% per round (docs/benchmarks.md), more than
a few nodes change them.  Valgrind's cachegrind counts the instructions a process executes,
which other jobs on the machine do not change.  Same scene as shading.py (the sphere filling
the frame, sun 45° + overcast sky, 2 bounces, fixed seed), one render thread; each material is
rendered by a child process under cachegrind at two sample counts, and the instructions of one
sample are the slope between them, so the set-up (import, scene, kernel loading) drops out.
Instructions are not seconds (a division or a cache miss costs more than an addition): this
sizes and ranks changes; shading.py's times on a quiet machine remain the measure in seconds.

    python benchmarks/shading_instructions.py [--size 48] [--jobs 2] [--materials NAME ...] [--functions N]
        [--out FILE]

Needs valgrind; each child takes about 2.5 minutes (most of it importing bpy under valgrind).
"""

import argparse
import collections
import concurrent.futures
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

from benchmarks import scenes  # noqa: E402

SAMPLES = (8, 40)
DEFAULT_MATERIALS = (
    "Diffuse+Glossy",
    "porous key light",
    "porous ambient",
    "all three modes, key light",
    "all three modes, key light, baked maps",
)
#: Functions of Cycles' shader virtual machine (the node interpreter and the nodes it runs)
#: and the maths library the nodes call.
SHADER_FUNCTIONS = ("svm_", "powf", "acosf", "expf", "logf")
#: Cycles' own instructions: its functions (namespace ccl) and the C maths library's they call.
#: The rest of a render's (Blender's image buffers, the allocator, Python's callbacks) varies by
#: about ±1% from one run of the same material to the next: it is counted apart.
CYCLES_NAMESPACE = "ccl::"
MATHS_LIBRARY = (
    "sinf",
    "cosf",
    "tanf",
    "powf",
    "expf",
    "exp2f",
    "logf",
    "log2f",
    "sqrtf",
    "fmodf",
    "acosf",
    "asinf",
    "atanf",
)
#: Without these a child's set-up differs from run to run (hashing, BLAS threads spinning).
DETERMINISTIC_ENV = {"PYTHONHASHSEED": "0", "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}


def render_in_child(name, samples, size):
    """The child: build shading.py's scene with one render thread and material ``name``, render."""
    import bpy

    from benchmarks import shading
    from porous_weathering.samples import studio

    scene, obj, sun, _ = shading.scene_filling_the_frame(size, threads=1)
    studio.assign(obj, shading.material_makers(sun)[name]())
    scene.cycles.samples = samples
    bpy.ops.render.render(scene=scene.name)


def counts_by_function(path):
    """{function: instructions} of a cachegrind output file."""
    counts = collections.Counter()
    function = None
    for line in path.read_text(errors="replace").splitlines():
        if line.startswith("fn="):
            function = line[3:]
        elif line[:1].isdigit() and function is not None:
            counts[function] += int(line.split()[1])
    return counts


def count(name, samples, size, workdir):
    """{function: instructions} of one child process rendering ``name`` at ``samples``."""
    out = workdir / f"{''.join(c if c.isalnum() else '_' for c in name)}-{samples}.cachegrind"
    command = [
        "valgrind",
        "--tool=cachegrind",
        "--cache-sim=no",
        f"--cachegrind-out-file={out}",
        sys.executable,
        __file__,
        "--child",
        name,
        str(samples),
        "--size",
        str(size),
    ]
    subprocess.run(command, check=True, capture_output=True, env={**os.environ, **DETERMINISTIC_ENV})
    return counts_by_function(out)


def by_function(low, high):
    """{function: instructions of one sample}: the slope between two runs, function by function."""
    span = SAMPLES[1] - SAMPLES[0]
    return {function: (high[function] - low[function]) / span for function in set(low) | set(high)}


def is_cycles(function):
    """Whether ``function`` is Cycles' own or the maths library's."""
    return CYCLES_NAMESPACE in function or ("::" not in function and any(f in function for f in MATHS_LIBRARY))


def totals(slopes):
    """(all instructions, shader-VM instructions, Cycles' own) of one sample, from by_function's
    slopes."""
    shader = sum(value for function, value in slopes.items() if any(part in function for part in SHADER_FUNCTIONS))
    cycles = sum(value for function, value in slopes.items() if is_cycles(function))
    return sum(slopes.values()), shader, cycles


def short_name(function):
    """A C++ function's qualified name without its return type, template and argument lists."""
    name, depth = "", 0
    for char in function.replace("(anonymous namespace)", "{anonymous}"):
        depth += {"<": 1, ">": -1}.get(char, 0)
        if char == "(" and depth == 0:
            break
        if depth == 0 and char != ">":
            name += char
    return name.split()[-1] if name.strip() else function


def function_table(slopes, names, pixels, rows):
    """Markdown: the ``rows`` functions (by name) whose instructions per pixel differ most from
    the baseline's (names[0]), with each material's difference; the rest summed as 'other'."""
    per_pixel = {name: collections.Counter() for name in names}
    for name in names:
        for function, value in slopes[name].items():
            per_pixel[name][short_name(function)] += value / pixels
    base = per_pixel[names[0]]
    extra = {}
    for name in names[1:]:
        extra[name] = {f: per_pixel[name][f] - base[f] for f in per_pixel[name].keys() | base.keys()}
    functions = {function for differences in extra.values() for function in differences}
    largest = sorted(functions, key=lambda f: -max(abs(differences.get(f, 0.0)) for differences in extra.values()))
    largest = largest[:rows]
    table = [[f"`{f}`", *(f"{differences.get(f, 0.0):+.0f}" for differences in extra.values())] for f in largest]
    table.append(["other", *(f"{sum(d.values()) - sum(d.get(f, 0.0) for f in largest):+.0f}" for d in extra.values())])
    table.append(["all", *(f"{sum(differences.values()):+.0f}" for differences in extra.values())])
    return (
        f"\n\n#### Where the extra instructions go: per pixel and sample, over {names[0]}, by function\n\n"
        + scenes.markdown_table(["function", *extra], table)
    )


def report(names, size, jobs, functions=0):
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="pw-instructions-"))
    # the baseline twice (the second in a directory of its own): how far two runs differ
    runs = [(name, samples, workdir) for name in names for samples in SAMPLES]
    runs += [(names[0], samples, workdir / "again") for samples in SAMPLES]
    (workdir / "again").mkdir()
    try:
        with concurrent.futures.ThreadPoolExecutor(jobs) as pool:
            futures = {run: pool.submit(count, run[0], run[1], size, run[2]) for run in runs}
            counts = {run: future.result() for run, future in futures.items()}
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    slopes = {name: by_function(counts[name, SAMPLES[0], workdir], counts[name, SAMPLES[1], workdir]) for name in names}
    cost = {name: totals(slopes[name]) for name in names}
    again, _, again_cycles = totals(by_function(*(counts[names[0], samples, workdir / "again"] for samples in SAMPLES)))
    base_all, _, base_cycles = cost[names[0]]
    pixels = size * size
    rows = [
        [
            name,
            f"{total / 1e6:.2f}",
            f"{total / pixels:.0f}",
            f"{cycles / pixels:.0f}",
            f"{shader / pixels:.0f}",
            f"{total / base_all:.3f}",
            f"{cycles / base_cycles:.3f}",
            f"{(total - base_all) / pixels:+.0f}",
        ]
        for name, (total, shader, cycles) in cost.items()
    ]
    header = [
        "material",
        "M instructions / sample",
        "per pixel",
        "of which Cycles' own",
        "of which shader VM + maths library",
        f"× {names[0]}",
        "× in Cycles' own",
        f"extra per pixel vs {names[0]}",
    ]
    return (
        f"### Shading cost in instructions (Cycles CPU under cachegrind, {size} px sphere filling the frame, "
        f"sun 45° + overcast sky, 2 bounces, 1 render thread)\n\n"
        f"Instructions of one sample = slope between {SAMPLES[0]} and {SAMPLES[1]} samples, each count a child "
        f"process of its own (load on the machine does not change it). Shader VM = Cycles' functions "
        f"named svm_* (the node interpreter and its nodes) and the maths library's "
        f"{'/'.join(name for name in SHADER_FUNCTIONS if name != 'svm_')}. Cycles' own = its functions "
        f"(namespace ccl) and the maths library's they call; the rest (Blender's buffers, the allocator, "
        f"Python) is not exactly repeatable from run to run.\n\n"
        + scenes.markdown_table(header, rows)
        + f"\n\nThe baseline counted twice: {base_all / 1e6:.2f} and {again / 1e6:.2f} M instructions per sample "
        f"({again / base_all - 1:+.2%}; in Cycles' own {again_cycles / base_cycles - 1:+.3%})."
        + (function_table(slopes, names, pixels, functions) if functions else "")
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=48)
    parser.add_argument("--jobs", type=int, default=2, help="child processes at once (one core each)")
    parser.add_argument(
        "--materials", nargs="+", default=DEFAULT_MATERIALS, help="shading.py's names; the first is the baseline"
    )
    parser.add_argument("--child", nargs=2, metavar=("MATERIAL", "SAMPLES"), help=argparse.SUPPRESS)
    parser.add_argument(
        "--functions", type=int, default=0, metavar="N", help="also list the N functions that add the most instructions"
    )
    parser.add_argument("--out", type=pathlib.Path, help="write the markdown here instead of printing it")
    args = parser.parse_args()
    if args.child:
        render_in_child(args.child[0], int(args.child[1]), args.size)
        return
    if shutil.which("valgrind") is None:
        parser.error("needs valgrind (apt install valgrind)")
    scenes.print_or_write(report(list(args.materials), args.size, args.jobs, args.functions), args.out)


if __name__ == "__main__":
    main()
