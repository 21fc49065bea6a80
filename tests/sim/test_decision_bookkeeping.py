"""The decisions' bookkeeping shortcuts against the NumPy calls they replace, bit for bit."""

from __future__ import annotations

from typing import cast

import numpy as np
import pytest

from nodnav.planning.base import Planner
from nodnav.sim.agent_queries import weighted_choice


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


def _players_by_argsort(L, i, k):
    """Eq. (7) as numpy ranks it: the k largest L_ij, j != i, ties to the lower index."""
    others = np.delete(np.arange(L.shape[0]), i)
    ranked = others[np.argsort(-L[i, others], kind="stable")]
    return tuple(sorted(int(j) for j in ranked[:k]))


def test_game_players_rank_as_numpy_argsort_does():
    from nodnav.decision.players import select_game_players
    rng = np.random.default_rng(3)
    for n in (2, 3, 4, 8):
        for _ in range(200):
            L = rng.choice([0.0, -0.0, 0.25, 0.5, 1.0, -np.inf], size=(n, n))  # many ties
            if rng.random() < 0.5:
                L = rng.random((n, n))
            i, k = int(rng.integers(n)), int(rng.integers(n))
            assert select_game_players(L, i, k) == _players_by_argsort(L, i, k)
    L = np.array([[0.0, np.nan, 0.3], [0.1, 0.0, 0.2], [0.5, 0.5, 0.0]])
    assert select_game_players(L, 0, 1) == _players_by_argsort(L, 0, 1) == (2,)


def test_once_computes_once_per_round():
    from nodnav.sim.plan_cache import PlanCache
    cache = PlanCache(planner=cast(Planner, None))  # no plan is asked of it
    calls = []
    kept = np.zeros(3)

    def compute():
        calls.append(1)
        return ("template", len(calls))

    assert cache.once(("k", id(kept)), compute, kept) == ("template", 1)
    assert cache.once(("k", id(kept)), compute, kept) == ("template", 1)  # the same round: remembered
    cache.clear()
    assert cache.once(("k", id(kept)), compute, kept) == ("template", 2)  # a new round: computed again
