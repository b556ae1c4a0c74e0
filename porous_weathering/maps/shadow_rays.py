"""Shadow rays: whether rays from points towards directions meet a set of triangles, and which
they meet first, many at once.

Through Embree (``embreex``, its occlusion query, a thread per core: some 3 M rays a second on
two cores) where its wheel is installed, else through ``mathutils``' BVH one ray at a time (some six
times slower, the same answers). Triangles are taken in single precision, so the caller places
them about the origin at about unit size (``sky_bake.unit_placing``).
"""

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

try:
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh
except ImportError:  # no wheel for this platform (macOS on arm64 before 13): mathutils' BVH
    rtcore_scene = None

#: Rays handed to Embree in one call (each thread takes its share of them).
RAYS_AT_ONCE = 1 << 20


class Occluders:
    """The triangles that cast shadows, ``vertices`` (V, 3) and ``triangles`` (T, 3) indices into
    them, ready for ``blocked``."""

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray):
        vertices = np.ascontiguousarray(vertices, dtype=np.float32).reshape(-1, 3)
        triangles = np.ascontiguousarray(triangles, dtype=np.int32).reshape(-1, 3)
        self._empty = not len(triangles)
        if self._empty:
            return
        if rtcore_scene is not None:
            self._scene = rtcore_scene.EmbreeScene()
            TriangleMesh(self._scene, vertices, triangles)
            # the scene builds its BVH at its first query: one ray here, before threads query it together
            self._scene.run(np.zeros((1, 3), np.float32), np.array([[0.0, 0.0, 1.0]], np.float32), query="OCCLUDED")
        else:
            from mathutils.bvhtree import BVHTree  # noqa: PLC0415  (only without Embree)

            self._tree = BVHTree.FromPolygons(vertices.tolist(), triangles.tolist(), all_triangles=True)

    def blocked(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(N,) bool: whether the ray from each of ``origins`` (N, 3) towards its unit direction
        (N, 3) meets a triangle."""
        if self._empty or not len(origins):
            return np.zeros(len(origins), dtype=bool)
        if rtcore_scene is None:
            cast = self._tree.ray_cast
            rays = zip(origins.tolist(), directions.tolist())
            return np.fromiter((cast(origin, towards)[0] is not None for origin, towards in rays), bool, len(origins))
        blocked = np.empty(len(origins), dtype=bool)

        def occluded(a, b, starts, towards):
            # the occlusion query gives -1 where the ray meets nothing
            blocked[a:b] = self._scene.run(starts, towards, query="OCCLUDED") != -1

        _in_threads(origins, directions, occluded)
        return blocked

    def first_hits(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(N,) int32: the triangle that the ray from each of ``origins`` (N, 3) towards its unit
        direction (N, 3) meets first, -1 for none."""
        triangle = np.full(len(origins), -1, dtype=np.int32)
        if self._empty or not len(origins):
            return triangle
        if rtcore_scene is None:
            for i, (origin, towards) in enumerate(zip(origins.tolist(), directions.tolist())):
                index = self._tree.ray_cast(origin, towards)[2]
                if index is not None:
                    triangle[i] = index
            return triangle

        def intersected(a, b, starts, towards):
            triangle[a:b] = self._scene.run(starts, towards, query="INTERSECT")  # -1 where it meets nothing

        _in_threads(origins, directions, intersected)
        return triangle


def _in_threads(origins, directions, query):
    """Run ``query(a, b, origins[a:b], directions[a:b])`` over spans of the rays, a thread per
    core (Embree releases the GIL), at most RAYS_AT_ONCE rays a call."""
    origins = np.ascontiguousarray(origins, dtype=np.float32)
    directions = np.ascontiguousarray(directions, dtype=np.float32)
    threads = max(1, os.cpu_count() or 1)
    spans = []
    for start in range(0, len(origins), RAYS_AT_ONCE):
        stop = min(start + RAYS_AT_ONCE, len(origins))
        edges = np.linspace(start, stop, threads + 1).astype(np.int64)
        spans += [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]
    with ThreadPoolExecutor(threads) as pool:
        list(pool.map(lambda span: query(*span, origins[span[0] : span[1]], directions[span[0] : span[1]]), spans))
