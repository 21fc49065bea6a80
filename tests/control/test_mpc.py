"""The B-spline MPC: its pure helpers against hand values, and closed loops checked at a fine step."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import linprog

from nodnav.control import ControlRequest, bspline
from nodnav.control.interpolation import interpolation_matrix, slope_matrix
from nodnav.control.mpc import BSplineMPC, braking_profile
from nodnav.control.mpc_problem import initial_state_nullspace
from nodnav.control.mpc_rows import chord_inflation, constraint_grid, plan_extremes, polygon_normals, stopping_rows
from nodnav.control.qp import infeasibility_certificate, solve_qp
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import paper_world

WORLD = paper_world()
ROBOT = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))  # radius 0.2, 1 m/s, 2 m/s^2
PARAMS = MPCParams()  # dt 0.1, horizon 0.8
TIMES = 0.1 * np.arange(1, 9)
FINE = np.linspace(0.0, PARAMS.dt, 21)
NO_OTHERS = np.zeros((0, 8, 2))


def request(p, v, reference, others=NO_OTHERS, radii=(), margins=None):
    return ControlRequest(position=np.asarray(p, float), velocity=np.asarray(v, float),
                          reference=np.asarray(reference, float), sample_times=TIMES,
                          others=np.asarray(others, float), other_radii=np.asarray(radii, float),
                          margins=None if margins is None else np.asarray(margins, float))


# ---------------------------------------------------------------------------------------------
# Pure helpers


def test_interpolation_matrix_by_hand():
    times = np.array([0.1, 0.2, 0.4])
    values = np.array([1.0, 3.0, 4.0])
    w = interpolation_matrix(times, np.array([0.0, 0.15, 0.3, 0.4, 0.7]))
    # Before the first sample the first segment continues: 1 - (3 - 1) = -1 at t = 0.
    np.testing.assert_allclose(w @ values, [-1.0, 2.0, 3.5, 4.0, 4.0])
    np.testing.assert_allclose(w.sum(axis=1), 1.0)
    np.testing.assert_allclose(interpolation_matrix([0.3], [0.0, 0.9]) @ [2.5], [2.5, 2.5])


def test_slope_matrix_by_hand():
    times = np.array([0.1, 0.2, 0.4])
    values = np.array([1.0, 3.0, 4.0])
    assert slope_matrix(times, 0.4) @ values == pytest.approx(5.0)
    assert slope_matrix(times, 0.15) @ values == pytest.approx(20.0)
    assert slope_matrix(times, 0.5) @ values == 0.0  # held after the last sample


def test_constraint_grid_contains_samples_and_respects_the_longest_interval():
    g = constraint_grid(TIMES, 0.8, 0.05)
    np.testing.assert_allclose(g, 0.05 * np.arange(17))
    g = constraint_grid(np.array([0.13, 0.5, 0.8]), 0.8, 0.1)
    assert g[0] == 0.0 and g[-1] == pytest.approx(0.8)
    assert np.all(np.isin(np.round([0.13, 0.5], 12), np.round(g, 12)))
    assert np.diff(g).max() <= 0.1 + 1e-12 and np.all(np.diff(g) > 0)


def test_chord_inflation_is_the_deviation_of_a_parabola_from_its_chord():
    a, dt = 2.0, 0.1
    t = np.linspace(0.0, dt, 1001)
    f = 0.5 * a * t**2                      # |f''| = a everywhere: the worst case
    chord = f[0] + (f[-1] - f[0]) * t / dt
    assert np.max(np.abs(f - chord)) == pytest.approx(chord_inflation(a, dt), rel=1e-6)


@pytest.mark.parametrize("sides", [8, 16])
def test_polygon_is_inscribed_with_faces_across_the_axes(sides):
    a = polygon_normals(sides)
    inner = np.cos(np.pi / sides)
    # Adjacent faces meet on the unit circle.
    for s in range(sides):
        vertex = np.linalg.solve(np.stack([a[s], a[(s + 1) % sides]]), [inner, inner])
        assert np.linalg.norm(vertex) == pytest.approx(1.0)
    ang = np.linspace(0.0, 2.0 * np.pi, 361)
    circle = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    assert np.all((circle * inner) @ a.T <= inner + 1e-12)       # the inscribed circle is inside
    np.testing.assert_allclose(a[0], [1.0, 0.0])


def closed_distance_ramp_then_brake(s, alpha, span, decel, dt=1e-5):
    """Largest distance closed by the terminal manoeuvre, integrated numerically."""
    t = np.arange(0.0, span + 10.0, dt)
    acc = np.where(t < span, alpha + (-decel - alpha) * t / span, -decel)
    speed = s + np.concatenate([[0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1]) * dt)])
    stop = np.argmax(speed <= 0.0) if np.any(speed <= 0.0) else len(t)
    closed = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * dt)])
    return closed[: max(stop, 1)].max()


def test_stopping_rows_cover_the_ramp_and_brake_manoeuvre():
    span, decel, vmax = 0.1, 1.3, 2.0
    w_v, w_a, const = stopping_rows(span, decel, vmax, 4)
    for s in np.linspace(0.0, 1.8, 7):
        for alpha in (-1.0, 0.0, 1.0):
            s_h = s + (alpha - decel) * span / 2
            if not 0.0 <= s_h <= vmax:
                continue
            required = np.max(w_v * s + w_a * alpha + const)
            closed = closed_distance_ramp_then_brake(s, alpha, span, decel)
            assert required >= closed - 1e-6
            # The secants are exact at their ends, so the requirement is not wildly conservative.
            assert required <= closed + (vmax / 4) ** 2 / (8 * decel) + 1e-6


def test_braking_profile_by_hand():
    p, v = np.array([1.0, 2.0]), np.array([0.6, 0.8])     # speed 1 along (0.6, 0.8)
    pos, vel = braking_profile(p, v, 2.0, np.array([0.1, 0.5, 1.0]))
    np.testing.assert_allclose(vel[0], 0.8 * np.array([0.6, 0.8]))
    np.testing.assert_allclose(pos[0], p + (0.1 - 0.01) * np.array([0.6, 0.8]))
    np.testing.assert_allclose(pos[1:], np.tile(p + 0.25 * np.array([0.6, 0.8]), (2, 1)))  # stopped after 0.25 m
    np.testing.assert_allclose(vel[1:], 0.0)
    pos, vel = braking_profile(p, np.zeros(2), 2.0, np.array([0.3]))
    np.testing.assert_allclose(pos, [p])


def testplan_extremes_agree_with_the_world_and_direct_norms():
    rng = np.random.default_rng(5)
    points = np.column_stack([rng.uniform(-7.5, 7.5, 40), rng.uniform(-3.0, 3.0, 40)])  # some outside, some in walls
    rates = rng.normal(size=(12, 2))
    preds = rng.normal(size=(3, 40, 2))
    clear, closest, fastest, hardest = plan_extremes(np.vstack([points, rates]), 40, 5, WORLD.obstacle_array,
                                                      WORLD.piece_array, np.asarray(WORLD.bounds, dtype=float), preds)
    assert clear == pytest.approx(WORLD.clearance(points).min(), abs=1e-12)
    np.testing.assert_allclose(closest, np.linalg.norm(points[None] - preds, axis=-1).min(axis=1))
    assert fastest == pytest.approx(np.linalg.norm(rates[:5], axis=1).max())
    assert hardest == pytest.approx(np.linalg.norm(rates[5:], axis=1).max())


def test_initial_state_nullspace():
    knots = bspline.uniform_knots(0.8, 8, 3)
    t_mat = initial_state_nullspace(knots, 3)
    assert t_mat.shape == (11, 9)
    assert np.linalg.matrix_rank(t_mat) == 9
    np.testing.assert_allclose(bspline.basis_derivative([0.0], knots, 3, 0) @ t_mat, 0.0, atol=1e-12)
    np.testing.assert_allclose(bspline.basis_derivative([0.0], knots, 3, 1) @ t_mat, 0.0, atol=1e-12)


def test_qp_adapter_conventions_by_hand():
    """``rows @ x >= lower``, cost ``x^T H x / 2 + g^T x``, bounds on the variables, infeasibility."""
    # min (x1 - 1)^2 + (x2 - 2)^2 subject to x1 + x2 <= 2: the projection of (1, 2) onto the line
    # x1 + x2 = 2 is (0.5, 1.5).
    h, g = 2.0 * np.eye(2), np.array([-2.0, -4.0])
    sol = solve_qp(h, g, np.array([[-1.0, -1.0]]), np.array([-2.0]), 1e-9)
    assert sol.success and sol.reason == ""
    np.testing.assert_allclose(sol.x, [0.5, 1.5], atol=1e-12)
    # A row at -inf never binds: the unconstrained minimiser (1, 2).
    sol = solve_qp(h, g, np.array([[-1.0, -1.0]]), np.array([-np.inf]), 1e-9)
    np.testing.assert_allclose(sol.x, [1.0, 2.0], atol=1e-12)
    # Bounds x2 >= 2.5 on top of the row: x2 = 2.5 and x1 as close to 1 as x1 <= -0.5 allows.
    sol = solve_qp(h, g, np.array([[-1.0, -1.0]]), np.array([-2.0]), 1e-9, bounds=np.array([-np.inf, 2.5]))
    np.testing.assert_allclose(sol.x, [-0.5, 2.5], atol=1e-12)
    # x1 >= 1 and x1 <= 0 cannot both hold.
    sol = solve_qp(h, g, np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 0.0]), 1e-9)
    assert not sol.success and sol.reason == "infeasible"


def test_infeasibility_certificate_by_hand():
    """x1 >= 1 and x1 + x2 <= 0 and x2 >= 0 cannot all hold (their sum gives 0 >= 1); the rows
    x2 >= -5 and (at -inf) x1 <= -3 play no part. A consistent set has no certificate."""
    rows = np.array([[0.0, 1.0], [1.0, 0.0], [-1.0, -1.0], [0.0, 1.0], [-1.0, 0.0]])
    lower = np.array([-5.0, 1.0, 0.0, 0.0, -np.inf])
    np.testing.assert_array_equal(infeasibility_certificate(rows, lower), [1, 2, 3])
    assert infeasibility_certificate(rows[:3], lower[:3]).size == 0
    # Two parallel rows facing apart: x1 >= 1 and x1 <= 0.
    np.testing.assert_array_equal(infeasibility_certificate(np.array([[1.0], [-1.0]]), np.array([1.0, 0.0])), [0, 1])


def _feasible(rows, lower):
    """Whether some x has rows @ x >= lower, decided by HiGHS (an independent LP solver)."""
    res = linprog(np.zeros(rows.shape[1]), A_ub=-rows, b_ub=-lower, bounds=(None, None), method="highs")
    return res.status == 0


def test_infeasibility_certificate_is_an_infeasible_subsystem():
    """On random systems made infeasible by a planted contradiction (a . x >= 1 and a . x <= -1),
    the certified rows alone are infeasible (checked by HiGHS) and include the planted pair;
    consistent systems (x = 0 meets every row) get no certificate."""
    rng = np.random.default_rng(3)
    for _ in range(30):
        n, m = int(rng.integers(2, 8)), int(rng.integers(5, 40))
        rows = rng.normal(size=(m, n))
        lower = rng.normal(size=m) - 4.0  # consistent: x = 0 is 4 clear of most rows
        lower = np.minimum(lower, -0.5)
        assert infeasibility_certificate(rows, lower).size == 0
        a = rng.normal(size=n)
        bad_rows, bad_lower = np.vstack([rows, a, -a]), np.append(lower, [1.0, 1.0])
        support = infeasibility_certificate(bad_rows, bad_lower)
        assert support.size and not _feasible(bad_rows[support], bad_lower[support])
        assert {m, m + 1} <= set(support.tolist())


def test_infeasibility_certificate_without_daqp_falls_back_to_highs(monkeypatch):
    """Should DAQP not converge, the HiGHS dual LP gives the same hand-checked certificate."""
    import nodnav.control.qp as qp

    def not_converged(*args, **kwargs):
        return np.zeros(3), 0.0, -4, {"lam": np.zeros(6), "iterations": 0}

    monkeypatch.setattr(qp.daqp, "solve", not_converged)
    monkeypatch.setattr(qp, "NATIVE_DAQP", False)  # through daqp.solve, the one replaced
    rows = np.array([[0.0, 1.0], [1.0, 0.0], [-1.0, -1.0], [0.0, 1.0], [-1.0, 0.0]])
    lower = np.array([-5.0, 1.0, 0.0, 0.0, -np.inf])
    np.testing.assert_array_equal(qp.infeasibility_certificate(rows, lower), [1, 2, 3])


def test_softened_rows_are_the_soft_groups_rows_only():
    """Softening the last robot must not soften the static rows (box, speed, acceleration): they
    belong to no group (a negative group index must not wrap round to the last one)."""
    prob = BSplineMPC(WORLD, ROBOT, PARAMS)._problem(2, TIMES)
    soft = np.zeros(prob.n_groups, dtype=bool)
    soft[-1] = True
    rows = prob.softened_rows(soft)
    assert not rows[:prob.n_static].any()
    assert rows.sum() == prob.rows_per_group
    assert (np.flatnonzero(rows) >= prob.n_separation - prob.rows_per_group).all()
    assert not prob.softened_rows(np.zeros(prob.n_groups, dtype=bool)).any()


def test_rows_with_a_private_slack_never_enter_a_certificate():
    """Why the evasive QP's soft set is grown on the hard rows alone: a row ``a . x + s >= b``
    with ``s >= 0`` can always be met by raising ``s``, so no Farkas certificate uses it. Here
    x >= 1 and x <= 0 conflict (hard); the softened x >= 5 and x <= -5 must not be named."""
    # Variables (x, s1, s2); rows: hard x >= 1, hard -x >= 0, soft x + s1 >= 5, soft -x + s2 >= 5, s >= 0.
    rows = np.array([[1.0, 0, 0], [-1.0, 0, 0], [1.0, 1, 0], [-1.0, 0, 1], [0, 1.0, 0], [0, 0, 1.0]])
    lower = np.array([1.0, 0.0, 5.0, 5.0, 0.0, 0.0])
    np.testing.assert_array_equal(infeasibility_certificate(rows, lower), [0, 1])
    # Without the hard pair the system is feasible whatever the soft rows demand.
    assert infeasibility_certificate(rows[2:], lower[2:]).size == 0


# ---------------------------------------------------------------------------------------------
# The controller in closed loop


def closed_loop(ctl, p, v, steps, reference, obstacles=None, radii=(), check=None, margins=None):
    """Apply next_position / next_velocity; ``check(t, ctl, result)`` sees every step."""
    p, v = np.asarray(p, float), np.asarray(v, float)
    results = []
    for k in range(steps):
        t = k * PARAMS.dt
        others = NO_OTHERS if obstacles is None else obstacles(t + TIMES)
        res = ctl.control(request(p, v, reference(t, p), others, radii, margins))
        if check is not None:
            check(t, ctl, res)
        results.append(res)
        p, v = res.next_position, res.next_velocity
    return p, v, results


def test_tracks_a_straight_reference_within_a_centimetre():
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    start = np.array([-6.0, 1.0])
    line = lambda t: start + 0.5 * t[:, None] * np.array([1.0, 0.0])  # noqa: E731
    errors = []

    def check(t, ctl, res):
        assert res.success
        errors.append(np.linalg.norm(res.next_position - line(np.array([t + PARAMS.dt]))[0]))

    closed_loop(ctl, start, [0.0, 0.0], 30, lambda t, p: line(t + TIMES), check=check)
    assert max(errors[10:]) < 0.01


def test_speed_and_acceleration_limits_hold_everywhere():
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    goal = np.array([-1.5, 1.8])                       # 5 m away, in the room's corner direction
    whole = np.linspace(0.0, PARAMS.horizon, 321)
    peak = []

    def check(t, ctl, res):
        assert res.success
        vel = ctl.motion(whole, 1)
        acc = np.diff(vel, axis=0) / np.diff(whole)[:, None]
        assert np.linalg.norm(vel, axis=1).max() <= ROBOT.max_speed + 1e-9
        assert np.linalg.norm(acc, axis=1).max() <= ROBOT.max_accel + 1e-6
        peak.append(np.linalg.norm(vel, axis=1).max())

    closed_loop(ctl, [-6.0, 0.0], [0.0, 0.0], 40, lambda t, p: np.tile(goal, (8, 1)), check=check)
    assert max(peak) > 0.9 * ROBOT.max_speed           # it does drive fast


def test_initial_position_and_velocity_hold_exactly():
    rng = np.random.default_rng(1)
    for _ in range(5):
        p0 = np.array([rng.uniform(-6.0, -4.0), rng.uniform(-1.5, 1.5)])
        v0 = rng.uniform(-0.6, 0.6, size=2)
        ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
        res = ctl.control(request(p0, v0, p0 + rng.normal(scale=0.3, size=(8, 2))))
        assert res.success
        np.testing.assert_allclose(ctl.motion([0.0])[0], p0, atol=1e-12)
        np.testing.assert_allclose(ctl.motion([0.0], 1)[0], v0, atol=1e-12)
        np.testing.assert_allclose(res.next_position, ctl.motion([PARAMS.dt])[0], atol=1e-12)
        np.testing.assert_allclose(res.next_velocity, ctl.motion([PARAMS.dt], 1)[0], atol=1e-12)
        np.testing.assert_allclose(res.velocity, (res.next_position - p0) / PARAMS.dt)
        np.testing.assert_allclose(res.planned_positions, ctl.motion(TIMES), atol=1e-12)


@pytest.mark.parametrize("offset", [0.0, 0.05])
def test_never_closes_in_on_a_robot_coming_head_on(offset):
    """A robot drives at 0.5 m/s along the same line towards ours, whose reference (re-planned
    from where it is, ignoring the other) pushes it forward at 0.8 m/s; the other never yields."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    other = lambda t: np.stack([-2.5 - 0.5 * np.asarray(t), np.full(np.shape(t), offset)], axis=-1)  # noqa: E731
    need = 2 * ROBOT.radius + PARAMS.safety_margin

    def check(t, ctl, res):
        assert res.success, res.reason
        gap = np.linalg.norm(ctl.motion(FINE) - other(t + FINE), axis=1)
        assert gap.min() >= need - 1e-6
        assert np.linalg.norm(res.planned_positions - other(t + TIMES), axis=1).min() >= need - 1e-6

    closed_loop(ctl, [-5.0, 0.0], [0.0, 0.0], 45,
                lambda t, p: p + 0.8 * TIMES[:, None] * np.array([1.0, 0.0]),
                obstacles=lambda t: other(t)[None], radii=[ROBOT.radius], check=check)


