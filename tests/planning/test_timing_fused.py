"""The fast planner's fused timing call against the plain steps it replaces, bit for bit: the
compiled twin of ``np.interp`` against NumPy itself, and ``_search_kernel`` (gates, search,
retiming, samples) against ``close_gates``, ``earliest_arrival_bits``, ``retimed`` and
``points_at`` run one after the other, on random tables; ``_timing_kernel`` (the earlier
robots' rows ORed into the table first) against that table made with NumPy, as ``_timing``
made it before."""

import math

import numpy as np
import pytest

from nodnav.planning.fast_state import plain_stays
from nodnav.planning.fused_timing import NO_GEOMETRY, _closed_kernel, _search_kernel, _timing_kernel, stay_geometry
from nodnav.planning.occupancy import close_gates, mask_words
from nodnav.planning.retiming import interp_twin, points_at, retimed
from nodnav.planning.timing import earliest_arrival_bits, timing_of
from nodnav.scenario.world import Passage, World, paper_world


def _knots(rng, n):
    """Non-decreasing knots with repeated values now and then."""
    steps = rng.uniform(0.0, 0.2, n - 1)
    steps[rng.random(n - 1) < 0.2] = 0.0
    return np.concatenate([[0.0], np.cumsum(steps)]) + rng.uniform(-1, 1)


def test_interp_twin_is_numpy_bit_for_bit():
    rng = np.random.default_rng(3)
    for _ in range(500):
        n = int(rng.integers(1, 30))
        xp = _knots(rng, n)
        fp = rng.normal(size=n) * rng.choice([1e-6, 1.0, 1e6])
        lo, hi = xp[0], xp[-1]
        x = np.concatenate([
            rng.uniform(lo - 0.5, hi + 0.5, 20),  # inside and beyond both ends
            xp,  # on the knots (repeated ones included)
            [lo, hi, np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf), np.nextafter(hi, -np.inf),
             lo - 1e9, hi + 1e9],
        ])
        rng.shuffle(x)
        expected = np.interp(x, xp, fp)
        got = interp_twin(x, xp, fp)
        assert got.tobytes() == expected.tobytes()


def test_interp_twin_by_hand():
    # Halfway between (0, 0) and (2, 4): 2; clamped to the end values outside; the knot's value on a knot.
    xp, fp = np.array([0.0, 2.0, 2.0, 3.0]), np.array([0.0, 4.0, 5.0, 5.0])
    assert interp_twin(np.array([1.0, -1.0, 9.0, 2.0, 2.5]), xp, fp).tolist() == [2.0, 0.0, 5.0, 5.0, 5.0]


def _plain(closed, n, gates, t0, ok2, wait_early, retime, cell_arc, cells_xy, v0, vmax, accel, dt):
    """The planner's former Python path (``_timing``'s end and ``timed_motion``)."""
    close_gates(closed, n, t0, gates)
    free = np.invert(closed, out=closed)
    free[:, -1] &= mask_words(n, 0)[-1]
    timing = earliest_arrival_bits(free, n, ok2, wait_early)
    if timing.success and retime:
        timing = retimed(timing, cell_arc, free, v0, vmax, accel, dt)
    if not timing.success:
        return timing, None
    if timing.arc is None:
        return timing, cells_xy[timing.cells]
    return timing, points_at(cells_xy, cell_arc, timing.arc)


@pytest.mark.parametrize("seed", range(4))
def test_search_kernel_is_the_plain_path(seed):
    rng = np.random.default_rng(seed)
    outcomes = set()
    for _ in range(300):
        n = int(rng.integers(2, 150))
        words = (n + 63) // 64
        rows = int(rng.integers(1, 60))
        density = rng.choice([0.0, 0.02, 0.1, 0.3])
        closed_bool = rng.random((rows, n)) < density
        packed = np.zeros((rows, 8 * words), dtype=np.uint8)
        p = np.packbits(closed_bool, axis=1, bitorder="little")
        packed[:, :p.shape[1]] = p
        closed = packed.view("<u8").astype(np.uint64)
        t0 = int(rng.integers(0, 5))
        gates = [(int(rng.integers(-1, n)), int(rng.integers(0, rows + t0 + 5)))
                 for _ in range(int(rng.integers(0, 4)))]
        ok2 = rng.random(n + int(rng.integers(0, 3))) < 0.7
        cell_arc = np.concatenate([[0.0], np.cumsum(rng.uniform(0.01, 0.1, n - 1))])
        cells_xy = np.cumsum(rng.normal(size=(n, 2)) * 0.05, axis=0)
        wait_early, retime = bool(rng.random() < 0.7), bool(rng.random() < 0.7)
        v0, vmax, accel, dt = float(rng.uniform(0, 1)), float(rng.uniform(0.2, 1.5)), float(rng.uniform(0.1, 3)), 0.1
        expected, samples = _plain(closed.copy(), n, gates, t0, ok2, wait_early, retime, cell_arc, cells_xy, v0,
                                   vmax, accel, dt)
        status, step, steps, arc, got_samples, stays = _search_kernel(
            closed.copy(), n, np.array(gates, dtype=np.int64).reshape(-1, 2), t0, ok2, wait_early, retime,
            cell_arc, cells_xy, v0, vmax, accel * dt, dt, NO_GEOMETRY)
        got = timing_of(status, step, steps, arc if len(arc) else None, got_samples)
        outcomes.add((got.success, got.arc is not None))
        assert (got.success, got.reason, got.trapped_at) == (expected.success, expected.reason, expected.trapped_at)
        assert got.cells.tobytes() == expected.cells.tobytes()
        assert (got.arc is None) == (expected.arc is None)
        if got.arc is not None:
            assert got.arc.tobytes() == expected.arc.tobytes()
        if got.success:
            assert got.samples.tobytes() == np.ascontiguousarray(samples).tobytes()
    assert outcomes >= {(True, True), (True, False), (False, False)}  # every branch was taken


