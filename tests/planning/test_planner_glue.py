"""The planner's glue cut down (issue 23): each shortcut against the plain code it replaces."""

from __future__ import annotations

import numpy as np

from nodnav.planning.base import feasible_order
from nodnav.planning.occupancy import TOL, Motion, _blocked_kernel, _close_kernel, _conflicts_with, join_motions
from nodnav.planning.retiming import points_at
from nodnav.planning.velocity_tuning import _allclose_point


def _random_motion(rng: np.random.Generator) -> Motion:
    m = int(rng.integers(1, 6))
    path = np.cumsum(rng.normal(size=(m, 2)), axis=0)
    knots = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    arc = np.sort(rng.uniform(0.0, knots[-1], int(rng.integers(0, 40)) + 1))
    arc[0] = 0.0
    return Motion(path, points_at(path, knots, arc), arc)


def test_blocked_kernel_subtracts_the_offsets_as_numpy():
    """``_blocked_kernel`` given NumPy's product and the offsets: the table that ``_close_kernel``
    makes of ``_conflicts_with``'s intervals (whose frame is ``cells @ basis - offset`` in NumPy),
    bit for bit, on random motions and cells (moving, standing still and parked)."""
    rng = np.random.default_rng(23)
    for _ in range(300):
        motion = _random_motion(rng)
        lo, hi = motion.path.min(axis=0) - 1, motion.path.max(axis=0) + 1
        cells = np.ascontiguousarray(rng.uniform(lo, hi, (int(rng.integers(1, 200)), 2)))
        r = float(rng.uniform(0.05, 1.0))
        basis, offset, s0, length, step, chord_a, chord_b = motion.sweep
        moving = motion.last_step > 0 and len(length)
        product = cells @ basis if moving else np.zeros((0, 0))
        got = _blocked_kernel(cells, product, offset, motion.samples[-1], motion.arc, s0, length, step, chord_a,
                              chord_b, motion.last_step, r, (r - TOL) ** 2)
        expected = np.zeros((motion.last_step + 1, (len(cells) + 63) // 64), dtype=np.uint64)
        _close_kernel(expected, *_conflicts_with(cells, motion, r))
        assert got.tobytes() == expected.tobytes()


def test_motion_length_is_the_sum_of_its_segments():
    """``Motion.length`` (remembered) is ``float(segments[2].sum())``, and ``join_motions``
    shifts the tail's arc lengths by it."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        head, tail = _random_motion(rng), _random_motion(rng)
        assert float(head.length).hex() == float(head.segments[2].sum()).hex()
        tail = Motion(tail.path - tail.path[0] + head.samples[-1], tail.samples - tail.path[0] + head.samples[-1],
                      tail.arc)
        joined = join_motions(head, tail)
        assert joined.arc[len(head.arc) - 1:].tobytes() == (tail.arc + float(head.segments[2].sum())).tobytes()


def test_allclose_point_is_numpy_allclose():
    """``_allclose_point`` against ``np.allclose`` on points near each other at every scale."""
    rng = np.random.default_rng(11)
    for _ in range(3000):
        b = rng.normal(size=2) * 10.0 ** rng.integers(-9, 3)
        a = b + rng.normal(size=2) * 10.0 ** rng.integers(-12, 0)
        if rng.random() < 0.2:
            a[int(rng.integers(0, 2))] = b[int(rng.integers(0, 2))]
        x, y = a.tolist()
        assert _allclose_point(x, y, b.tolist()) == bool(np.allclose(a, b))


def test_no_entered_robot_keeps_the_order():
    """What ``plan`` now takes without calling ``feasible_order`` when nobody has entered:
    the requested order itself, whatever the directions."""
    for order in ((0, 1, 2, 3), (3, 1, 0, 2), (2, 0, 1)):
        for dirs in (None, [1] * len(order), [-1, 0, 1, 1][:len(order)]):
            assert feasible_order(order, (), dirs) == order


def test_remembered_property_computes_once_and_keeps_the_value():
    """``remembered_property`` (``cached_property`` without the lock): computed on the first
    read only, kept in the instance, documented as the function, the descriptor on the class."""
    from nodnav.planning.memo import remembered_property

    calls = []

    class Thing:
        @remembered_property
        def value(self) -> int:
            """The value."""
            calls.append(1)
            return 7

    thing = Thing()
    assert thing.value == 7 and thing.value == 7 and len(calls) == 1
    assert thing.__dict__["value"] == 7
    assert isinstance(Thing.value, remembered_property) and Thing.value.__doc__ == "The value."