@pytest.mark.parametrize("margin", [None, 0.031, 0.1])
def test_stops_behind_a_robot_standing_in_the_corridor(margin):
    """Inside the single-file corridor there is no way round: at full speed, it must stop in time,
    as close as the request's margin allows (the controller's own without one)."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    standing = np.array([0.0, 0.0])
    need = 2 * ROBOT.radius + (PARAMS.safety_margin if margin is None else margin)

    states = []

    def check(t, ctl, res):
        assert res.success, res.reason
        assert np.linalg.norm(ctl.motion(FINE) - standing, axis=1).min() >= need - 1e-6
        assert WORLD.clearance(ctl.motion(FINE)).min() >= ROBOT.radius - 1e-9
        states.append((np.linalg.norm(res.next_velocity), np.linalg.norm(res.next_position - standing)))

    closed_loop(ctl, [-2.5, 0.0], [0.97, 0.0], 40, lambda t, p: p + TIMES[:, None] * [1.0, 0.0],
                obstacles=lambda t: np.tile(standing, (1, 8, 1)), radii=[ROBOT.radius], check=check,
                margins=None if margin is None else [margin])
    speed, gap = states[-1]
    assert speed < 0.01 and gap < need + 0.01           # stopped, close behind


def test_never_plans_into_a_wall_at_a_corner():
    """The reference cuts straight through the corner of the corridor's upper wall."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    start, goal = np.array([-4.5, 1.0]), np.array([0.0, 0.0])
    u = (goal - start) / np.linalg.norm(goal - start)

    def check(t, ctl, res):
        assert res.success, res.reason
        assert WORLD.clearance(ctl.motion(FINE)).min() >= ROBOT.radius - 1e-9
        assert WORLD.clearance(res.planned_positions).min() >= ROBOT.radius - 1e-9

    p, _, _ = closed_loop(ctl, start, [0.0, 0.0], 50,
                          lambda t, p: start + np.minimum(t + TIMES, 4.5)[:, None] * u, check=check)
    assert WORLD.in_corridor(p)                          # it went round the corner, into the corridor


