"""What every controller in ``nodnav.control.CONTROLLERS`` must do, whatever its method."""

import numpy as np
import pytest

from nodnav.control import CONTROLLERS, Controller, ControlRequest, ControlResult, make_controller
from nodnav.control.base import STEP_FRACTIONS
from nodnav.scenario.params import ControllerParams, MPCParams, RobotSpec
from nodnav.scenario.world import paper_world

WORLD = paper_world()
ROBOT = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))
DT = ControllerParams().dt
TIMES = ControllerParams().horizon * np.arange(1, 9) / 8


@pytest.fixture(params=CONTROLLERS)
def name(request):
    return request.param


def make(name, robot=ROBOT):
    return make_controller(MPCParams(name=name), WORLD, robot)


def request(p, v, reference, others=None, radii=None):
    others = np.zeros((0, len(TIMES), 2)) if others is None else np.asarray(others, float)
    radii = np.full(len(others), ROBOT.radius) if radii is None else np.asarray(radii, float)
    return ControlRequest(position=np.asarray(p, float), velocity=np.asarray(v, float),
                          reference=np.asarray(reference, float), sample_times=TIMES, others=others,
                          other_radii=radii)


def check_result(res, req):
    assert isinstance(res, ControlResult)
    assert res.velocity.shape == (2,) and res.next_position.shape == (2,) and res.next_velocity.shape == (2,)
    assert res.planned_positions.shape == (len(req.sample_times), 2)
    for a in (res.velocity, res.next_position, res.next_velocity, res.planned_positions):
        assert np.all(np.isfinite(a))
    np.testing.assert_allclose(res.velocity, (res.next_position - req.position) / DT, atol=1e-12)
    assert res.solve_time >= 0.0 and isinstance(res.info, dict)
    assert isinstance(res.reason, str) and (res.success or res.reason)
    if res.step_positions is not None:
        # The motion within the step ends where the step does and moves no faster than allowed.
        assert res.step_positions.shape == (len(STEP_FRACTIONS), 2)
        np.testing.assert_allclose(res.step_positions[-1], res.next_position, atol=1e-12)
        hops = np.diff(np.vstack([req.position, res.step_positions]), axis=0)
        assert np.all(np.linalg.norm(hops, axis=1) <= ROBOT.max_speed * DT * np.diff([0, *STEP_FRACTIONS]) + 1e-9)


def test_registry_builds_a_controller(name):
    ctl = make(name)
    assert isinstance(ctl, Controller)
    assert ctl.name == name


def test_result_contract_in_free_space(name):
    ctl = make(name)
    req = request([-5.0, 1.0], [0.2, 0.0], np.array([-5.0, 1.0]) + TIMES[:, None] * [0.5, 0.0])
    res = ctl.control(req)
    check_result(res, req)
    assert res.success and res.reason == ""


@pytest.mark.parametrize("m", [0, 1, 3])
def test_any_number_of_other_robots(name, m):
    ctl = make(name)
    far = np.array([[-5.5, -2.0], [-6.5, 2.0], [-4.0, -1.8]])[:m]
    req = request([-5.0, 0.0], [0.0, 0.0], np.tile([-4.5, 0.0], (8, 1)),
                  others=np.repeat(far[:, None], len(TIMES), axis=1))
    res = ctl.control(req)
    check_result(res, req)
    assert res.success


def test_closed_loop_reaches_the_goal_within_the_limits(name):
    ctl = make(name)
    p, v = np.array([-6.0, -1.0]), np.zeros(2)
    goal = np.array([-3.6, 1.2])
    for _ in range(50):
        req = request(p, v, np.tile(goal, (8, 1)))
        res = ctl.control(req)
        check_result(res, req)
        assert np.linalg.norm(res.next_velocity) <= ROBOT.max_speed + 1e-9
        assert WORLD.clearance(res.next_position) >= ROBOT.radius - 1e-9
        p, v = res.next_position, res.next_velocity
    assert np.linalg.norm(p - goal) < 0.05


def test_two_robots_crossing_keep_apart(name):
    """Two robots swap places across the left room; each predicts the other at constant velocity."""
    robots = [make(name), make(name)]
    pos = np.array([[-6.0, 0.0], [-4.0, 0.1]])
    vel = np.zeros((2, 2))
    goals = pos[::-1].copy()
    fine = np.linspace(0.0, 1.0, 11)[:, None]
    for _ in range(40):
        new_pos, new_vel = pos.copy(), vel.copy()
        for i in range(2):
            j = 1 - i
            pred = pos[j] + TIMES[:, None] * vel[j]
            direction = goals[i] - pos[i]
            dist = np.linalg.norm(direction)
            ref = pos[i] + np.minimum(0.8 * TIMES, dist)[:, None] * direction / max(dist, 1e-9)
            req = request(pos[i], vel[i], ref, others=pred[None])
            res = robots[i].control(req)
            check_result(res, req)
            new_pos[i], new_vel[i] = res.next_position, res.next_velocity
        # Contacts are judged on straight lines between steps, as the simulator does.
        a = pos[0] + fine * (new_pos[0] - pos[0])
        b = pos[1] + fine * (new_pos[1] - pos[1])
        assert np.linalg.norm(a - b, axis=1).min() >= 2 * ROBOT.radius - 1e-3
        pos, vel = new_pos, new_vel


def test_overlap_is_reported_and_the_robot_does_not_speed_up(name):
    ctl = make(name)
    v0 = np.array([0.5, 0.0])
    req = request([-5.0, 0.0], v0, np.tile([-4.0, 0.0], (8, 1)), others=np.tile([-4.75, 0.0], (1, 8, 1)))
    res = ctl.control(req)
    check_result(res, req)
    assert not res.success and res.reason
    assert np.linalg.norm(res.next_velocity) <= np.linalg.norm(v0) + 1e-12
