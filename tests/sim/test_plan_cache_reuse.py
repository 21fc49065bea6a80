"""The plan cache keeping a query's plan of the round before (``planner.reuse_tolerance``).

A stub planner with a hand-made plan (robot 0 drives 2 m along x at 1 m/s in 0.1 s steps, robot
1 stands) gives the expected tail by hand: sample 10 of the old plan at the new time, arrival
times 1 s shorter. The tolerance test is checked on each side of its edge in position and in
velocity (|dv|^2 / 2a), and every way the key or the plan can rule a plan out. With the setting
at 0 every round asks the planner, as before."""


import numpy as np
import pytest

from nodnav import load_scenario
from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult
from nodnav.planning.prioritized import PrioritizedPlanner
from nodnav.scenario.params import FastPlannerParams, plan_reuse
from nodnav.sim.plan_cache import (
    PlanCache,
    on_plan,
    plan_offsets_plain,
    state_key,
    tail_arrays,
    trajectory_states,
    within_plan,
)

DT, TOL, ACCEL = 0.1, 0.05, 2.0
WORLD = load_scenario("2r-case1").world


class StubPlanner:
    """Robot 0 drives 2 m along +x at 1 m/s from where it is; robot 1 stands; counts its calls.
    ``fail``: every plan fails."""

    name = "stub"

    def __init__(self, tolerance: float = TOL, fail: bool = False):
        self.tolerance = tolerance
        self.calls = 0
        self.fail = fail

    def plan(self, request: PlanRequest) -> PlanResult:
        self.calls += 1
        if self.fail:
            return PlanResult.failure(request, "no way")
        steps = np.arange(21)
        positions = np.repeat(request.positions[None].astype(float), 21, axis=0)
        positions[:, 0, 0] += DT * steps  # 1 m/s for 2 s
        trajectory = JointTrajectory.from_positions(request.t0 + DT * steps, positions)
        arrival = np.array([2.0, 0.0])
        return PlanResult(True, "", 2.0, trajectory, tuple(request.order), tuple(request.order),
                          info={"arrival_times": arrival})


def request(t0: float, p0=(0.0, 0.0), v0=(1.0, 0.0), p1=(3.0, 2.0), entered=(), destination1=(3.0, 2.0),
            order=(0, 1)) -> PlanRequest:
    return PlanRequest(world=WORLD, positions=np.array([p0, p1], dtype=float),
                       velocities=np.array([v0, (0.0, 0.0)], dtype=float),
                       destinations=np.array([(2.0, 0.0), destination1]), radii=np.full(2, 0.3),
                       max_speeds=np.ones(2), order=order, entered=entered, t0=t0, max_accels=np.full(2, ACCEL))


def on_it(t0: float = 1.0, **changes) -> PlanRequest:
    """A request at ``t0`` with robot 0 where the stub's plan has it then, but for ``changes``."""
    return request(t0, **{"p0": (t0, 0.0), **changes})


def two_rounds(second: PlanRequest, planner: StubPlanner | None = None) -> tuple[StubPlanner, PlanCache, PlanResult]:
    """The first round plans ``request(0)``; the second asks ``second`` through ``plan_orders``."""
    planner = planner or StubPlanner()
    cache = PlanCache(planner, planner.tolerance, DT)
    cache.plan(request(0.0))
    cache.clear()
    result = cache.plan_orders(second, [second.order], state_key(second))[0]
    return planner, cache, result


