"""The other navigation methods: each does what its name says, checked against independent references."""

import importlib.util
import math

import numpy as np
import pytest

from nodnav.planning import make_planner
from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_from_dict
from nodnav.sim.baselines import (
    IndependentMethod,
    best_strategy,
    closest_first_order,
    fixed_preference_probabilities,
    next_waypoint,
    planned_makespan,
    preferred_velocity,
    route_trajectory,
    wall_polygons,
)
from nodnav.sim.methods import METHODS, make_method
from nodnav.sim.sensing import OcclusionLimit
from nodnav.sim.simulator import Simulation, run_trial, trial_generators

needs_rvo2 = pytest.mark.skipif(importlib.util.find_spec("pyrvo") is None,
                                reason="orca needs pyrvo (pip install 'nodnav[baselines]')")


def short(name: str, seconds: float, **overrides):
    return load_scenario(name).with_overrides(time_limit=seconds, **overrides)


def run_for(scenario, method: str, seed: int = 1) -> Simulation:
    sim = Simulation(scenario, method, seed)
    while not sim.step():
        pass
    return sim


def shoelace(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


# -- pure functions ----------------------------------------------------------------------------


def _plan(times, positions, success=True):
    traj = JointTrajectory.from_positions(np.asarray(times, float), np.asarray(positions, float))
    return PlanResult(success, "", 0.0, traj, (0, 1), (0, 1))


def test_planned_makespan_is_the_last_first_arrival_after_the_start():
    # Start at 10 s, 1 s steps. Robot A is on (2, 0) from step 2. Robot B is 0.5 m short of
    # (0, 3) at step 1, 0.1 m short at step 2, there at step 3: within 0.15 m it arrives at
    # step 2, within 0.05 m at step 3.
    a = [[0, 0], [1, 0], [2, 0], [2, 0]]
    b = [[0, 0], [0, 2.5], [0, 2.9], [0, 3.0]]
    plan = _plan([10, 11, 12, 13], np.stack([a, b], axis=1))
    dest = np.array([[2.0, 0.0], [0.0, 3.0]])
    assert planned_makespan(plan, dest, 0.15) == pytest.approx(2.0)
    assert planned_makespan(plan, dest, 0.05) == pytest.approx(3.0)
    # A robot that never gets there, or a failed plan, has no makespan.
    assert planned_makespan(plan, dest + [[0, 1], [0, 0]], 0.15) == math.inf
    assert planned_makespan(_plan([10, 11, 12, 13], np.stack([a, b], axis=1), success=False), dest, 0.15) == math.inf


def test_best_strategy_breaks_ties_by_cost_then_index():
    assert best_strategy([5.0, 3.0, 3.0, 4.0], [1.0, 9.0, 7.0, 0.0]) == 2
    assert best_strategy([3.0, 3.0, 3.0], [2.0, 2.0, 2.0]) == 0
    # Sums of 0.1 s steps differ in the last bits; they still tie.
    assert best_strategy([0.1 + 0.2, 0.3], [5.0, 4.0]) == 1
    assert best_strategy([math.inf, 7.0], [math.inf, 100.0]) == 1


def test_closest_first_orders_by_distance_then_robot_number():
    assert closest_first_order([2.5, 1.0, 2.5, 0.3], 0.01) == (3, 1, 0, 2)
    # Within a centimetre counts as equal: the lower robot number goes first either way round.
    assert closest_first_order([1.0, 1.004], 0.01) == (0, 1)
    assert closest_first_order([1.004, 1.0], 0.01) == (0, 1)
    assert closest_first_order([1.03, 1.0], 0.01) == (1, 0)


def test_fixed_preference_is_a_softmax_of_initial_opinion_plus_bias():
    assert np.allclose(fixed_preference_probabilities(np.zeros(6), np.zeros(6), 1.0), 1 / 6)
    # e^{ln 3} : e^0 = 3 : 1, whether the preference comes from z(0) or from the bias.
    assert np.allclose(fixed_preference_probabilities([math.log(3), 0.0], [0.0, 0.0], 1.0), [0.75, 0.25])
    assert np.allclose(fixed_preference_probabilities([0.0, 0.0], [math.log(3), 0.0], 1.0), [0.75, 0.25])
    # eta = 2 halves the exponent: e^{ln 9 / 2} = 3.
    assert np.allclose(fixed_preference_probabilities([math.log(9), 0.0], [0.0, 0.0], 2.0), [0.75, 0.25])


def test_route_trajectory_drives_the_polyline_at_constant_speed():
    # 3 m along x then 4 m up, at 2 m/s sampled every 1 s: 7 m take 3.5 s, so 4 steps.
    traj = route_trajectory(np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 4.0]]), 2.0, 1.0, 5.0)
    assert np.allclose(traj.times, [5, 6, 7, 8, 9])
    expected = [[0, 0], [2, 0], [3, 1], [3, 3], [3, 4]]
    assert np.allclose(traj.positions[:, 0], expected)
    assert traj.n_robots == 1


