"""The PRM* planner: timing, the paper's cost, order, relabelling and failures, on tiny roadmaps."""

import itertools

import numpy as np
import pytest

from nodnav.planning import make_planner
from nodnav.planning.base import PlanRequest, corridor_entry_order, crossing_directions, feasible_order
from nodnav.planning.prm import PRMStarPlanner, path_cost, timed_trajectory
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import PRMParams
from nodnav.scenario.world import paper_world

R = 0.2
W1, VARSIGMA = 0.4, 0.1


@pytest.fixture(scope="module")
def planner(tmp_path_factory):
    params = PRMParams(name="prm", roadmap_vertices=300, cache_dir=str(tmp_path_factory.mktemp("roadmaps")))
    p = make_planner(params, paper_world())
    assert isinstance(p, PRMStarPlanner) and p.name == "prm"
    return p


def request(world, positions, destinations, order, entered=(), t0=0.0):
    p = np.asarray(positions, dtype=float)
    n = len(p)
    return PlanRequest(world, p, np.zeros_like(p), np.asarray(destinations, dtype=float), np.full(n, R),
                       np.ones(n), tuple(order), tuple(entered), t0)


def scenario_request(name, order):
    sc = load_scenario(name)
    return PlanRequest(sc.world, sc.origins, np.zeros_like(sc.origins), sc.destinations, sc.radii, sc.max_speeds,
                       tuple(order))


def hand_cost(path, radii):
    """The appendix's cost written out: joint length plus w1 times Phi at every vertex."""
    x = path.reshape(len(path), -1)
    total = sum(np.sqrt(np.sum((x[i + 1] - x[i]) ** 2)) for i in range(len(x) - 1))
    for config in path:
        for a, b in itertools.combinations(range(len(config)), 2):
            d = np.sqrt(np.sum((config[a] - config[b]) ** 2))
            total += W1 / max(d - radii[a] - radii[b], VARSIGMA)
    return total


# ---------------------------------------------------------------------------------------------
# Pure functions


def test_timed_trajectory_hand_values():
    # One robot: 0.25 m then 0.75 m at 1 m/s, dt 0.1 -> 3 and 8 whole steps.
    path = np.array([[[0.0, 0.0]], [[0.25, 0.0]], [[0.25, 0.0]], [[0.25, 0.75]]])  # with a repeated vertex
    tr = timed_trajectory(path, np.array([1.0]), 0.1, t0=2.0)
    assert np.allclose(tr.times, 2.0 + 0.1 * np.arange(12))
    assert np.allclose(tr.positions[3, 0], [0.25, 0.0]) and np.allclose(tr.positions[-1, 0], [0.25, 0.75])
    assert np.allclose(tr.positions[1, 0], [0.25 / 3, 0.0])
    assert np.allclose(np.linalg.norm(tr.velocities[:3, 0], axis=1), 0.25 / 0.3)
    assert np.allclose(np.linalg.norm(tr.velocities[3:11, 0], axis=1), 0.75 / 0.8)
    # Two robots: A moves 0.3 m at 1 m/s (0.3 s), B 0.5 m at 2 m/s (0.25 s): the segment lasts 0.3 s.
    path = np.array([[[0.0, 0.0], [0.0, 1.0]], [[0.3, 0.0], [0.5, 1.0]]])
    tr = timed_trajectory(path, np.array([1.0, 2.0]), 0.1)
    assert len(tr.times) == 4
    assert np.allclose(tr.velocities[0], [[1.0, 0.0], [0.5 / 0.3, 0.0]])


def test_path_cost_hand_values():
    # Two robots 1 m apart step 1 m up together: length sqrt(2), Phi = 1 / (1 - 0.4) at both ends.
    path = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 1.0, 1.0]])
    assert path_cost(path, [R, R], W1, VARSIGMA) == pytest.approx(np.sqrt(2) + W1 * 2 / 0.6)
    # Robots 0.45 m apart: the gap 0.05 is below varsigma, so Phi = 1 / 0.1.
    assert path_cost(np.array([[0.0, 0.0, 0.45, 0.0]]), [R, R], W1, VARSIGMA) == pytest.approx(W1 / 0.1)


# ---------------------------------------------------------------------------------------------
# Plans


