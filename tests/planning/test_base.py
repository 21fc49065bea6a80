"""The planner interface (base.py) against hand computations."""

import numpy as np
import pytest

from nodnav.planning.base import (
    JointTrajectory,
    PlanRequest,
    PlanResult,
    corridor_entry_order,
    crossing_directions,
    feasible_order,
)
from nodnav.scenario.world import paper_world


@pytest.fixture
def world():
    return paper_world()


@pytest.fixture
def traj():
    # Robot 0: (0,0) -> (1,0) -> (1,2); robot 1 stands at (5,5) throughout. Samples at 0, 1, 2 s.
    pos = np.array([[[0.0, 0.0], [5.0, 5.0]],
                    [[1.0, 0.0], [5.0, 5.0]],
                    [[1.0, 2.0], [5.0, 5.0]]])
    return JointTrajectory.from_positions(np.array([0.0, 1.0, 2.0]), pos)


def test_positions_at_interpolates_linearly(traj):
    # Halfway along the first leg and the second leg, by hand.
    assert traj.positions_at(0.5)[0].tolist() == [0.5, 0.0]
    assert traj.positions_at(1.5)[0].tolist() == [1.0, 1.0]
    assert traj.positions_at(1.25)[0] == pytest.approx([1.0, 0.5])
    # Exactly on samples.
    assert traj.positions_at(1.0)[0].tolist() == [1.0, 0.0]
    assert traj.positions_at(2.0)[0].tolist() == [1.0, 2.0]
    # The standing robot never moves.
    assert traj.positions_at(1.7)[1].tolist() == [5.0, 5.0]


def test_positions_are_held_outside_the_time_span(traj):
    assert traj.positions_at(-3.0)[0].tolist() == [0.0, 0.0]
    assert traj.positions_at(10.0)[0].tolist() == [1.0, 2.0]


def test_positions_at_keeps_the_shape_of_t(traj):
    assert traj.positions_at(0.3).shape == (2, 2)
    assert traj.positions_at(np.array([0.1, 0.2, 0.3])).shape == (3, 2, 2)
    assert traj.positions_at(np.zeros((4, 5))).shape == (4, 5, 2, 2)


def test_velocities_are_forward_differences(traj):
    # First leg: 1 m in x in 1 s; second leg: 2 m in y in 1 s; zero at and after the end.
    assert traj.velocities[0, 0].tolist() == [1.0, 0.0]
    assert traj.velocities[1, 0].tolist() == [0.0, 2.0]
    assert traj.velocities[2, 0].tolist() == [0.0, 0.0]
    assert traj.velocities_at(0.5)[0].tolist() == [1.0, 0.0]
    assert traj.velocities_at(1.5)[0].tolist() == [0.0, 2.0]
    assert traj.velocities_at(2.0)[0].tolist() == [0.0, 0.0]
    assert traj.velocities_at(7.0)[0].tolist() == [0.0, 0.0]


def test_from_positions_with_uneven_steps():
    pos = np.array([[[0.0, 0.0]], [[1.0, 0.0]], [[1.0, 3.0]]])
    t = JointTrajectory.from_positions(np.array([0.0, 0.5, 2.0]), pos)
    # 1 m in 0.5 s, then 3 m in 1.5 s.
    assert t.velocities[:, 0].tolist() == [[2.0, 0.0], [0.0, 2.0], [0.0, 0.0]]


def test_duration_count_subset_and_hold(traj):
    assert traj.duration == 2.0
    assert traj.n_robots == 2
    sub = traj.subset([1])
    assert sub.n_robots == 1 and sub.positions[:, 0].tolist() == [[5.0, 5.0]] * 3
    hold = JointTrajectory.hold(3.0, np.array([[1.0, 2.0], [3.0, 4.0]]))
    assert hold.times.tolist() == [3.0] and hold.duration == 0.0
    assert hold.positions_at(100.0).tolist() == [[1.0, 2.0], [3.0, 4.0]]
    assert hold.velocities_at(3.0).tolist() == [[0.0, 0.0], [0.0, 0.0]]


def test_feasible_order_keeps_history_first():
    assert feasible_order((2, 0, 1), ()) == (2, 0, 1)
    # Robot 1 has entered: it leads, the others keep their requested relative order.
    assert feasible_order((2, 0, 1), (1,)) == (1, 2, 0)
    # Two robots have entered, 2 before 0.
    assert feasible_order((0, 1, 2), (2, 0)) == (2, 0, 1)
    # An order that agrees with history is unchanged.
    assert feasible_order((1, 0, 2), (1,)) == (1, 0, 2)


