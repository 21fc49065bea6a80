"""A control step's fused compiled calls (round 13) against the separate calls and Python
expressions they replace, bit for bit: the plan check's verdict, the velocity command, the first
QP's gradient and rows, the braking tail's weight and reach."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from nodnav.control.mpc import BSplineMPC
from nodnav.control.mpc_plan import plan_passes
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import paper_world

WORLD = paper_world()
ROBOT = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))
TIMES = 0.1 * np.arange(1, 9)


def _step(rng, n_others, params=MPCParams()):
    """A controller, its problem and one step's data with ``n_others`` others around a random state."""
    ctl = BSplineMPC(WORLD, ROBOT, params)
    prob = ctl._problem(n_others, TIMES)
    p0, v0 = rng.uniform([-6.0, -0.6], [6.0, 0.6]), rng.normal(0.0, 0.5, 2)
    ref = p0 + np.outer(TIMES, rng.normal(0.0, 0.4, 2))
    others = p0 + rng.normal(0.0, 1.5, (n_others, 1, 2)) + np.outer(TIMES, rng.normal(0.0, 0.3, 2))[None]
    return ctl, prob, ctl._step_data(prob, p0, v0, ref, others, np.full(n_others, 0.2))


def test_plan_passes_is_the_verdict_empty():
    """The compiled test passes exactly where :meth:`MPCProblem._verdict` finds nothing, on values
    at, around and far from each threshold (and the infinities of no others and no tail)."""
    rng = np.random.default_rng(1)
    prob = BSplineMPC(WORLD, ROBOT, MPCParams())._problem(2, TIMES)
    tol, v_max, a_max = prob.setup.settings.check_tolerance, ROBOT.max_speed, ROBOT.max_accel
    seen = set()

    def near(x):  # at, just above, just below or anywhere around a threshold
        return float(rng.choice([x, np.nextafter(x, np.inf), np.nextafter(x, -np.inf), x + rng.normal()]))

    for _ in range(4000):
        need = float(rng.choice([0.2, 0.3, np.inf]))
        clear = near(need - tol)
        short = float(rng.choice([-np.inf, near(tol)]))
        speed, accel = near(v_max + tol), near(a_max + tol)
        has_tail = bool(rng.integers(2))
        tail = near(need - tol) if has_tail else np.inf  # plan_check's tail without one
        separation = bool(rng.integers(2))
        data = SimpleNamespace(need_clear=need, tail_weight=1.0 if has_tail else 0.0)
        verdict = prob._verdict(data, separation, clear, short, 0, speed, accel, tail)
        passes = plan_passes(clear, short, speed, accel, tail, need, tol, separation, v_max, a_max)
        assert passes == (verdict == "")
        seen.add(verdict.split(" (")[0].split(" comes")[0])
    assert len(seen) == 5  # passing, and each of the checks failing first (walls, robots, tail, limits)


@pytest.mark.parametrize("n_others", [0, 2])
def test_checked_plan_command_is_the_numpy_expression(n_others):
    """The velocity command written by the plan's compiled call is ``(p(dt) - p0) / dt`` in NumPy."""
    rng = np.random.default_rng(2 + n_others)
    for _ in range(50):
        ctl, prob, data = _step(rng, n_others)
        z = rng.normal(0.0, 0.1, 2 * prob.free_map.shape[1])
        c, post, why = prob.checked_plan(data, z, separation=True)
        assert np.array_equal(post[4], (post[2][0] - data.p0) / ctl.dt)
        assert len(post) == 5  # evaluate's four values (tests/control/test_plan_kernel.py), then the command


@pytest.mark.parametrize("cold", [False, True])
def test_tracking_rows_are_gradient_then_write_separation(cold):
    """One call gives the gradient, rows and bounds of :meth:`gradient` and :meth:`write_separation`."""
    rng = np.random.default_rng(4)
    for n_others in (0, 1, 3):
        for _ in range(20):
            ctl, prob, data = _step(rng, n_others)
            lin = prob.interp_ends @ (data.ref_local + data.p0) + rng.normal(0.0, 0.05, (len(prob.ends), 2))
            gradient, lower = prob.tracking_rows(data, lin, cold)
            rows = prob.rows.copy()
            prob.rows[prob.n_static:prob.n_separation] = np.nan  # every entry written afresh below
            ref_lower = prob.write_separation(data, lin, cold, data.need)
            assert np.array_equal(gradient, prob.gradient(data.v0, data.ref_local))
            assert np.array_equal(lower, ref_lower) and np.array_equal(rows, prob.rows)


