"""Mixed teams (robots[i].method), people (social force) and who caused a contact, against hand computations."""

import importlib.util
import math

import numpy as np
import pytest

from nodnav.errors import NodnavError
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict
from nodnav.scenario.world import paper_world
from nodnav.sim.methods import NODMethod, Team, make_team
from nodnav.sim.simulator import Simulation, run_trial, trial_generators
from nodnav.sim.social_force import (
    SocialForceParams,
    agent_forces,
    clip_against_walls,
    driving_force,
    lateral,
    preferred_speed,
    view_weights,
    wall_forces,
    wall_social,
)
from nodnav.sim.team_contacts import PeopleContacts, approach_speeds, contact_causes

P = SocialForceParams()


def with_methods(name: str, methods: dict[int, str]):
    scenario = load_scenario(name)
    raw = scenario_to_dict(scenario)
    for i, m in methods.items():
        raw["robots"][i]["method"] = m
    return scenario_from_dict(raw, scenario.name)


# -- the social force model, by hand ----------------------------------------------------------


def test_driving_force_is_mass_times_velocity_gap_over_tau():
    # 80 kg * ((1.34, 0) - (0.5, 0)) / 0.5 s = (134.4, 0) N
    assert np.allclose(driving_force(np.array([0.5, 0.0]), np.array([1.34, 0.0]), 80.0, 0.5), [134.4, 0.0])


def test_repulsion_between_two_people_apart_is_the_exponential_alone():
    # d = 0.5 m, r_i + r_j = 0.4 m: A exp(-0.1 / 0.08) = 2000 e^-1.25 = 573.0096 N, pushing i away from j (-x).
    f = agent_forces(np.zeros(2), np.zeros(2), 0.2, np.array([[0.5, 0.0]]), np.zeros((1, 2)), np.array([0.2]), P)
    assert np.allclose(f[0], [-2000 * math.exp(-1.25), 0.0])
    assert math.isclose(2000 * math.exp(-1.25), 573.0096, rel_tol=1e-6)


def test_body_force_and_sliding_friction_in_contact():
    # d = 0.3 m, overlap 0.1 m; j moves at (0, 1) past i at rest. n_ij = (-1, 0), t_ij = (0, -1),
    # (v_j - v_i).t_ij = -1: normal 2000 e^1.25 + 1.2e5 * 0.1 along n, tangential 2.4e5 * 0.1 * (-1) t.
    f = agent_forces(np.zeros(2), np.zeros(2), 0.2, np.array([[0.3, 0.0]]), np.array([[0.0, 1.0]]),
                     np.array([0.2]), P)
    normal = 2000 * math.exp(1.25) + 12000.0
    assert np.allclose(f[0], [-normal, 24000.0])


def test_wall_pushes_a_person_away_along_its_normal():
    world = paper_world()
    # A person 0.5 m above the top of a wall block: the wall point nearest is straight below.
    x0, y0, x1, y1 = world.obstacles[0]
    p = np.array([(x0 + x1) / 2, y1 + 0.5])
    f = wall_forces(p, np.zeros(2), 0.2, np.array([[p[0], y1]]), P)
    assert np.allclose(f[0], [0.0, 2000 * math.exp(-3.75)])  # 47.04 N upward


def test_the_walls_social_term_only_steers():
    # (-100, 50) N against a person heading along +x: the -100 N along its heading is dropped.
    assert np.allclose(lateral(np.array([-100.0, 50.0]), np.array([1.0, 0.0])), [0.0, 50.0])
    assert np.allclose(lateral(np.array([-100.0, 50.0]), np.array([-1.0, 0.0])), [-100.0, 50.0])
    # The social part of the wall force alone: 2000 e^((0.2 - 0.5) / 0.08) N away from the wall.
    assert np.allclose(wall_social(np.array([0.0, 0.5]), 0.2, np.zeros(2), P), [0.0, 2000 * math.exp(-3.75)])


