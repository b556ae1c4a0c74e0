"""The unwrap: a new lightmap made of the triangles' positions (``make_lightmap``), and the child
process the bake runs it in (docs/maps.md, "The lightmap").

A new map is made unit-free: the positions are centred and scaled to a mean triangle area of 1,
so millimetres, metres and normalised units give the same map. Small meshes get xatlas' charts;
scans get charts by projection on the axes (each face along the axis closest to its normal
smoothed over its neighbours, so that scan noise does not fragment them). Where a chart folds
over itself, those faces are charted again by xatlas; xatlas packs the charts at the bake's
resolution, and the map is checked (``lightmap_check``): faces that still break it are charted
again and all is packed again, and a map that still fails is refused with what is wrong.

This file is also the child process of ``lightmap.iter_lightmap``, run as a script
(``python -P lightmap_child.py``): then it imports nothing but numpy, xatlas and
``lightmap_check`` (loaded by its path, not through the package, which imports bpy), so a
caller stays responsive, sees its progress and can stop it at once.
"""

import io
import json
import os
import sys
import threading
from collections.abc import Callable
from dataclasses import asdict

import numpy as np

if __package__:
    from .lightmap_check import (
        LightmapReport,
        check_uvs,
        connected_components,
        inspect_uvs,
        rasterise,
        surface_points,
        triangle_areas,
    )
else:  # the child process: the lightmap check beside this file, without the package (and bpy)
    import importlib.util

    _spec = importlib.util.spec_from_file_location(
        "lightmap_check", os.path.join(os.path.dirname(os.path.abspath(__file__)), "lightmap_check.py")
    )
    _check = importlib.util.module_from_spec(_spec)
    sys.modules[_spec.name] = _check
    _spec.loader.exec_module(_check)
    LightmapReport, check_uvs, connected_components, inspect_uvs, rasterise, surface_points, triangle_areas = (
        _check.LightmapReport,
        _check.check_uvs,
        _check.connected_components,
        _check.inspect_uvs,
        _check.rasterise,
        _check.surface_points,
        _check.triangle_areas,
    )

#: Meshes of up to this many triangles are charted by xatlas (fewer seams, no folds; about
#: 75-350 µs a triangle on 2 cores), larger ones by projection on the axes (benchmarks/bench_unwrap.py).
XATLAS_CHARTS = 20_000
#: Rounds of face -> vertex -> face averaging of the normals that choose a face's direction.
SMOOTHING_ROUNDS = 3
#: A face is projected along its smoothed direction only if its own normal is this close to it
#: (cosine), else along the axis closest to its own normal (never folded, never starved).
MIN_COSINE = 0.3
#: Rounds of "faces that break the map go alone" before a map is refused; the rings of
#: neighbours charted again by xatlas with the faces where the projection folds (a fold is found
#: where a sample falls twice: its neighbours are likely in it too).
REPAIR_ROUNDS = 6
CULPRIT_RINGS = 4
#: The rings of neighbours that go alone with a face where xatlas' charts fold or the check finds
#: an overlap: the fold around it, which the next packing's texel centres would find.
LONE_RINGS = 1
#: Folds are looked for before packing with this many samples per texel (along each side) of
#: the bake, so that the texel centres of the bake are unlikely to find one the search missed.
FOLD_SAMPLING = 1.0
#: ... and at least this many samples a face where faces are smaller than the bake's texels (a
#: scan at a low resolution: a fold smaller than a texel is hit by one of the packed map's texel
#: centres as likely as not), up to FOLD_SAMPLES_MOST samples in all (memory: about 100 bytes each).
FOLD_SAMPLES_PER_FACE = 16
FOLD_SAMPLES_MOST = 2**24

#: UVs (in the units of ``normalised``: a mean triangle has an area of 1) farther out than this
#: lose their detail to xatlas' float32 (steps of 1/128 there, a step of 8 at 10^6).
FAR_UV = 2.0**16

AXES = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], dtype=np.float64)

Progress = Callable[[float, str], None]
#: What the child writes on stderr before its progress ("<tag> <fraction> <stage>") and its
#: refusal ("<tag> <why>"), read by ``lightmap.iter_lightmap``.
PROGRESS_TAG, ERROR_TAG = "PW-PROGRESS", "PW-ERROR"


# --- making a lightmap -------------------------------------------------------------------------


