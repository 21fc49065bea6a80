"""The plan cache's kept plans built once per trajectory (sim/plan_cache.py): orders a planner
repaired to one shared its trajectory and arrival times, and their kept plans share them again.

Each kept answer is checked against the plain reference, :func:`kept_plan` of the round before's
plan and the request in its own order, field by field; the test and the tail are made once per
trajectory, and no request in an order is built for an order that is kept. A stub planner gives
every order the same hand-made plan (robot 0 drives 2 m along x at 1 m/s in 0.1 s steps, robot 1
stands), as the fast planner gives orders repaired to the same one."""

from dataclasses import replace

import numpy as np
import pytest

import nodnav.sim.plan_cache as plan_cache_module
from nodnav import load_scenario
from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult, relabel
from nodnav.sim.plan_cache import PlanCache, arrivals, kept_plan, kept_steps, plan_tail, state_key

DT, TOL, ACCEL = 0.1, 0.05, 2.0
WORLD = load_scenario("2r-case1").world
ORDERS = [(0, 1), (1, 0)]


class SharingStub:
    """One joint plan per state, shared by every order asked of it (a repairing planner's)."""

    name = "sharing stub"

    def __init__(self):
        self.calls = 0
        self._joint: dict = {}

    def plan(self, request: PlanRequest) -> PlanResult:
        self.calls += 1
        key = (request.t0, request.positions.tobytes())
        if key not in self._joint:
            steps = np.arange(21)
            positions = np.repeat(request.positions[None].astype(float), 21, axis=0)
            positions[:, 0, 0] += DT * steps
            trajectory = JointTrajectory.from_positions(request.t0 + DT * steps, positions)
            for a in (trajectory.times, trajectory.positions, trajectory.velocities):
                a.setflags(write=False)
            self._joint[key] = (trajectory, np.array([2.0, 0.0]))
        trajectory, arrival = self._joint[key]
        return PlanResult(True, f"planned as {ORDERS[0]}", 2.0, trajectory, tuple(request.order), ORDERS[0],
                          info={"arrival_times": arrival})


def request(t0: float, x0: float, order=(0, 1)) -> PlanRequest:
    return PlanRequest(world=WORLD, positions=np.array([[x0, 0.0], [3.0, 2.0]]),
                       velocities=np.array([[1.0, 0.0], [0.0, 0.0]]), destinations=np.array([(2.0, 0.0), (3.0, 2.0)]),
                       radii=np.full(2, 0.3), max_speeds=np.ones(2), order=order, t0=t0,
                       max_accels=np.full(2, ACCEL))


def same_result(a: PlanResult, b: PlanResult) -> bool:
    """Every field equal, arrays bit for bit (the info's arrays too)."""
    ta, tb = a.trajectory, b.trajectory
    arrays = all(np.array_equal(getattr(ta, f), getattr(tb, f)) for f in ("times", "positions", "velocities"))
    info = a.info.keys() == b.info.keys() and all(np.array_equal(a.info[k], b.info[k]) for k in a.info)
    return (arrays and info and (a.success, a.reason, a.cost, a.order, a.order_planned, a.compute_time)
            == (b.success, b.reason, b.cost, b.order, b.order_planned, b.compute_time))


def test_kept_plans_of_orders_sharing_a_trajectory_share_its_tail_and_are_each_kept_plans(monkeypatch):
    planner = SharingStub()
    cache = PlanCache(planner, TOL, DT)
    first = request(0.0, 0.0)
    old = cache.plan_orders(first, ORDERS, state_key(first))
    assert planner.calls == 2 and old[0].trajectory is old[1].trajectory
    cache.clear()
    second = request(1.0, 1.02)  # 0.02 m ahead of the plan at 1 s
    built = []
    original = plan_cache_module._in_order
    monkeypatch.setattr(plan_cache_module, "_in_order", lambda t, o: built.append(o) or original(t, o))
    kept = cache.plan_orders(second, ORDERS, state_key(second))
    assert planner.calls == 2 and cache.reused == 2 and not built  # no request built for a kept order
    assert kept[0].trajectory is kept[1].trajectory
    assert kept[0].info["arrival_times"] is kept[1].info["arrival_times"]
    for order, last, result in zip(ORDERS, old, kept):
        reference = kept_plan(last, replace(second, order=order), TOL, DT)
        assert reference is not None and same_result(result, reference) and result.order == order
    assert not kept[0].trajectory.times.flags.writeable and not kept[0].info["arrival_times"].flags.writeable
    # The round after, the shared tail is tested and carried on once more, still shared.
    cache.clear()
    third = request(1.5, 1.5)
    again = cache.plan_orders(third, ORDERS, state_key(third))
    assert planner.calls == 2 and cache.reused == 4 and again[0].trajectory is again[1].trajectory
    assert same_result(again[1], kept_plan(kept[1], replace(third, order=(1, 0)), TOL, DT))


def test_an_order_off_its_plan_is_planned_anew_in_its_own_order():
    planner = SharingStub()
    cache = PlanCache(planner, TOL, DT)
    first = request(0.0, 0.0)
    cache.plan_orders(first, ORDERS, state_key(first))
    cache.clear()
    second = request(1.0, 1.08)  # 0.08 m off
    fresh = cache.plan_orders(second, ORDERS, state_key(second))
    assert planner.calls == 4 and cache.reused == 0 and [r.order for r in fresh] == ORDERS


@pytest.mark.parametrize("x0, t0, expected", [(1.02, 1.0, 10), (1.06, 1.0, 0), (1.05, 1.05, 0), (0.0, 0.0, 0)])
def test_kept_steps_are_the_steps_on_a_plan_kept(x0, t0, expected):
    last = SharingStub().plan(request(0.0, 0.0))
    now = request(t0, x0)
    steps = kept_steps(last, now.t0, now.positions, now.velocities, now.max_accels, TOL, DT)
    assert steps == expected and (kept_plan(last, now, TOL, DT) is None) == (expected == 0)


def test_the_tail_without_arrival_times_keeps_the_cost_and_with_none_has_none_left():
    trajectory = JointTrajectory.from_positions(np.arange(5) * DT, np.zeros((5, 1, 2)))
    without = PlanResult(True, "", 7.0, trajectory, (0,), (0,), info={})
    tail = plan_tail(without, 2, 0.2, DT)
    assert arrivals(without.info) is None and tail.cost == 7.0 and "arrival_times" not in tail.info
    assert tail.info["kept_from"] == 0.0 and tail.trajectory.times.tolist() == pytest.approx([0.2, 0.3, 0.4])
    none = PlanResult(True, "", 7.0, trajectory, (0,), (0,), info={"arrival_times": None})
    tail = plan_tail(none, 2, 0.2, DT)
    assert tail.cost == 0.0 and tail.info["arrival_times"].shape == (0,)


def test_relabel_is_dataclasses_replace_of_its_fields():
    trajectory = JointTrajectory.from_positions(np.arange(4) * DT, np.random.default_rng(1).normal(size=(4, 3, 2)))
    result = PlanResult(True, "note", 3.0, trajectory, (2, 0, 1), (0, 2, 1), 0.5, {"arrival_times": np.ones(3)})
    robots = [1, 2, 0]
    out = relabel(result, robots)
    reference = replace(result, trajectory=trajectory.subset(robots), order=(1, 2, 0), order_planned=(2, 1, 0),
                        info={**result.info, "query_robots": (1, 2, 0)})
    assert type(out) is PlanResult and same_result(out, reference) and out == out