def check_plan(res, req, fine=5):
    """Independent checks of a successful plan."""
    world, tr = req.world, res.trajectory
    assert res.success, res.reason
    assert res.order_planned == feasible_order(req.order, req.entered)
    assert np.allclose(tr.positions[0], req.positions) and np.allclose(tr.positions[-1], req.destinations)
    assert np.allclose(np.diff(tr.times), 0.1)
    speed = np.linalg.norm(np.diff(tr.positions, axis=0), axis=2) / 0.1
    assert np.all(speed <= req.max_speeds + 1e-9)
    t = np.linspace(tr.times[0], tr.times[-1], fine * (len(tr.times) - 1) + 1)
    p = tr.positions_at(t)
    for a, b in itertools.combinations(range(len(req.radii)), 2):
        assert np.linalg.norm(p[:, a] - p[:, b], axis=1).min() >= 2 * R - 1e-9
    assert np.all(world.clearance(p) >= R - 1e-9)
    dirs = crossing_directions(world, req.positions, req.destinations)
    crossing = [k for k in res.order_planned if dirs[k] != 0]
    assert [k for k in corridor_entry_order(world, tr) if dirs[k] != 0] == crossing
    inside = world.in_corridor(tr.positions)
    for a, b in zip(crossing, crossing[1:]):
        if dirs[a] != dirs[b]:
            assert np.nonzero(inside[:, b])[0][0] > np.nonzero(inside[:, a])[0][-1]


@pytest.mark.parametrize("name", ["2r-case2", "3r-case4"])
def test_every_order_is_planned_and_respected(planner, name):
    n = load_scenario(name).n_robots
    for order in itertools.permutations(range(n)):
        req = scenario_request(name, order)
        res = planner.plan(req)
        check_plan(res, req)
        assert res.order == tuple(order) and not res.repaired and res.reason == ""


def test_cost_is_the_papers_cost_of_the_returned_path(planner):
    req = scenario_request("3r-case3", (1, 0, 2))
    res = planner.plan(req)
    path = res.info["path"]
    assert not res.info["direct"] and len(path) >= 3
    assert res.cost == pytest.approx(hand_cost(path, req.radii), rel=1e-12)
    # Every path vertex is a sample of the trajectory (so the checked path is what is followed).
    for config in path:
        assert np.min(np.abs(res.trajectory.positions - config).max(axis=(1, 2))) < 1e-9
    # Shortcuts only ever lower the cost of the roadmap path.
    assert res.info["roadmap_cost"] >= res.cost - 1e-9


def test_relabelling_robots_gives_the_same_plan(planner):
    sc = load_scenario("3r-case4")
    order = (2, 0, 1)
    perm = np.array([1, 2, 0])  # new robot i is old robot perm[i]
    inv = np.argsort(perm)
    base = planner.plan(scenario_request("3r-case4", order))
    req = PlanRequest(sc.world, sc.origins[perm], np.zeros((3, 2)), sc.destinations[perm], sc.radii[perm],
                      sc.max_speeds[perm], tuple(int(inv[k]) for k in order))
    moved = planner.plan(req)
    assert base.success and moved.success
    assert moved.cost == pytest.approx(base.cost, rel=1e-12)
    assert np.allclose(moved.trajectory.positions, base.trajectory.positions[:, perm])
    assert moved.info["pattern"] == base.info["pattern"]


def test_entered_robot_keeps_its_place(planner):
    world = paper_world()
    # Robot 2 is in the corridor heading left: it goes first whatever was asked.
    req = request(world, [[-5.0, 1.0], [5.0, -1.0], [1.0, 0.0]], [[5.5, 1.0], [-5.5, -1.0], [-5.5, 1.5]],
                  order=(0, 1, 2), entered=(2,), t0=12.0)
    res = planner.plan(req)
    assert res.order_planned == (2, 0, 1) and res.repaired and "ruled out" in res.reason
    assert res.trajectory.times[0] == 12.0
    check_plan(res, req)


