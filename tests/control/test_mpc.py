"""The B-spline MPC: its pure helpers against hand values, and closed loops checked at a fine step."""

import numpy as np
import pytest

from nodnav.control import ControlRequest, bspline
from nodnav.control.bench import benchmark_mpc, queue_references
from nodnav.control.mpc import (
    BSplineMPC,
    braking_profile,
    chord_inflation,
    constraint_grid,
    initial_state_nullspace,
    interpolation_matrix,
    nearest_points_on_boxes,
    polygon_normals,
    slope_matrix,
    stopping_rows,
)
from nodnav.scenario.schema import ControllerParams, RobotSpec, load_scenario
from nodnav.scenario.world import paper_world

WORLD = paper_world()
ROBOT = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))  # radius 0.2, 1 m/s, 2 m/s^2
PARAMS = ControllerParams()  # dt 0.1, horizon 0.8, margin 0.02
TIMES = 0.1 * np.arange(1, 9)
FINE = np.linspace(0.0, PARAMS.dt, 21)
NO_OTHERS = np.zeros((0, 8, 2))


def request(p, v, reference, others=NO_OTHERS, radii=()):
    return ControlRequest(position=np.asarray(p, float), velocity=np.asarray(v, float),
                          reference=np.asarray(reference, float), sample_times=TIMES,
                          others=np.asarray(others, float), other_radii=np.asarray(radii, float))


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


def test_initial_state_nullspace():
    knots = bspline.uniform_knots(0.8, 8, 3)
    t_mat = initial_state_nullspace(knots, 3)
    assert t_mat.shape == (11, 9)
    assert np.linalg.matrix_rank(t_mat) == 9
    np.testing.assert_allclose(bspline.basis_derivative([0.0], knots, 3, 0) @ t_mat, 0.0, atol=1e-12)
    np.testing.assert_allclose(bspline.basis_derivative([0.0], knots, 3, 1) @ t_mat, 0.0, atol=1e-12)


def test_nearest_points_on_boxes_by_hand():
    boxes = np.array([[0.0, 0.0, 1.0, 1.0], [2.0, -1.0, 3.0, 0.0]])
    near = nearest_points_on_boxes(np.array([[1.5, 0.5], [0.5, 0.5]]), boxes)
    np.testing.assert_allclose(near, [[[1.0, 0.5], [2.0, 0.0]], [[0.5, 0.5], [2.0, 0.0]]])


# ---------------------------------------------------------------------------------------------
# The controller in closed loop


def closed_loop(ctl, p, v, steps, reference, obstacles=None, radii=(), check=None):
    """Apply next_position / next_velocity; ``check(t, ctl, result)`` sees every step."""
    p, v = np.asarray(p, float), np.asarray(v, float)
    results = []
    for k in range(steps):
        t = k * PARAMS.dt
        others = NO_OTHERS if obstacles is None else obstacles(t + TIMES)
        res = ctl.control(request(p, v, reference(t, p), others, radii))
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


def test_stops_behind_a_robot_standing_in_the_corridor():
    """Inside the single-file corridor there is no way round: at full speed, it must stop in time."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    standing = np.array([0.0, 0.0])
    need = 2 * ROBOT.radius + PARAMS.safety_margin

    states = []

    def check(t, ctl, res):
        assert res.success, res.reason
        assert np.linalg.norm(ctl.motion(FINE) - standing, axis=1).min() >= need - 1e-6
        assert WORLD.clearance(ctl.motion(FINE)).min() >= ROBOT.radius - 1e-9
        states.append((np.linalg.norm(res.next_velocity), np.linalg.norm(res.next_position - standing)))

    closed_loop(ctl, [-2.5, 0.0], [0.97, 0.0], 30, lambda t, p: p + TIMES[:, None] * [1.0, 0.0],
                obstacles=lambda t: np.tile(standing, (1, 8, 1)), radii=[ROBOT.radius], check=check)
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


def test_overlap_is_infeasible_and_the_robot_brakes():
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    p0, v0 = np.array([-5.0, 0.0]), np.array([0.6, 0.0])
    res = ctl.control(request(p0, v0, np.tile([-4.0, 0.0], (8, 1)),
                              others=np.tile([-4.7, 0.0], (1, 8, 1)), radii=[0.2]))
    assert not res.success
    assert "infeasible" in res.reason and "braking" in res.reason
    # Decelerating at 2 m/s^2 along +x: 0.6 -> 0.4 m/s, 0.06 - 0.01 = 0.05 m in one step.
    np.testing.assert_allclose(res.next_velocity, [0.4, 0.0])
    np.testing.assert_allclose(res.next_position, [-4.95, 0.0])
    assert np.linalg.norm(res.next_velocity) < np.linalg.norm(v0)
    assert res.info["braking"]
    # Braking continues until the robot stands, never speeding up or turning.
    speeds = []
    p, v = res.next_position, res.next_velocity
    for _ in range(4):
        res = ctl.control(request(p, v, np.tile([-4.0, 0.0], (8, 1)), others=np.tile([-4.7, 0.0], (1, 8, 1)),
                                  radii=[0.2]))
        assert not res.success and res.next_velocity[1] == 0.0 and res.next_velocity[0] >= 0.0
        speeds.append(np.linalg.norm(res.next_velocity))
        p, v = res.next_position, res.next_velocity
    assert speeds == sorted(speeds, reverse=True) and speeds[-1] == 0.0


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
        BSplineMPC(WORLD, ROBOT, ControllerParams(dt=1.0, horizon=0.8))


def test_benchmark_situation_is_consistent_and_runs():
    scenario = load_scenario("4r-case1")
    grid = np.arange(0.0, 30.0, 0.02)
    refs = queue_references(scenario.world, scenario.origins, scenario.destinations[[2, 3, 0, 1]], 0.8, 1.2, grid)
    gaps = np.linalg.norm(refs[:, :, None] - refs[:, None], axis=-1) + 10.0 * np.eye(4)
    assert gaps.min() > 2 * ROBOT.radius + PARAMS.safety_margin
    assert scenario.world.clearance(refs).min() >= ROBOT.radius
    result = benchmark_mpc(duration=2.0)
    assert result.solves == 4 * 20
    assert result.infeasible == 0
    assert result.min_separation > 0.0 and result.min_clearance >= -1e-9
    assert 0.0 < result.median <= result.p95 <= result.max
