"""Hard cases (benchmarks/stability.py, small): the numpy model and the rendered node groups
stay finite and agree on grazing angles, m, k_a, s_p, alpha, masks and t at their bounds."""

import numpy as np
import pytest

from benchmarks import stability

#: Largest model-vs-nodes difference of a weight allowed: float32 in the shader.  Measured
#: 8e-5 over 2304 cases per group (at s_p = 1000 seen head-on, where acos of a float32
#: cosine near 1 is least exact); a wrong term or a missing clamp is far above it.
FLOAT32_TOLERANCE = 1e-3


@pytest.mark.parametrize("label", ["porous (key sun)", "porous (ambient)", "every mode"])
def test_node_groups_agree_with_the_model_on_hard_cases(label):
    result = stability.compare(label, size=12)
    assert result["model non-finite"] == 0
    assert result["nodes non-finite"] == 0
    assert result["model out of [0, 1]"] == 0
    assert result["errors"].max() < FLOAT32_TOLERANCE, result["worst case"]


def test_hard_cases_cover_every_bound():
    """The draw reaches each hard value of each input at least once."""
    cases = stability.draw_cases(stability.GROUPS["every mode"][0], 12 * 12)
    for name, values in {**stability.POROUS_VALUES, **stability.STATE_VALUES}.items():
        drawn = cases[name].reshape(len(cases[name]), -1)
        for value in values:
            target = np.float32(value).astype(np.float64)
            assert (np.abs(drawn - target) == 0).all(axis=1).any(), (name, value)


def test_model_stays_finite_and_in_range_with_nan_and_infinite_inputs():
    for label, _count, non_finite, out_of_range in stability.model_sweep(count=20_000):
        assert (non_finite, out_of_range) == (0, 0), label