def test_replanning_midway_continues_the_plan(planner):
    req = scenario_request("2r-case1", (1, 0))
    first = planner.plan(req)
    tr = first.trajectory
    for k in (len(tr.times) // 3, 2 * len(tr.times) // 3):
        inside = req.world.in_corridor(tr.positions[: k + 1])
        entered = tuple(int(i) for i in np.argsort(np.where(inside.any(0), inside.argmax(0), 10**9), kind="stable")
                        if inside[:, i].any())
        again = PlanRequest(req.world, tr.positions[k], np.zeros((2, 2)), req.destinations, req.radii,
                            req.max_speeds, (1, 0), entered, tr.times[k])
        check_plan(planner.plan(again), again)


def test_single_robot_goes_straight_or_around(planner):
    world = paper_world()
    res = planner.plan(request(world, [[-5.5, 0.0]], [[5.5, 0.0]], order=(0,)))
    assert res.success and res.info["direct"]
    assert res.trajectory.duration == pytest.approx(11.0)  # 11 m at 1 m/s, a whole number of steps
    # Diagonal across: the straight line hits the walls, so the one-robot roadmap is used.
    req = request(world, [[-5.0, 2.0]], [[5.0, -2.0]], order=(0,))
    res = planner.plan(req)
    check_plan(res, req)
    assert not res.info["direct"] and res.info["pattern"] == "+"
    # Never shorter than the straight line; the path length of the plan is what it lasts at 1 m/s.
    length = np.sum(np.linalg.norm(np.diff(res.info["path"][:, 0], axis=0), axis=1))
    assert length > np.hypot(10.0, 4.0)
    assert length <= res.trajectory.duration <= length + 0.1 * (len(res.info["path"]) - 1) + 1e-9


def test_start_within_the_margin_is_accepted(planner):
    world = paper_world()
    # Two robots 0.42 m apart (less than 2 r + margin = 0.45) queue on the left.
    req = request(world, [[-4.0, 0.0], [-4.42, 0.0]], [[5.0, 0.0], [5.0, 1.5]], order=(0, 1))
    res = planner.plan(req)
    check_plan(res, req)
    p = res.trajectory.positions_at(np.linspace(0, res.trajectory.duration, 2000))
    assert np.linalg.norm(p[:, 0] - p[:, 1], axis=1).min() >= 0.42 - 1e-9


@pytest.mark.parametrize("positions, destinations, order, entered, words", [
    ([[-5.0, 1.0], [5.0, 0.0]], [[5.0, 1.0], [-5.0, 0.0]], (0, 0), (), "permutation"),
    ([[-5.0, 1.0], [5.0, 0.0]], [[-3.1, 0.5], [-5.0, 0.0]], (0, 1), (), "wall"),
    ([[-5.0, 1.0], [-5.2, 1.0]], [[5.0, 1.0], [5.0, -1.0]], (0, 1), (), "overlapping"),
    # Robot 1 is inside the corridor but was not reported as entered: the order cannot hold.
    ([[-5.0, 1.0], [0.0, 0.0]], [[5.0, 1.0], [-5.0, 0.0]], (0, 1), (), "violates the passing order"),
])
def test_bad_requests_fail_cleanly(planner, positions, destinations, order, entered, words):
    req = request(paper_world(), positions, destinations, order, entered, t0=3.0)
    res = planner.plan(req)
    assert not res.success and words in res.reason
    assert res.cost == float("inf") and res.trajectory.times.tolist() == [3.0]
    assert np.array_equal(res.trajectory.positions[0], req.positions)


def test_one_roadmap_serves_every_order_of_a_pattern(planner):
    # 3r-case1: three robots cross rightwards; whatever the order, by rank the directions are
    # (+1, +1, +1), so all six orders share one roadmap.
    fresh = PRMStarPlanner(planner.world, planner.params)
    for order in itertools.permutations(range(3)):
        assert fresh.plan(scenario_request("3r-case1", order)).success
    assert [(r.n_robots, r.pattern) for r in fresh.roadmap_reports()] == [(3, "+++")]


def test_accelerated_trajectory_with_a_segment_too_short_to_resolve():
    # Issue 20: a 1e-13 m segment (a start next to a roadmap vertex) gave a profile without a
    # step, and indexing its last fraction raised IndexError. It now takes one step to its end.
    from nodnav.planning.prm import accelerated_trajectory

    path = np.array([[[0.0, 0.0], [5.0, 5.0]], [[1e-13, 0.0], [5.0, 5.0]], [[2.0, 0.0], [5.0, 5.0]]])
    dt, vmax, amax = 0.1, np.ones(2), np.ones(2)
    traj = accelerated_trajectory(path, vmax, amax, dt, 1.0)
    assert np.array_equal(traj.positions[0], path[0]) and np.array_equal(traj.positions[-1], path[-1])
    assert np.allclose(np.diff(traj.times), dt) and traj.times[0] == 1.0
    speed = np.linalg.norm(np.diff(traj.positions, axis=0), axis=-1) / dt
    assert speed.max() <= 1.0 + 1e-9
    # The 2 m segment from rest to rest at 1 m/s^2 and 1 m/s: at least 2 / 1 + 1 / 1 = 3 s (trapezoid).
    assert traj.duration >= 3.0 - 1e-9


def test_a_joint_path_without_points_is_a_failed_plan(planner, monkeypatch):
    # Issue 20: a plan with no points must be a failed result with a reason, never an exception.
    from nodnav.planning.prm import SearchResult

    req = request(paper_world(), [[-5.0, 1.0], [5.0, 0.0]], [[5.0, 1.0], [-5.0, 0.0]], (0, 1), t0=2.0)
    monkeypatch.setattr(planner, "_search", lambda *args: SearchResult(True, "", np.zeros((0, 4)), {}))
    res = planner.plan(req)
    assert not res.success and "no points" in res.reason
    assert res.trajectory.times.tolist() == [2.0] and np.array_equal(res.trajectory.positions[0], req.positions)
