"""The run-off bake's speed (docs/maps.md, "Run-off"; targets: the façade at 2048² and a
2M-triangle scan to attributes, each in 30 s or less on 2 cores, in 2 GiB, time linear in the
surface's nodes).

Each stage runs in a child process of its own, whose peak resident memory is its
``ru_maxrss`` (making the scene included) and the bake's own peak, ``runoff_peak_mib`` (the
process's peak started anew before the bake); only the run-off bake is timed
(``bake.bake_maps(maps=("runoff",))``), the rain it reads being made first from the surface's
own normals (vertical rain, no occlusion: what the flow costs does not depend on it):

- ``facade``: the bundled façade's parts joined into one object (its 0.2 m faces as they are
  in the file), to one image of ``--resolution``² on its lightmap;
- ``scan``: the scan generator's bust of ``--triangles`` triangles, in millimetres, to colour
  attributes;
- ``series``: the numpy flow alone (``runoff_flow.sample_surface`` and ``route``) on a sphere at
  growing node counts: the time per node (the slope) and how it stays linear.

    python benchmarks/bench_runoff.py [--stages facade scan series] [--resolution 2048]
        [--triangles 2000000]
"""

import os
import sys
import time

import apart  # benchmarks/apart.py (the script's folder is on the path)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
STAGES = ("facade", "scan", "series")


def _reset_peak_memory():
    """Start the process's peak resident memory (VmHWM) anew (Linux 4.0+), so that the peak read
    after the bake is the bake's, not the scene's making."""
    with open("/proc/self/clear_refs", "w") as stream:
        stream.write("5")


def _peak_memory_mib():
    with open("/proc/self/status") as stream:
        line = next(line for line in stream if line.startswith("VmHWM:"))
    return round(int(line.split()[1]) / 1024)


def _vertical_rain_attribute(obj):
    """pw_rain of vertical rain (E = max(0, N.z) per corner), recorded as baked."""
    import numpy as np

    from porous_weathering.blender import mesh_arrays
    from porous_weathering.maps import rain

    mesh = obj.data
    normals = np.empty(len(mesh.loops) * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", normals)
    mesh_arrays.write_corner_attribute(mesh, rain.RAIN_ATTRIBUTE, np.clip(normals.reshape(-1, 3)[:, 2], 0.0, 1.0))
    mesh[f"{rain.RAIN_ATTRIBUTE}_inputs"] = "vertical rain"


def facade(resolution, out_dir):
    import bpy

    import numpy as np

    from porous_weathering.common import imageio
    from porous_weathering.maps import bake, edges, rain

    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", "limestone_facade.blend"), load_ui=False)
    parts = [obj for obj in bpy.context.scene.objects if obj.type == "MESH" and obj.name != "Ground"]
    with bpy.context.temp_override(active_object=parts[0], selected_editable_objects=parts):
        bpy.ops.object.join()
    parts = parts[:1]
    # the lightmaps and rain maps as the bake makes them, then the rain of vertical rain in their place
    started = time.monotonic()
    options = bake.BakeOptions(
        maps=("rain",), resolution=resolution, out_dir=out_dir, rain_settings=rain.RainSettings(samples=1)
    )
    bake.bake_maps(parts, options)
    prepared = time.monotonic() - started
    texels = 0
    for obj in parts:
        path = imageio.image_path(out_dir, obj.name, "rain")
        _, header = imageio.read_image(path)
        _, normals, islands = edges.bake_texel_geometry(obj, header["pw:uv_map"], resolution)
        exposure = np.where(islands, np.clip(normals[..., 2], 0.0, 1.0), 0.0)[..., None].astype(np.float32)
        imageio.write_image(path, exposure, metadata=header)
        texels += int(islands.sum())
    _reset_peak_memory()
    started = time.monotonic()
    bake.bake_maps(parts, bake.BakeOptions(maps=("runoff",), resolution=resolution, out_dir=out_dir))
    seconds = time.monotonic() - started
    return dict(
        parts=len(parts),
        texels=texels,
        prepare_s=round(prepared, 1),
        runoff_s=round(seconds, 1),
        runoff_peak_mib=_peak_memory_mib(),
    )


def scan(triangles):
    import bpy

    sys.path.insert(0, os.path.join(ROOT, "sample_blends"))
    import scan_generator

    from porous_weathering.maps import bake

    bpy.ops.wm.read_factory_settings(use_empty=True)
    vertices, faces = scan_generator.bust_mesh(triangles)
    obj = scan_generator.add_to_scene(
        "Bust", scan_generator.scaled(vertices, "mm"), faces, bpy.context.scene.collection
    )
    _vertical_rain_attribute(obj)
    del vertices, faces
    _reset_peak_memory()
    started = time.monotonic()
    bake.bake_maps([obj], bake.BakeOptions(maps=("runoff",), target="attribute"))
    seconds = time.monotonic() - started
    return dict(triangles=len(obj.data.polygons), runoff_s=round(seconds, 1), runoff_peak_mib=_peak_memory_mib())


def series():
    import numpy as np

    from porous_weathering.maps import runoff_flow

    def sphere(n):
        u, v = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, 2 * n + 1), indexing="ij")
        theta, phi = np.pi * u.ravel(), 2 * np.pi * v.ravel()
        points = np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
        index = np.arange((n + 1) * (2 * n + 1)).reshape(n + 1, 2 * n + 1)
        a, b, c, d = index[:-1, :-1].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel(), index[:-1, 1:].ravel()
        faces = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
        corners = points[faces]
        outward = np.einsum(
            "ij,ij->i", np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), corners.mean(1)
        )
        faces[outward < 0] = faces[outward < 0][:, ::-1]
        return points, faces

    vertices, triangles = sphere(200)
    rows = []
    for spacing in (0.02, 0.01, 0.005):
        started = time.monotonic()
        surface = runoff_flow.sample_surface(vertices, triangles, spacing)
        exposure = np.clip(surface.normals[:, 2], 0.0, None)
        runoff_flow.route(surface, exposure)
        seconds = time.monotonic() - started
        rows.append(
            dict(
                nodes=len(surface.areas),
                seconds=round(seconds, 2),
                us_per_node=round(1e6 * seconds / len(surface.areas), 1),
            )
        )
    return rows


def child(stage, args):
    """Run one stage in this process and print its result as JSON."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="pw_bench_runoff_") as out_dir:
        if stage == "facade":
            result = facade(args.resolution, out_dir)
        elif stage == "scan":
            result = scan(args.triangles)
        else:
            result = series()
    apart.report(result)


def main(argv=None):
    return apart.stages_main(
        __file__, __doc__.splitlines()[0], STAGES, child, resolution=2048, triangles=2_000_000, argv=argv
    )


if __name__ == "__main__":
    sys.path.insert(0, ROOT)
    main()
