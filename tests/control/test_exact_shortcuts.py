"""The MPC step's shortcuts that must give the same numbers bit for bit (docs/performance-8-control.md).

Each is compared with ``array_equal`` or ``==`` against the computation it skips: the library's
``hypot``, the golden-section search for a segment's nearest point of a wall, every closest
distance of a plan to a prediction, and the NumPy expressions of DAQP's start flags.
"""

import math

import numba
import numpy as np
import pytest

from nodnav.control import braking
from nodnav.control.braking import (
    _closest_on_segment,
    _segment_wall_distance,
    hypot_axis,
    segment_clearance,
    tail_rows,
)
from nodnav.control.mpc_rows import plan_extremes
from nodnav.control.qp import QPSolution, start_flags, start_from, warm_flags
from nodnav.scenario.world import paper_world

WORLD = paper_world()
BOXES = WORLD.obstacle_array
PIECES = WORLD.piece_array
NO_PIECES = np.zeros((0, 4, 2))


def _awkward_values(rng: np.random.Generator, n: int) -> np.ndarray:
    """Magnitudes from subnormal to huge, both signs, and signed zeros."""
    v = rng.uniform(0.5, 2.0, n) * 10.0 ** rng.integers(-320, 300, n) * rng.choice([-1.0, 1.0], n)
    return np.concatenate([v, [0.0, -0.0, 5e-324, -5e-324, 1.7e308, 1e-310]])


def test_hypot_axis_is_the_librarys_hypot_bit_for_bit():
    rng = np.random.default_rng(0)
    values = _awkward_values(rng, 20000)
    others = np.concatenate([values, np.zeros(values.size), -np.zeros(values.size)])
    ones = np.concatenate([np.roll(values, 1), values, values])
    for a, b in ((ones, others), (others, ones)):
        got = np.array([hypot_axis(x, y) for x, y in zip(a, b)])
        want = np.hypot(a, b)
        assert np.array_equal(got, want)
        assert np.array_equal(np.signbit(got), np.signbit(want))  # no -0.0 where hypot gives +0.0
        assert all(math.hypot(x, y) == g for x, y, g in zip(a[::97], b[::97], got[::97]))
        # Compiled code called np.hypot where it now calls hypot_axis (group_state, plan_extremes).
        assert np.array_equal(_compiled_np_hypot(a, b), got)


@numba.njit
def _compiled_np_hypot(a, b):
    out = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        out[i] = np.hypot(a[i], b[i])
    return out


def _segments(rng: np.random.Generator, n: int) -> np.ndarray:
    """Segments ``(n, 4)`` near the paper's corridor walls: beside their faces (parallel,
    nearly parallel, steep, within 1e-6 m), across corners and mouths, and inside them."""
    a = np.column_stack([rng.uniform(-3.5, 3.5, n), rng.uniform(-0.6, 0.6, n)])
    kind = rng.integers(0, 4, n)
    step = np.where(kind[:, None] == 0, rng.normal(0.0, 1.0, (n, 2)) * [1.0, 1e-9],  # nearly parallel
                    np.where(kind[:, None] == 1, rng.normal(0.0, 0.3, (n, 2)),
                             np.where(kind[:, None] == 2, rng.normal(0.0, 1.0, (n, 2)) * [1.0, 0.0],  # parallel
                                      rng.normal(0.0, 3.0, (n, 2)))))
    seg = np.hstack([a, a + step])
    # Ends just beside a face: 1e-7 .. 1e-5 m out of the wall at y = +-0.35.
    near = rng.random(n) < 0.1
    seg[near, 1] = 0.35 + 10.0 ** rng.uniform(-7, -5, near.sum())
    seg[near, 3] = 0.35 + 10.0 ** rng.uniform(-7, -5, near.sum())
    return seg


def test_segment_distance_beside_a_face_is_the_searchs_bit_for_bit():
    rng = np.random.default_rng(1)
    beside = 0
    for ax, ay, bx, by in _segments(rng, 6000):
        for g in range(len(BOXES)):
            got = _segment_wall_distance(ax, ay, bx, by, g, BOXES, PIECES)
            assert got == _closest_on_segment(ax, ay, bx, by, g, BOXES, PIECES)[1]
            beside += braking._beside_face(ax, ay, bx, by, g, BOXES)
    assert beside > 3000  # the shortcut was taken, and often


