"""Ways to a less noisy or cheaper sun map, against Cycles' image bake (docs/maps.md, "Sun exposure",
"Measured and not kept"): smoothing the baked map over its neighbours, drawing the suns by their
share of each plane's open exposure, and a smaller sky image.

    python benchmarks/bench_sun_estimators.py [--reference 1024] [--only terrain facade sky]

Smoothing: on bench_sun's terrain (128², the image bake, 50° N) a Gaussian of SIGMAS texels over
the sun baked at 16 and 64 samples and the rain at 64, each against its own bake at --reference
samples (another seed); on the main job's façade per point (bench_sun's façade: the bake's points,
one per vertex and face plane) one pass of averaging each point with its neighbours along its
faces' edges (never across a crease), the sun at 16, 32 and 64 samples.

Drawing by w · cos: on the same façade points, the bake's own rays through a ``mathutils`` BVH of
the façade and its occluders as rendered; per cluster of equal normals the suns of the year's
table (365 days × STEPS_PER_DAY instants, 50° N) drawn on Roberts' R2 lattice over (day, hour),
shifted at random per point, through the table's marginal and conditional CDFs, either by the
weight w alone (the estimate the mean of max(0, N·s) V) or by w · max(0, N·s) (the open plane's S
times the share of rays that escape). Points where the two geometries disagree (the 256-draw
estimate over 0.1 off the reference: crevices where the façade's parts meet, which a single ray
and Cycles' probe see differently) are left out of every error, Cycles' included.

A smaller sky image: on bench_sun's terrain, the sun at 64 samples under sky images SKY_WIDTHS
pixels wide (the bake's is ``sun.SKY_WIDTH``) and the rain at 64, two rounds, each timed, the sun's
error against the bake's own image at --reference samples. Prints the lines.
"""

import argparse
import dataclasses
import pathlib
import sys
import time
from types import SimpleNamespace

import bpy

import numpy as np
from mathutils.bvhtree import BVHTree

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
import bench_life  # noqa: E402  (benchmarks/bench_life.py: the main job's façade)
import bench_sun  # noqa: E402  (benchmarks/bench_sun.py: the terrain and the bakes)

from porous_weathering.blender import mesh_arrays, scratch_scene  # noqa: E402
from porous_weathering.core import solar  # noqa: E402
from porous_weathering.maps import rain, sky_bake, sun  # noqa: E402

SIGMAS = (0.7, 1.0, 1.5)
SKY_WIDTHS = (1024, 512, 256)
DRAWS = (16, 32, 64)
LATITUDE = 50.0
#: Roberts' R2 lattice: the plastic number's powers.
PLASTIC = 1.32471795724474602596
#: How far above the surface a ray starts, metres (the bake's probes sit about as high).
LIFT = 1e-3


def rmse(values, reference, kept=None):
    error = values - reference
    return float(np.sqrt(np.mean(error**2 if kept is None else error[kept] ** 2)))


def gaussian(image, sigma):
    """``image`` blurred by a Gaussian of ``sigma`` texels, separably, its edges renormalised."""
    radius = int(np.ceil(3 * sigma))
    kernel = np.exp(-(np.arange(-radius, radius + 1) ** 2) / (2 * sigma**2))
    kernel /= kernel.sum()

    def blur(a):
        for axis in (0, 1):
            a = np.apply_along_axis(lambda line: np.convolve(line, kernel, mode="same"), axis, a)
        return a

    return blur(image) / blur(np.ones_like(image))


def terrain_smoothing(reference_samples):
    bake, _, _ = bench_sun.terrain(SimpleNamespace(resolution=128))
    for kind, counts in (("sun", (16, 64)), ("rain", (64,))):
        reference = bake(kind, reference_samples, 1)
        for samples in counts:
            values = bake(kind, samples, 0)
            blurred = ", ".join(f"σ {s}: {rmse(gaussian(values, s), reference):.4f}" for s in SIGMAS)
            print(f"terrain {kind} {samples} samples: RMSE {rmse(values, reference):.4f}; blurred {blurred}")
    sun_reference = bake("sun", reference_samples, 1)
    biases = ", ".join(f"σ {s}: {rmse(gaussian(sun_reference, s), sun_reference):.4f}" for s in SIGMAS)
    print(f"terrain sun reference blurred against itself: {biases}")


