"""The rising-damp bake's speed against the rain bake's (docs/maps.md, "Rising damp timings"; target:
the damp bake takes at most the rain bake's time on the same object and target).

Each stage runs in a child process of its own and bakes the rain (its default samples) and then
the damp on the same object, each timed alone:

- ``facade``: the bundled façade's parts joined into one object, to images of ``--resolution``²
  on its lightmap (made by the rain bake, so not in the damp's time);
- ``scan``: the scan generator's bust of ``--triangles`` triangles, in millimetres, to colour
  attributes.

    python benchmarks/bench_damp.py [--stages facade scan] [--resolution 1024] [--triangles 200000]
"""

import os
import sys
import time

import apart  # benchmarks/apart.py (the script's folder is on the path)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
STAGES = ("facade", "scan")


def _timed(objects, **options):
    from porous_weathering.maps import bake

    started = time.monotonic()
    bake.bake_maps(objects, bake.BakeOptions(**options))
    return round(time.monotonic() - started, 2)


def facade(resolution, out_dir):
    import bpy

    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", "limestone_facade.blend"), load_ui=False)
    parts = [obj for obj in bpy.context.scene.objects if obj.type == "MESH" and obj.name != "Ground"]
    with bpy.context.temp_override(active_object=parts[0], selected_editable_objects=parts):
        bpy.ops.object.join()
    common = dict(resolution=resolution, out_dir=out_dir)
    rain_s = _timed(parts[:1], maps=("rain",), **common)  # makes the lightmap too
    rain_again_s = _timed(parts[:1], maps=("rain",), rain_settings=_other_seed(), **common)
    damp_s = _timed(parts[:1], maps=("damp",), **common)
    return dict(resolution=resolution, rain_s=rain_s, rain_on_its_lightmap_s=rain_again_s, damp_s=damp_s)


def _other_seed():
    from porous_weathering.maps import rain

    return rain.RainSettings(seed=1)


def scan(triangles):
    import bpy

    sys.path.insert(0, os.path.join(ROOT, "sample_blends"))
    import scan_generator

    bpy.ops.wm.read_factory_settings(use_empty=True)
    vertices, faces = scan_generator.bust_mesh(triangles)
    obj = scan_generator.add_to_scene(
        "Bust", scan_generator.scaled(vertices, "mm"), faces, bpy.context.scene.collection
    )
    bpy.context.scene.unit_settings.scale_length = 0.001
    rain_s = _timed([obj], maps=("rain",), target="attribute")
    damp_s = _timed([obj], maps=("damp",), target="attribute")
    return dict(triangles=len(obj.data.polygons), rain_s=rain_s, damp_s=damp_s)


def child(stage, args):
    import tempfile

    with tempfile.TemporaryDirectory(prefix="pw_bench_damp_") as out_dir:
        result = facade(args.resolution, out_dir) if stage == "facade" else scan(args.triangles)
    apart.report(result)


def main(argv=None):
    return apart.stages_main(
        __file__, __doc__.splitlines()[0], STAGES, child, resolution=1024, triangles=200_000, argv=argv
    )


if __name__ == "__main__":
    sys.path.insert(0, ROOT)
    main()
