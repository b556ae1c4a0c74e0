"""How close the lichens' Voronoi seeds come to the Boolean model (docs/model.md §9.3).

Blender's 2D Voronoi texture puts one seed in each unit cell, uniformly within it, and its F1 and F2
are the distances to the nearest and the second nearest seed among the cell and its eight
neighbours.  This script draws the same seeds in numpy (independently of Blender), measures the
share of points within r of their nearest seed, and compares it with the Boolean model of Poisson
seeds of the same density, 1 - exp(-lambda pi r^2): every thallus of radius r seen from the nearest
seed alone, and the mode's own ``lichen_cover`` (each thallus its own size, of mean square r^2, seen
from the two nearest seeds), and on the limestone: each point's reach by the stone's uptake s, drawn
as the limestone's field gives it (z_p of standard deviation 0.20, s = clamp(G z_p, -1, 1), §8.7).
Plain numpy, no bpy:  python benchmarks/lichen_cover.py
"""

import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

from porous_weathering.core.backends import NumpyOps
from porous_weathering.core.modes import base, biological


def voronoi_seeds(cells: int = 400, points: int = 200_000, seed: int = 1):
    """The LICHEN_SEEDS at ``points`` random points of a ``cells`` x ``cells`` grid of one seed per
    cell, as Blender's 2D Voronoi F1 and F2 find them: the nearest seed's (distance in cells, value,
    size draw), then the second nearest's."""
    rng = np.random.default_rng(seed)
    sx, sy = (np.arange(cells)[axis] + rng.random((cells, cells)) for axis in (np.s_[:, None], np.s_[None, :]))
    draws = rng.random((2, cells, cells))
    where = rng.random((points, 2)) * (cells - 4) + 2
    cx, cy = np.floor(where).astype(int).T
    neighbours = [(cx + dx, cy + dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
    distance = np.stack([np.hypot(sx[cell] - where[:, 0], sy[cell] - where[:, 1]) for cell in neighbours])
    values = np.stack([np.stack([draw[cell] for draw in draws]) for cell in neighbours])  # (9, 2, points)
    order = np.argsort(distance, axis=0)[:2]
    nearest = [np.take_along_axis(distance, order[k : k + 1], 0)[0] for k in (0, 1)]
    own = [np.take_along_axis(values, order[k][None, None, :].repeat(2, 1), 0)[0] for k in (0, 1)]
    return nearest[0], *own[0], nearest[1], *own[1]


#: The limestone's porosity field's standard deviation on a bed face (docs/model.md §8.7).
LIMESTONE_FIELD_DEVIATION = 0.20


def limestone_spread(points, seed=2):
    """The stone's uptake s at ``points`` points of the limestone at variation 1 (docs/model.md §8.7)."""
    field = np.random.default_rng(seed).normal(0.0, LIMESTONE_FIELD_DEVIATION, points)
    return base.uptake_spread(NumpyOps(colour=False), field, 1.0)


def cover(seeds, u, suitability=1.0, spread=None):
    """The mean lichen cover of the mode at lambda pi r^2 = ``u`` (lambda = 1 per m², level 1, a
    surface as damp and lit as lichens need, scaled to ``suitability``), each point's thalli reaching
    by its uptake ``spread`` if given (a stone)."""
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
    xp = NumpyOps(colour=False)
    return float(np.mean(biological.in_either(xp, *biological.thalli_covers(xp, state, seeds, None, spread))))


def main():
    seeds = voronoi_seeds()
    distance = seeds[0]
    spread = limestone_spread(len(distance))
    print(
        "u = lambda pi r^2 | Boolean | one seed per cell, r as is, F1 | the mode | the mode on the limestone"
        " | L = 0.5: Boolean, mode"
    )
    for u in (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 3.0, 4.0):
        plain = float(np.mean(distance < np.sqrt(u / np.pi)))
        boolean, half = 1.0 - np.exp(-u), 1.0 - np.exp(-0.5 * u)
        print(
            f"{u:5.2f} | {boolean:.3f} | {plain:.3f} | {cover(seeds, u):.3f} | {cover(seeds, u, spread=spread):.3f}"
            f" | {half:.3f}, {cover(seeds, u, 0.5):.3f}"
        )


if __name__ == "__main__":
    main()