def normalised(positions: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """``positions`` centred on the bounding box of the surface (``surface_points``: not on a
    stray point, whose distance xatlas' float32 would take the faces' detail from) and scaled
    to a mean triangle area of 1."""
    positions = np.asarray(positions, dtype=np.float64)
    surface = surface_points(positions, vertices)
    centre = (surface.min(axis=0) + surface.max(axis=0)) / 2 if len(surface) else np.zeros(3)
    centred = positions - centre
    mean_area = triangle_areas(centred[vertices]).mean() if len(vertices) else 0.0
    return centred / np.sqrt(mean_area) if mean_area > 0 else centred


def polygon_normals(positions: np.ndarray, vertices: np.ndarray, polygons: np.ndarray) -> np.ndarray:
    """Each polygon's area vector (P, 3): its normal times twice its area, summed over its triangles."""
    a, b, c = (positions[vertices[:, k]] for k in range(3))
    area_vectors = np.cross(b - a, c - a)
    return np.stack([np.bincount(polygons, area_vectors[:, k]) for k in range(3)], axis=1)


def chart_directions(vertices: np.ndarray, polygons: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """The axis (an index into AXES) each polygon is projected along (P,): the axis closest to
    its normal (``normals``, area vectors) smoothed over SMOOTHING_ROUNDS rings of neighbours,
    if its own normal is within MIN_COSINE of it, else the axis closest to its own normal."""
    smooth = normals
    corners = vertices.ravel()
    for _ in range(SMOOTHING_ROUNDS):
        spread = np.repeat(smooth[polygons], 3, axis=0)
        at_vertex = np.stack([np.bincount(corners, spread[:, k]) for k in range(3)], axis=1)
        gathered = at_vertex[vertices].sum(axis=1)
        smooth = np.stack([np.bincount(polygons, gathered[:, k], minlength=len(normals)) for k in range(3)], axis=1)
    direction = np.argmax(smooth @ AXES.T, axis=1)
    cosine = (normals @ AXES.T) / np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]
    astray = cosine[np.arange(len(normals)), direction] < MIN_COSINE
    direction[astray] = np.argmax(cosine[astray], axis=1)
    return direction


def tangent_bases(normals: np.ndarray) -> np.ndarray:
    """(N, 2, 3): two unit vectors u, v across each of ``normals`` (N, 3), u × v along it."""
    normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(normals, helper)
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    return np.stack([u, np.cross(normals, u)], axis=1)


def cube_charts(
    points: np.ndarray, vertices: np.ndarray, polygons: np.ndarray, normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(corner keys (T, 3), corner UVs (T, 3, 2)) of charts made by projecting every polygon along
    its axis (``chart_directions``): corners share a UV point when they share the key, a
    vertex projected along an axis, so the connected faces of one axis make one chart."""
    direction = chart_directions(vertices, polygons, normals)[polygons]
    uvs = np.empty(vertices.shape + (2,))
    for axis, basis in enumerate(tangent_bases(AXES)):
        along = direction == axis
        uvs[along] = points[vertices[along]] @ basis.T
    return vertices * len(AXES) + direction[:, None], uvs


def xatlas_charts(
    points: np.ndarray, vertices: np.ndarray, polygons: np.ndarray, normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(corner keys (T, 3), corner UVs (T, 3, 2)) of xatlas' own charts (in the units of
    ``points``). xatlas charts triangles: a polygon it cuts along a diagonal (which one UV per
    face corner cannot express) becomes a chart of its own, on its own plane."""
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(points.astype(np.float32), vertices.astype(np.uint32))
    atlas.generate()
    _, keys, atlas_uvs = atlas[0]
    keys, uvs = keys.astype(np.int64), atlas_uvs[keys].astype(np.float64)
    # xatlas works in float32: faces a million of their sizes apart can come back collapsed (or
    # not finite); their polygons go alone, on their own planes, below
    uv_areas, areas = triangle_areas(uvs), triangle_areas(points[vertices])
    collapsed = ~(uv_areas > 0) & (areas > 0) | ~np.isfinite(uvs).all(axis=(1, 2))
    # its charts at the scale of the mesh, so that they and any polygon on its own plane agree
    uvs *= np.sqrt(areas[~collapsed].sum() / max(uv_areas[~collapsed].sum(), 1e-300))
    # a polygon is cut where one of its vertices has two keys: sort its corners by (polygon, vertex)
    polygon, vertex, key = np.repeat(polygons, 3), vertices.ravel(), keys.ravel()
    order = np.lexsort((vertex, polygon))
    polygon, vertex, key = polygon[order], vertex[order], key[order]
    same_corner = (polygon[1:] == polygon[:-1]) & (vertex[1:] == vertex[:-1])
    cut = np.zeros(len(normals), dtype=bool)
    cut[polygon[1:][same_corner & (key[1:] != key[:-1])]] = True
    cut[polygons[collapsed]] = True
    return _alone(keys, uvs, points, vertices, polygons, normals, cut)


def _alone(keys, uvs, points, vertices, polygons, normals, alone):
    """``keys`` and ``uvs`` with the polygons ``alone`` (P,) each a chart of its own, on its own
    plane (its area vector in ``normals``)."""
    lone = alone[polygons]
    if not lone.any():
        return keys, uvs
    keys, uvs = keys.copy(), uvs.copy()
    keys[lone] = keys.max() + 1 + vertices[lone] * len(alone) + polygons[lone, None]
    uvs[lone] = np.einsum("tkd,tjd->tkj", points[vertices[lone]], tangent_bases(normals[polygons[lone]]))
    return keys, uvs


def _rechart(keys, uvs, points, vertices, polygons, normals, chosen):
    """``keys`` and ``uvs`` with the polygons ``chosen`` (P,) charted again by xatlas, on their
    own: xatlas' charts do not fold (it checks them), and the few faces where a projection
    folds are quick to chart."""
    picked = chosen[polygons]
    if not picked.any():
        return keys, uvs
    used, local_vertices = np.unique(vertices[picked], return_inverse=True)
    kept, local_polygons = np.unique(polygons[picked], return_inverse=True)
    local_keys, local_uvs = xatlas_charts(points[used], local_vertices.reshape(-1, 3), local_polygons, normals[kept])
    keys, uvs = keys.copy(), uvs.copy()
    keys[picked] = keys.max() + 1 + local_keys
    uvs[picked] = local_uvs
    return keys, uvs


def _chart_points(keys, uvs):
    """(UV points (N, 2), triangles over them (T, 3)): one point per key."""
    _, first, triangles = np.unique(keys.ravel(), return_index=True, return_inverse=True)
    return uvs.reshape(-1, 2)[first], triangles.reshape(-1, 3)


def _charts_of(uvs, triangles):
    """The chart (0, 1, ...) of each UV point (N,): points joined by triangles make one."""
    first, second = np.concatenate([triangles[:, :2], triangles[:, 1:]]).T
    return np.unique(connected_components(len(uvs), first, second), return_inverse=True)[1]


def _folded(keys, uvs, texels_per_unit):
    """The triangles (T,) bool of the charts of ``keys`` and ``uvs`` (``_chart_points``) on which a
    sample falls twice at ``texels_per_unit`` (``_folds``)."""
    chart_uvs, triangles = _chart_points(keys, uvs)
    return _folds(chart_uvs, triangles, _charts_of(chart_uvs, triangles), texels_per_unit)


def _folds(uvs, triangles, chart, texels_per_unit):
    """The triangles (T,) bool on which a texel centre falls twice when every chart is
    sampled apart, at ``texels_per_unit``: where a chart folds over itself."""
    count = int(chart.max()) + 1
    low, high = np.full((count, 2), np.inf), np.full((count, 2), -np.inf)
    np.minimum.at(low, chart, uvs)
    np.maximum.at(high, chart, uvs)
    cell = float((high - low).max()) * texels_per_unit + 2  # texels: the largest chart and a border
    per_row = int(np.ceil(np.sqrt(count)))
    corner = np.stack([chart % per_row, chart // per_row], axis=1) * cell + 1
    placed = (uvs - low[chart]) * texels_per_unit + corner
    centre, triangle, _, _ = rasterise(placed[triangles], int(per_row * cell) + 2, np.zeros(len(triangles), bool))
    order = np.argsort(centre, kind="stable")
    centre, triangle = centre[order], triangle[order]
    twice = centre[1:] == centre[:-1]
    folded = np.zeros(len(triangles), dtype=bool)
    folded[triangle[1:][twice]] = True
    folded[triangle[:-1][twice]] = True
    return folded


def pack(uvs: np.ndarray, triangles: np.ndarray, chart: np.ndarray, resolution: int, spacing: int) -> np.ndarray:
    """Per-triangle UVs (T, 3, 2) in [0, 1]: the charts of ``uvs`` (``chart`` of each point)
    packed by xatlas, ``spacing`` texels around each (xatlas keeps about twice that between
    charts).

    xatlas takes every chart flat, as its UVs, each at a height of its own: given the mesh's
    positions, it sees the points where charts meet as one (and let charts overlap, on a
    sculpted sample). It picks a scale that fills ``resolution`` only roughly: a larger atlas
    (by up to about a quarter) is shrunk to fit, which narrows the gaps by as much;
    ``make_lightmap`` checks them."""
    import xatlas

    if not np.isfinite(uvs).all():  # xatlas would never finish
        raise LightmapError("the charts' UVs are not finite numbers (does the mesh have vertices at inf or NaN?)")
    # a chart lying far out is packed from its own corner: xatlas reads float32
    low = np.full((int(chart.max()) + 1, 2), np.inf)
    np.minimum.at(low, chart, uvs)
    uvs = uvs - np.where(np.abs(low) > FAR_UV, low, 0.0)[chart]
    points = np.concatenate([uvs, chart.reshape(-1, 1)], axis=1)

    charts = xatlas.ChartOptions()
    charts.use_input_mesh_uvs = True
    options = xatlas.PackOptions()
    options.resolution = resolution
    options.padding = spacing
    options.bilinear = True
    atlas = xatlas.Atlas()
    atlas.add_mesh(points.astype(np.float32), triangles.astype(np.uint32), uvs=uvs.astype(np.float32))
    atlas.generate(chart_options=charts, pack_options=options)
    if atlas.atlas_count != 1:
        raise LightmapError(f"xatlas packed the charts into {atlas.atlas_count} atlases, not one")
    _, indices, atlas_uvs = atlas[0]
    texels = atlas_uvs * np.array([atlas.width, atlas.height], dtype=np.float64)
    return (texels / max(atlas.width, atlas.height, resolution))[indices].astype(np.float32)  # as stored


class LightmapError(ValueError):
    """No lightmap that passes ``check_uvs`` could be made."""


def make_lightmap(
    positions: np.ndarray,
    vertices: np.ndarray,
    polygons: np.ndarray,
    resolution: int,
    padding: int,
    progress: Progress | None = None,
) -> tuple[np.ndarray, LightmapReport]:
    """(per-triangle UVs (T, 3, 2), LightmapReport) of a new lightmap of the triangles
    ``vertices`` (T, 3) of polygons ``polygons`` (T,) over ``positions`` (V, 3), checked at
    ``resolution``² with ``padding`` texels between islands. Meshes of up to XATLAS_CHARTS
    triangles get xatlas' charts, larger ones ``cube_charts`` (benchmarks/bench_unwrap.py).
    Where the charts fold over themselves (``_folds``, before packing) those faces and
    CULPRIT_RINGS rings of neighbours are charted again by xatlas; where xatlas' charts fold in
    turn, those faces and LONE_RINGS rings of neighbours each become a chart of its own (a lone
    face never folds), and so do the faces the check then finds overlapping or starved, packed
    again up to REPAIR_ROUNDS times; then LightmapError says what is still wrong.
    ``progress(fraction, stage)``."""
    progress = progress or (lambda fraction, stage: None)
    progress(0.0, "charts")
    used, vertices = np.unique(vertices, return_inverse=True)  # loose vertices play no part
    vertices = vertices.reshape(-1, 3)
    points = normalised(np.asarray(positions)[used], vertices)
    areas = triangle_areas(points[vertices])
    normals = polygon_normals(points, vertices, polygons)
    charts = xatlas_charts if len(vertices) <= XATLAS_CHARTS else cube_charts
    keys, uvs = charts(points, vertices, polygons, normals)
    progress(0.1, "folds")
    # where the projection folds, at a little finer than the bake's texels will be (about 60% used),
    # and where the faces are smaller than those texels, at FOLD_SAMPLES_PER_FACE samples a face
    samples = min(max(0.6 * resolution**2 * FOLD_SAMPLING**2, FOLD_SAMPLES_PER_FACE * len(vertices)), FOLD_SAMPLES_MOST)
    texels_per_unit = np.sqrt(samples / max(triangle_areas(uvs).sum(), 1e-300))
    folded = _folded(keys, uvs, texels_per_unit)
    again = _grown(polygons[folded], vertices, polygons, len(normals), CULPRIT_RINGS)
    keys, uvs = _rechart(keys, uvs, points, vertices, polygons, normals, again)
    # xatlas' own charts can fold too (a scan's busy relief): there each face goes alone
    recharted = again[polygons]
    lone = np.zeros(len(normals), dtype=bool)
    if recharted.any():
        folded = _folded(keys[recharted], uvs[recharted], texels_per_unit)
        lone = _grown(polygons[recharted][folded], vertices, polygons, len(normals), LONE_RINGS)
    spacing = padding // 2 + 1  # xatlas keeps about twice this between charts, less once shrunk to fit
    for attempt in range(REPAIR_ROUNDS + 1):
        # the first round takes most of the time (packing and checking about 40% each, at 2M
        # triangles), a repair round as long again, but it is rarely needed: the bar never goes back
        low, high = (0.2, 0.9) if not attempt else (1 - 0.1 / attempt, 1 - 0.1 / (attempt + 1))
        changed = again | lone
        progress(low, f"packing, {changed.sum()} faces charted again" if changed.any() else "packing")
        chart_uvs, triangles = _chart_points(*_alone(keys, uvs, points, vertices, polygons, normals, lone))
        triangle_uvs = pack(chart_uvs, triangles, _charts_of(chart_uvs, triangles), resolution, spacing)
        progress(low + 0.5 * (high - low), "checking")
        report, culprits = inspect_uvs(triangle_uvs, areas, resolution, padding)
        if report.ok:
            return triangle_uvs, report
        lone |= _grown(polygons[culprits], vertices, polygons, len(lone), LONE_RINGS)
        spacing += report.crowded > 0  # xatlas' shrunk atlas came too close
    raise LightmapError(f"no lightmap at {resolution}² passes: {'; '.join(report.problems())}")


def _grown(chosen, vertices, polygons, count, rings):
    """The polygons (count,) bool ``chosen`` and those within ``rings`` rings of them (sharing a vertex)."""
    found = np.zeros(count, dtype=bool)
    found[chosen] = True
    for _ in range(rings):
        touched = np.zeros(int(vertices.max()) + 1, dtype=bool)
        touched[vertices[found[polygons]]] = True
        found[polygons[touched[vertices].any(axis=1)]] = True
    return found


# --- the child process ------------------------------------------------------------------------


#: PR_SET_PDEATHSIG (linux/prctl.h): the signal a process gets when its parent dies.
_PR_SET_PDEATHSIG = 1


def end_with_parent(parent: int) -> None:
    """Have the kernel kill this process as soon as its ``parent`` (its pid) dies, however it
    dies (SIGKILL too), on Linux (PR_SET_PDEATHSIG): even while xatlas' C code holds the GIL,
    where ``main``'s thread that watches stdin cannot run (elsewhere that thread is all there
    is). The kernel tells when the thread that started this process ends: the bake's unwrap
    runs on the thread that started it."""
    if sys.platform.startswith("linux"):
        import ctypes
        import signal

        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # it died before the kernel was asked to tell
        os._exit(1)


def main() -> None:
    """The child process of the parent whose pid is its one argument: the job on stdin (its
    length, then an npz), progress and errors on stderr, the result (an npz) on stdout. It
    checks the job's candidate UV maps in order and picks the first that passes, or makes a
    lightmap."""
    end_with_parent(int(sys.argv[1]))
    size = int.from_bytes(sys.stdin.buffer.read(8), "little")
    job = np.load(io.BytesIO(sys.stdin.buffer.read(size)))
    threading.Thread(target=lambda: (os.read(0, 1), os._exit(1)), daemon=True).start()  # the caller died

    def progress(fraction, stage):
        print(f"{PROGRESS_TAG} {fraction:.3f} {stage}", file=sys.stderr, flush=True)

    def answer(**result):
        found = io.BytesIO()
        np.savez(found, **result)
        sys.stdout.buffer.write(found.getbuffer())
        sys.stdout.buffer.flush()

    positions, vertices, polygons, candidates = (
        job[name] for name in ("positions", "vertices", "polygons", "candidates")
    )
    resolution, padding, make = (int(value) for value in job["settings"])
    areas = triangle_areas(positions.astype(np.float64)[vertices])
    reports = []
    for number, candidate in enumerate(candidates):
        progress(number / len(candidates), f"checking UV map {number + 1}/{len(candidates)}")
        reports.append(check_uvs(candidate, areas, resolution, padding))
        if reports[-1].ok:
            return answer(chosen=number, report=json.dumps(asdict(reports[-1])))
    if not make:  # the first candidate is our own lightmap: refused, with its report
        return answer(chosen=-1, report=json.dumps(asdict(reports[0])))
    try:
        triangle_uvs, report = make_lightmap(positions, vertices, polygons, resolution, padding, progress)
    except LightmapError as error:
        print(f"{ERROR_TAG} {error}", file=sys.stderr, flush=True)
        os._exit(3)
    progress(1.0, "done")
    answer(chosen=-1, uvs=triangle_uvs, report=json.dumps(asdict(report)))


if __name__ == "__main__":
    main()
    os._exit(0)  # not waiting for the thread that watches the caller
