"""The wall index of maps' worlds: its clearances are exactly the full loop's (bit for bit)."""

import numpy as np
import pytest

from nodnav.geometry import _segment_clearance_kernel, clearance_of
from nodnav.wall_grid import WallGrid, clearance_indexed, segment_clearance_indexed


@pytest.mark.parametrize("seed", range(4))
def test_indexed_clearances_equal_the_full_loop(seed):
    rng = np.random.default_rng(seed)
    bounds = np.array([-3.0, -2.0, 9.0, 7.0])
    lo = rng.uniform(bounds[:2], bounds[2:], (300, 2))
    boxes = np.hstack([lo, lo + rng.uniform(0.05, 1.5, (300, 2))])  # some reach past the bounds
    grid = WallGrid(boxes, bounds, cell=0.5)
    pts = rng.uniform(bounds[:2] - 1.0, bounds[2:] + 1.0, (2000, 2))
    assert np.array_equal(clearance_indexed(pts, bounds, boxes, *grid.arrays()), clearance_of(pts, bounds, boxes))
    a, b = pts[:1000], pts[1000:]
    b[::3] = a[::3] + rng.normal(0.0, 0.2, (len(a[::3]), 2))  # short segments as well as long ones
    pieces = np.zeros((0, 3, 2))
    full = _segment_clearance_kernel(a, b, boxes, bounds, pieces)
    assert np.array_equal(segment_clearance_indexed(a, b, boxes, bounds, pieces, *grid.arrays()), full)


def test_near_holds_every_box_meeting_the_rectangle():
    rng = np.random.default_rng(7)
    bounds = np.array([0.0, 0.0, 10.0, 10.0])
    lo = rng.uniform(0.0, 10.0, (200, 2))
    boxes = np.hstack([lo, lo + rng.uniform(0.05, 1.0, (200, 2))])
    grid = WallGrid(boxes, bounds, cell=0.5)
    for _ in range(50):
        a = rng.uniform(0.0, 10.0, 2)
        b = a + rng.uniform(0.0, 3.0, 2)
        meeting = np.flatnonzero((boxes[:, 0] <= b[0]) & (boxes[:, 2] >= a[0]) & (boxes[:, 1] <= b[1])
                                 & (boxes[:, 3] >= a[1]))
        assert set(meeting) <= set(grid.near(a, b).tolist())


def test_a_world_with_a_map_goes_through_its_index_with_the_same_values():
    from nodnav.geometry import segment_clearance
    from nodnav.scenario.world import Passage, World

    rng = np.random.default_rng(3)
    lo = rng.uniform(0.0, 10.0, (150, 2))
    boxes = tuple(map(tuple, np.hstack([lo, lo + rng.uniform(0.05, 1.0, (150, 2))])))
    passage = (Passage(start=(0.0, 5.0), end=(1.0, 5.0), width=0.5),)
    mapped = World(bounds=(0.0, 0.0, 10.0, 10.0), obstacles=boxes, passages=passage, map_walls=len(boxes))
    plain = World(bounds=(0.0, 0.0, 10.0, 10.0), obstacles=boxes, passages=passage)
    assert mapped.wall_grid is not None and plain.wall_grid is None
    a, b = rng.uniform(0.0, 10.0, (500, 2)), rng.uniform(0.0, 10.0, (500, 2))
    assert np.array_equal(segment_clearance(mapped, a, b), segment_clearance(plain, a, b))
    assert np.array_equal(mapped.clearance(a), plain.clearance(a))


@pytest.mark.parametrize("seed", range(4))
def test_the_clearance_verdict_through_the_index_is_the_full_loops(seed):
    """segment_clear_indexed against the full loop's value compared with the threshold, with
    thresholds drawn round the exact clearance (equal to it, a hair above and below), negative
    ones, and segments leaving the world."""
    from nodnav.wall_grid import segment_clear_indexed

    rng = np.random.default_rng(seed)
    bounds = np.array([-3.0, -2.0, 9.0, 7.0])
    lo = rng.uniform(bounds[:2], bounds[2:], (300, 2))
    boxes = np.hstack([lo, lo + rng.uniform(0.05, 1.5, (300, 2))])
    grid = WallGrid(boxes, bounds, cell=0.5)
    a = rng.uniform(bounds[:2] - 0.5, bounds[2:] + 0.5, (3000, 2))
    b = rng.uniform(bounds[:2] - 0.5, bounds[2:] + 0.5, (3000, 2))
    b[::2] = a[::2] + rng.normal(0.0, 0.4, (len(a[::2]), 2))
    pieces = np.zeros((0, 3, 2))
    full = _segment_clearance_kernel(a, b, boxes, bounds, pieces)
    for need in (full, np.nextafter(full, np.inf), np.nextafter(full, -np.inf), full + rng.normal(0.0, 0.3, len(full)),
                 rng.uniform(-0.5, 1.5, len(full)), np.full(len(full), 0.25)):
        got = segment_clear_indexed(a, b, np.ascontiguousarray(need), boxes, bounds, pieces, *grid.arrays())
        assert np.array_equal(got, full >= need)


