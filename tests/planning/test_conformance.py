"""The conformance suite every planner in ``nodnav.planning.PLANNERS`` must pass.

Every scenario of the paper is planned from its origins in every passing order (the PRM* planner,
with a small roadmap in a temporary cache, in a handful of orders for four robots), every crowd
built-in (5 to 8 robots) by the fast planner in a handful of orders, and the joint
trajectory is checked independently of the planner: separation and free space at a step five
times finer than the plan's, speed limits, start and end points, the corridor entry order and
the single-file rule. Requests with robots that have entered the corridor, an unreachable
destination and a lone robot complete the suite.
"""

import importlib.util
import itertools

import numpy as np
import pytest

from nodnav.planning import PLANNERS, make_planner
from nodnav.planning.base import PlanRequest, corridor_entry_order, crossing_directions, feasible_order
from nodnav.scenario.catalogue import PAPER_SCENARIOS, crowd_scenarios
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import FastPlannerParams, PRMParams
from nodnav.scenario.world import paper_world

#: PRM*: roadmap vertices per robot for the test roadmaps (built once per session).
PRM_VERTICES = 500
#: PRM*: every how many-th order is planned for four robots.
PRM_ORDER_STRIDE = 6
FINE = 5


@pytest.fixture(scope="module", params=PLANNERS)
def planner(request, tmp_path_factory):
    name = request.param
    if name == "prm":
        if importlib.util.find_spec("nodnav.planning.prm") is None:
            pytest.skip("the prm planner is not written yet")
        params = PRMParams(name="prm", roadmap_vertices=PRM_VERTICES,
                               cache_dir=str(tmp_path_factory.mktemp("roadmaps")))
    else:
        params = FastPlannerParams(name=name)
    return make_planner(params, paper_world())


def plan_request(world, positions, destinations, order, entered=(), t0=0.0, radius=0.2, speed=1.0):
    p = np.asarray(positions, dtype=float)
    n = len(p)
    return PlanRequest(world, p, np.zeros_like(p), np.asarray(destinations, dtype=float), np.full(n, radius),
                       np.full(n, speed), tuple(order), tuple(entered), t0)


def assert_conforms(planner, result, req):
    """Check a successful plan against the request, independently of how it was made."""
    world, tr = req.world, result.trajectory
    n = len(req.positions)
    assert result.success, result.reason
    assert result.order == tuple(req.order)
    assert result.order_planned == feasible_order(req.order, req.entered)
    assert np.isfinite(result.cost)
    # Sampled every dt from the request's time, from the current positions to the destinations.
    assert tr.times[0] == pytest.approx(req.t0)
    assert np.diff(tr.times) == pytest.approx(np.full(len(tr.times) - 1, planner.params.dt))
    assert tr.positions.shape == (len(tr.times), n, 2)
    assert np.allclose(tr.positions[0], req.positions, atol=1e-9)
    assert np.allclose(tr.positions[-1], req.destinations, atol=1e-6)
    # Speed limits, from the positions themselves.
    speed = np.linalg.norm(np.diff(tr.positions, axis=0), axis=2) / np.diff(tr.times)[:, None]
    assert np.all(speed <= req.max_speeds + 1e-9)
    # Separation and free space at a step FINE times finer than the plan's.
    t = np.linspace(tr.times[0], tr.times[-1], FINE * (len(tr.times) - 1) + 1)
    p = tr.positions_at(t)
    for a, b in itertools.combinations(range(n), 2):
        gap = np.linalg.norm(p[:, a] - p[:, b], axis=1).min()
        assert gap >= req.radii[a] + req.radii[b] - 1e-9, f"robots {a} and {b} come {gap:.4f} m close"
    assert np.all(world.is_free(p, req.radii)), "a robot leaves free space"
    # Corridor: entry order, and single file (opposite directions wait until the corridor is clear).
    dirs = crossing_directions(world, req.positions, req.destinations)
    crossing = [k for k in result.order_planned if dirs[k] != 0]
    assert [k for k in corridor_entry_order(world, tr) if dirs[k] != 0] == crossing
    inside = world.in_corridor(tr.positions)
    for a, b in zip(crossing, crossing[1:]):
        if dirs[a] != dirs[b]:
            assert np.nonzero(inside[:, b])[0][0] > np.nonzero(inside[:, a])[0][-1], \
                f"robot {b} enters before robot {a} has left"


def orders_for(planner, n):
    orders = list(itertools.permutations(range(n)))
    return orders[::PRM_ORDER_STRIDE] if planner.name == "prm" and n >= 4 else orders


@pytest.mark.parametrize("name", PAPER_SCENARIOS)
def test_builtin_scenario_every_order(planner, name):
    sc = load_scenario(name)
    for order in orders_for(planner, sc.n_robots):
        req = PlanRequest(sc.world, sc.origins, np.zeros_like(sc.origins), sc.destinations, sc.radii,
                          sc.max_speeds, order)
        assert_conforms(planner, planner.plan(req), req)


@pytest.mark.parametrize("name", crowd_scenarios())
def test_crowd_scenario_some_orders(name):
    """5 to 8 robots have 120 to 40,320 orders: the fast planner (the one their trials use; the
    PRM* roadmaps are built for up to 4 robots) plans the identity, its reverse and three drawn ones."""
    sc = load_scenario(name)
    planner = make_planner(FastPlannerParams(), sc.world)
    rng = np.random.default_rng(12)
    orders = [tuple(range(sc.n_robots)), tuple(reversed(range(sc.n_robots)))]
    orders += [tuple(int(k) for k in rng.permutation(sc.n_robots)) for _ in range(3)]
    for order in orders:
        req = PlanRequest(sc.world, sc.origins, np.zeros_like(sc.origins), sc.destinations, sc.radii,
                          sc.max_speeds, order)
        assert_conforms(planner, planner.plan(req), req)


def test_entered_robots_keep_their_place(planner):
    world = paper_world()
    # Robot 2 is in the corridor heading left; robot 0 waits on the left, robot 1 on the right.
    req = plan_request(world, [[-5.0, 1.0], [5.0, -1.0], [1.0, 0.0]], [[5.5, 1.0], [-5.5, -1.0], [-5.5, 1.5]],
                       order=(0, 1, 2), entered=(2,), t0=12.0)
    res = planner.plan(req)
    assert res.order_planned == (2, 0, 1) and res.repaired
    assert_conforms(planner, res, req)


def test_unreachable_destination_fails_cleanly(planner):
    world = paper_world()
    # 0.1 m from the end of the upper corridor wall: no room for a robot of radius 0.2.
    req = plan_request(world, [[-5.0, 1.0], [5.0, 0.0]], [[-3.1, 0.5], [-5.0, 0.0]], order=(0, 1), t0=2.0)
    res = planner.plan(req)
    assert not res.success and res.reason
    assert res.cost == float("inf")
    assert res.trajectory.times.tolist() == [2.0]
    assert np.array_equal(res.trajectory.positions_at(7.0), req.positions)


def test_single_robot_goes_straight_at_full_speed(planner):
    world = paper_world()
    req = plan_request(world, [[-5.5, 0.0]], [[5.5, 0.0]], order=(0,))
    res = planner.plan(req)
    assert_conforms(planner, res, req)
    # 11 m at 1 m/s, within a few steps.
    assert abs(res.trajectory.duration - 11.0) <= 3 * planner.params.dt