def test_segment_clearance_unchanged_on_maps_walls():
    """Rectangles and a convex piece: the clearance equals the minimum of the searches' values."""
    rng = np.random.default_rng(2)
    boxes = np.array([[-3.0, -2.5, 3.0, -0.35], [-3.0, 0.35, 3.0, 2.5], [4.0, -1.0, 4.5, 1.0]])
    bounds = np.array([-7.0, -2.5, 7.0, 2.5])
    for ax, ay, bx, by in _segments(rng, 2000):
        a, b = np.array([ax, ay]), np.array([bx, by])
        want = min(min(a[0] - bounds[0], bounds[2] - a[0], a[1] - bounds[1], bounds[3] - a[1]),
                   min(b[0] - bounds[0], bounds[2] - b[0], b[1] - bounds[1], bounds[3] - b[1]),
                   *(_closest_on_segment(ax, ay, bx, by, g, boxes, NO_PIECES)[1] for g in range(len(boxes))))
        assert segment_clearance(a, b, boxes, NO_PIECES, bounds) == want


_SEARCHING: list = []


def _searching_tail_rows(monkeypatch, *args):
    """``tail_rows`` as before the shortcut, compiled as it is (the compiled code may fuse a
    multiply-add that Python rounds twice): every segment searched."""
    if not _SEARCHING:
        monkeypatch.setattr(braking, "_beside_face", numba.njit(lambda *a: False))
        _SEARCHING.append(numba.njit(tail_rows.py_func))
        _SEARCHING[0](*args)  # compiled now, with the search always taken
        monkeypatch.undo()
    _SEARCHING[0](*args)


@pytest.mark.parametrize("cold", [False, True])
def test_tail_rows_beside_a_face_are_the_searchs_bit_for_bit(monkeypatch, cold):
    rng = np.random.default_rng(3)
    nz, n_walls = 9, len(BOXES)
    phi, line = rng.normal(size=(2, nz)), rng.normal(size=2)
    beside = 0
    for ax, ay, bx, by in _segments(rng, 800):
        lin_p = np.array([ax, ay])
        weight = rng.uniform(0.2, 3.0)
        lin_v = (np.array([bx, by]) - lin_p) / weight
        p0 = lin_p + rng.normal(0.0, 0.2, 2)
        v0 = rng.normal(0.0, 0.4, 2)
        x_now = np.column_stack([np.clip(p0[0], BOXES[:, 0], BOXES[:, 2]), np.clip(p0[1], BOXES[:, 1], BOXES[:, 3])])
        away = (p0 - x_now) / np.maximum(np.hypot(*(p0 - x_now).T), 1e-9)[:, None]
        dist_now = np.hypot(*(p0 - x_now).T)
        need = rng.uniform(0.1, 0.5, n_walls)
        args = (lin_p, lin_v, weight, p0, v0, x_now, away, dist_now, need, 5.0, BOXES, NO_PIECES,
                np.array([-6.8, -2.3]), np.array([6.8, 2.3]), phi, line, 1e-6, cold)
        got_rows, got_lower = np.full((2 * n_walls + 4, 2 * nz), np.nan), np.full(2 * n_walls + 4, np.nan)
        want_rows, want_lower = got_rows.copy(), got_lower.copy()
        tail_rows(*args, got_rows, got_lower, 0)
        _searching_tail_rows(monkeypatch, *args, want_rows, want_lower, 0)
        assert np.array_equal(got_rows, want_rows) and np.array_equal(got_lower, want_lower)
        assert np.array_equal(np.signbit(got_rows), np.signbit(want_rows))
        e = lin_p + weight * lin_v
        beside += sum(braking._beside_face(ax, ay, e[0], e[1], g, BOXES) for g in range(n_walls))
    assert beside > 300