def test_preferred_velocity_points_at_the_waypoint_and_stops_at_the_goal():
    assert np.allclose(preferred_velocity([0, 0], [3, 4], 10.0, 1.0, 0.1), [0.6, 0.8])
    # 0.05 m left: 0.5 m/s covers it in one 0.1 s step.
    assert np.allclose(preferred_velocity([0, 0], [0.03, 0.04], 0.05, 1.0, 0.1), [0.3, 0.4])
    assert np.allclose(preferred_velocity([1, 1], [1, 1], 0.0, 1.0, 0.1), [0, 0])


def test_next_waypoint_skips_the_current_position():
    route = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 2.0]])
    assert np.allclose(next_waypoint(route, [0.0, 0.0]), [1.0, 0.0])
    assert np.allclose(next_waypoint(route[1:], [1.0, 0.0]), [2.0, 2.0])
    assert np.allclose(next_waypoint(route[2:], [2.0, 2.0]), [2.0, 2.0])


def test_wall_polygons_follow_rvo2_orientation():
    world = load_scenario("2r-case1").world
    polys = wall_polygons(world)
    assert len(polys) == len(world.obstacles) + 1
    for poly, (x0, y0, x1, y1) in zip(polys, world.obstacles):
        assert shoelace(poly) == pytest.approx((x1 - x0) * (y1 - y0))  # counter-clockwise
        assert {tuple(v) for v in poly} == {(x0, y0), (x1, y0), (x1, y1), (x0, y1)}
    x0, y0, x1, y1 = world.bounds
    assert shoelace(polys[-1]) == pytest.approx(-(x1 - x0) * (y1 - y0))  # clockwise: encloses the robots


# -- the registry --------------------------------------------------------------------------------


@needs_rvo2
def test_every_method_is_made_by_name():
    s = load_scenario("2r-case2")
    rngs, _ = trial_generators(1, s.n_robots)
    for name in ("nod", "no-coordination", "independent", "closest-first", "oracle", "orca"):
        assert name in METHODS
        assert make_method(name, s, rngs).name == name


# -- no-coordination -----------------------------------------------------------------------------


def test_no_coordination_has_no_game_players_and_holds_others_still():
    s = short("2r-case1", 2.0)
    sim = run_for(s, "no-coordination")
    h = sim.history.arrays()
    assert len(h["players"]) == 2 and not h["players"].any()
    method = sim.method
    views = sim.views()
    for i, view in views.items():
        decision = method.decisions[i]
        assert decision.robots == (i,) and decision.players == ()
        assert decision.plan.trajectory.n_robots == 1
        # The paper's prediction of the other robot (the first row per other robot) is where
        # it is seen now, at every sample of the horizon.
        other = 1 - i
        pred = method.predictions(i, sim.t, view)
        assert pred.shape[1:] == (len(method.sample_times), 2)
        assert np.allclose(pred[0], view.positions[other][None])


# -- independent ---------------------------------------------------------------------------------


def test_independent_robots_keep_their_own_opposite_preferences():
    # Robot 1 strongly prefers S2 = (2, 1), robot 2 S1 = (1, 2): probabilities 1 - e^{-100}.
    # Without a social term neither ever gives in (NOD resolves exactly this case).
    s = short("2r-case2", 3.0, **{"opinion.init": "given", "opinion.z0": [[-50.0, 50.0], [50.0, -50.0]]})
    sim = run_for(s, "independent", seed=3)
    strategies = sim.history.arrays()["strategies"]
    assert len(strategies) == 3
    assert (strategies[:, 0] == 1).all() and (strategies[:, 1] == 0).all()
    d = sim.method.decisions[0]
    assert np.isnan(d.opinions).all() and np.isnan(d.probabilities).all()


