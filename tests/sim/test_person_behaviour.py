"""A person's route, its slowing for bends and its making way, against hand computations."""

import math

import numpy as np

from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict
from nodnav.sim.agent import RobotView
from nodnav.sim.person import PersonMethod
from nodnav.sim.person_steering import away_from, turn_speed

INF = math.inf


def person_in(name: str, robot: int) -> tuple:
    scenario = load_scenario(name)
    raw = scenario_to_dict(scenario)
    raw["robots"][robot]["method"] = "person"
    scenario = scenario_from_dict(raw, scenario.name)
    rngs = [np.random.default_rng(k) for k in range(scenario.n_robots)]
    return scenario, PersonMethod(scenario, rngs)


def view_at(positions, velocities=None) -> RobotView:
    p = np.asarray(positions, dtype=float)
    v = np.zeros_like(p) if velocities is None else np.asarray(velocities, dtype=float)
    states = np.concatenate([p, v], axis=1)[:, None, :]
    return RobotView(t=0.0, window_times=np.array([0.0]), window_states=states, entered=())


# -- slowing for bends ------------------------------------------------------------------------


def test_no_bend_no_limit():
    route = np.array([[0.0, 0.0], [1.0, 0.0], [3.0, 0.0]])
    assert turn_speed(route, route[0], np.array([INF, 0.2, INF]), 2.0, 0.5, 5.0) == INF


def test_a_quarter_turn_by_hand():
    # At the vertex: lateral speed at most min(c / tau, sqrt(2 a c)) = min(0.4, 0.894) = 0.4 m/s,
    # all of it lateral (sin 90 deg = 1); from rest, braking at 2 m/s^2 over 1 m: sqrt(0.16 + 4).
    route = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    rooms = np.array([INF, 0.2, INF])
    assert math.isclose(turn_speed(route, route[0], rooms, 2.0, 0.5, 5.0), math.sqrt(0.16 + 4.0))
    # Moving at 1 m/s it brakes only after tau: over 1 - 0.5 = 0.5 m.
    assert math.isclose(turn_speed(route, route[0], rooms, 2.0, 0.5, 5.0, np.array([1.0, 0.0])),
                        math.sqrt(0.16 + 2.0))
    # A bend beyond the look-ahead does not count.
    assert turn_speed(route, route[0], rooms, 2.0, 0.5, 0.9) == INF


def test_a_half_quarter_turn_and_a_slow_body_by_hand():
    route = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 1.0]])
    rooms = np.array([INF, 0.2, INF])
    at_vertex = 0.4 / math.sin(math.pi / 4)
    assert math.isclose(turn_speed(route, route[0], rooms, 2.0, 0.5, 5.0), math.sqrt(at_vertex ** 2 + 4.0))
    # A body that accelerates at 0.25 m/s^2 needs u^2 / (2 a) of room: u = sqrt(2 0.25 0.2) = 0.316 m/s.
    at_vertex = math.sqrt(0.1) / math.sin(math.pi / 4)
    assert math.isclose(turn_speed(route, route[0], rooms, 0.25, 0.5, 5.0), math.sqrt(at_vertex ** 2 + 0.5))


def test_a_velocity_that_lags_the_heading_counts():
    # Heading straight on, but still moving sideways at 1 m/s: a quarter turn against the velocity.
    route = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    rooms = np.array([INF, 0.2, INF])
    assert math.isclose(turn_speed(route, route[0], rooms, 2.0, 0.5, 5.0, np.array([0.0, 1.0])),
                        math.sqrt(0.16 + 2.0))


# -- the route keeps comfortable clearance ---------------------------------------------------


def test_the_route_runs_along_the_middle_of_a_narrow_corridor():
    scenario, person = person_in("2r-case1", 0)
    # 0.7 m corridor, radius 0.2 m: 0.35 - 0.2 - 0.01 = 0.14 m beyond the radius, below 0.3 m.
    assert math.isclose(person.comfortable_margin(0.2), 0.14)
    assert math.isclose(person.comfortable_margin(0.3), person.params.route_margin)  # never below it
    route = person.route(0, scenario.origins[0])
    seg = np.linspace(0.0, 1.0, 201)
    pts = np.concatenate([a + seg[:, None] * (b - a) for a, b in zip(route[:-1], route[1:])])
    inside = scenario.world.in_corridor(pts)
    assert inside.any() and np.all(np.abs(pts[inside, 1]) <= 0.01 + 1e-6)
    corners = np.array([[-3.0, 0.35], [-3.0, -0.35], [3.0, 0.35], [3.0, -0.35]])
    gaps = np.linalg.norm(pts[:, None] - corners[None], axis=2).min()
    assert gaps >= 0.2 + 0.14 - 1e-6


# -- making way ------------------------------------------------------------------------------


