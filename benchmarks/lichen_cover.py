"""How close the lichens' Voronoi seeds come to the Boolean model (docs/model.md §9.3).

Blender's 2D Voronoi texture puts one seed in each unit cell, uniformly within it, and its F1 is
the distance to the nearest seed among the cell and its eight neighbours.  This script draws the
same seeds in numpy (independently of Blender), measures the share of points within r of their
nearest seed, and compares it with the Boolean model of Poisson seeds of the same density,
1 - exp(-lambda pi r^2): without a correction, and with the mode's own ``lichen_cover`` (its crowded
radius).  Plain numpy, no bpy:  python benchmarks/lichen_cover.py
"""

import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

from porous_weathering.core.backends import NumpyOps
from porous_weathering.core.modes import biological


def voronoi_seeds(cells: int = 400, points: int = 200_000, seed: int = 1):
    """(distance in cells to the nearest seed, that seed's value) at ``points`` random points of a
    ``cells`` x ``cells`` grid of one seed per cell, as Blender's 2D Voronoi F1 finds them."""
    rng = np.random.default_rng(seed)
    sx, sy = (np.arange(cells)[axis] + rng.random((cells, cells)) for axis in (np.s_[:, None], np.s_[None, :]))
    values = rng.random((cells, cells))
    where = rng.random((points, 2)) * (cells - 4) + 2
    cx, cy = np.floor(where).astype(int).T
    best, value = np.full(points, np.inf), np.zeros(points)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            d = np.hypot(sx[cx + dx, cy + dy] - where[:, 0], sy[cx + dx, cy + dy] - where[:, 1])
            closer = d < best
            best = np.where(closer, d, best)
            value = np.where(closer, values[cx + dx, cy + dy], value)
    return best, value


def cover(distance, value, u, suitability=1.0):
    """The mean lichen cover of the mode at lambda pi r^2 = ``u`` (lambda = 1 per m², level 1, a
    surface as damp and lit as lichens need, scaled to ``suitability``)."""
    density = 1.0
    radius = np.sqrt(u / (np.pi * density))
    years = biological.LICHEN_LAG_YEARS + radius / 0.0005  # growth 1 mm a year across
    state = dict(
        biological_years=years,
        lichen_growth=1.0,
        lichen_density=density,
        biological_level=suitability,
        sun_map=1.0,
        rain_map=1.0,
        runoff_map=0.0,
        runoff=0.0,
        damp_map=0.0,
    )
    return float(np.mean(biological.lichen_cover(NumpyOps(colour=False), state, distance, value)))


def main():
    distance, value = voronoi_seeds()
    print("u = lambda pi r^2 | Boolean | one seed per cell, r as is | the mode (crowded r) | L = 0.5: Boolean, mode")
    for u in (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 3.0, 4.0):
        plain = float(np.mean(distance < np.sqrt(u / np.pi)))
        boolean, half = 1.0 - np.exp(-u), 1.0 - np.exp(-0.5 * u)
        print(
            f"{u:5.2f} | {boolean:.3f} | {plain:.3f} | {cover(distance, value, u):.3f}"
            f" | {half:.3f}, {cover(distance, value, u, 0.5):.3f}"
        )


if __name__ == "__main__":
    main()