def test_field_of_view_weighs_those_behind_by_c():
    w = view_weights(np.array([1.0, 0.0]), np.zeros(2), np.array([[-1.0, 0.0], [1.0, 1.0], [-0.1, 1.0]]), P)
    # behind (180 deg): c = 0.5; 45 deg and 95.7 deg are within the 100 deg half field of view.
    assert np.allclose(w, [0.5, 1.0, 1.0])


def test_a_person_slides_along_a_wall_instead_of_entering_it():
    world = paper_world()
    x0, y0, x1, y1 = world.obstacles[0]
    p = np.array([(x0 + x1) / 2, y1 + 0.21])  # 1 cm of clearance beyond its radius
    step = clip_against_walls(world, p, np.array([0.1, -0.1]), 0.2)
    assert np.allclose(step, [0.1, 0.0])
    assert world.clearance((p + step)[None])[0] >= 0.2


def test_preferred_speeds_are_weidmanns_normal_clipped_to_the_body():
    rng = np.random.default_rng(0)
    speeds = np.array([preferred_speed(rng, 3.0, P) for _ in range(4000)])
    assert abs(speeds.mean() - 1.34) < 0.02 and abs(speeds.std() - 0.26) < 0.02
    assert max(preferred_speed(rng, 1.0, P) for _ in range(100)) <= 1.0


# -- who caused a contact -----------------------------------------------------------------------


def test_the_one_moving_into_the_other_caused_the_contact():
    u_a, u_b = approach_speeds(np.zeros(2), np.array([0.39, 0.0]), np.array([1.0, 0.0]), np.zeros(2))
    assert (u_a, u_b) == (1.0, 0.0) and contact_causes(u_a, u_b) == (True, False)
    # head on, both at 1 m/s: both caused it; sideways sliding (no approach) by neither more than the other
    assert contact_causes(*approach_speeds(np.zeros(2), np.array([0.39, 0]), np.array([1.0, 0]),
                                           np.array([-1.0, 0]))) == (True, True)


def test_attribution_on_a_constructed_contact():
    scenario = with_methods("2r-case1", {0: "person"})
    people = PeopleContacts(scenario, np.array([True, False]))
    start = np.array([[-5.5, 0.0], [-5.05, 0.0]])
    # The person (0) walks 0.1 m into the robot (1), which stands still: the person caused it.
    path = np.stack([start + [[f * 0.1, 0.0], [0.0, 0.0]] for f in (0.25, 0.5, 0.75, 1.0)])
    events: list[dict] = []
    assert people.judge(start, path, 1.0, 0.1, events) == 0
    assert events[0]["caused_by"] == [0] and events[0]["robots"] == [0, 1]
    assert math.isclose(events[0]["approach"][0], 1.0) and events[0]["approach"][1] == 0.0
    assert people.judge(path[-1], np.repeat(path[-1:], 4, axis=0), 1.1, 0.1, events) == 0
    assert len(events) == 1  # still touching: the same contact, counted once
    # A robot driving into a person at rest caused it.
    people = PeopleContacts(scenario, np.array([True, False]))
    path = np.stack([start - [[0.0, 0.0], [f * 0.1, 0.0]] for f in (0.25, 0.5, 0.75, 1.0)])
    assert people.judge(start, path, 1.0, 0.1, []) == 1


# -- mixed teams end to end ---------------------------------------------------------------------


def test_a_team_of_one_method_is_that_method_and_runs_the_same():
    scenario = load_scenario("2r-case1")
    same = with_methods("2r-case1", {0: "nod"})
    assert isinstance(make_team(same, "nod", trial_generators(1, 2)[0]), NODMethod)
    a, b = run_trial(scenario, "nod", 1), run_trial(same, "nod", 1)
    assert np.array_equal(np.array(a.history.positions), np.array(b.history.positions))


