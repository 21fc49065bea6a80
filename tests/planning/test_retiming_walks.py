"""The retiming kernels' shortcuts against the plain computations they replace, bit for bit: the
samples of a profile (:func:`_points_kernel`, which finds each knot by walking on from the one
before) against ``np.interp`` of each coordinate, the clearance check (:func:`_clear_kernel`)
against a binary search per step, :func:`_largest_speed` (which skips the square root where the
floor is known to reach ``k``) against its formula with the root always taken, and the joint
plan's arrays (:func:`joint_arrays`) against ``JointTrajectory.from_positions``."""

import math

import numpy as np

from nodnav.planning.fast_state import joint_arrays, joint_arrays_plain
from nodnav.planning.retiming import (
    EPS,
    _clear_kernel,
    _largest_speed,
    _last_at_or_below,
    _points_kernel,
    _points_plain,
    feasible_profile,
)


def _knots(rng, n):
    """Non-decreasing knots starting at 0, with repeated values now and then (a path's cells)."""
    steps = rng.uniform(0.0, 0.2, n - 1)
    steps[rng.random(n - 1) < 0.2] = 0.0
    return np.concatenate([[0.0], np.cumsum(steps)])


def test_last_at_or_below_is_searchsorted():
    rng = np.random.default_rng(5)
    for _ in range(300):
        xp = _knots(rng, int(rng.integers(1, 40)))
        queries = np.concatenate([rng.uniform(-0.5, xp[-1] + 0.5, 30), xp])
        if rng.random() < 0.5:
            queries.sort()  # mostly walking on; unsorted ones fall back to the search
        i = -1
        for x in queries:
            i = _last_at_or_below(xp, x, i)
            assert i == np.searchsorted(xp, x, side="right") - 1


def test_points_of_a_profile_are_numpy_interp_bit_for_bit():
    rng = np.random.default_rng(7)
    for _ in range(300):
        n = int(rng.integers(1, 60))
        cell_arc = _knots(rng, n)
        cells = rng.normal(size=(n, 2)) * rng.choice([1e-3, 1.0, 10.0])
        arc = np.sort(rng.uniform(-0.1, cell_arc[-1] + 0.1, int(rng.integers(1, 80))))
        if rng.random() < 0.3:
            arc = np.concatenate([arc, cell_arc])  # on the knots, and a step back to the start
        expected = np.stack([np.interp(arc, cell_arc, cells[:, 0]), np.interp(arc, cell_arc, cells[:, 1])], axis=1)
        got = _points_kernel(cells, cell_arc, arc)
        assert got.tobytes() == expected.tobytes()
        assert got.tobytes() == _points_plain(cells, cell_arc, arc).tobytes()