@pytest.mark.parametrize("braking_tail", [True, False])
def test_step_state_tail_weight_and_reach_are_the_python_expressions(braking_tail):
    """The braking tail's weight and reach computed in ``step_state`` are the controller's former
    Python expressions, bit for bit (speeds below, at and above the limit)."""
    rng = np.random.default_rng(5)
    params = MPCParams(braking_tail=braking_tail)
    ctl = BSplineMPC(WORLD, ROBOT, params)
    prob = ctl._problem(1, TIMES)
    r, v_max, a_max, horizon = ROBOT.radius, ROBOT.max_speed, ROBOT.max_accel, ctl.horizon
    assert prob.state_constants[10] == r + v_max * horizon + 0.1  # the walls' reach, as the controller had it
    for speed in [0.0, 1e-9, v_max, 2.0 * v_max] + list(rng.uniform(0.0, 1.5 * v_max, 200)):
        p0, v0 = rng.uniform([-6.0, -0.6], [6.0, 0.6]), speed * np.array([math.cos(speed), math.sin(speed)])
        ref = p0 + np.outer(TIMES, [0.5, 0.0])
        data = ctl._step_data(prob, p0, v0, ref, p0 + np.ones((1, len(TIMES), 2)), np.full(1, 0.2))
        now = math.hypot(v0[0], v0[1])
        weight, reach = 0.0, 0.0
        if braking_tail:
            top = min(v_max, now + a_max * horizon)
            weight = top / (2.0 * prob.tail_decel)
            reach = r + min(v_max * horizon, now * horizon + a_max * horizon**2 / 2) + weight * top + 0.1
        assert (data.tail_weight, data.tail_reach) == (weight, reach)


def test_braking_reach_is_braking_deviation_fully_grown():
    """The hopeless-step test's reach from the compiled scalar terms is NumPy's ``braking_deviation`` at ``inf``."""
    from nodnav.control.mpc_braking import braking_reach
    from nodnav.control.mutual_braking import braking_deviation

    rng = np.random.default_rng(6)
    cases = [(0.0, 2.0, 0.1), (0.2, 2.0, 0.1), (1e-12, 1.0, 0.05)]
    cases += [(float(rng.uniform(0.0, 2.0)), float(rng.uniform(0.5, 4.0)), float(rng.uniform(0.02, 0.3)))
              for _ in range(500)]
    for speed, decel, dt in cases:
        assert braking_reach(speed, decel, dt) == float(braking_deviation(speed, decel, dt, math.inf))


def test_brake_is_the_two_braking_profiles():
    """Braking's result from one profile over the step's end, the samples and the points within
    the step is what the two separate profiles gave, bit for bit."""
    from nodnav.control.base import STEP_FRACTIONS, ControlRequest
    from nodnav.control.braking import braking_profile
    from nodnav.control.qp import SolverEffort

    rng = np.random.default_rng(8)
    for _ in range(100):
        ctl, prob, data = _step(rng, 1)
        request = ControlRequest(position=data.p0, velocity=data.v0, reference=data.ref_local + data.p0,
                                 sample_times=TIMES, others=np.zeros((1, len(TIMES), 2)), other_radii=np.full(1, 0.2))
        out = ctl._brake(request, prob, 0.0, SolverEffort(), "test")
        a = ROBOT.max_accel
        pos, vel = braking_profile(data.p0, data.v0, a, np.concatenate([[ctl.dt], prob.sample_times]))
        assert np.array_equal(out.velocity, (pos[0] - data.p0) / ctl.dt)
        assert np.array_equal(out.next_position, pos[0]) and np.array_equal(out.next_velocity, vel[0])
        assert np.array_equal(out.planned_positions, pos[1:])
        assert np.array_equal(out.step_positions, braking_profile(data.p0, data.v0, a, ctl.dt * STEP_FRACTIONS)[0])