def test_a_person_among_nod_robots_arrives_and_the_team_is_reported_per_method():
    scenario = with_methods("2r-case1", {0: "person"})
    sim = Simulation(scenario, "nod", 1)
    assert isinstance(sim.method, Team) and sim.pedestrians.tolist() == [True, False]
    result = run_trial(scenario, "nod", 1)
    m = result.to_dict()
    assert result.outcome == "success" and m["robot_methods"] == ["person", "nod"]
    assert m["people"] == [1] and m["per_method"]["nod"]["robots"] == [2] and m["per_method"]["person"]["arrived"] == 1
    # The person walks its own way: its decisions carry no opinions, its plan is its route.
    assert np.isnan(np.array(result.history.opinions)[:, 0]).all()


def test_a_nod_robot_among_closest_first_robots():
    scenario = with_methods("3r-case4", {0: "nod"})
    result = run_trial(scenario, "closest-first", 1)
    m = result.to_dict()
    assert m["robot_methods"] == ["nod", "closest-first", "closest-first"]
    assert set(m["per_method"]) == {"nod", "closest-first"}
    assert result.outcome in ("success", "collision", "deadlock", "timeout")


def test_person_yielding_waits_before_its_mouth_while_someone_comes_the_other_way():
    scenario = with_methods("2r-case1", {1: "person-yielding"})
    sim = Simulation(scenario, "nod", 1)
    member = sim.method.members["person-yielding"]
    views = sim.views()
    view = views[1]
    states = view.window_states.copy()
    ent = np.asarray(scenario.world.entrance_for(np.array(sim.sides[1])))
    states[1, -1, :2] = ent + [1.0 * (1 if sim.sides[1] > 0 else -1), 0.0]  # 1 m before its entrance
    corridor = scenario.world.corridor
    states[0, -1, :2] = [(corridor.x_min + corridor.x_max) / 2, (corridor.y_min + corridor.y_max) / 2]
    from nodnav.sim.agent import RobotView
    seen = RobotView(t=view.t, window_times=view.window_times, window_states=states, entered=())
    assert sim.sides[0] == -sim.sides[1] and member.waits(1, seen)
    states[0, -1, :2] = scenario.origins[0]
    assert not member.waits(1, RobotView(t=view.t, window_times=view.window_times, window_states=states, entered=()))


def test_bad_methods_per_robot_are_one_line():
    raw = scenario_to_dict(load_scenario("2r-case1"))
    raw["robots"][0]["method"] = 3
    with pytest.raises(ScenarioError, match=r"robots\[0\].method: expected a method name"):
        scenario_from_dict(raw, "x")
    with pytest.raises(NodnavError, match=r"robots\[0\].method: unknown method 'persn'.*person"):
        Simulation(with_methods("2r-case1", {0: "persn"}), "nod", 1)
    with pytest.raises(NodnavError, match=r"robots\[1\].method: 'oracle' is a central coordinator"):
        Simulation(with_methods("2r-case1", {1: "oracle"}), "nod", 1)
    with pytest.raises(NodnavError, match=r"method 'oracle' is a central coordinator.*robots\[0\].method: person"):
        Simulation(with_methods("2r-case1", {0: "person"}), "oracle", 1)


@pytest.mark.skipif(importlib.util.find_spec("pyrvo") is None, reason="orca needs pyrvo (nodnav[baselines])")
def test_other_conventions_per_robot_in_one_trial():
    scenario = with_methods("3r-case4", {1: "orca", 2: "independent"})
    sim = Simulation(scenario, "nod", 3)
    assert set(sim.method.members) == {"nod", "orca", "independent"}
    for _ in range(15):  # one and a half opinion periods: every method decided and moved its own robot
        sim.step()
    decisions = sim.history.strategies[-1]
    assert decisions[1] == -1 and decisions[0] >= 0 and decisions[2] >= 0  # orca follows no order
    assert np.linalg.norm(sim.history.positions[-1][1] - scenario.origins[1]) > 0.5  # ORCA drives at once
