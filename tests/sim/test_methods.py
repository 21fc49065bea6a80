"""The predictions a planned method gives its MPC."""

import numpy as np
import pytest

from nodnav.sim.methods import braking_extrapolation


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