def test_a_plan_the_robots_follow_is_kept_and_carried_on_to_now():
    # One second on the plan has robot 0 at (1, 0) at 1 m/s; it is 0.03 m ahead.
    planner, cache, kept = two_rounds(on_it(p0=(1.03, 0.0)))
    assert planner.calls == 1 and cache.reused == 1 and cache.misses == 1
    times = kept.trajectory.times
    assert times[0] == 1.0 and len(times) == 11 and np.allclose(np.diff(times), DT)
    assert np.allclose(kept.trajectory.positions[0], [[1.0, 0.0], [3.0, 2.0]])
    assert np.allclose(kept.trajectory.positions[-1], [[2.0, 0.0], [3.0, 2.0]])
    assert np.allclose(kept.info["arrival_times"], [1.0, 0.0]) and kept.cost == pytest.approx(1.0)
    assert kept.info["kept_from"] == 0.0 and kept.success
    # Evaluated over the next window it is the old plan's motion at the same times.
    window = np.linspace(1.0, 2.0, 11)
    old = PlanCache(StubPlanner()).plan(request(0.0)).trajectory
    assert np.allclose(trajectory_states(kept.trajectory.times, kept.trajectory.positions,
                                         kept.trajectory.velocities, window),
                       trajectory_states(old.times, old.positions, old.velocities, window))
    # Asked again in the same round it is the same object (a hit).
    again = cache.plan(request(1.0, p0=(1.03, 0.0)))
    assert again is kept and cache.hits == 1


def test_a_kept_plan_is_kept_again_the_round_after():
    planner, cache, _ = two_rounds(on_it(p0=(1.01, 0.0)))
    cache.clear()
    third = cache.plan(request(2.0, p0=(2.0, 0.0), v0=(0.0, 0.0)))  # arrived: the plan holds it there
    assert planner.calls == 1 and cache.reused == 2
    assert third.trajectory.times.tolist() == [2.0] and np.allclose(third.trajectory.velocities, 0.0)
    assert np.allclose(third.info["arrival_times"], 0.0) and third.cost == 0.0


@pytest.mark.parametrize("second", [
    on_it(p0=(1.06, 0.0)),  # robot 0 0.06 m off its plan
    on_it(p1=(3.0, 2.06)),  # robot 1 (standing: a parked robot of the plan, say) moved 0.06 m
    on_it(v0=(1.0, 0.45)),  # 0.45 m/s off: 0.45^2 / 4 = 0.051 m beyond the plan
    on_it(p0=(1.02, 0.0), v0=(1.0, 0.4)),  # 0.02 + 0.04 m
    on_it(entered=(0,)),  # a robot entered the corridor: another key
    on_it(destination1=(3.0, 2.5)),  # another robot in the query: another key
    on_it(order=(1, 0)),  # another order
    on_it(1.05),  # not a whole number of the planner's steps on
])
def test_a_plan_the_robots_left_or_another_query_is_planned_anew(second):
    planner, cache, result = two_rounds(second)
    assert planner.calls == 2 and cache.reused == 0
    assert result.trajectory.times[0] == second.t0 and np.array_equal(result.trajectory.positions[0], second.positions)


def test_the_velocity_error_counts_as_the_distance_braking_it_away_takes():
    trajectory = StubPlanner().plan(request(0.0)).trajectory
    at = np.array([[1.0, 0.0], [3.0, 2.0]])
    accels = np.full(2, ACCEL)
    # 0.3 m/s off: 0.09 / 4 = 0.0225 m, plus 0.027 m off in position: 0.0495 m, within 0.05 m.
    assert on_plan(trajectory, 10, at + [[0.027, 0.0], [0.0, 0.0]], np.array([[1.0, 0.3], [0.0, 0.0]]), accels, TOL)
    assert not on_plan(trajectory, 10, at + [[0.028, 0.0], [0.0, 0.0]], np.array([[1.0, 0.3], [0.0, 0.0]]),
                       accels, TOL)
    # Without acceleration limits (the planner times by speed alone) the velocity is not read.
    assert on_plan(trajectory, 10, at, np.array([[5.0, 5.0], [0.0, 0.0]]), None, TOL)


def test_a_failed_plan_is_never_kept():
    planner, cache, result = two_rounds(request(0.1, p0=(0.0, 0.0), v0=(0.0, 0.0)), StubPlanner(fail=True))
    assert planner.calls == 2 and cache.reused == 0 and not result.success


def test_at_zero_every_round_is_planned_anew():
    planner, cache, result = two_rounds(on_it(), StubPlanner(tolerance=0.0))
    assert planner.calls == 2 and cache.reused == 0 and cache.reuse_tolerance == 0.0
    assert result.trajectory.times[0] == 1.0