def _plain_closed(parts, t0, gates, words):
    """The table of closed cells as ``_timing`` made it with NumPy: each motion's rows from
    ``min(t0, last)`` on, ORed in, its last row repeated past its end."""
    n_rows = max([len(b) for b in parts] + [a + 1 for _, a in gates] + [t0 + 1]) - t0
    closed = np.zeros((n_rows, words), dtype=np.uint64)
    for bits in parts:
        part = bits[min(t0, len(bits) - 1):]
        closed[:len(part)] |= part
        if len(part) < n_rows:
            closed[len(part):] |= part[-1]
    return closed


@pytest.mark.parametrize("seed", range(3))
def test_timing_kernel_is_the_table_then_the_search(seed):
    """The rows of 0-4 motions of random lengths (some of one row, parked from the start),
    started at random steps before, at and past their ends, and random gates: the table
    ``_closed_kernel`` makes is the NumPy one bit for bit, and ``_timing_kernel`` answers as
    ``_search_kernel`` on that table."""
    rng = np.random.default_rng(100 + seed)
    for _ in range(300):
        n = int(rng.integers(2, 150))
        words = (n + 63) // 64
        parts = []
        for _ in range(int(rng.integers(0, 5))):
            rows = int(rng.integers(1, 50))
            closed_bool = rng.random((rows, n)) < rng.choice([0.01, 0.05, 0.2])
            packed = np.zeros((rows, 8 * words), dtype=np.uint8)
            p = np.packbits(closed_bool, axis=1, bitorder="little")
            packed[:, :p.shape[1]] = p
            parts.append(packed.view("<u8").astype(np.uint64))
        t0 = int(rng.integers(0, 60))
        gates = np.array([(int(rng.integers(-1, n)), int(rng.integers(0, 80))) for _ in range(int(rng.integers(0, 4)))],
                         dtype=np.int64).reshape(-1, 2)
        stack = np.concatenate(parts) if parts else np.zeros((0, words), dtype=np.uint64)
        rows = np.array([len(b) for b in parts], dtype=np.int64)
        expected = _plain_closed(parts, t0, [tuple(g) for g in gates], words)
        got = _closed_kernel(stack, rows, t0, gates, words)
        assert got.shape == expected.shape and got.tobytes() == expected.tobytes()
        ok2 = rng.random(n) < 0.7
        cell_arc = np.concatenate([[0.0], np.cumsum(rng.uniform(0.01, 0.1, n - 1))])
        cells_xy = np.cumsum(rng.normal(size=(n, 2)) * 0.05, axis=0)
        args = (n, gates, t0, ok2, bool(rng.random() < 0.7), bool(rng.random() < 0.7), cell_arc, cells_xy, 0.3, 1.0,
                0.05, 0.1, NO_GEOMETRY)
        want = _search_kernel(expected, *args)
        have = _timing_kernel(stack, rows, *args)
        assert have[:2] == want[:2] and have[2].tobytes() == want[2].tobytes()
        assert have[3].tobytes() == want[3].tobytes() and have[4].tobytes() == want[4].tobytes()
        assert tuple(have[5]) == tuple(want[5])