class FacadePoints:
    """The main job's façade as the bake sees it: its points (one per vertex and face plane), their
    normals, each corner's point, the point pairs along its faces' edges and a BVH of it and its
    occluders as rendered."""

    def __init__(self, obj):
        self.obj, self.occluders = obj, sky_bake.default_occluders(obj)
        with scratch_scene.rendered(self.obj) as seen:
            placed = sky_bake._Placed(seen.mesh, np.array(self.obj.matrix_world, dtype=np.float64))
            self.points, self.normals, self.corner_point = placed.corner_points(smooth=False)
            self.pairs = self._edge_pairs(seen.mesh)
        self.tree = self._tree()

    def _edge_pairs(self, mesh):
        starts = np.empty(len(mesh.polygons), dtype=np.int32)
        mesh.polygons.foreach_get("loop_start", starts)
        corner_face = mesh_arrays.corner_faces(mesh)
        corners = len(self.corner_point)
        following = np.arange(corners) + 1
        ends = np.append(starts[1:], corners)[corner_face]
        following[following == ends] = starts[corner_face][following == ends]
        pairs = np.column_stack([self.corner_point, self.corner_point[following]])
        pairs = pairs[pairs[:, 0] != pairs[:, 1]]
        return np.unique(np.sort(pairs, axis=1), axis=0)

    def _tree(self):
        depsgraph = bpy.context.evaluated_depsgraph_get()
        positions, faces, offset = [], [], 0
        for obj in (self.obj, *self.occluders):
            evaluated = obj.evaluated_get(depsgraph)
            mesh = evaluated.to_mesh()
            matrix = np.array(obj.matrix_world)
            vertices = mesh_arrays.attribute(mesh, "position", np.float32, 3) @ matrix[:3, :3].T + matrix[:3, 3]
            positions.append(vertices)
            faces += [[offset + index for index in face.vertices] for face in mesh.polygons]
            offset += len(vertices)
            evaluated.to_mesh_clear()
        return BVHTree.FromPolygons(np.concatenate(positions).tolist(), faces, epsilon=0.0)

    def per_point(self, corner_values):
        values = np.zeros(len(self.points))
        values[self.corner_point] = corner_values
        return values

    def smoothed(self, values):
        """One pass: each point the mean of itself and its neighbours along the faces' edges."""
        total, count = values.copy(), np.ones(len(values))
        for this, other in (self.pairs.T, self.pairs[:, ::-1].T):
            np.add.at(total, this, values[other])
            np.add.at(count, this, 1.0)
        return total / count


def year_table():
    """The year's suns at LATITUDE as a (days, instants) table (``solar.year_grid``, day by day):
    scene directions and weights."""
    directions, weights = solar.year_grid(LATITUDE)
    return solar.scene_directions(directions, 0.0), weights / weights.sum()


def drawn_exposure(facade, draws, by_cosine, rng):
    """S at every façade point from ``draws`` rays (see the module's docstring)."""
    directions, weights = year_table()
    days, instants = solar.DAYS, solar.STEPS_PER_DAY
    lattice = np.arange(draws)[:, None] * np.array([1 / PLASTIC, 1 / PLASTIC**2])
    keys = np.round(facade.normals * 1000).astype(np.int64)
    _, cluster = np.unique(keys, axis=0, return_inverse=True)
    exposure = np.zeros(len(facade.points))
    for members in np.split(np.argsort(cluster.ravel()), np.cumsum(np.bincount(cluster.ravel()))[:-1]):
        normal = facade.normals[members].mean(axis=0)
        normal /= np.linalg.norm(normal)
        cosine = np.maximum(0.0, directions @ normal)
        table = (weights * cosine if by_cosine else weights).reshape(days, instants)
        day_weights = table.sum(axis=1)
        if not day_weights.any():  # a plane the sun never reaches (facing down): S = 0
            continue
        day_cdf = np.cumsum(day_weights) / day_weights.sum()
        hour_cdf = np.cumsum(table, axis=1) / np.maximum(day_weights[:, None], 1e-300)
        open_plane = float((weights * cosine).sum())
        for point in members:
            u = (lattice + rng.random(2)) % 1.0
            day = np.minimum(np.searchsorted(day_cdf, u[:, 0]), days - 1)
            hour = np.minimum([np.searchsorted(hour_cdf[d], h) for d, h in zip(day, u[:, 1])], instants - 1)
            drawn = day * instants + hour
            start = facade.points[point] + LIFT * normal
            lit = [s for s in drawn if cosine[s] > 0.0 and facade.tree.ray_cast(start, directions[s])[0] is None]
            exposure[point] = (open_plane * len(lit) if by_cosine else cosine[lit].sum()) / draws
    return exposure