def test_plan_extremes_closest_distances_are_every_hypots_minimum():
    rng = np.random.default_rng(4)
    for _ in range(300):
        n = int(rng.integers(1, 60))
        points = rng.normal(0.0, 2.0, (n, 2))
        preds = points[None] + rng.normal(0.0, 10.0 ** rng.uniform(-3, 1), (4, n, 2))
        preds[0] = points + [0.3, 0.0]  # ties: the same distance at every point
        preds[1, :, 1] = points[:, 1]  # offsets along one axis only
        values = np.vstack([points, rng.normal(size=(6, 2))])
        closest = plan_extremes(values, n, 3, BOXES, PIECES, np.asarray(WORLD.bounds, dtype=float), preds)[1]
        assert np.array_equal(closest, np.hypot(*(points[None] - preds).transpose(2, 0, 1)).min(axis=1))


def test_start_flags_are_numpys_and_the_start_is_flatnonzero():
    rng = np.random.default_rng(5)
    for _ in range(200):
        n = int(rng.integers(1, 600))
        low = rng.normal(size=n)
        low[rng.random(n) < 0.2] = -np.inf
        start = np.sort(rng.choice(n, size=int(rng.integers(1, min(n, 40) + 1)), replace=False))
        want = np.zeros(n, dtype=np.intc)
        want[start[np.isfinite(low[start])]] = 3
        got = start_flags(low, start)
        assert got.dtype == np.intc and np.array_equal(got, want)
        lam = np.where(rng.random(n) < 0.05, -rng.random(n), 0.0)
        assert np.array_equal(start_from(QPSolution(True, "", np.zeros(2), 1, lam)), np.flatnonzero(lam))


def test_warm_flags_are_the_flags_of_start_from_or_a_cold_start():
    """The flags from an earlier solution's multipliers in one pass (:func:`warm_flags`) are
    those of its nonzero indices (:func:`start_from`, then :func:`start_flags`), and it returns
    False exactly where :func:`solve_qp` started cold from those indices: none, or one beyond the bounds."""
    rng = np.random.default_rng(11)
    for trial in range(400):
        n = int(rng.integers(1, 600))
        low = rng.normal(size=n)
        low[rng.random(n) < 0.2] = -np.inf
        size = n + int(rng.integers(-3, 4)) if trial % 4 == 0 else n  # the wrong length now and then
        lam = np.where(rng.random(max(size, 0)) < (0.0 if trial % 7 == 0 else 0.05), -rng.random(max(size, 0)), 0.0)
        lam[rng.random(lam.shape[0]) < 0.01] = np.nan  # truthy, as in np.flatnonzero
        lam[rng.random(lam.shape[0]) < 0.01] = -0.0  # falsy
        start = start_from(QPSolution(True, "", np.zeros(2), 1, lam))
        got = np.full(n, 7, dtype=np.intc)  # every entry is written
        warm = warm_flags(low, lam, got)
        assert warm == bool(len(start) and start[-1] < len(low))
        if warm:
            assert np.array_equal(got, start_flags(low, start))



def _braking_profile_with_norm(position, velocity, max_accel, times):
    """The braking profile as written with ``np.linalg.norm`` (the plain version)."""
    p, v = np.asarray(position, dtype=float), np.asarray(velocity, dtype=float)
    t = np.asarray(times, dtype=float)[:, None]
    speed = float(np.linalg.norm(v))
    if speed == 0.0:
        return np.repeat(p[None], len(t), axis=0), np.zeros((len(t), 2))
    u = v / speed
    tt = np.minimum(t, speed / max_accel)
    return p + (speed * tt - 0.5 * max_accel * tt**2) * u, np.maximum(speed - max_accel * t, 0.0) * u


def test_braking_profile_takes_the_speed_as_numpys_norm_bit_for_bit():
    from nodnav.control.braking import braking_profile

    rng = np.random.default_rng(4)
    times = np.concatenate([[0.1], 0.25 * np.arange(1, 9)])
    pairs = rng.normal(size=(3000, 2)) * 10.0 ** rng.uniform(-150, 150, (3000, 1))
    pairs[::7, 0] = 0.0  # along an axis
    pairs[::11] = 0.0  # at rest
    strided = np.zeros((3000, 4))
    strided[:, ::2] = pairs  # views that are not contiguous
    for v in (*pairs[:1500], *strided[1500:, ::2]):
        p = rng.normal(size=2)
        for got, want in zip(braking_profile(p, v, 2.0, times), _braking_profile_with_norm(p, v, 2.0, times)):
            assert np.array_equal(got, want, equal_nan=True)