@pytest.mark.parametrize("turned", [False, True])
def test_search_kernel_stays_are_plain_stays(turned):
    """The stays the fused call computes for a plan against ``plain_stays`` (``World.on_line``
    and ``in_door_zone``) on random walks across the paper's corridor and across a passage
    turned by 40 degrees; a sample on a door zone's circle in every walk."""
    world = paper_world()
    if turned:
        c, s = math.cos(0.7), math.sin(0.7)
        world = World(bounds=(-10.0, -10.0, 10.0, 10.0), obstacles=(),
                      passages=(Passage(start=(-3 * c, -3 * s), end=(3 * c, 3 * s), width=1.2),))
    geometry = stay_geometry(world, 1.0)
    rng = np.random.default_rng(11)
    (e0x, e0y), (e1x, e1y) = world.entrances[0], world.entrances[1]
    seen = set()
    for _ in range(200):
        n = int(rng.integers(2, 80))
        a, b = np.array([e0x, e0y]), np.array([e1x, e1y])
        start, end = a + (a - b) * rng.uniform(0.0, 0.6), b + (b - a) * rng.uniform(-1.2, 0.6)
        cells_xy = start + (end - start) * np.linspace(0, 1, n)[:, None] + rng.normal(size=(n, 2)) * 0.1
        cells_xy[rng.integers(0, n)] = (e0x + 1.0, e0y)  # on a door zone's circle
        cell_arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(cells_xy, axis=0).T))])
        closed = np.zeros((1, (n + 63) // 64), dtype=np.uint64)
        status, _, steps, arc, samples, stays = _search_kernel(
            closed, n, np.zeros((0, 2), dtype=np.int64), 0, np.ones(n, dtype=bool), True, bool(rng.random() < 0.5),
            cell_arc, cells_xy, 0.0, 0.5, 0.05, 0.1, geometry)
        assert status == 0
        expected = plain_stays(world, samples, 1.0)
        assert tuple(int(v) for v in stays) == tuple(int(v) for v in expected)
        seen.add(stays[0] >= 0)
    assert seen == {True, False}


def test_blocked_rows_are_blocked_bits_of_the_intervals():
    """``blocked_rows`` (one compiled call) against ``blocked_bits`` of ``conflict_intervals``
    for one motion, on random polylines driven at random speeds, standing still and parked."""
    from nodnav.planning.occupancy import Motion, blocked_bits, blocked_rows, conflict_intervals

    rng = np.random.default_rng(5)
    for _ in range(300):
        m = int(rng.integers(1, 6))
        path = np.cumsum(rng.normal(size=(m, 2)), axis=0)
        knots = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
        steps = int(rng.integers(0, 40))
        arc = np.sort(rng.uniform(0.0, knots[-1], steps + 1))
        arc[0] = 0.0
        if rng.random() < 0.5:
            arc[-1] = knots[-1]
        motion = Motion(path, points_at(path, knots, arc), arc)
        cells = rng.uniform(path.min(axis=0) - 1, path.max(axis=0) + 1, (int(rng.integers(1, 140)), 2))
        r = float(rng.uniform(0.05, 1.0))
        expected = blocked_bits(len(cells), motion.last_step + 1, [conflict_intervals(cells, [motion], [r])])
        got = blocked_rows(np.ascontiguousarray(cells), motion, r)
        assert got.dtype == expected.dtype and got.tobytes() == expected.tobytes()


def test_boxes_apart_against_numpy_and_blocked_rows():
    """``boxes_apart`` decides as its NumPy form on random cells and motions (boxes exactly the
    separation apart included), and whenever it says apart, ``blocked_rows`` is all clear: the
    rows ``_blocked`` writes as zeros are the ones the kernel gives."""
    from nodnav.planning.occupancy import Motion, blocked_rows, boxes_apart, boxes_apart_plain
    rng = np.random.default_rng(11)
    apart = 0
    for _ in range(600):
        cells = np.cumsum(rng.normal(0.0, 0.05, (int(rng.integers(1, 120)), 2)), axis=0) + rng.uniform(-3, 3, 2)
        path = np.cumsum(rng.normal(0.0, 0.6, (int(rng.integers(2, 6)), 2)), axis=0) + rng.uniform(-3, 3, 2)
        seg = np.hypot(*np.diff(path, axis=0).T)
        total = float(seg.sum())
        arc = np.sort(rng.uniform(0.0, total, int(rng.integers(1, 40))))
        arc[0] = 0.0
        knots = np.concatenate([[0.0], np.cumsum(seg)])
        samples = np.stack([np.interp(arc, knots, path[:, d]) for d in (0, 1)], axis=1)
        motion = Motion(path, samples, arc)
        required = float(rng.uniform(0.1, 1.5))
        if rng.random() < 0.1:  # the boxes exactly the separation apart along x
            required = float(cells[:, 0].min() - max(path[:, 0].max(), samples[:, 0].max()))
            required = abs(required) if required else 0.5
        fast = bool(boxes_apart(cells, path, samples, required))
        assert fast == boxes_apart_plain(cells, path, samples, required)
        if fast:
            apart += 1
            assert not blocked_rows(np.ascontiguousarray(cells), motion, required).any()
    assert apart > 50
