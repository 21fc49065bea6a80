"""The eighth round's single calls of the closed loop (docs/performance-8-loop.md) against the
separate steps they replace: the same numbers, bit for bit."""

import numpy as np

from nodnav.planning import make_planner
from nodnav.planning.base import JointTrajectory, PlanResult
from nodnav.scenario.loading import load_scenario
from nodnav.sim.plan_cache import PlanCache
from nodnav.sim.progress import PlanProgress, route_arcs, route_arcs_plain
from nodnav.sim.simulator import Simulation


def _routes(rng: np.random.Generator, n: int) -> list[np.ndarray | None]:
    """Random walks of different lengths, one robot without a route, one with repeated points."""
    routes: list[np.ndarray | None] = []
    for k in range(n):
        if k == 1:
            routes.append(None)
            continue
        steps = rng.normal(0.0, 0.1, (int(rng.integers(2, 40)), 2))
        if k == 2:
            steps[3:6] = 0.0  # a wait: repeated points are dropped by follow
        routes.append(np.cumsum(steps, axis=0))
    return routes


def test_advanced_in_one_call_is_each_robots_step_bit_for_bit():
    rng = np.random.default_rng(4)
    n = 6
    one, each = PlanProgress(n, 0.05), PlanProgress(n, 0.05)
    routes = _routes(rng, n)
    for k, route in enumerate(routes):
        one.follow(k, route)
        each.follow(k, route)
    reach = rng.uniform(0.1, 0.4, n)
    for step in range(60):
        if step == 30:  # a new plan for one robot mid-way: the routes laid end to end anew
            route = np.cumsum(rng.normal(0.0, 0.1, (25, 2)), axis=0)
            one.follow(3, route)
            each.follow(3, route)
        positions = np.array([r[min(step // 2, len(r) - 1)] if r is not None else np.zeros(2) for r in routes])
        positions += rng.normal(0.0, 0.05, positions.shape)
        got, want = one.advanced(positions, reach), each.advanced_plain(positions, reach)
        assert np.array_equal(got, want)
        assert np.array_equal(one.cursor, each.cursor)
        assert one.credited.tobytes() == each.credited.tobytes()
    assert each.cursor.max() > 0 and each.credited.max() > 0  # the walk got somewhere


def test_advanced_without_any_route_credits_nobody():
    progress = PlanProgress(3, 0.1)
    assert not progress.advanced(np.zeros((3, 2)), np.ones(3)).any()


def _plan(rng: np.random.Generator, n: int) -> PlanResult:
    times = np.linspace(0.0, 4.0, 21)
    positions = np.cumsum(rng.normal(0.0, 0.1, (21, n, 2)), axis=0)
    order = tuple(range(n))
    return PlanResult(success=True, reason="", cost=0.0, trajectory=JointTrajectory.from_positions(times, positions),
                      order=order, order_planned=order)


def test_stacked_states_are_np_stack_of_each_plans_states():
    rng = np.random.default_rng(7)
    scenario = load_scenario("3r-case1")
    cache = PlanCache(make_planner(scenario.planner, scenario.world))  # no planning asked of it
    plans = [_plan(rng, 3) for _ in range(5)]
    times = np.linspace(0.5, 1.5, 11)
    got = cache.stacked_states(plans, times)
    want = np.stack([cache.states_at(p, times) for p in plans])
    assert got.dtype == want.dtype and got.shape == want.shape and got.tobytes() == want.tobytes()
    assert cache.stacked_states([_plan(rng, 3), _plan(rng, 2)], times).shape == (0,)  # unequal robot counts
    assert cache.stacked_states([], times).shape == (0,)


def test_route_arcs_is_the_numpy_version_bit_for_bit():
    rng = np.random.default_rng(11)
    for k in (2, 3, 17, 60):
        route = np.cumsum(rng.normal(0.0, 0.2, (k, 2)), axis=0)
        route[k // 2] = route[k // 2 - 1]  # a repeated point, dropped
        for r in (route, route[::-1], np.repeat(route[:1], k, axis=0), np.asfortranarray(route)):
            got, want = route_arcs(np.asarray(r, dtype=float)), route_arcs_plain(r)
            assert got[0].tobytes() == want[0].tobytes() and got[1].tobytes() == want[1].tobytes()
    # a straight route along x: the arc lengths are the distances from its start
    line = np.stack([np.array([0.0, 0.5, 0.5, 2.0]), np.zeros(4)], axis=1)
    points, arcs = route_arcs(line)
    assert points.tolist() == [[0.0, 0.0], [0.5, 0.0], [2.0, 0.0]] and arcs.tolist() == [0.0, 0.5, 2.0]


def test_one_shared_view_is_every_robots_own_view():
    """With exact sensing every robot's view is the same: the shared view holds what each robot's
    own would (the same window, time and entry records)."""
    sim = Simulation(load_scenario("3r-case4"), "nod", 1)
    for _ in range(120):
        views = sim.views()
        assert len({id(v) for v in views.values()}) == 1
        times = sim.t - sim._window_offsets
        for i, view in views.items():
            assert view.window_states is sim._windows[i]
            assert view.t == sim.t and view.window_times.tobytes() == times.tobytes()
            assert view.entered == tuple(sim.entered_seen[i])
            assert view.age is None and view.sigma is None and view.passage_entered == ()
        if sim.step():
            break
    assert sim.entered_true  # robots entered the corridor on the way