def test_independent_choice_is_its_own_and_follows_the_bias():
    s = load_scenario("3r-case2")
    views = Simulation(s, "nod", seed=1).views()
    # A bias of 150 on S4 outweighs everything: every robot keeps S4.
    biased = s.with_overrides(**{"opinion.bias": {"S4": 150.0}})
    rngs, _ = trial_generators(1, 3)
    assert IndependentMethod(biased, rngs).choose(views) == {0: 3, 1: 3, 2: 3}
    # Robot 1's choice depends on its own generator only.
    rngs_a, _ = trial_generators(5, 3)
    rngs_b, _ = trial_generators(5, 3)
    rngs_b[1] = np.random.default_rng(12345)
    rngs_b[2] = np.random.default_rng(678)
    a = IndependentMethod(s, rngs_a).choose(views)
    b = IndependentMethod(s, rngs_b).choose(views)
    assert a[0] == b[0]
    # Without a bias, the choice is the draw a NOD robot makes at t = 0 with the same generator.
    for seed in (1, 2):
        nod = Simulation(s, "nod", seed)
        nod.step()
        first = {i: int(j) for i, j in enumerate(nod.history.strategies[0])}
        assert IndependentMethod(s, trial_generators(seed, 3)[0]).choose(views) == first
    # With zero opinions the choice is uniform over the six orders: across seeds it varies.
    picks = {IndependentMethod(s, trial_generators(seed, 3)[0]).choose(views)[0] for seed in range(1, 21)}
    assert len(picks) >= 3


# -- closest-first -------------------------------------------------------------------------------


def test_closest_first_follows_the_distance_order():
    # Distances to the entrances at (-3, 0) and (3, 0): robot 1 sqrt(3^2 + 1^2) = 3.16 m,
    # robot 2 2.5 m, robot 3 1.0 m: order (3, 2, 1), the last of the six, S6 (index 5).
    s = scenario_from_dict({"name": "three", "time_limit": 1.0, "robots": [
        {"origin": [-6.0, 1.0], "destination": [5.5, 1.5]},
        {"origin": [5.5, 0.0], "destination": [-5.5, -1.0]},
        {"origin": [-4.0, 0.0], "destination": [5.5, -1.5]}]})
    sim = run_for(s, "closest-first")
    strategies = sim.history.arrays()["strategies"]
    assert (strategies == 5).all()
    d = sim.method.decisions[2]
    # Robot 3 plans with all the others as players, in the convention's order (plans number
    # their robots locally, robot 3 first).
    assert tuple(d.robots[k] for k in d.plan.order) == (2, 1, 0)
    # Symmetric start (2.5 m each): the tie goes to robot 1, S1 = (1, 2), kept at every period.
    sim = run_for(short("2r-case1", 3.0), "closest-first")
    assert (sim.history.arrays()["strategies"] == 0).all()


# -- oracle --------------------------------------------------------------------------------------


def test_oracle_gives_everyone_the_order_with_the_smallest_planned_makespan():
    s = load_scenario("3r-case2")
    # Plan every order from the start in the test, with a planner of our own, timed as the robots
    # can drive it: within each one's speed and acceleration limit (planner.timing: feasible).
    planner = make_planner(s.planner, s.world)
    tol = s.sim.goal_tolerance
    orders = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    makespans, costs = [], []
    for order in orders:
        plan = planner.plan(PlanRequest(world=s.world, positions=s.origins, velocities=np.zeros((3, 2)),
                                        destinations=s.destinations, radii=s.radii, max_speeds=s.max_speeds,
                                        order=order, max_accels=np.array([r.max_accel for r in s.robots])))
        assert plan.success
        last = 0.0
        for k in range(3):
            gap = np.linalg.norm(plan.trajectory.positions[:, k] - s.destinations[k], axis=1)
            last = max(last, plan.trajectory.times[np.flatnonzero(gap <= tol)[0]])
        makespans.append(last)
        costs.append(plan.cost)
    # The smallest makespan; among equal ones the smallest total arrival time, then the first.
    fastest = [j for j in range(6) if abs(makespans[j] - min(makespans)) < 1e-9]
    best = min(fastest, key=lambda j: (costs[j], j))
    sim = run_for(s.with_overrides(time_limit=2.0), "oracle")
    assert np.allclose(sim.method.makespans, makespans)
    strategies = sim.history.arrays()["strategies"]
    assert (strategies == best).all()
    for i in range(3):
        d = sim.method.decisions[i]
        assert tuple(d.robots[k] for k in d.plan.order) == orders[best]
        # The plan lists its robots as d.robots does: robot i first, where it is now.
        k = int(np.searchsorted(sim.history.times, sim.history.decision_times[-1] - 1e-9))
        assert np.allclose(d.plan.trajectory.positions[0], sim.history.positions[k][list(d.robots)])


# -- orca ----------------------------------------------------------------------------------------


