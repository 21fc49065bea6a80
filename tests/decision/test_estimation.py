"""Opinion estimation from observed motion, eq. (4)."""

import numpy as np
import pytest

from nodnav.decision.estimation import (
    estimate_social_term,
    estimated_opinions,
    mismatch_predictions,
    reachable_predictions,
)


def straight_line(start, velocity, times):
    """States (px, py, vx, vy) of constant-velocity motion, shape (M, 4)."""
    start, velocity = np.asarray(start, float), np.asarray(velocity, float)
    p = start[None, :] + times[:, None] * velocity[None, :]
    return np.concatenate([p, np.broadcast_to(velocity, p.shape)], axis=1)


@pytest.fixture
def window():
    T, M = 1.0, 11
    return np.linspace(0.0, T, M), T / (M - 1)


def test_matching_prediction_scores_zero_and_highest(window):
    times, dt = window
    observed = np.stack([straight_line([-4, 0], [1, 0], times), straight_line([4, 1], [-0.5, 0], times)])
    planned = np.stack([
        np.stack([straight_line([-4, 0], [0, 0], times), straight_line([4, 1], [-0.5, 0], times)]),
        observed,  # strategy 1 predicted both robots exactly
        np.stack([straight_line([-4, 0.2], [1, 0], times), straight_line([4, 1], [0, 0], times)]),
    ])
    z = estimated_opinions(observed, planned, dt, K1=5.0)
    assert z.shape == (2, 3)
    assert np.all(z <= 0)
    np.testing.assert_array_equal(z[:, 1], 0.0)
    np.testing.assert_array_equal(z[1, 0], 0.0)  # robot 1's prediction under strategy 0 was exact too
    r = estimate_social_term(z)
    assert np.all(r[:, 1] == r.max(axis=1))
    assert np.all((r >= 0) & (r <= 1))


@pytest.mark.parametrize("T,M", [(1.0, 11), (2.5, 6), (0.3, 2)])
def test_constant_offset_gives_minus_K1_e2_T(T, M):
    # ||X - X'||^2 = e^2 at every instant, so the integral is exactly -K1 e^2 T.
    times = np.linspace(0.0, T, M)
    e = np.array([0.3, -0.4])  # |e| = 0.5
    observed = straight_line([1, 2], [0.7, -0.2], times)[None]
    planned = observed.copy()
    planned[..., :2] += e
    z = estimated_opinions(observed, planned[None], T / (M - 1), K1=5.0)
    np.testing.assert_allclose(z, [[-5.0 * 0.25 * T]], rtol=1e-14)


def test_velocity_deviation_counts_like_position():
    times = np.linspace(0.0, 2.0, 21)
    observed = straight_line([0, 0], [1, 0], times)[None]
    planned = observed.copy()
    planned[..., 2:] += np.array([0.0, 0.2])  # velocity off by 0.2 m/s, positions as observed
    z = estimated_opinions(observed, planned[None], 0.1, K1=2.0)
    np.testing.assert_allclose(z, [[-2.0 * 0.04 * 2.0]], rtol=1e-13)


def test_linearly_growing_deviation_matches_the_trapezoid_formula():
    # Deviation c*tau in x over [0, T]: the exact integral is c^2 T^3 / 3; the trapezoidal rule
    # with step h adds c^2 T h^2 / 6 (its error term (T h^2 / 12) f'' with f'' = 2 c^2).
    c, T, M = 0.8, 1.5, 16
    h = T / (M - 1)
    times = np.linspace(0.0, T, M)
    observed = straight_line([0, 0], [1, 0], times)[None]
    planned = observed.copy()
    planned[..., 0] += c * times
    planned[..., 2] += c  # the planned velocity differs by c as well
    z = estimated_opinions(observed, planned[None], h, K1=1.0)
    expected = -(c**2 * T**3 / 3 + c**2 * T * h**2 / 6 + c**2 * T)
    np.testing.assert_allclose(z, [[expected]], rtol=1e-13)


