"""The mutual braking check: the deviation bound against brute force, the slack against hand
computations and a fine NumPy reference."""

import numpy as np
import pytest

from nodnav.control.braking import braking_profile
from nodnav.control.mutual_braking import (
    BrakingPartners,
    braking_deviation,
    braking_slack,
    restart_gap,
    takes_weak_check,
)


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


def _partners(p, v, strong, a=2.0, a_i=2.0, contact=0.4, dt=0.1):
    """Robot 0 (the one checked; its own state here only decides the convention) and robot j = 1;
    the index convention gives robot 0 the weak check, ``strong`` (convention 2) the strong one."""
    return BrakingPartners(robot=0, positions=np.array([[0.0, 0.0], p], float),
                           velocities=np.array([[0.0, 0.0], v], float),
                           decels=np.array([a_i, a]), radii=np.full(2, contact / 2), keeps_rule=np.ones(2, bool),
                           seen=np.ones(2, bool), turn=0, convention=2 if strong else 1, dt=dt)


def _slack(p_i, v_i, partners):
    out, worst = braking_slack(p_i, v_i, partners)
    assert out[0] == np.inf and worst in (-1, 1)
    return out[1]


def test_head_on_slack_by_hand():
    """i (after its step) at 0 going +x at 1 m/s stops at 0.25 m; j at 1 m going -x at 1 m/s is at
    0.91 m one step later at 0.8 m/s and stops at 0.75 m: 0.5 m apart at the closest, 0.1 m
    beyond contact. Strong: less the deviation once stopped, 0.26 m: -0.16 m."""
    weak = _slack([0.0, 0.0], [1.0, 0.0], _partners([1.0, 0.0], [-1.0, 0.0], False))
    assert 0.1 - 0.011 <= weak <= 0.1 + 1e-12
    strong = _slack([0.0, 0.0], [1.0, 0.0], _partners([1.0, 0.0], [-1.0, 0.0], True))
    assert -0.16 - 0.013 <= strong <= -0.16 + 1e-12


def test_slack_is_a_lower_bound_close_to_the_fine_minimum():
    rng = np.random.default_rng(7)
    dt = 0.1
    for _ in range(200):
        a_i, a_j = rng.uniform(0.2, 3.0, 2)
        p_i, p_j = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
        v_i, v_j = rng.normal(size=2), rng.normal(size=2)
        strong = bool(rng.integers(2))
        slack = _slack(p_i, v_i, _partners(p_j, v_j, strong, a=a_j, a_i=a_i))
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


def test_far_robots_pass_and_unseen_robots_are_not_checked():
    assert _slack([0, 0], [1, 0], _partners([10.0, 0.0], [-1.0, 0.0], True)) > 1.0
    unseen = _partners([0.3, 0.0], [-1.0, 0.0], True)._replace(seen=np.array([True, False]))
    out, worst = braking_slack([0, 0], [1, 0], unseen)
    assert worst == -1 and np.all(out == np.inf)


def test_one_weak_check_per_pair_by_each_convention():
    """Of two robots that keep the rule exactly one takes the weak check (speed: the faster; of two
    standing still, the lower- and the higher-numbered in turn; index: the lower index), neither
    with strong, and never towards a robot that does not keep the rule."""
    cases = [(1.0, 0.5), (0.5, 1.0), (0.7, 0.7), (0.0, 0.0), (1e-4, 0.0), (0.3, 0.0), (0.0, 0.3)]
    for speed_i, speed_j in cases:
        for convention in (0, 1):
            for turn in (0, 1):
                weak_ij = takes_weak_check(2, 5, speed_i, speed_j, True, convention, turn, 2.0, 2.0, 0.1)
                weak_ji = takes_weak_check(5, 2, speed_j, speed_i, True, convention, turn, 2.0, 2.0, 0.1)
                assert weak_ij != weak_ji
                if convention == 1:
                    assert weak_ij  # robot 2 before robot 5
        assert not takes_weak_check(2, 5, speed_i, speed_j, True, 2, 0, 2.0, 2.0, 0.1)
        assert not takes_weak_check(2, 5, 10.0, 0.0, False, 0, 0, 2.0, 2.0, 0.1)
    assert takes_weak_check(2, 5, 1.0, 0.5, True, 0, 0, 2.0, 2.0, 0.1)          # the faster
    assert not takes_weak_check(2, 5, 0.5, 1.0, True, 0, 1, 2.0, 2.0, 0.1)
    assert takes_weak_check(5, 2, 0.3, 0.0, True, 0, 0, 2.0, 2.0, 0.1)          # moving against standing still
    assert takes_weak_check(2, 5, 0.0, 0.0, True, 0, 0, 2.0, 2.0, 0.1)          # both still: in turn
    assert takes_weak_check(5, 2, 0.0, 0.0, True, 0, 1, 2.0, 2.0, 0.1)
    assert takes_weak_check(5, 2, 1e-4, 0.0, True, 0, 1, 2.0, 2.0, 0.1)         # below REST_SPEED counts as still


