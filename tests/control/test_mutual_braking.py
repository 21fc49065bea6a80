"""The mutual braking check: the deviation bound against brute force, the slack against hand
computations and a fine NumPy reference."""

import numpy as np
import pytest

from nodnav.control.braking import braking_profile
from nodnav.control.mutual_braking import BrakingPartners, braking_deviation, braking_slack


def _after_step(p, v, accel, dt):
    """State after a step of constant acceleration ``accel`` (the simulator's exact motion)."""
    return p + v * dt + 0.5 * accel * dt * dt, v + accel * dt


def test_deviation_bounds_every_step_the_robot_can_take():
    """Whatever a robot does for one step within its limit, its braking trajectory afterwards stays
    within braking_deviation of its braking trajectory now, at every instant (brute force)."""
    rng = np.random.default_rng(3)
    dt = 0.1
    for _ in range(300):
        a = rng.uniform(0.1, 3.0)
        p = rng.uniform(-1, 1, 2)
        v = rng.normal(size=2) * rng.choice([0.0, rng.uniform(0.0, 0.3), rng.uniform(0.0, 1.5)])
        elapsed = np.linspace(0.0, 30.0, 3001)
        now = braking_profile(p, v, a, dt + elapsed)[0]
        for angle in np.linspace(0, 2 * np.pi, 9)[:-1]:
            for norm in (a, 0.5 * a):
                u = norm * np.array([np.cos(angle), np.sin(angle)])
                p1, v1 = _after_step(p, v, u, dt)
                later = braking_profile(p1, v1, a, elapsed)[0]
                gap = np.linalg.norm(later - now, axis=1)
                assert np.all(gap <= braking_deviation(np.linalg.norm(v), a, dt, elapsed) + 1e-12)


def test_deviation_by_hand():
    # 1 m/s, 2 m/s^2, 0.1 s: 0.02 m right after the step, 2 (1 + 0.2) 0.1 + 0.02 = 0.26 m from 0.6 s on.
    assert braking_deviation(1.0, 2.0, 0.1, 0.0) == pytest.approx(0.02)
    assert braking_deviation(1.0, 2.0, 0.1, 0.6) == pytest.approx(0.26)
    assert braking_deviation(1.0, 2.0, 0.1, 5.0) == pytest.approx(0.26)
    # From rest: a dt^2 / 2 = 0.01 m, growing by a dt = 0.2 m/s for 0.1 s: 0.03 m.
    assert braking_deviation(0.0, 2.0, 0.1, 0.0) == pytest.approx(0.01)
    assert braking_deviation(0.0, 2.0, 0.1, 1.0) == pytest.approx(0.03)


def _partners(p, v, strong, a=2.0, contact=0.4, dt=0.1):
    return BrakingPartners(positions=np.array([p], float), velocities=np.array([v], float), decels=np.array([a]),
                           contact=np.array([contact]), strong=np.array([strong]), dt=dt)


def test_head_on_slack_by_hand():
    """i (after its step) at 0 going +x at 1 m/s stops at 0.25 m; j at 1 m going -x at 1 m/s is at
    0.91 m one step later at 0.8 m/s and stops at 0.75 m: 0.5 m apart at the closest, 0.1 m
    beyond contact. Strong: less the deviation once stopped, 0.26 m: -0.16 m."""
    weak = braking_slack([0.0, 0.0], [1.0, 0.0], 2.0, _partners([1.0, 0.0], [-1.0, 0.0], False))[0]
    assert 0.1 - 0.011 <= weak <= 0.1 + 1e-12
    strong = braking_slack([0.0, 0.0], [1.0, 0.0], 2.0, _partners([1.0, 0.0], [-1.0, 0.0], True))[0]
    assert -0.16 - 0.013 <= strong <= -0.16 + 1e-12


def test_slack_is_a_lower_bound_close_to_the_fine_minimum():
    rng = np.random.default_rng(7)
    dt = 0.1
    for _ in range(200):
        a_i, a_j = rng.uniform(0.2, 3.0, 2)
        p_i, p_j = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
        v_i, v_j = rng.normal(size=2), rng.normal(size=2)
        strong = bool(rng.integers(2))
        slack = braking_slack(p_i, v_i, a_i, _partners(p_j, v_j, strong, a=a_j))[0]
        s = np.linspace(0.0, 40.0, 400001)
        b_i = braking_profile(p_i, v_i, a_i, s)[0]
        b_j = braking_profile(p_j, v_j, a_j, dt + s)[0]
        margin = braking_deviation(np.linalg.norm(v_j), a_j, dt, s) if strong else 0.0
        fine = np.min(np.linalg.norm(b_i - b_j, axis=1) - 0.4 - margin)
        if fine > 1.0:
            continue  # far apart: the check only says so
        growth = min(np.linalg.norm(v_j), a_j * dt) + a_j * dt if strong else 0.0
        pad = 0.5 * 0.01 * (np.linalg.norm(v_i) + np.linalg.norm(v_j) + growth)
        assert fine - pad - 1e-6 <= slack <= fine + 1e-6


def test_far_robots_pass_and_no_partner_is_empty():
    assert braking_slack([0, 0], [1, 0], 2.0, _partners([10.0, 0.0], [-1.0, 0.0], True))[0] > 1.0
    none = BrakingPartners(positions=np.zeros((0, 2)), velocities=np.zeros((0, 2)), decels=np.zeros(0),
                           contact=np.zeros(0), strong=np.zeros(0, bool), dt=0.1)
    assert braking_slack([0, 0], [1, 0], 2.0, none).shape == (0,)
