"""Lightmap UVs for baked maps: reuse a UV map that can hold a bake, or make one (docs/maps.md,
"The lightmap").

Three modules, one job each: the check (``lightmap_check``: ``check_uvs``, pure numpy), the
unwrap that makes a new map (``lightmap_child``: ``make_lightmap``, numpy and xatlas, also the
child process the bake runs it in) and this one, the bake's side: a mesh's triangles and UV maps
read as arrays, the UV map to bake on (a reused one, or a new one from the child process:
``iter_lightmap``) and the new UV layer (``LIGHTMAP_UV``; the user's own UV maps are never
changed). The names of the other two are re-exported here, the documented ``uv`` module
(docs/api.md).

The bake's unwrap (``iter_lightmap``) runs in a child Python process (``lightmap_child``, run as
a script: it imports nothing but numpy and xatlas), so a caller stays responsive, sees its
progress and can stop it at once.
"""

import io
import json
import os
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import bpy

import numpy as np

from ..blender import mesh_arrays
from . import lightmap_child
from .lightmap_check import (  # noqa: F401  (public: docs/api.md, the ``uv`` module)
    ON_EDGE,
    PADDING,
    PADDING_FULL_FROM,
    RASTER_BLOCK,
    STARVED_MAX,
    STARVED_SHARE,
    LightmapReport,
    check_uvs,
    connected_components,
    overlapping_texels,
    padding_for,
    triangle_areas,
)
from .lightmap_child import (  # noqa: F401  (public: docs/api.md, the ``uv`` module)
    AXES,
    CULPRIT_RINGS,
    ERROR_TAG,
    FOLD_SAMPLING,
    MIN_COSINE,
    PROGRESS_TAG,
    REPAIR_ROUNDS,
    SMOOTHING_ROUNDS,
    XATLAS_CHARTS,
    LightmapError,
    Progress,
    chart_directions,
    cube_charts,
    make_lightmap,
    normalised,
    pack,
    polygon_normals,
    tangent_bases,
    xatlas_charts,
)

if TYPE_CHECKING:
    from ..blender import scratch_scene

LIGHTMAP_UV = "PW Lightmap"
#: The Data Transfer modifier that lays a lightmap over the corners of an object's modifiers
#: (Array, Mirror, Solidify, Bevel, ...), copied by index from a carrier object holding that
#: mesh with its lightmap (``lay_out``); named after the UV map it fills.
LIGHTMAP_MODIFIER = LIGHTMAP_UV


# --- the mesh as arrays (bpy meshes, read in the caller's process) ---------------------------


def corner_uvs(mesh: "bpy.types.Mesh", name: str) -> np.ndarray:
    """The UV map ``name`` as a float32 (len(mesh.loops), 2) array."""
    uvs = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers[name].data.foreach_get("uv", uvs)
    return uvs.reshape(-1, 2)