def test_stopping_convention_compares_stopping_times_and_holds_the_turn_while_starting():
    """``stopping`` (code 3): of every pair exactly one weak check; the robot that needs longer to
    stop (|v| / a, by hand: 0.3 / 0.5 = 0.6 s against 1.0 / 2.5 = 0.4 s) takes it even when slower;
    a robot that can stop within dt = 0.1 s (|v| <= a dt) counts as standing still, so of two such
    the turn decides whoever is a hair faster, and one such against a robot that cannot stop
    within the step takes the strong check."""
    dt = 0.1
    speeds = [0.0, 1e-4, 0.004, 0.05, 0.1, 0.3, 0.7, 1.0]
    accels = [0.1, 0.5, 2.5]
    for speed_i in speeds:
        for speed_j in speeds:
            for a_i in accels:
                for a_j in accels:
                    for turn in (0, 1):
                        weak_ij = takes_weak_check(2, 5, speed_i, speed_j, True, 3, turn, a_i, a_j, dt)
                        weak_ji = takes_weak_check(5, 2, speed_j, speed_i, True, 3, turn, a_j, a_i, dt)
                        assert weak_ij != weak_ji
                        if speed_i <= a_i * dt and speed_j <= a_j * dt:  # both can stop within the step
                            assert weak_ij == (turn == 0)
                        elif speed_i <= a_i * dt:
                            assert not weak_ij
                        elif speed_j <= a_j * dt:
                            assert weak_ij
                        elif speed_i / a_i != speed_j / a_j:
                            assert weak_ij == (speed_i / a_i > speed_j / a_j)
    assert takes_weak_check(2, 5, 0.3, 1.0, True, 3, 0, 0.5, 2.5, dt)        # slower, but 0.6 s to stop
    assert not takes_weak_check(2, 5, 0.3, 1.0, True, 0, 0, 0.5, 2.5, dt)   # speed: the faster instead
    # Trembling at rest: 4 mm/s against 1 mm/s at 2 m/s^2 (a dt = 0.2 m/s): the turn, not the speed.
    assert takes_weak_check(2, 5, 0.001, 0.004, True, 3, 0, 2.0, 2.0, dt)
    assert not takes_weak_check(2, 5, 0.001, 0.004, True, 0, 0, 2.0, 2.0, dt)
    assert not takes_weak_check(2, 5, 10.0, 0.0, False, 3, 0, 2.0, 2.0, dt)  # not towards a non-keeper


def test_robots_that_do_not_keep_the_rule_are_not_checked():
    """The rule is mutual: towards a robot that may not brake (a person, another method) there is
    no check, whatever the geometry."""
    near = _partners([0.3, 0.0], [-1.0, 0.0], True)._replace(keeps_rule=np.array([True, False]))
    out, worst = braking_slack([0, 0], [1, 0], near)
    assert worst == -1 and np.all(out == np.inf)


def test_the_kernel_applies_the_stopping_convention_with_each_robots_deceleration():
    """Robot 0 at rest, robot 1 0.005 m beyond contact (0.4 m), both at 2 m/s^2, dt = 0.1 s: the
    strong check from rest needs 1.5 a dt^2 = 0.03 m, so staying put passes only the weak check.
    Robot 1 drifting away at 0.1 m/s (below a dt = 0.2 m/s, it can stop within the step; its
    braking from one step on stands at 0.4075 m): with ``stopping`` it still counts as standing
    still, and the turn gives robot 0 the weak check (slack 0.005-0.0075 m) in even periods and
    the strong one (below 0.0075 - 0.03) in odd ones; with ``speed`` the drifting robot is the
    faster and robot 0 is strong in both."""
    def partners(v1, convention, turn):
        return BrakingPartners(0, np.array([[0.0, 0.0], [0.405, 0.0]]), np.array([[0.0, 0.0], [v1, 0.0]]),
                               np.array([2.0, 2.0]), np.full(2, 0.2), np.ones(2, bool), np.ones(2, bool), turn,
                               convention, 0.1)

    for v1, most in ((0.0, 0.005), (0.1, 0.0075)):
        weak = _slack([0.0, 0.0], [0.0, 0.0], partners(v1, 3, 0))
        assert 0.005 - 0.001 <= weak <= most + 1e-12
        assert _slack([0.0, 0.0], [0.0, 0.0], partners(v1, 3, 1)) <= most - 0.03 + 1e-12
    for turn in (0, 1):
        assert _slack([0.0, 0.0], [0.0, 0.0], partners(0.1, 0, turn)) <= 0.0075 - 0.03 + 1e-12