def test_a_map_worlds_clearance_verdict_equals_the_plain_worlds():
    from nodnav.geometry import segment_is_clear
    from nodnav.scenario.world import Passage, World

    rng = np.random.default_rng(5)
    lo = rng.uniform(0.0, 10.0, (150, 2))
    boxes = tuple(map(tuple, np.hstack([lo, lo + rng.uniform(0.05, 1.0, (150, 2))])))
    passage = (Passage(start=(0.0, 5.0), end=(1.0, 5.0), width=0.5),)
    mapped = World(bounds=(0.0, 0.0, 10.0, 10.0), obstacles=boxes, passages=passage, map_walls=len(boxes))
    plain = World(bounds=(0.0, 0.0, 10.0, 10.0), obstacles=boxes, passages=passage)
    a, b = rng.uniform(0.0, 10.0, (50, 4, 2)), rng.uniform(0.0, 10.0, (50, 4, 2))
    need = np.array([0.0, 0.1, 0.2, 0.4])  # one per robot, broadcast as the joint checks do
    assert np.array_equal(segment_is_clear(mapped, a, b, need), segment_is_clear(plain, a, b, need))
    assert segment_is_clear(mapped, a, b, need).shape == (50, 4)


@pytest.mark.parametrize("seed", range(3))
def test_the_prm_joint_checks_through_the_index_are_the_full_loops(seed):
    """The PRM* planner's compiled joint checks (states and straight edges of 2-3 robots) give on
    a map's world, through its wall index, exactly the verdicts of the full loop over every wall
    (the same world without the index), including thresholds equal to a robot's exact clearance."""
    from nodnav.geometry import TOL, segment_clearance_one
    from nodnav.planning.joint_validity import CompiledRules
    from nodnav.scenario.world import Passage, World

    rng = np.random.default_rng(seed)
    lo = rng.uniform(0.0, 10.0, (400, 2))
    boxes = tuple(map(tuple, np.hstack([lo, lo + rng.uniform(0.05, 0.6, (400, 2))])))
    passage = (Passage(start=(0.0, 5.0), end=(1.0, 5.0), width=0.5),)
    mapped = World(bounds=(0.0, 0.0, 10.0, 10.0), obstacles=boxes, passages=passage, map_walls=len(boxes))
    plain = World(bounds=(0.0, 0.0, 10.0, 10.0), obstacles=boxes, passages=passage)
    checked = 0
    for n in (2, 3):
        dirs = np.zeros(n, dtype=int)  # no robot crosses: the order rule only forbids the passage
        sep = np.full(n * (n - 1) // 2, 0.3)
        radii = rng.uniform(0.0, 0.4, n)
        index, full = CompiledRules.of(mapped, radii, dirs, sep), CompiledRules.of(plain, radii, dirs, sep)
        assert index.args[-3][3] > 0 and full.args[-3][3] == 0  # the first goes through the index
        a = rng.uniform(0.0, 10.0, (3000, 2 * n))
        b = a + rng.normal(0.0, rng.choice([0.05, 0.5, 3.0]), a.shape)
        assert np.array_equal(index.motions_ok(a, b), full.motions_ok(a, b))
        states = [index.state_ok(x) for x in a[:1000]]
        assert states == [full.state_ok(x) for x in a[:1000]]
        checked += int(np.sum(states))
        # Thresholds on the verdict's edge: robot 0's requirement equal to its exact clearance
        # (the full loop's value) along the edge, then a hair above it.
        for x, y in zip(a[:200], b[:200]):
            exact = segment_clearance_one(x[0], x[1], y[0], y[1], plain.obstacle_array, plain.bounds_array,
                                          plain.piece_array)
            for need in (exact + TOL, np.nextafter(exact + TOL, np.inf)):
                clear = np.array([need] + [0.0] * (n - 1))
                one = CompiledRules.of(mapped, clear, dirs, np.zeros_like(sep))
                other = CompiledRules.of(plain, clear, dirs, np.zeros_like(sep))
                assert one.motion_ok(x, y) == other.motion_ok(x, y)
                assert one.state_ok(x) == other.state_ok(x)
    assert checked > 0  # some valid states among them, not only refusals
