"""The visibility graph's choice of the first and last vertex of a path (planning/wall_paths.py,
``best_via``): the compiled loop against the NumPy table it replaces, and against a hand count."""

import numpy as np

from nodnav.planning.wall_paths import best_via as _best_via
from nodnav.planning.wall_paths import best_via_plain as _best_via_plain

INF = np.inf


def test_the_least_sum_and_its_first_pair_by_hand():
    # Three vertices; the start sees 0 and 1 (1 and 2 m), the goal sees 1 and 2 (2 and 1 m).
    # Through (0, 2): 1 + 3 + 1 = 5; (1, 2): 2 + 1 + 1 = 4; (1, 1): 2 + 0 + 2 = 4; (0, 1): 1 + 4 + 2 = 7.
    # Two pairs tie at 4: the first in row-major order, (1, 1), is kept: 1 * 3 + 1 = 4.
    dist = np.array([[0.0, 4.0, 3.0], [4.0, 0.0, 1.0], [3.0, 1.0, 0.0]])
    d_start = np.array([[1.0, 2.0, INF]])
    d_goal = np.array([[INF, 2.0, 1.0]])
    best, cost = _best_via(d_start, dist, d_goal, np.isfinite(d_start), np.isfinite(d_goal))
    assert best.tolist() == [4] and cost.tolist() == [4.0]
    # Nothing seen from the goal: no pair, an infinite cost.
    best, cost = _best_via(d_start, dist, d_goal, np.isfinite(d_start), np.zeros((1, 3), dtype=bool))
    assert best.tolist() == [0] and cost.tolist() == [INF]


def test_the_compiled_loop_equals_the_table_bit_for_bit():
    rng = np.random.default_rng(11)
    for _ in range(100):
        nv, m = int(rng.integers(1, 30)), int(rng.integers(1, 5))
        points = rng.normal(size=(nv, 2))
        dist = np.linalg.norm(points[:, None] - points[None], axis=2)
        dist[rng.random((nv, nv)) < 0.2] = INF  # disconnected pairs
        np.fill_diagonal(dist, 0.0)
        # Ties: some legs rounded to a coarse grid.
        from_start, to_goal = rng.random((m, nv)) < 0.5, rng.random((m, nv)) < 0.5
        d_start = np.where(from_start, np.round(rng.random((m, nv)) * 4) / 4, INF)
        d_goal = np.where(to_goal, np.round(rng.random((m, nv)) * 4) / 4, INF)
        got = _best_via(d_start, dist, d_goal, from_start, to_goal)
        want = _best_via_plain(d_start, dist, d_goal, from_start, to_goal)
        assert np.array_equal(got[0], want[0])
        assert np.array_equal(got[1], want[1])
