"""Shadow rays: whether rays from points towards directions meet a set of triangles, many at once.

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
        origins = np.ascontiguousarray(origins, dtype=np.float32)
        directions = np.ascontiguousarray(directions, dtype=np.float32)
        threads = max(1, os.cpu_count() or 1)
        blocked = np.empty(len(origins), dtype=bool)
        spans = []
        for start in range(0, len(origins), RAYS_AT_ONCE):
            stop = min(start + RAYS_AT_ONCE, len(origins))
            edges = np.linspace(start, stop, threads + 1).astype(np.int64)
            spans += [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]

        def run(span):
            a, b = span
            # the occlusion query gives -1 where the ray meets nothing (the GIL released meanwhile)
            blocked[a:b] = self._scene.run(origins[a:b], directions[a:b], query="OCCLUDED") != -1

        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(run, spans))
        return blocked
