"""The regions of the corpus benchmark (benchmarks/bench_corpus.py), found from the geometry and
the baked maps alone, never from the weathering code's results (docs/benchmarks.md, "The
untuned corpus"):

- the water reaching a point, rain or run-off: W = E + R (1 - E) (docs/model.md §7.2, with the
  API's default ``runoff`` = 1);
- **sheltered hollows**: W < ``SHELTERED_BELOW`` (neither rain nor run-off reaches them) in the
  concave part of the edge mask: the mean curvature H < 0 there and the mask C >=
  ``CAVITY_FROM`` (the mask C = clip(weights · |H| · r / 0.45) does not keep H's sign, so the
  sign comes from the geometry, docs/maps.md);
- **washed**: W >= ``WASHED_FROM``;
- **the rest**: everything else.

And the run-off's streaks (benchmarks/bench_runoff_look.py): where rain alone would not wash
(E < e_rain), the **clean streaks** the run-off washes (W >= e_rain) and the **dirty tails** it
reaches too weakly to wash (R >= ``TAIL_FROM``, W < e_rain).

Pure numpy: the same function classifies per pixel (the benchmark), per vertex or any array.
"""

import numpy as np

SHELTERED_HOLLOW, WASHED, REST = 0, 1, 2
NAMES = {SHELTERED_HOLLOW: "sheltered hollows", WASHED: "washed", REST: "the rest"}

#: W below which neither rain nor run-off reaches a point.
SHELTERED_BELOW = 0.1
#: W from which a point counts as washed.
WASHED_FROM = 0.8
#: The edge mask C from which a concave point is in "the concave part of the edge mask": a
#: quarter of its range, so that facets and scan noise (C of a few hundredths) do not count.
CAVITY_FROM = 0.25
#: W from which rain or run-off reaches a point, for the wet measure.
REACHED_FROM = 0.1
#: R from which run-off reaches a point (a dirty tail's lower end).
TAIL_FROM = 0.1


def water_reaching(rain, runoff):
    """W = E + R (1 - E): rain falling on a point or run-off over it (docs/model.md §7.2)."""
    rain, runoff = np.asarray(rain, float), np.asarray(runoff, float)
    return rain + runoff * (1.0 - rain)


def classify(rain, runoff, edges, curvature):
    """Each point's region (SHELTERED_HOLLOW, WASHED or REST) from its rain exposure E, run-off
    R, edge mask C and signed mean curvature (or any number of its sign: < 0 concave)."""
    water = water_reaching(rain, runoff)
    concave = (np.asarray(curvature) < 0.0) & (np.asarray(edges) >= CAVITY_FROM)
    regions = np.full(water.shape, REST, dtype=np.int8)
    regions[(water < SHELTERED_BELOW) & concave] = SHELTERED_HOLLOW
    regions[water >= WASHED_FROM] = WASHED
    return regions


def streak_regions(rain, runoff, threshold):
    """(clean streaks, dirty tails), boolean arrays, for the washing threshold e_rain ``threshold``."""
    rain, runoff = np.asarray(rain, float), np.asarray(runoff, float)
    unwashed_by_rain = rain < threshold
    washed = water_reaching(rain, runoff) >= threshold
    return unwashed_by_rain & washed, unwashed_by_rain & ~washed & (runoff >= TAIL_FROM)
