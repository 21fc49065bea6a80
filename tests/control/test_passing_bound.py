"""The bound that lets the MPC skip solving when no plan can pass mutual braking: it must bound
the check's slack of every next state the robot can reach in one step (brute force), and be
tight where it can be computed by hand."""

from dataclasses import replace

import numpy as np
import pytest

from nodnav.control import ControlRequest, mpc_braking
from nodnav.control.mpc import BSplineMPC
from nodnav.control.mutual_braking import BrakingPartners, braking_slack, passing_bound
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import paper_world


def _partners(p_i, v_i, p_j, v_j, a_i, a_j, convention, contact=0.4, dt=0.1):
    """Robot 0 (checked) at ``(p_i, v_i)`` now and robot 1 at ``(p_j, v_j)``; convention 0 (speed),
    1 (index: robot 0 takes the weak check), 2 (strong) or 3 (stopping)."""
    return BrakingPartners(robot=0, positions=np.array([p_i, p_j], float), velocities=np.array([v_i, v_j], float),
                           decels=np.array([a_i, a_j], float), radii=np.full(2, contact / 2),
                           keeps_rule=np.ones(2, bool), seen=np.ones(2, bool), turn=0, convention=convention, dt=dt)


def test_bound_is_above_the_slack_of_every_reachable_next_state():
    """Whatever one step within the limit the robot takes (constant accelerations of every
    direction and of half and full norm, and braking), the check's slack from where it ends is at
    most the bound: a negative bound means every plan is refused."""
    rng = np.random.default_rng(11)
    dt, negative = 0.1, 0
    for _ in range(400):
        a_i, a_j = rng.uniform(0.3, 3.0, 2)
        p_i = np.zeros(2)
        v_i = rng.normal(size=2) * rng.choice([0.0, 0.05, rng.uniform(0.0, 1.5)])
        p_j = rng.normal(size=2) * rng.uniform(0.3, 1.5)
        v_j = rng.normal(size=2) * rng.choice([0.0, rng.uniform(0.0, 1.5)])
        partners = _partners(p_i, v_i, p_j, v_j, a_i, a_j, int(rng.integers(4)))
        bound, j = passing_bound(p_i, v_i, partners)
        negative += bound < 0
        steps = [a_i * f * np.array([np.cos(t), np.sin(t)]) for t in np.linspace(0, 2 * np.pi, 13)[:-1]
                 for f in (0.5, 1.0)]
        speed = np.linalg.norm(v_i)
        steps.append(-a_i * v_i / speed if speed > 0 else np.zeros(2))
        for accel in steps:
            p1, v1 = p_i + v_i * dt + 0.5 * accel * dt * dt, v_i + accel * dt
            slack = braking_slack(p1, v1, partners)[0][1]
            assert slack <= bound + 1e-12
    assert negative > 20  # the property was exercised where it matters


def test_bound_by_hand_for_two_robots_at_rest():
    """Both at rest, 0.01 m beyond contact, the robot checked strongly: braking trajectories are
    points, so the bound is 0.01 m plus its own deviation from rest (a dt^2 / 2 + a dt * dt =
    0.03 m at 2 m/s^2 and 0.1 s) less the other's (the same, 0.03 m): 0.01 m."""
    partners = _partners([0.0, 0.0], [0.0, 0.0], [0.41, 0.0], [0.0, 0.0], 2.0, 2.0, convention=2)
    bound, j = passing_bound([0.0, 0.0], [0.0, 0.0], partners)
    assert j == 1 and bound == pytest.approx(0.01, abs=1e-12)


def test_bound_by_hand_head_on():
    """Robot 0 at 2 m/s (2 m/s^2) straight at robot 1 at rest 0.6 m away, the weak check (index
    convention). Its braking now passes robot 1's centre at t = 1 - sqrt(0.4) = 0.3675 s, i.e.
    s = 0.2675 s after the step, where any step moves it by at most 0.02 + 0.4 s = 0.127 m: the
    bound is 0.127 - 0.4 = -0.273 m (the minimum: before, the distance falls at the speed, above
    the deviation's 0.4 m/s; after, both grow), sampled every 0.01 s at under 1.3 m/s relative."""
    partners = _partners([0.0, 0.0], [2.0, 0.0], [0.6, 0.0], [0.0, 0.0], 2.0, 2.0, convention=1)
    bound, j = passing_bound([0.0, 0.0], [2.0, 0.0], partners)
    crossing = 1.0 - np.sqrt(0.4) - 0.1
    exact = 0.02 + 0.4 * crossing - 0.4
    assert j == 1 and exact - 1e-12 <= bound <= exact + 0.005 * (1.3 + 0.4)


def test_no_bound_towards_robots_not_checked():
    partners = _partners([0.0, 0.0], [1.0, 0.0], [0.41, 0.0], [0.0, 0.0], 2.0, 2.0, convention=2)
    partners = partners._replace(keeps_rule=np.array([True, False]))
    assert passing_bound([0.0, 0.0], [1.0, 0.0], partners) == (np.inf, -1)


def test_the_mpc_skips_solving_only_where_solving_would_be_refused(monkeypatch):
    """A robot at 1 m/s whose braking stops 0.15 m from a robot standing ahead, which it checks
    strongly: no plan can pass. With ``skip_unpassable`` the MPC brakes without a QP, and the
    full solve (the default) ends in the same fallback, with the same next state."""
    world, params = paper_world(), MPCParams(skip_unpassable=True)
    robot = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))  # radius 0.2, 1 m/s, 2 m/s^2
    times = params.dt * np.arange(1, 9)
    p, v, other = np.array([-5.0, 0.0]), np.array([1.0, 0.0]), np.array([-4.6, 0.0])
    partners = BrakingPartners(robot=0, positions=np.array([p, other]), velocities=np.array([v, [0.0, 0.0]]),
                               decels=np.full(2, robot.max_accel), radii=np.full(2, robot.radius),
                               keeps_rule=np.ones(2, bool), seen=np.ones(2, bool), turn=0, convention=2,
                               dt=params.dt)
    request = ControlRequest(position=p, velocity=v, reference=p + 1.0 * times[:, None] * np.array([1.0, 0.0]),
                             sample_times=times, others=np.repeat(other[None, None], len(times), axis=1),
                             other_radii=np.array([robot.radius]), braking=partners)
    assert passing_bound(p, v, partners)[0] < 0
    skipped = BSplineMPC(world, robot, params).control(request)
    assert not skipped.success and "no plan can pass" in skipped.reason and skipped.info["qps"] == 0
    solved = BSplineMPC(world, robot, replace(params, skip_unpassable=False)).control(request)
    assert not solved.success and solved.info["fallback"] == skipped.info["fallback"]
    assert np.array_equal(solved.next_position, skipped.next_position)
    assert np.array_equal(solved.next_velocity, skipped.next_velocity)


def test_in_closed_loop_skipped_steps_are_steps_the_full_solve_refuses(capsys, tool_script):
    """tools/check_passing_bound.py on the mirror start that once collided (5r-mixed, one game
    player, seed 20): the full solve decides, and at every step where the bound says no plan can
    pass, it refused every plan."""
    module = tool_script("check_passing_bound")
    assert module.main(["5r-mixed/1/20"]) == 0
    out = capsys.readouterr().out
    assert "skippable" in out and "ACCEPTED" not in out
    assert mpc_braking.passing_bound is passing_bound  # restored