def test_overlap_triggers_the_evasive_plan_which_backs_out():
    """Already overlapping another robot's prediction: the tracking QP is skipped, and the evasive
    plan sheds the speed towards it and backs out until the margin is restored."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    p, v = np.array([-5.0, 0.0]), np.array([0.6, 0.0])
    other = np.array([-4.7, 0.0])
    need = 2 * ROBOT.radius + PARAMS.safety_margin
    results = []
    for _ in range(15):
        res = ctl.control(request(p, v, np.tile([-4.0, 0.0], (8, 1)), others=np.tile(other, (1, 8, 1)), radii=[0.2]))
        assert WORLD.clearance(ctl.motion(FINE)).min() >= ROBOT.radius - 1e-9
        results.append(res)
        p, v = res.next_position, res.next_velocity
    first = results[0]
    assert not first.success and first.reason.startswith("infeasible: evasive: overlapping robot 0")
    assert first.info["fallback"] == "evasive" and first.info["intrusion"] > 0.0
    # It brakes at least as hard as the acceleration polygon allows (0.92 of 2 m/s^2 over 0.1 s).
    assert first.next_velocity[0] <= 0.6 - 0.92 * 2.0 * 0.1 + 1e-6
    gaps = np.array([np.linalg.norm(r.next_position - other) for r in results])
    out = int(np.argmax(gaps >= need))
    assert gaps[out] >= need and results[-1].success      # out of the disc, back to tracking
    turn = int(np.argmin(gaps))
    assert turn < out and np.all(np.diff(gaps[turn:out + 1]) > 0)   # once stopped, it backs straight out
    assert all(r.info["fallback"] == "evasive" for r in results[:out])


def test_evasive_plan_keeps_clear_of_a_robot_it_can_avoid_while_another_forces_an_intrusion():
    """Robot A overlaps ours now and drives off at 1 m/s: intruding into A's disc at first is
    unavoidable. Robot B stands 0.5 m below, and the reference pulls through B. Keeping clear of
    B costs tracking alone, so the evasive plan keeps B's whole margin at every instant and
    intrudes into A no more than it would with B absent, where it would drive deep into B's disc."""
    need = 2 * ROBOT.radius + PARAMS.safety_margin
    a = np.array([-4.7, 0.0]) + TIMES[:, None] * [1.0, 0.0]
    b = np.array([-5.0, -0.5])
    whole = np.linspace(0.0, PARAMS.horizon, 161)

    def evade(others):
        ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
        res = ctl.control(request([-5.0, 0.0], [0.0, 0.0], np.tile([-5.0, -1.2], (8, 1)), others=others,
                                  radii=[ROBOT.radius] * len(others)))
        assert not res.success and res.reason.startswith("infeasible: evasive: overlapping robot 0")
        assert WORLD.clearance(ctl.motion(whole)).min() >= ROBOT.radius - 1e-9
        return res, np.linalg.norm(ctl.motion(whole) - b, axis=1).min()

    res, closest_b = evade(np.stack([a, np.tile(b, (8, 1))]))
    assert res.info["intruded"] == [0] and res.info["intrusion"] > 0.05
    assert closest_b >= need - 1e-4
    alone, closest_b_alone = evade(a[None])
    assert closest_b_alone < need - 0.2                  # B is in the way of tracking
    assert res.info["intrusion"] == pytest.approx(alone.info["intrusion"], abs=1e-3)