def test_larger_deviation_means_lower_estimate(window):
    times, dt = window
    observed = straight_line([0, 0], [1, 0], times)[None]
    offsets = np.array([0.0, 0.1, 0.5, 1.0])
    planned = np.stack([observed + np.array([0, off, 0, 0]) for off in offsets])
    z = estimated_opinions(observed, planned, dt)
    assert np.all(np.diff(z[0]) < 0)
    np.testing.assert_allclose(z[0], -5.0 * offsets**2 * 1.0, rtol=1e-13)


def test_social_term_hand_values():
    # z' = (0, -2, -4): mean -2, zbar' = (2, 0, -2), r = R(zbar').
    r = estimate_social_term(np.array([[0.0, -2.0, -4.0]]))
    R2 = 0.5 * (np.tanh(2.0) + 1)
    np.testing.assert_allclose(r, [[R2, 0.5, 1 - R2]], rtol=1e-14)


def test_social_term_is_shift_invariant_per_robot():
    z = np.array([[-1.0, -3.0], [-10.0, -10.0]])
    np.testing.assert_allclose(estimate_social_term(z - np.array([[5.0], [2.0]])), estimate_social_term(z))
    np.testing.assert_allclose(estimate_social_term(z)[1], [0.5, 0.5])


def test_shape_errors_are_reported():
    with pytest.raises(ValueError):
        estimated_opinions(np.zeros((2, 5, 4)), np.zeros((3, 2, 4, 4)), 0.1)
    with pytest.raises(ValueError):
        estimated_opinions(np.zeros((5, 4)), np.zeros((3, 5, 4)), 0.1)
    with pytest.raises(ValueError):
        estimated_opinions(np.zeros((2, 5, 4)), np.zeros((3, 2, 5, 4)), 0.0)


def test_strategies_without_a_plan_get_no_support_and_the_rest_are_centred_among_themselves():
    # Three strategies; the second has no joint path. The other two, -1 and -3, are centred on
    # their own mean -2: +1 and -1.
    z_prime = np.array([[-1.0, 0.0, -3.0]])
    r = estimate_social_term(z_prime, np.array([True, False, True]))
    expected = 0.5 * (np.tanh(np.array([1.0, -1.0])) + 1.0)
    np.testing.assert_allclose(r[0, [0, 2]], expected)
    assert r[0, 1] == 0.0
    # No strategy with a plan: no evidence, R(0) = 1/2 everywhere.
    np.testing.assert_allclose(estimate_social_term(z_prime, np.zeros(3, dtype=bool)), 0.5)


def test_reachable_prediction_of_a_feasible_plan_is_the_plan(window):
    # A plan the robot can follow from where it is (same start, same constant velocity) is unchanged.
    times, dt = window
    observed = straight_line([-4, 0], [1, 0.5], times)[None]
    planned = observed[None].copy()
    assert np.allclose(reachable_predictions(observed, planned, np.array([2.0]), dt), planned)


def test_reachable_reversal_brakes_first(window):
    # Observed at -1 m/s, the plan backs out at +1 m/s from the start; with a = 2 m/s^2 the robot
    # stops after 0.5 s, having moved -1 * 0.5 + 2 * 0.5^2 / 2 = -0.25 m, and is back where it
    # started at +1 m/s after 1 s (uniform acceleration: x(t) = -t + t^2).
    times, dt = window
    observed = straight_line([0, 0], [-1, 0], times)[None]
    planned = straight_line([0, 0], [1, 0], times)[None, None]
    out = reachable_predictions(observed, planned, np.array([2.0]), dt)[0, 0]
    assert np.allclose(out[:, 0], -times + times ** 2)
    assert np.allclose(out[:, 2], np.clip(-1 + 2 * times, -1, 1))
    # Eq. (4) now matches a robot that brakes to back out with the plan that backs out, not with
    # the one that keeps going (which the raw plans got wrong).
    keep_going = straight_line([0, 0], [-1, 0], times)[None, None]
    both = np.concatenate([planned, keep_going])
    braking = np.stack([-times + times ** 2, np.zeros_like(times), -1 + 2 * times, np.zeros_like(times)], axis=1)[None]
    raw = estimated_opinions(braking, both, dt)
    reach = estimated_opinions(braking, reachable_predictions(braking, both, np.array([2.0]), dt), dt)
    assert raw[0, 1] > raw[0, 0]  # the raw plans read the braking robot as keeping going
    assert reach[0, 0] > reach[0, 1]  # the reachable ones as backing out


