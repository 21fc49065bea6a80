"""The decisions' bookkeeping shortcuts against the NumPy calls they replace, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from nodnav.sim.agent import weighted_choice


def _cases():
    rng = np.random.default_rng(7)
    for n in (1, 2, 6, 24):
        for _ in range(40):
            p = rng.random(n) ** 3
            p[rng.random(n) < 0.3] = 0.0  # unavailable strategies
            if not p.any():
                p[rng.integers(n)] = 1.0
            yield p / p.sum()
    yield np.array([0.0, 1.0, 0.0])  # one strategy left
    yield np.array([1.0, 0.0])
    yield np.full(24, 1.0 / 24)  # sums to 1 only up to rounding
    yield np.array([True, False, True]) / 2  # selection_probabilities' fallback: a mask / its count


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_weighted_choice_draws_what_generator_choice_draws(seed):
    ours, numpy_s = np.random.default_rng(seed), np.random.default_rng(seed)
    for p in _cases():
        for _ in range(5):
            got = weighted_choice(ours, p)
            want = int(numpy_s.choice(len(p), p=p))
            assert got == want
            assert p[got] > 0.0  # never an unavailable strategy
    # Both generators consumed the same draws: their next numbers agree.
    assert ours.random() == numpy_s.random()
