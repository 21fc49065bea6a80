"""The predictions a planned method gives its MPC."""

import numpy as np
import pytest

from nodnav.sim.methods import braking_extrapolation, horizon_predictions


def test_braking_extrapolation_stops_after_the_braking_distance():
    # 1 m/s braking at 2 m/s^2: stops after 0.5 s, 0.25 m on; before that it has gone t - t^2.
    times = np.array([0.1, 0.25, 0.5, 0.8])
    got = braking_extrapolation(np.array([[1.0, 2.0]]), np.array([[0.0, -1.0]]), np.array([2.0]), times)
    travelled = np.array([0.1 - 0.01, 0.25 - 0.0625, 0.25, 0.25])
    assert got.shape == (1, 4, 2)
    assert got[0, :, 0] == pytest.approx(np.ones(4))
    assert got[0, :, 1] == pytest.approx(2.0 - travelled)


def test_braking_extrapolation_holds_a_robot_at_rest():
    got = braking_extrapolation(np.array([[0.5, 0.0], [1.0, 1.0]]), np.zeros((2, 2)), np.array([2.0, 1.0]),
                                np.array([0.1, 0.8]))
    assert np.array_equal(got, np.repeat([[[0.5, 0.0]], [[1.0, 1.0]]], 2, axis=1))


def test_horizon_predictions_by_hand():
    """Robot A is column 1 of a plan that moves it +1 m in x per second from (0, 0); robot B is
    not in the plan. Observed: A at (5, 5) moving (0, 1) m/s, B at (1, 1) at rest."""
    times = np.array([0.4, 0.8])
    planned = np.zeros((3, 2, 2))
    planned[:, 1, 0] = [0.0, 0.4, 0.8]
    got = horizon_predictions(planned, np.array([1, -1]), np.array([[5.0, 5.0], [1.0, 1.0]]),
                              np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([2.0, 2.0]), times)
    assert got.shape == (6, 2, 2)
    np.testing.assert_allclose(got[0], [[5.4, 5.0], [5.8, 5.0]])  # the plan's motion, from where A is
    np.testing.assert_allclose(got[1], [[1.0, 1.0], [1.0, 1.0]])  # B held still
    np.testing.assert_allclose(got[2], [[5.0, 5.4], [5.0, 5.8]])  # A at constant velocity
    np.testing.assert_allclose(got[3], [[1.0, 1.0], [1.0, 1.0]])
    # A braking at 2 m/s^2 from 1 m/s stops after 0.5 s and 0.25 m: 0.4 - 0.16 = 0.24 m at 0.4 s.
    np.testing.assert_allclose(got[4], [[5.0, 5.24], [5.0, 5.25]])
    np.testing.assert_allclose(got[5], [[1.0, 1.0], [1.0, 1.0]])


def test_reaction_margin_is_how_far_a_braking_trajectory_can_move_in_one_step():
    from nodnav.sim.execution import reaction_margin

    # a dt^2 + (v + a dt / 2) dt: at rest 2 * 0.01 + 0.1 * 0.1 = 0.03 m; at 1 m/s 0.02 + 0.11 = 0.13 m.
    np.testing.assert_allclose(reaction_margin(np.array([0.0, 1.0]), np.array([2.0, 2.0]), 0.1), [0.03, 0.13])


def test_unexpected_approach_counts_only_deviations_towards_the_robot():
    from nodnav.sim.execution import unexpected_approach

    dt = 0.1
    # Robot 0 at the origin; robot 1 starts from rest towards it (1 cm in a step it was expected to
    # stand still); robot 2 starts away from it; robot 3 drives at it at constant velocity (no
    # surprise: 1 m/s for 0.1 s is the 0.1 m it covered); robot 4 starts sideways, across the line.
    seen_positions = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [2.0, 0.0]])
    seen_velocities = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 0.0]])
    positions = np.array([[0.0, 0.0], [0.99, 0.0], [0.0, 1.01], [-0.9, 0.0], [2.0, 0.01]])
    others = np.array([1, 2, 3, 4])
    got = unexpected_approach(seen_positions, seen_velocities, positions, 0, others, dt, threshold=5e-3)
    np.testing.assert_array_equal(got, [True, False, False, False])
    # A deviation of 4 mm towards the robot is below a 5 mm threshold.
    positions[1] = [0.996, 0.0]
    assert not unexpected_approach(seen_positions, seen_velocities, positions, 0, others, dt, threshold=5e-3)[0]
