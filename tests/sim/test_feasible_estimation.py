"""Eq. (4) compares observed motion with motion the robots can perform (issue 18, item 2).

The agent asks the planner with every robot's acceleration limit, and the states eq. (4) reads
of last period's plans (:meth:`PlanCache.states_at`) start from rest no faster than a robot
accelerating at its limit can: after ``n`` steps of ``dt`` at most ``a dt^2 n (n + 1) / 2`` from
where it stood (the discrete-time bound of ``a t^2 / 2``, speed constant within a step).
"""

import numpy as np
import pytest

from nodnav.planning import make_planner
from nodnav.scenario.loading import load_scenario
from nodnav.sim.agent import NODAgent, RobotView
from nodnav.sim.plan_cache import PlanCache

ACCEL = 0.3  # m/s^2, both robots


class Recording:
    """The scenario's planner, remembering every request."""

    def __init__(self, planner):
        self.planner = planner
        self.requests = []

    def plan(self, request):
        self.requests.append(request)
        return self.planner.plan(request)


def farthest_excess(timing: str) -> float:
    """How far (m) the plans eq. (4) would read next period run ahead of the acceleration bound."""
    scenario = load_scenario("2r-case1").with_overrides(**{"robots[0].max_accel": ACCEL,
                                                           "robots[1].max_accel": ACCEL,
                                                           "planner.timing": timing})
    planner = Recording(make_planner(scenario.planner, scenario.world))
    agent = NODAgent(scenario, 0, np.random.default_rng(1), PlanCache(planner))
    times = np.array([0.0])
    states = np.zeros((2, 1, 4))
    states[:, 0, :2] = scenario.origins
    agent.decide(RobotView(t=0.0, window_times=times, window_states=states, entered=()))
    assert planner.requests and all(np.array_equal(r.max_accels, [ACCEL, ACCEL]) for r in planner.requests)
    _, _, _, plans = agent.previous
    window = np.round(np.arange(0.0, 3.0 + 1e-9, 0.1), 12)  # the next windows, on the control step
    n = np.round(window / 0.1)
    bound = ACCEL * 0.1**2 * n * (n + 1) / 2
    excess = 0.0
    for plan in plans:
        assert plan.success
        read = agent.plans.states_at(plan, window)  # (robots, M, 4), what eq. (4) compares with
        moved = np.linalg.norm(read[:, :, :2] - scenario.origins[:, None], axis=2)
        excess = max(excess, float((moved - bound[None]).max()))
    return excess


def test_eq4_reads_plans_a_slow_robot_can_follow():
    assert farthest_excess("feasible") <= 1e-9


def test_speed_only_plans_run_ahead_of_what_the_robot_can_do():
    # The old timing starts at full speed at once: the comparison above has teeth.
    assert farthest_excess("speed-only") > 0.1


def test_plan_cache_tells_requests_with_other_accelerations_apart():
    scenario = load_scenario("2r-case1")
    planner = Recording(make_planner(scenario.planner, scenario.world))
    cache = PlanCache(planner)
    view = RobotView(t=0.0, window_times=np.array([0.0]),
                     window_states=np.concatenate([scenario.origins[:, None], np.zeros((2, 1, 2))], axis=2),
                     entered=())
    from nodnav.sim.agent_queries import joint_requests
    request = joint_requests(scenario, view, (0, 1), [(0, 1)])[0]
    slow = joint_requests(scenario.with_overrides(**{"robots[1].max_accel": 0.2}), view, (0, 1), [(0, 1)])[0]
    assert slow.max_accels == pytest.approx([2.0, 0.2])
    first, second = cache.plan(request), cache.plan(slow)
    assert len(planner.requests) == 2 and first.trajectory.duration < second.trajectory.duration