def test_firm_predictions_are_softened_only_when_nothing_else_is_left():
    """At 1 m/s in the corridor, 0.45 m behind a robot standing still: no plan keeps the margin
    (stopping takes 0.25 m). Firm or not, that robot's prediction is the only one to soften; the
    evasive plan softens a firm one only once keeping it hard has failed, and says so."""
    p, v = [-1.0, 0.0], [1.0, 0.0]
    ahead = np.tile([-0.55, 0.0], (1, 8, 1))
    for firm in (False, True):
        ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
        req = replace(request(p, v, np.tile([1.0, 0.0], (8, 1)), others=ahead, radii=[0.2]), firm=np.array([firm]))
        res = ctl.control(req)
        assert not res.success and res.info["fallback"] == "evasive"
        assert res.info["firm_softened"] is firm and res.info["intruded"] == [0]


def test_evasive_plan_keeps_clear_of_a_firm_prediction_when_it_can():
    """Robot A overlaps ours now and drives off (an intrusion into it is unavoidable); B, firm,
    stands 0.5 m below, where the reference pulls: B is kept clear, nothing firm is softened."""
    need = 2 * ROBOT.radius + PARAMS.safety_margin
    a = np.array([-4.7, 0.0]) + TIMES[:, None] * [1.0, 0.0]
    b = np.array([-5.0, -0.5])
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    req = replace(request([-5.0, 0.0], [0.0, 0.0], np.tile([-5.0, -1.2], (8, 1)), others=np.stack([a, np.tile(b, (8,
                                                                                                                  1))]),
                          radii=[0.2, 0.2]), firm=np.array([False, True]))
    res = ctl.control(req)
    assert not res.success and res.info["fallback"] == "evasive" and not res.info["firm_softened"]
    whole = np.linspace(0.0, PARAMS.horizon, 161)
    assert np.linalg.norm(ctl.motion(whole) - b, axis=1).min() >= need - 1e-4