def facade_runs(reference_samples):
    _, [obj], _ = bench_life.facade()
    bake, facade = bench_sun.corner_bake(obj), FacadePoints(obj)
    reference = facade.per_point(bake("sun", reference_samples, 1))
    baked = {samples: facade.per_point(bake("sun", samples, 0)) for samples in DRAWS}
    rain = [facade.per_point(bake("rain", samples, seed)) for samples, seed in ((reference_samples, 1), (64, 0))]
    corners = facade.corner_point  # errors per corner, as bench_sun measures them
    print(f"façade: {len(facade.points)} points, {len(facade.pairs)} edge pairs")
    for samples, values in baked.items():
        smoothed, bias = facade.smoothed(values), facade.smoothed(reference)
        print(
            f"façade sun {samples} samples: RMSE {rmse(values[corners], reference[corners]):.4f}, "
            f"smoothed {rmse(smoothed[corners], reference[corners]):.4f} "
            f"(the reference smoothed: {rmse(bias[corners], reference[corners]):.4f})"
        )
    rng = np.random.default_rng(0)
    fine = drawn_exposure(facade, 256, True, rng)
    kept = (np.abs(fine - reference) <= 0.1)[corners]
    print(f"façade points left out (geometries disagree): {int((np.abs(fine - reference) > 0.1).sum())}")
    print(f"façade rain 64 samples: RMSE {rmse(rain[1][corners], rain[0][corners], kept):.4f}")
    for draws in DRAWS:
        cycles = rmse(baked[draws][corners], reference[corners], kept)
        for by_cosine in (False, True):
            started = time.perf_counter()
            values = drawn_exposure(facade, draws, by_cosine, rng)
            seconds = time.perf_counter() - started
            print(
                f"façade {draws} draws by {'w · cos' if by_cosine else 'w'}: RMSE "
                f"{rmse(values[corners], reference[corners], kept):.4f} in {seconds:.1f} s (Cycles: {cycles:.4f})",
                flush=True,
            )


def sky_widths(reference_samples):
    obj, roof = bench_sun.terrain_scene()
    settings = sun.SunSettings(latitude=LATITUDE, north_angle=0.0)
    directions, weights = solar.year(LATITUDE)
    directions = solar.scene_directions(directions, 0.0)

    def sun_bake(width, samples, seed):
        radiance = sun.sky_radiance(directions, weights, width)
        sky = sun.sky(dataclasses.replace(settings, samples=samples, seed=seed), LATITUDE, 0.0)
        sky = dataclasses.replace(sky, add=lambda scene, made: sun._add_sky(scene, radiance, made))
        return sky_bake.bake_image(obj, "UVMap", 128, sky, [roof])

    def timed(bake):
        started = time.perf_counter()
        values = bake()
        return values, time.perf_counter() - started

    rain_settings = rain.RainSettings(cone=15.0, samples=64)
    reference = sun_bake(sun.SKY_WIDTH, reference_samples, 1)
    for round_ in (1, 2):
        _, seconds = timed(lambda: rain.bake_rain_image(obj, "UVMap", 128, rain_settings, [roof]))
        print(f"sky round {round_}: rain 64 samples {seconds:.2f} s", flush=True)
        for width in SKY_WIDTHS:
            values, seconds = timed(lambda width=width: sun_bake(width, 64, 0))
            error = rmse(values, reference)
            print(f"sky round {round_}: sun 64 samples, {width} wide, {seconds:.2f} s, RMSE {error:.4f}", flush=True)


PARTS = {"terrain": terrain_smoothing, "facade": facade_runs, "sky": sky_widths}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--reference", type=int, default=1024)
    parser.add_argument("--only", nargs="+", choices=tuple(PARTS), default=tuple(PARTS), help="these parts only")
    args = parser.parse_args()
    for part in args.only:
        PARTS[part](args.reference)


if __name__ == "__main__":
    main()