def test_sidestep_out_of_the_line_of_a_waiting_or_moving_robot():
    # Standing robot at (1, 0): the line from it through the person is -x; its left is -y.
    assert np.allclose(away_from([0.0, 0.0], [[1.0, 0.0]], [[0.0, 0.0]]), [0.0, -1.0])
    # With more room on the other side, that side.
    assert np.allclose(away_from([0.0, 0.0], [[1.0, 0.0]], [[0.0, 0.0]], room=lambda q: q[1]), [0.0, 1.0])
    # A robot at (1, 0.2) moving along -x: out of its line, on the person's side (-y).
    assert np.allclose(away_from([0.0, 0.0], [[1.0, 0.2]], [[-1.0, 0.0]]), [0.0, -1.0])
    # Before a passage along x, below its centreline: also across it, downwards; (0, -1) + (0, -1).
    assert np.allclose(away_from([0.0, 0.0], [[1.0, 0.2]], [[-1.0, 0.0]], np.array([1.0, 0.0]), -0.3), [0.0, -1.0])
    # ... and the two cancel above it.
    assert np.allclose(away_from([0.0, 0.0], [[1.0, 0.2]], [[-1.0, 0.0]], np.array([1.0, 0.0]), 0.3), [0.0, 0.0])


def test_an_arrived_person_makes_way_until_the_robot_has_passed():
    scenario, person = person_in("2r-case1", 0)
    goal = scenario.destinations[0]
    person.arrived.add(0)
    assert person.params.make_way_gap == 0.5
    robot = goal + [0.2 + 0.2 + 0.3, 0.0]  # 0.3 m between the bodies, still under way
    assert person.in_the_way_of(0, view_at([goal, robot])) == [1]
    heading, speed = person.make_way(0, view_at([goal, robot]), [1])
    assert speed > 0.0 and abs(heading[0]) < 1e-9 and math.isclose(abs(heading[1]), 1.0)
    # Held while within twice the gap (0.9 m apart), released beyond it (1.1 m) ...
    assert person.in_the_way_of(0, view_at([goal, goal + [1.3, 0.0]])) == [1]
    coming = view_at([goal, goal + [1.3, 0.0]], [[0.0, 0.0], [-0.5, 0.0]])  # the robot drives on
    heading, speed = person.make_way(0, coming, [1])
    assert speed == 0.0  # farther than make_way_gap: it stands aside
    # ... unless the robot waits there (slower than waiting_speed, 0.1 m/s): it goes on making way.
    assert person.params.waiting_speed == 0.1
    waiting = view_at([goal, goal + [1.3, 0.0]], [[0.0, 0.0], [-0.05, 0.0]])
    heading, speed = person.make_way(0, waiting, [1])
    assert speed > 0.0 and math.isclose(abs(heading[1]), 1.0)
    assert person.in_the_way_of(0, view_at([goal, goal + [1.5, 0.0]])) == []
    # ... or once the robot is at its own destination.
    assert person.in_the_way_of(0, view_at([goal, robot])) == [1]
    assert person.in_the_way_of(0, view_at([goal, scenario.destinations[1]])) == []


def test_an_arrived_person_makes_way_for_a_robot_waiting_near_it():
    # A robot still 0.9 m off (bodies 0.2 m each, centres 1.3 m apart), under way: it waits for the
    # person, who starts to make way although it is farther than make_way_gap (0.5 m) ...
    scenario, person = person_in("2r-case1", 0)
    goal = scenario.destinations[0]
    person.arrived.add(0)
    still = view_at([goal, goal + [1.3, 0.0]])
    assert person.in_the_way_of(0, still) == [1]
    # ... but not for one still beyond twice the gap (1.1 m), nor for one driving up at 0.5 m/s.
    person.making_way.clear()
    assert person.in_the_way_of(0, view_at([goal, goal + [1.5, 0.0]])) == []
    assert person.in_the_way_of(0, view_at([goal, goal + [1.3, 0.0]], [[0.0, 0.0], [-0.5, 0.0]])) == []


def test_a_person_before_the_corridor_steps_off_the_line_for_one_coming_out():
    scenario, person = person_in("2r-case1", 0)
    side = int(person.sides[0])
    entrance = np.asarray(scenario.world.entrance_for(np.array(side)))
    outside = entrance + [0.3 * side, 0.0]  # 0.3 m before its entrance, on the corridor's line
    coming = entrance - [0.5 * side, 0.0]  # robot 2, from the other side, inside: 0.4 m apart
    assert int(person.sides[1]) == -side
    view = view_at([outside, coming], [[0.0, 0.0], [0.5 * side, 0.0]])
    assert person.in_the_way_of(0, view) == [1]
    heading, speed = person.make_way(0, view, [1])
    assert speed > 0.0 and abs(heading[1]) > 0.99  # across the line
    # Off the line (beyond half the width plus both radii), it stands and waits ...
    aside = outside + [0.0, 0.35 + 0.2 + 0.2 + 0.05]
    view = view_at([aside, coming + [0.3 * side, 0.0]])
    assert person.in_the_way_of(0, view) == [1]
    assert person.make_way(0, view, [1])[1] == 0.0
    # ... until the robot has left the corridor.
    assert person.in_the_way_of(0, view_at([aside, entrance + [1.0 * side, 0.6]])) == []
    # Nobody near: it does not yield.
    assert person.in_the_way_of(0, view_at([outside, entrance - [3.0 * side, 0.0]])) == []