def _clear_plain(arc, cell_arc, free):
    """:func:`_clear_kernel` with a binary search at every step, as it was written first."""
    n_rows, n = free.shape[0], len(cell_arc)
    last = len(arc) - 1

    def has(row, c):
        return (int(row[c // 64]) >> (c % 64)) & 1 == 1

    for t in range(1, max(last, n_rows - 1) + 1):
        s = arc[min(t, last)]
        row = free[min(t, n_rows - 1)]
        c = min(max(int(np.searchsorted(cell_arc, s + EPS, side="right")) - 1, 0), n - 1)
        if not has(row, c):
            return t
        if c + 1 < n and s > cell_arc[c] + EPS and not has(row, c + 1):
            return t
    return -1


def test_clear_check_is_the_binary_search():
    rng = np.random.default_rng(11)
    found = 0
    for _ in range(400):
        n = int(rng.integers(1, 150))
        cell_arc = _knots(rng, n)
        words = (n + 63) // 64
        free = rng.integers(0, 2**63, size=(int(rng.integers(1, 40)), words), dtype=np.uint64)
        free |= rng.integers(0, 2**63, size=free.shape, dtype=np.uint64) << np.uint64(1)  # mostly free
        arc = np.minimum(np.cumsum(rng.uniform(0.0, 0.25, int(rng.integers(1, 60)))), cell_arc[-1])
        if rng.random() < 0.2:
            arc = arc[::-1].copy()  # decreasing: the walk falls back to the search
        expected = _clear_plain(arc, cell_arc, free)
        found += expected >= 0
        assert _clear_kernel(arc, cell_arc, free) == expected
    assert found > 50  # both outcomes were exercised


def _largest_speed_plain(s, t, up, goal, alpha, dt, hi):
    """:func:`_largest_speed` with the square root taken at every ``k`` (its first version)."""
    best = hi
    for k in range(int(math.ceil(hi / alpha)) + 2):
        j = t + 1 + k
        g = (up[j] if j < len(up) else goal) - s
        if g < -EPS:
            return -1.0
        g = max(g, 0.0)
        m = min(max(int(math.floor((-1.0 + math.sqrt(1.0 + 8.0 * g / (dt * alpha))) / 2.0)), 0), k)
        best = min(best, g / (dt * (m + 1)) + alpha * m / 2.0)
        if best <= k * alpha:
            break
    return best


def test_largest_speed_skips_the_root_only_where_it_cannot_matter():
    rng = np.random.default_rng(13)
    for _ in range(3000):
        up = np.cumsum(rng.uniform(0.0, 0.15, int(rng.integers(1, 30))))
        goal = float(up[-1])
        t = int(rng.integers(0, len(up)))
        s = float(up[t]) - float(rng.uniform(0.0, 0.3)) * (rng.random() < 0.8)
        alpha, dt = float(rng.choice([0.05, 0.2, 0.3])), float(rng.choice([0.05, 0.1]))
        hi = float(rng.uniform(0.0, 1.5))
        assert _largest_speed(s, t, up, goal, alpha, dt, hi) == _largest_speed_plain(s, t, up, goal, alpha, dt, hi)


def test_profile_from_rest_by_hand():
    # From rest at 0.2 m/s^2 a step (dt 0.1 s, limit 1 m/s) over a long path: 0.2, 0.4, ... m/s,
    # so the arc after three steps is 0.1 * (0.2 + 0.4 + 0.6) = 0.12 m.
    arc, ahead = feasible_profile(np.array([50.0]), 50.0, 0.0, 1.0, 2.0, 0.1)
    assert not ahead
    assert math.isclose(arc[3], 0.12, rel_tol=1e-12)
    assert arc[-1] == 50.0


def test_joint_arrays_are_from_positions_bit_for_bit():
    rng = np.random.default_rng(17)
    for _ in range(200):
        samples = [np.cumsum(rng.normal(size=(int(rng.integers(1, 40)), 2)), axis=0) for _ in range(rng.integers(1, 9))]
        t0, dt = float(rng.uniform(0, 100)), float(rng.choice([0.1, 0.05, 0.3]))
        ends = np.array([len(x) for x in samples], dtype=np.int64)
        got = joint_arrays(np.concatenate(samples), ends, t0, dt)
        for a, b in zip(got, joint_arrays_plain(samples, t0, dt)):
            assert a.tobytes() == b.tobytes()


def test_joint_arrays_by_hand():
    # Robot 0 moves 1 m in x per 0.5 s step, robot 1 stands: velocities 2 m/s, then 0 at the end.
    times, positions, velocities = joint_arrays(np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 5.0]]),
                                                np.array([2, 1], dtype=np.int64), 10.0, 0.5)
    assert times.tolist() == [10.0, 10.5]
    assert positions[:, 1].tolist() == [[5.0, 5.0], [5.0, 5.0]]
    assert velocities[0].tolist() == [[2.0, 0.0], [0.0, 0.0]] and velocities[1].tolist() == [[0.0, 0.0], [0.0, 0.0]]


def test_search_from_any_hint_is_searchsorted():
    from nodnav.planning.occupancy import search_from

    rng = np.random.default_rng(19)
    for _ in range(400):
        a = _knots(rng, int(rng.integers(1, 120)))
        if rng.random() < 0.3:
            a[rng.random(len(a)) < 0.5] = a[0]
            a.sort()  # long runs of one value (a robot waiting)
        for x in np.concatenate([rng.uniform(a[0] - 0.3, a[-1] + 0.3, 20), a]):
            h = int(rng.integers(-3, len(a) + 4))
            for right in (False, True):
                assert search_from(a, x, h, right) == np.searchsorted(a, x, side="right" if right else "left")