def triangle_corners(mesh: "bpy.types.Mesh") -> tuple[np.ndarray, np.ndarray]:
    """(corner indices (T, 3), vertex indices (T, 3)) of the mesh's loop triangles."""
    mesh.calc_loop_triangles()
    count = len(mesh.loop_triangles)
    loops = np.empty(count * 3, dtype=np.int64)
    vertices = np.empty(count * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    mesh.loop_triangles.foreach_get("vertices", vertices)
    return loops.reshape(-1, 3), vertices.reshape(-1, 3)


@dataclass
class Geometry:
    """A mesh's loop triangles: vertex positions (V, 3), and per triangle its face corners (T, 3),
    vertices (T, 3) and polygon (T,)."""

    positions: np.ndarray
    corners: np.ndarray
    vertices: np.ndarray
    polygons: np.ndarray

    @classmethod
    def of(cls, mesh: "bpy.types.Mesh") -> "Geometry":
        corners, vertices = triangle_corners(mesh)
        polygons = np.empty(len(corners), dtype=np.int64)
        mesh.loop_triangles.foreach_get("polygon_index", polygons)
        positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", positions)
        return cls(positions.reshape(-1, 3), corners, vertices, polygons)

    def areas(self) -> np.ndarray:
        """The triangles' areas (T,), in the mesh's units."""
        return triangle_areas(self.positions.astype(np.float64)[self.vertices])


# --- the unwrap, in a child process ----------------------------------------------------------

#: Seconds the caller waits for news from the unwrap before it yields control anyway.
POLL_SECONDS = 0.1


@dataclass(frozen=True)
class Lightmap:
    """What ``iter_lightmap`` settled on: the UV map ``name`` to bake on, ``uvs`` per face
    corner when that map is new (None when the mesh's own map is reused) and its report."""

    name: str
    uvs: np.ndarray | None
    report: LightmapReport


def iter_lightmap(
    mesh: "bpy.types.Mesh", resolution: int, padding: int | None = None, *, replaceable: bool = False
) -> Generator[tuple[float, str], None, Lightmap]:
    """The lightmap of ``mesh`` for a bake at ``resolution``², as a generator of
    (fraction, stage) while it runs in a child process (closing it stops that process at once);
    its return value (``StopIteration.value``) is the Lightmap.

    The mesh's own "PW Lightmap", then its other UV maps in order, are reused if they pass
    ``check_uvs``; else a new lightmap is made, unless the mesh has a "PW Lightmap" (made for
    another resolution, or since distorted): that is refused (ValueError saying what is wrong),
    as maps baked on it would no longer match it, unless it is ``replaceable`` (it comes from a
    carrier ``lay_out`` made, whose mesh no longer matches the modifiers'). A lightmap that
    cannot be made raises LightmapError."""
    padding = padding_for(resolution) if padding is None else padding
    geometry = Geometry.of(mesh)
    names = _candidates(mesh)
    job = io.BytesIO()
    np.savez(
        job,
        positions=geometry.positions,
        vertices=geometry.vertices,
        polygons=geometry.polygons,
        candidates=np.stack([corner_uvs(mesh, name)[geometry.corners] for name in names])
        if names
        else np.zeros((0, len(geometry.vertices), 3, 2), np.float32),
        settings=np.array([resolution, padding, replaceable or LIGHTMAP_UV not in names]),
    )
    # No files: pipes work where a disk is full or file sizes are limited, and leave nothing behind.
    process = subprocess.Popen(
        [sys.executable, "-P", os.path.abspath(lightmap_child.__file__), str(os.getpid())],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=dict(os.environ, PYTHONPATH=os.pathsep.join(path for path in sys.path if path)),
    )
    try:
        news, result = queue.Queue(), []
        threading.Thread(target=_forward_lines, args=(process.stderr, news), daemon=True).start()
        reader = threading.Thread(target=lambda: result.append(process.stdout.read()), daemon=True)
        reader.start()
        try:
            process.stdin.write(len(job.getbuffer()).to_bytes(8, "little") + job.getbuffer())
            process.stdin.flush()  # and kept open: the child ends when it closes (``end_with_parent``)
        except BrokenPipeError:  # the child died first: its last words say why
            pass
        fraction, stage, errors, started = 0.0, "starting", [], time.monotonic()
        while True:
            try:
                line = news.get(timeout=POLL_SECONDS)
            except queue.Empty:
                line = ""
            if line is None:  # the child closed its stderr: it is done
                break
            if line.startswith(PROGRESS_TAG):
                _, value, stage = line.rstrip("\n").split(" ", 2)
                fraction = float(value)
            elif line.strip():
                errors.append(line.strip())
            yield fraction, f"{stage} ({time.monotonic() - started:.0f} s)"
        code = process.wait()
        reader.join()
        failure = next((line[len(ERROR_TAG) :].strip() for line in errors if line.startswith(ERROR_TAG)), None)
        if failure is not None:
            raise LightmapError(failure)
        if code != 0 or not result:
            raise RuntimeError(f"the lightmap unwrap stopped (exit code {code}): {' / '.join(errors[-3:])}")
        with np.load(io.BytesIO(result[0])) as found:
            report = LightmapReport(**json.loads(str(found["report"])))
            chosen = int(found["chosen"])
            if chosen >= 0:
                return Lightmap(names[chosen], None, report)
            if LIGHTMAP_UV in names and not replaceable:
                raise ValueError(
                    f"mesh '{mesh.name}': its UV map '{LIGHTMAP_UV}' cannot hold a bake at {resolution}²: "
                    f"{'; '.join(report.problems())}. Bake at the resolution it was made for, or remove "
                    "it to let the bake make a new one (the maps baked on it are then baked again)"
                )
            uvs = np.zeros((len(mesh.loops), 2), dtype=np.float32)
            uvs[geometry.corners] = found["uvs"]
            return Lightmap(LIGHTMAP_UV, uvs, report)
    finally:
        if process.poll() is None:
            process.kill()
        process.wait()
        for stream in (process.stdin, process.stdout, process.stderr):
            stream.close()


def _forward_lines(stream, lines):
    for line in stream:
        lines.put(line.decode(errors="replace"))
    lines.put(None)


def lightmap_uvs(mesh: "bpy.types.Mesh", resolution: int, padding: int | None = None) -> np.ndarray:
    """A new lightmap of ``mesh`` for ``resolution``² (float32 (len(loops), 2)), whatever UV
    maps it has (``make_lightmap``, in this process)."""
    padding = padding_for(resolution) if padding is None else padding
    geometry = Geometry.of(mesh)
    triangle_uvs, _ = make_lightmap(geometry.positions, geometry.vertices, geometry.polygons, resolution, padding)
    uvs = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    uvs[geometry.corners] = triangle_uvs
    return uvs


def find_bakeable_uv_map(mesh: "bpy.types.Mesh", resolution: int, padding: int | None = None) -> str | None:
    """The name of a UV map of ``mesh`` that can hold a bake at ``resolution``² (``check_uvs``),
    or None. Our own lightmap comes first, then the user's maps in their order."""
    geometry = Geometry.of(mesh)
    areas = geometry.areas()
    return next(
        (
            name
            for name in _candidates(mesh)
            if check_uvs(corner_uvs(mesh, name)[geometry.corners], areas, resolution, padding).ok
        ),
        None,
    )


def _candidates(mesh):
    """The UV maps a bake may reuse, in order: our own lightmap, then the user's maps."""
    return [LIGHTMAP_UV] * (LIGHTMAP_UV in mesh.uv_layers) + [
        layer.name for layer in mesh.uv_layers if layer.name != LIGHTMAP_UV
    ]


def add_uv_map(mesh: "bpy.types.Mesh", name: str, uvs: np.ndarray) -> "bpy.types.MeshUVLoopLayer":
    """A new UV map ``name`` on ``mesh`` holding per-corner ``uvs``; the active map is unchanged."""
    if name in mesh.uv_layers:
        raise ValueError(f"{mesh.name}: there is already a UV map named {name!r}")
    active = mesh.uv_layers.active
    layer = mesh.uv_layers.new(name=name, do_init=False)
    layer.data.foreach_set("uv", np.ascontiguousarray(uvs, dtype=np.float32).reshape(-1))
    if active is not None:
        mesh.uv_layers.active = active
    return layer


# --- where a new lightmap goes: the mesh, or a carrier over the modifiers ----------------------


def anchor(obj: "bpy.types.Object") -> int:
    """How many of ``obj``'s modifiers the lightmap is made after: all but the trailing ones that
    refine the surface by levels (Subdivision Surface, Multiresolution), which carry UVs across
    smoothly, so a lightmap made before them holds in the viewport and in renders alike, whatever
    levels each uses."""
    count = len(obj.modifiers)
    while count and hasattr(obj.modifiers[count - 1], "render_levels"):
        count -= 1
    return count


def lay_out(obj: "bpy.types.Object", made_on: "scratch_scene.Rendered", uvs: np.ndarray) -> Callable[[], None]:
    """Give ``obj`` the lightmap ``uvs``, per corner of ``made_on`` (``obj`` after its first
    ``anchor`` modifiers); returns the function that undoes it.

    Where those modifiers keep the mesh's corners (none, or modifiers that only move vertices),
    the lightmap is the UV map LIGHTMAP_UV of the mesh. Otherwise (Array, Mirror, Solidify,
    Bevel, ...) it cannot be one: the modifiers' copies would share its texels, and their new
    faces have no UVs of their own. Then a carrier object (in no scene, saved with the file)
    holds that mesh with the lightmap, and a Data Transfer modifier (LIGHTMAP_MODIFIER), placed
    after those modifiers, copies it corner by corner into the mesh's own LIGHTMAP_UV (all zeros
    on the mesh itself). A carrier made by an earlier bake is given the new mesh."""
    base, evaluated, undo = obj.data, made_on.evaluated, []

    def undo_all():
        for step in reversed(undo):
            step()

    same_corners = len(made_on.mesh.loops) == len(base.loops) and np.array_equal(
        mesh_arrays.attribute(made_on.mesh, ".corner_vert", np.int32),
        mesh_arrays.attribute(base, ".corner_vert", np.int32),
    )
    if LIGHTMAP_UV not in base.uv_layers:
        add_uv_map(base, LIGHTMAP_UV, uvs if same_corners else np.zeros((len(base.loops), 2), np.float32))
        undo.append(lambda: base.uv_layers.remove(base.uv_layers[LIGHTMAP_UV]))
    if same_corners:
        return undo_all
    carrier_mesh = bpy.data.meshes.new_from_object(evaluated)
    carrier_mesh.name = f"{obj.name} {LIGHTMAP_UV}"
    undo.append(lambda: bpy.data.meshes.remove(carrier_mesh) if carrier_mesh.users == 0 else None)
    layer = carrier_mesh.uv_layers.get(LIGHTMAP_UV) or carrier_mesh.uv_layers.new(name=LIGHTMAP_UV, do_init=False)
    layer.data.foreach_set("uv", np.ascontiguousarray(uvs, np.float32).reshape(-1))
    modifier = obj.modifiers.get(LIGHTMAP_MODIFIER)
    if modifier is not None and modifier.type == "DATA_TRANSFER" and modifier.object is not None:
        carrier, old_mesh = modifier.object, modifier.object.data
        carrier.data = carrier_mesh
        undo.append(lambda: setattr(carrier, "data", old_mesh))
        return undo_all
    carrier = bpy.data.objects.new(carrier_mesh.name, carrier_mesh)
    carrier.use_fake_user = True  # in no scene: kept for the modifier's sake
    undo.append(lambda: bpy.data.objects.remove(carrier))
    position = anchor(obj)
    modifier = obj.modifiers.new(LIGHTMAP_MODIFIER, "DATA_TRANSFER")
    undo.append(lambda: obj.modifiers.remove(obj.modifiers[LIGHTMAP_MODIFIER]))
    modifier.object = carrier
    modifier.use_loop_data = True
    modifier.data_types_loops = {"UV"}
    modifier.loop_mapping = "TOPOLOGY"
    modifier.layers_uv_select_src = "ALL"
    modifier.layers_uv_select_dst = "NAME"
    obj.modifiers.move(len(obj.modifiers) - 1, position)
    return undo_all
