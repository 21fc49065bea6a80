"""Clearing the way when no order can be planned."""

import numpy as np

from nodnav.planning.base import PlanRequest
from nodnav.planning.clearing import clear_the_way
from nodnav.scenario.params import PlannerParams
from nodnav.scenario.world import paper_world


def _request(positions, destinations):
    p, d = np.asarray(positions, float), np.asarray(destinations, float)
    n = len(p)
    return PlanRequest(paper_world(), p, np.zeros_like(p), d, np.full(n, 0.2), np.ones(n), tuple(range(n)))


def test_a_robot_in_the_door_moves_out_of_every_way_and_the_others_hold():
    # Robot 0 stands in front of the left mouth; robot 1, behind it, needs the mouth.
    request = _request([[-3.4, 0.0], [-5.5, 0.0]], [[-6.0, 2.0], [5.0, 0.0]])
    plan = clear_the_way(request, 0, "no order", PlannerParams(door_clearance=1.0, margin=0.05, dt=0.1))
    assert not plan.success and plan.reason.startswith("no order; clearing the way to")
    end = plan.trajectory.positions[-1]
    np.testing.assert_array_equal(plan.trajectory.positions[:, 1], np.repeat([[-5.5, 0.0]], len(end) and
                                                                               len(plan.trajectory.times), 0))
    world = request.world
    assert np.linalg.norm(end[0] - [-3.0, 0.0]) >= 1.0  # out of the door zone
    assert world.clearance(end[0]) >= 0.2 and not world.in_corridor(end[0])
    # Clear of robot 1's way (the corridor axis from x = -5.5 to the mouth) by 0.45 m.
    assert abs(end[0, 1]) >= 0.45 or end[0, 0] < -5.5 - 0.45
    steps = np.linalg.norm(np.diff(plan.trajectory.positions[:, 0], axis=0), axis=1)
    assert steps.max() <= 0.1 + 1e-9  # at most max_speed * dt per step


def test_a_robot_already_out_of_the_way_waits_where_it_is():
    request = _request([[-6.0, 2.0], [-5.5, 0.0]], [[-6.0, -2.0], [5.0, 0.0]])
    plan = clear_the_way(request, 0, "no order", PlannerParams(door_clearance=1.0, margin=0.05, dt=0.1))
    assert not plan.success and plan.reason == "no order"
    np.testing.assert_array_equal(plan.trajectory.positions[-1], request.positions)