@needs_rvo2
def test_orca_gives_the_walls_to_rvo2():
    s = load_scenario("2r-case1")
    method = make_method("orca", s, trial_generators(1, 2)[0])
    rvo = method.rvo
    assert len(method.obstacle_ids) == len(s.world.obstacles) + 1
    for first, poly in zip(method.obstacle_ids, wall_polygons(s.world)):
        # Walk RVO2's vertex chain round the polygon; RVO2 may split edges, adding collinear vertices.
        chain, v = [], first
        for _ in range(rvo.get_num_obstacle_vertices()):
            chain.append(rvo.get_obstacle_vertex(v).to_tuple())
            v = rvo.get_next_obstacle_vertex(v)
            if v == first:
                break
        chain = np.array(chain)
        corners = [tuple(np.round(c, 6)) for c in chain if any(np.allclose(c, q, atol=1e-6) for q in poly)]
        assert corners == [tuple(np.round(q, 6)) for q in poly]
        assert np.sign(shoelace(chain)) == np.sign(shoelace(poly))


@needs_rvo2
def test_orca_robot_never_enters_a_wall_and_reaches_its_goal():
    # Robot 1 starts against the left room's wall just above the corridor and goes to the right
    # room's far corner below it: its route turns tightly round both entrance corners. Robot 2
    # crosses in the same direction from the other corner.
    s = scenario_from_dict({"name": "orca-walls", "time_limit": 20.0, "robots": [
        {"origin": [-3.3, 2.2], "destination": [3.3, -2.2]},
        {"origin": [-5.0, -2.0], "destination": [5.0, 2.0]}]})
    sim = run_for(s, "orca")
    assert sim.outcome == "success"
    path = sim.history.arrays()["positions"]  # (K, 2, 2)
    w = np.linspace(0.0, 1.0, 11)[:, None, None, None]
    fine = (1 - w) * path[None, :-1] + w * path[None, 1:]  # straight motion between steps
    clearance = s.world.clearance(fine)
    assert clearance.min() >= 0.2 - 1e-6
    assert clearance.min() < 0.2 + 0.05  # it did go round the corners close to the walls
    speeds = np.linalg.norm(sim.history.arrays()["velocities"], axis=-1)
    assert speeds.max() <= 1.0 + 1e-5
    d = sim.method.decisions[0]
    assert d.strategy == -1 and d.players == () and np.isnan(d.opinions).all()
    assert d.plan.success and np.allclose(d.plan.trajectory.positions[-1, 0], s.destinations[0])


@needs_rvo2
def test_orca_step_moves_at_the_returned_velocity():
    s = load_scenario("2r-case2")
    sim = Simulation(s, "orca", seed=1)
    sim.step()
    views = sim.views()
    results = sim.method.act(sim.t, views)
    for i, res in results.items():
        assert res.success
        p = views[i].positions[i]
        assert np.allclose(res.next_position, p + res.velocity * s.controller.dt)
        assert np.allclose(res.next_velocity, res.velocity)
        # Alone in a room, heading for the corridor: at full speed towards its next waypoint.
        assert np.linalg.norm(res.velocity) == pytest.approx(1.0, abs=1e-5)


@needs_rvo2
def test_orca_keeps_the_occlusion_speed_limit_with_limited_sight():
    # A robot below the paper's left mouth cannot see into the corridor (walls block sight): the
    # place hidden nearest it is 1.56 m away (tests/sim/test_sensing.py works it out by hand), so
    # its speed limit is far below its own 5 m/s; with full sight it may go at 5 m/s.
    robots = [{"origin": [-4.0, -1.0], "destination": [5.0, 0.0]}, {"origin": [5.0, 1.0], "destination": [-5.0, 0.0]}]
    raw = {"name": "mouth", "robot_defaults": {"max_speed": 5.0, "max_accel": 1.0}, "robots": robots}
    speeds, caps = [], []
    for sensing in ({"walls_block": True}, {}):
        s = scenario_from_dict({**raw, "sensing": sensing})
        sim = Simulation(s, "orca", seed=1)
        sim.step()
        views = sim.views()
        speeds.append(float(np.linalg.norm(sim.method.act(sim.t, views)[0].velocity)))
        caps.append(OcclusionLimit(s).speed(0, views[0].positions[0], 5.0))
    assert caps[1] == 5.0 and caps[0] < 2.0  # stopping within half of ~1.2 m at 0.65 m/s^2
    assert 0.0 < speeds[0] <= caps[0] + 1e-6 < speeds[1]


@needs_rvo2
def test_methods_run_through_the_simulator_and_its_outcomes():
    s = short("2r-case2", 1.0)
    for name in ("independent", "closest-first", "oracle", "orca"):
        result = run_trial(s, name, seed=2)
        assert result.history.method == name
        assert result.outcome == "timeout"
        assert result.to_dict()["method"] == name