def _brake_at(p, v, a, s):
    """Braking along ``v`` at ``a`` from ``(p, v)``, where it is after ``s`` (seconds, an array) ``(len(s), 2)``."""
    speed = np.linalg.norm(v)
    if speed == 0.0:
        return np.tile(p, (len(s), 1))
    sigma = np.minimum(s, speed / a)
    return p + np.outer(speed * sigma - 0.5 * a * sigma * sigma, v / speed)


def _closest_braking_gap(p, v, a, radii, horizon=3.0, step=1e-3):
    """The least gap beyond contact between any two robots' braking trajectories, by brute force."""
    s = np.arange(0.0, horizon + step, step)
    tracks = [_brake_at(p[i], v[i], a[i], s) for i in range(len(p))]
    return min(np.min(np.linalg.norm(tracks[i] - tracks[j], axis=1)) - radii[i] - radii[j]
               for i in range(len(p)) for j in range(i + 1, len(p)))


def _crowd_run(convention, rng, checked=True, steps=40, dt=0.1, period=1.0):
    """Four robots at rest a few centimetres apart, each step pushing at random (a random
    acceleration within its limit, mostly towards the others) and braking instead where the check
    fails; returns the least gap between braking trajectories over the run (brute force)."""
    n = 4
    a = rng.uniform(0.3, 3.0, n)
    radii = np.full(n, 0.2)
    p = np.array([[0.0, 0.0], [0.42, 0.0], [0.0, 0.43], [0.44, 0.45]]) + rng.uniform(-0.01, 0.01, (n, 2))
    v = np.zeros((n, 2))
    worst = _closest_braking_gap(p, v, a, radii)
    for k in range(steps):
        partners = BrakingPartners(0, p.copy(), v.copy(), a, radii, np.ones(n, bool), np.ones(n, bool),
                                   int(np.floor(k * dt / period + 1e-9)) % 2, convention, dt)
        p_new, v_new = p.copy(), v.copy()
        for i in range(n):
            towards = p.mean(axis=0) - p[i] + rng.normal(0.0, 0.3, 2)
            u = a[i] * rng.uniform(0.0, 1.0) * towards / max(np.linalg.norm(towards), 1e-12)
            q, w = p[i] + v[i] * dt + 0.5 * u * dt * dt, v[i] + u * dt
            if checked and braking_slack(q, w, partners._replace(robot=i))[0].min() < 0.0:
                q = _brake_at(p[i], v[i], a[i], np.array([dt]))[0]  # brake for the step
                speed = np.linalg.norm(v[i])
                w = v[i] * (max(speed - a[i] * dt, 0.0) / speed) if speed > 0.0 else v[i]
            p_new[i], v_new[i] = q, w
        p, v = p_new, v_new
        worst = min(worst, _closest_braking_gap(p, v, a, radii))
    return worst


def test_the_invariant_holds_in_a_random_crowd_by_each_convention():
    """The docstring's case analysis, checked on its claim: robots pushing at one another at
    random, each accepting its step only if the check passes (else braking), never have two
    braking trajectories touch (brute force, every millisecond), whichever convention assigns the
    checks, ``stopping`` included; without the check they do (so the test can fail)."""
    for convention in (0, 1, 3):
        rng = np.random.default_rng(7 + convention)
        for _ in range(6):
            assert _crowd_run(convention, rng) >= -1e-9
    rng = np.random.default_rng(3)
    assert min(_crowd_run(3, rng, checked=False) for _ in range(3)) < -0.01


def test_restart_gap_by_hand_and_against_the_strong_check():
    """1.5 a dt^2 plus the check's allowance between samples (a dt times half its 0.01 s spacing),
    1.55 a dt^2 at the larger deceleration (0.031 m at 2 m/s^2 and 0.1 s); at rest, robot 0
    holding still passes the strong check towards robot 1 just beyond that gap and fails just
    inside it, whichever of the two brakes harder."""
    assert restart_gap(2.0, 2.0, 0.1) == pytest.approx(0.031)
    assert restart_gap(0.5, np.array([2.0, 0.2]), 0.1) == pytest.approx([0.031, 0.00775])
    for a_i, a_j in ((2.0, 2.0), (0.4, 2.9), (2.9, 0.4)):
        gap = float(restart_gap(a_i, a_j, 0.1))
        for extra, passes in ((1e-6, True), (-1e-3, False)):
            partners = _partners([0.4 + gap + extra, 0.0], [0.0, 0.0], True, a=a_j, a_i=a_i)
            # The strong check bounds robot 1's deviation with its own deceleration a_j: 1.5 a_j
            # dt^2, less at most a_j dt times half the samples' spacing (0.01 s at most).
            slack = _slack([0.0, 0.0], [0.0, 0.0], partners)
            assert gap + extra - 1.55 * a_j * 0.01 - 1e-12 <= slack <= gap + extra - 1.5 * a_j * 0.01 + 1e-12
            if passes:
                assert slack >= 0.0  # the gap lets either start again, whichever brakes harder
            elif a_j >= a_i:
                assert slack < 0.0  # and is no larger than the harder braker needs