def test_reachable_speed_change_is_limited_by_each_robots_accel(window):
    # Two robots at rest told to go at 1 m/s: with a = 0.5 and 4 m/s^2 their speeds after 0.2 s
    # are 0.1 and 0.8 m/s (a t), capped at 1 m/s.
    times, dt = window
    observed = np.stack([straight_line([0, 0], [0, 0], times), straight_line([5, 0], [0, 0], times)])
    planned = np.stack([straight_line([0, 0], [1, 0], times), straight_line([5, 0], [0, 1], times)])[None]
    out = reachable_predictions(observed, planned, np.array([0.5, 4.0]), dt)[0]
    assert np.allclose(out[0, :, 2], np.minimum(0.5 * times, 1.0))
    assert np.allclose(out[1, :, 3], np.minimum(4.0 * times, 1.0))
    assert np.allclose(out[0, 2, 0], 0.5 * 0.5 * 0.2 ** 2)


def test_mismatch_predictions_do_not_count_the_acceleration_limit_twice():
    # A plan timed within a = 2 m/s^2 from rest (planner.timing: feasible), as plans are sampled:
    # the velocity of sample m is that of step m, v_m = a dt (m + 1); positions x_m = a dt^2 m (m + 1) / 2.
    # The robot observed at the start of the window is at rest (v = 0), at x = 0.
    dt, a, m = 0.1, 2.0, np.arange(11)
    plan = np.stack([a * dt**2 * m * (m + 1) / 2, 0 * m, a * dt * (m + 1), 0 * m], axis=-1)[None, None].astype(float)
    observed = np.zeros((1, 11, 4))
    # Mismatch: the error of a dt in velocity is gone after one step; the position stays a dt^2 / 2 behind.
    out = mismatch_predictions(observed, plan, np.array([a]), dt)
    assert np.allclose(out[0, 0, 1:, 0], plan[0, 0, 1:, 0] - a * dt**2 / 2)
    assert np.allclose(out[0, 0, 1:, 2], plan[0, 0, 1:, 2])
    # Chasing the planned velocity at the limit lags one step for good: v = a dt m, x = a dt^2 m^2 / 2,
    # a deficit of a dt^2 m / 2 that grows over the window (0.1 m after 1 s).
    lag = reachable_predictions(observed, plan, np.array([a]), dt)
    assert np.allclose(lag[0, 0, :, 2], a * dt * m)
    assert np.allclose(lag[0, 0, :, 0], a * dt**2 * m**2 / 2)


def test_mismatch_predictions_brake_a_robot_moving_against_a_plan_at_rest():
    # Observed moving at 1 m/s along x; the plan holds it at rest. At a = 2 m/s^2 it stops in
    # 0.5 s after 0.25 m (1^2 / (2 a)), then stays (hand computation, trapezoidal positions exact).
    dt, a = 0.1, 2.0
    plan = np.zeros((1, 1, 11, 4))
    observed = np.zeros((1, 11, 4))
    observed[0, 0, 2] = 1.0
    out = mismatch_predictions(observed, plan, np.array([a]), dt)
    assert np.allclose(out[0, 0, :, 2], np.maximum(1.0 - a * np.arange(11) * dt, 0.0))
    assert np.isclose(out[0, 0, -1, 0], 0.25)
    # The same as reachable_predictions when the plan's velocity is constant.
    assert np.allclose(out, reachable_predictions(observed, plan, np.array([a]), dt))


def test_mismatch_predictions_compiled_equals_the_plain_computation_bit_for_bit():
    from nodnav.decision.estimation import mismatch_predictions, mismatch_predictions_plain

    rng = np.random.default_rng(11)
    for _ in range(200):
        g, n, m = (int(v) for v in rng.integers(1, [7, 4, 12]))
        observed = rng.normal(size=(n, m, 4))
        # Small and large velocity errors: below and above one step's acceleration.
        planned = rng.normal(size=(g, n, m, 4)) * rng.choice([0.01, 1.0, 3.0])
        accel = rng.uniform(0.1, 3.0, size=n)
        assert mismatch_predictions(observed, planned, accel, 0.1).tobytes() == \
            mismatch_predictions_plain(observed, planned, accel, 0.1).tobytes()