def scenario_request(t0: float, positions: np.ndarray, velocities: np.ndarray) -> PlanRequest:
    s = load_scenario("2r-case1")
    return PlanRequest(world=s.world, positions=positions, velocities=velocities, destinations=s.destinations,
                       radii=s.radii, max_speeds=s.max_speeds, order=(0, 1), t0=t0,
                       max_accels=np.array([r.max_accel for r in s.robots]))


def test_the_fast_planner_s_plan_is_kept_where_the_robots_follow_it_and_equal_a_fresh_one_at_zero():
    s = load_scenario("2r-case1")
    first = scenario_request(0.0, s.origins, np.zeros((2, 2)))
    for tolerance, fresh in ((0.05, False), (0.0, True)):
        params = FastPlannerParams(reuse_tolerance=tolerance)
        cache = PlanCache(PrioritizedPlanner(s.world, params), *plan_reuse(params))
        old = cache.plan(first)
        cache.clear()
        on = old.trajectory
        state = trajectory_states(on.times, on.positions, on.velocities, np.array([1.0]))[:, 0]
        second = scenario_request(1.0, state[:, :2].copy(), state[:, 2:].copy())
        result = cache.plan(second)
        assert cache.reused == (0 if fresh else 1)
        if fresh:  # the planner's own answer, bit for bit
            direct = PrioritizedPlanner(s.world).plan(second)
            assert np.array_equal(result.trajectory.positions, direct.trajectory.positions)
            assert np.array_equal(result.trajectory.times, direct.trajectory.times) and result.cost == direct.cost
        else:
            assert result.trajectory.times[0] == 1.0
            assert np.array_equal(result.trajectory.positions, on.positions[10:])
            assert result.cost == pytest.approx(sum(max(a - 1.0, 0.0) for a in old.info["arrival_times"]))


def test_the_compiled_test_agrees_with_the_plain_offsets():
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(1, 6))
        positions, planned = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
        velocities, planned_v = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
        accels = rng.uniform(0.5, 3.0, n)
        tolerance = float(rng.uniform(0.0, 4.0))
        for braking, held in ((True, False), (True, True), (False, False)):
            reference = plan_offsets_plain(positions, velocities, accels if braking else None, planned,
                                           np.zeros((n, 2)) if held else planned_v)
            assert within_plan(positions, velocities, accels, planned, planned_v, held, braking,
                               tolerance) == bool((reference <= tolerance).all())


def test_the_tail_s_times_and_arrivals_are_counted_from_the_new_start():
    times, left, cost = tail_arrays(4, 2.0, 0.1, np.array([0.5, 3.0, 1.0]), 1.0)
    assert np.allclose(times, [2.0, 2.1, 2.2, 2.3]) and np.allclose(left, [0.0, 2.0, 0.0]) and cost == 2.0


def test_only_the_fast_planner_keeps_plans_however_prm_is_chosen():
    """PRM*'s plans are planned anew each round (a kept one would keep its old path cost), whether
    the scenario names it or a sweep switches a fast-planner scenario to it."""
    assert plan_reuse(load_scenario("2r-case1").planner) == (0.05, 0.1)
    assert plan_reuse(load_scenario("2r-case1", {"planner.name": "prm"}).planner)[0] == 0.0
    assert plan_reuse(load_scenario("2r-case1").with_overrides(**{"planner.name": "prm"}).planner)[0] == 0.0


def test_every_query_is_counted_once_as_asked():
    """A query answered by the planner, again from the round's answers, then kept a round later:
    three queries asked, one of each kind."""
    planner = StubPlanner()
    cache = PlanCache(planner, planner.tolerance, DT)
    cache.plan(request(0.0))
    cache.plan(request(0.0))
    cache.clear()
    cache.plan(on_it())
    assert (cache.misses, cache.hits, cache.reused, cache.asked) == (1, 1, 1, 3)