def test_brakes_when_no_plan_keeps_clear_of_a_wall():
    """5 cm from the upper bound at 1 m/s towards it: no plan can stop in time (0.27 m at
    1.85 m/s^2), no other robot is involved, so the robot brakes along its velocity."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    res = ctl.control(request([-5.0, 2.25], [0.0, 1.0], np.tile([-5.0, 2.5], (8, 1))))
    assert not res.success and res.reason.startswith("infeasible: braking") and res.info["fallback"] == "braking"
    # Decelerating at 2 m/s^2 along +y: 1 -> 0.8 m/s, 0.1 - 0.01 = 0.09 m in one step.
    np.testing.assert_allclose(res.next_velocity, [0.0, 0.8])
    np.testing.assert_allclose(res.next_position, [-5.0, 2.34])


def scripted_encounter(settings, steps=30):
    """Robot A (our controller) moving at 0.5 m/s along +x, holding position as its reference;
    robot B drives straight at it at 1 m/s and never yields. A's prediction of B is exact
    (constant velocity). Returns (closest centre distance along the motion, results)."""
    ctl = BSplineMPC(WORLD, ROBOT, settings)
    p, v = np.array([-5.0, 0.0]), np.array([0.5, 0.0])
    b0, vb = np.array([-3.9, 0.0]), np.array([-1.0, 0.0])
    sub = np.linspace(0.0, 1.0, 11)[:, None]
    closest, results = np.inf, []
    for k in range(steps):
        b = b0 + vb * k * PARAMS.dt
        res = ctl.control(request(p, v, np.tile([-5.0, 0.0], (8, 1)), others=(b + TIMES[:, None] * vb)[None],
                                  radii=[ROBOT.radius]))
        assert WORLD.clearance(ctl.motion(FINE)).min() >= ROBOT.radius - 1e-9
        path = p + sub * (res.next_position - p)
        closest = min(closest, np.linalg.norm(path - (b + sub * vb * PARAMS.dt), axis=1).min())
        results.append(res)
        p, v = res.next_position, res.next_velocity
    return closest, results


def test_moves_away_from_an_approaching_robot_instead_of_braking_into_it():
    contact = 2 * ROBOT.radius
    closest, results = scripted_encounter(MPCParams())
    failed = [r for r in results if not r.success]
    assert failed and all(r.info["fallback"] == "evasive" for r in failed)
    assert closest >= contact - 1e-3                     # it got out of the way
    # At the first failure the evasive plan keeps farther from B at every sample than braking
    # along the velocity would: it steers away instead of rolling on into B's path.
    k = next(i for i, r in enumerate(results) if not r.success)
    b = np.array([-3.9, 0.0]) + np.array([-1.0, 0.0]) * (k * PARAMS.dt + TIMES[:, None])
    p_k = results[k - 1].next_position if k else np.array([-5.0, 0.0])
    v_k = results[k - 1].next_velocity if k else np.array([0.5, 0.0])
    braked, _ = braking_profile(p_k, v_k, ROBOT.max_accel, TIMES)
    evasive_gap = np.linalg.norm(results[k].planned_positions - b, axis=1)
    braking_gap = np.linalg.norm(braked - b, axis=1)
    assert np.all(evasive_gap >= braking_gap - 1e-9) and evasive_gap[-1] > braking_gap[-1] + 0.1
    # The earlier fallback, braking at once, stays in B's path and is hit.
    closest_braking, results_braking = scripted_encounter(MPCParams(evasive=False, braking_tail=False))
    assert any(r.info["fallback"] == "braking" for r in results_braking)
    assert closest_braking < contact - 0.1


def crossing(settings, steps=60):
    """Two robots of ours cross the left room on paths 120 degrees apart at 0.8 m/s. Each is told
    the other will stand still where it is seen (the paper's prediction for a robot outside its
    game, wrong here) and, as the simulator adds, where it goes at its observed velocity.
    The safety margin is a thin 2 cm, with which braking alone is not enough.
    Returns (closest centre distance along the motion, number of evasive steps)."""
    ctls = [BSplineMPC(WORLD, ROBOT, replace(settings, safety_margin=0.02)) for _ in range(2)]
    centre, u = np.array([-5.2, 0.0]), np.array([np.cos(np.radians(120)), np.sin(np.radians(120))])
    pos = np.array([centre - [1.2, 0.0], centre + 1.2 * u])
    goals = np.array([centre + [1.5, 0.0], centre - 1.5 * u])
    vel = np.zeros((2, 2))
    sub = np.linspace(0.0, 1.0, 11)[:, None]
    closest, evasive = np.inf, 0
    for _ in range(steps):
        new_pos, new_vel = pos.copy(), vel.copy()
        for i in range(2):
            j = 1 - i
            direction = goals[i] - pos[i]
            dist = np.linalg.norm(direction)
            ref = pos[i] + np.minimum(0.8 * TIMES, dist)[:, None] * direction / max(dist, 1e-9)
            others = np.stack([np.tile(pos[j], (8, 1)), pos[j] + TIMES[:, None] * vel[j]])
            res = ctls[i].control(request(pos[i], vel[i], ref, others=others, radii=[ROBOT.radius] * 2))
            evasive += res.info["fallback"] == "evasive"
            new_pos[i], new_vel[i] = res.next_position, res.next_velocity
        a = pos[0] + sub * (new_pos[0] - pos[0])
        b = pos[1] + sub * (new_pos[1] - pos[1])
        closest = min(closest, np.linalg.norm(a - b, axis=1).min())
        pos, vel = new_pos, new_vel
    return closest, evasive, np.linalg.norm(pos - goals, axis=1).max()


def test_two_robots_driving_at_each_other_keep_apart_with_the_evasive_fallback():
    contact = 2 * ROBOT.radius
    closest, evasive, left = crossing(MPCParams())
    assert evasive > 0 and closest >= contact - 1e-3
    assert left < 0.05                                   # both got through
    closest_braking, _, _ = crossing(MPCParams(evasive=False, braking_tail=False))
    assert closest_braking < contact - 1e-3              # braking along the velocity collides


def test_malformed_requests_raise():
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    with pytest.raises(ValueError):
        ctl.control(request([-5.0, 0.0], [0.0, 0.0], np.zeros((7, 2))))
    with pytest.raises(ValueError):
        ctl.control(ControlRequest(np.array([-5.0, 0.0]), np.zeros(2), np.zeros((8, 2)), TIMES + 0.5,
                                   NO_OTHERS, np.zeros(0)))
    with pytest.raises(ValueError):
        ctl.control(request([-5.0, 0.0], [0.0, 0.0], np.zeros((8, 2)), others=np.zeros((1, 8, 2)), radii=[]))
    with pytest.raises(ValueError):
        ctl.control(replace(request([-5.0, 0.0], [0.0, 0.0], np.zeros((8, 2))), firm=np.array([True])))
    for margins in ([0.02, 0.02], [-0.01], [np.nan]):  # one clearance >= 0 per prediction
        with pytest.raises(ValueError):
            ctl.control(request([-5.0, 0.0], [0.0, 0.0], np.zeros((8, 2)), others=np.full((1, 8, 2), 3.0),
                                radii=[0.2], margins=margins))
    with pytest.raises(ValueError):
        BSplineMPC(WORLD, ROBOT, MPCParams(dt=1.0, horizon=0.8))


def test_whitened_qp_has_the_plain_qps_cost_and_minimiser():
    """The QP's variables are whitened (``y = R z``, ``R^T R`` the cost's Hessian on the free
    control points): the cost ``y^T y / 2`` must be the tracking cost's quadratic part on the
    control points, and the minimiser must be the plain QP's (Hessian ``2 N^T G N`` on ``z``,
    solved by DAQP without whitening) up to rounding."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    prob = ctl._problem(1, TIMES)
    setup = prob.setup
    # c = free_map y: y^T y / 2 = c^T G c with G the Gram matrix (the cost is c^T G c, Hessian 2 G).
    assert np.allclose(2.0 * prob.free_map.T @ setup.cost_hessian @ prob.free_map, np.eye(prob.nz), atol=1e-10)
    # R from the plain Hessian on z: free_map = nullspace @ R^{-1}.
    r = np.linalg.lstsq(prob.free_map, setup.nullspace, rcond=None)[0]
    rng = np.random.default_rng(3)
    p0, v0 = np.array([-2.0, 0.1]), np.array([0.6, 0.05])
    ref = p0 + np.outer(TIMES, [0.9, 0.0])
    other = np.array([[1.0, -0.1]]) + np.outer(TIMES, [-0.5, 0.0])[None]
    data = ctl._step_data(prob, p0, v0, ref, other, np.array([0.2]))
    for _ in range(5):
        lin = prob.interp_ends @ ref + rng.normal(0.0, 0.05, (len(prob.ends), 2))
        lower = prob.write_separation(data, lin, True, data.need)
        sol = solve_qp(prob.hessian, prob.gradient(data.v0, data.ref_local), prob.rows, lower, PARAMS.qp_tolerance)
        assert sol.success
        big_r = np.kron(np.eye(2), r)
        p_half = setup.nullspace.T @ setup.cost_hessian @ setup.nullspace
        plain_h = np.kron(np.eye(2), 2.0 * p_half)
        # The plain gradient from the cost's definition: 2 (v0_d q - W ref_d) with q, W on z.
        inner = setup.knots[(setup.knots > 0) & (setup.knots < setup.horizon)]
        breaks = np.concatenate([[0.0, setup.horizon], inner, TIMES[TIMES < setup.horizon]])
        nodes, weights = bspline.gauss_legendre(breaks, 4)
        w_ref = setup.nullspace.T @ bspline.basis(nodes, setup.knots, 3).T @ (
            weights[:, None] * interpolation_matrix(TIMES, nodes))
        q = setup.nullspace.T @ setup.cost_hessian @ setup.greville
        plain_g = (2.0 * (q[:, None] * v0 - w_ref @ data.ref_local)).T.ravel()
        plain = solve_qp(plain_h, plain_g, prob.rows @ big_r, lower, PARAMS.qp_tolerance)
        assert plain.success
        assert np.allclose(np.linalg.solve(big_r, sol.x), plain.x, rtol=1e-9, atol=1e-9)
        c_plain = p0 + setup.greville[:, None] * v0 + setup.nullspace @ plain.x.reshape(2, -1).T
        assert np.allclose(prob.control_points(data, sol.x), c_plain, rtol=0.0, atol=1e-9)