def _feasible_order_as_it_was(order, entered, directions=None):
    """feasible_order before its directions' queues became counters (the reference)."""
    if not len(entered):
        return tuple(int(k) for k in order)
    done = tuple(int(k) for k in entered)
    rest = tuple(int(k) for k in order if int(k) not in done)
    if directions is None:
        return done + rest
    dirs = np.asarray(directions).tolist()
    crossed = tuple(k for k in done if dirs[k] == 0)
    queues = {d: [k for k in done if dirs[k] == d] for d in (1, -1)}
    requested = [int(k) for k in order if int(k) in done and dirs[int(k)] != 0]
    requested += [k for k in done if dirs[k] != 0 and k not in requested]
    inside = tuple(queues[int(dirs[k])].pop(0) for k in requested)
    return crossed + inside + rest


def test_feasible_order_matches_the_queues_it_replaced():
    rng = np.random.default_rng(4)
    for _ in range(2000):
        n = int(rng.integers(1, 7))
        order = tuple(int(k) for k in rng.permutation(n))
        entered = tuple(int(k) for k in rng.permutation(n)[:rng.integers(0, n + 1)])
        dirs = rng.integers(-1, 2, size=n)
        expected = _feasible_order_as_it_was(order, entered, dirs)
        assert feasible_order(order, entered, dirs) == expected
        assert feasible_order(order, entered, dirs.tolist()) == expected  # a list, as the planner passes
        assert feasible_order(np.array(order), entered, None) == _feasible_order_as_it_was(order, entered)


def test_crossing_directions(world):
    start = np.array([[-5.0, 0.0], [5.0, 1.0], [-5.0, 1.0], [0.0, 0.0], [1.0, 0.0], [0.5, 0.0], [5.0, 0.0]])
    goal = np.array([[5.0, 0.0], [-5.0, 1.0], [-6.0, -1.0], [6.0, 0.0], [-6.0, 0.0], [1.5, 0.0], [6.0, 1.0]])
    # left->right, right->left, left->left, inside->right, inside->left, inside->inside, right->right
    assert crossing_directions(world, start, goal).tolist() == [1, -1, 0, 1, -1, 0, 0]


def test_corridor_entry_order(world):
    # Robot 0 enters at sample 2, robot 1 at sample 1, robot 2 never.
    x = np.array([[-4.0, -3.5, -2.5],
                  [4.0, 2.5, 2.0],
                  [-5.0, -5.0, -5.0]])
    pos = np.stack([x.T, np.zeros_like(x.T)], axis=-1)
    t = JointTrajectory.from_positions(np.arange(3.0), pos)
    assert corridor_entry_order(world, t) == (1, 0)


def test_corridor_entry_order_ties_and_robots_already_inside(world):
    # Robot 2 is inside at the first sample; robots 0 and 1 both enter at sample 1 (tie: index).
    x = np.array([[-3.5, -2.9],
                  [3.5, 2.9],
                  [0.0, 0.5]])
    pos = np.stack([x.T, np.zeros_like(x.T)], axis=-1)
    t = JointTrajectory.from_positions(np.arange(2.0), pos)
    assert corridor_entry_order(world, t) == (2, 0, 1)


def test_failure_holds_and_repairs_the_order(world):
    pos = np.array([[-5.0, 0.0], [5.0, 0.0], [0.0, 0.0]])
    req = PlanRequest(world, pos, np.zeros_like(pos), -pos, np.full(3, 0.2), np.ones(3), (0, 1, 2),
                      entered=(2,), t0=4.0)
    res = PlanResult.failure(req, "because")
    assert not res.success and res.reason == "because" and res.cost == float("inf")
    assert res.order_planned == (2, 0, 1) and res.repaired
    assert res.trajectory.times.tolist() == [4.0]
    assert res.trajectory.positions_at(9.0).tolist() == pos.tolist()


def test_relabel_permutes_robots_and_orders():
    from nodnav.planning.base import PlanResult, relabel

    times = np.array([0.0, 1.0])
    pos = np.array([[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], [[0.0, 1.0], [1.0, 1.0], [2.0, 1.0]]])
    res = PlanResult(True, "", 3.0, JointTrajectory.from_positions(times, pos), (2, 0, 1), (2, 0, 1))
    out = relabel(res, [1, 2, 0])  # new robot 0 is old robot 1, new 1 is old 2, new 2 is old 0
    assert np.array_equal(out.trajectory.positions[:, 0], pos[:, 1])
    assert np.array_equal(out.trajectory.positions[:, 2], pos[:, 0])
    # Old order (2, 0, 1) -> new labels (1, 2, 0).
    assert out.order == (1, 2, 0) and out.order_planned == (1, 2, 0) and out.cost == 3.0
    # The planner's info stays in the query's numbering and says who is who, also when relabelled again.
    assert out.info["query_robots"] == (1, 2, 0)
    assert relabel(out, [2, 0, 1]).info["query_robots"] == (0, 1, 2)
