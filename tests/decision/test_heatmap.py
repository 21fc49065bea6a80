"""Fig. 2a/2b: steady-state selection of two robots, checked against the pitchfork analysis.

With y_i = z_i1 - z_i2, eq. (1) (A = 1, b = 0) reads dy_1/dt = -d (y_1 - u tanh(y_2 / 2)) and
symmetrically. For u < 2 the only equilibrium is y = 0 (x11 = 1/2). For u > 2 it is a saddle and
the consensus equilibria y_1 = y_2 = +-y*, y* = u tanh(y*/2), attract everything off the invariant
anti-diagonal y_1 + y_2 = 0, i.e. z_11(0) + z_21(0) = 0, whose points flow to the saddle.
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from nodnav.decision.heatmap import HeatmapResult, steady_state_selection, z_grid


def consensus_value(u):
    """The positive root y* of y = u tanh(y / 2), which exists for u > 2."""
    return brentq(lambda y: y - u * np.tanh(y / 2), 1e-6, u + 1)


def sigmoid(x):
    return 1.0 / (1.0 + np.exp(-x))


def regions(n):
    """Boolean masks of the grid cells above, on and below the anti-diagonal z_11 + z_21 = 0."""
    a, c = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    s = a + c - (n - 1)
    return s > 0, s == 0, s < 0


def test_z_grid_is_exactly_antisymmetric():
    for n in [2, 7, 21, 51, 101]:
        z = z_grid(n)
        assert z[0] == -10.0 and z[-1] == 10.0
        np.testing.assert_array_equal(z, -z[::-1])
        np.testing.assert_allclose(z, np.linspace(-10, 10, n), atol=1e-14)
    with pytest.raises(ValueError):
        z_grid(1)


def test_u_below_two_is_indecisive_everywhere():
    result = steady_state_selection(1.0, z_grid(15))
    assert isinstance(result, HeatmapResult)
    assert result.converged and result.reason == ""
    assert result.residual <= 1e-8
    np.testing.assert_allclose(result.x11, 0.5, atol=1e-7)


def test_u_ten_matches_the_consensus_equilibria():
    n = 21
    result = steady_state_selection(10.0, z_grid(n))
    assert result.converged
    y = consensus_value(10.0)
    above, on, below = regions(n)
    np.testing.assert_allclose(result.x11[above], sigmoid(y), atol=1e-7)
    np.testing.assert_allclose(result.x11[below], sigmoid(-y), atol=1e-7)
    np.testing.assert_allclose(result.x11[on], 0.5, atol=1e-9)


def test_moderate_u_temperature_and_time_constant():
    # u = 3: y* = 3 tanh(y*/2) is about 2.6, far from saturation, so eta and the value of y*
    # are really tested; d only rescales time.
    n, eta = 11, 0.5
    result = steady_state_selection(3.0, z_grid(n), d=2.0, eta=eta)
    assert result.converged
    y = consensus_value(3.0)
    assert 2.0 < y < 3.0
    above, on, below = regions(n)
    np.testing.assert_allclose(result.x11[above], sigmoid(y / eta), atol=1e-7)
    np.testing.assert_allclose(result.x11[below], sigmoid(-y / eta), atol=1e-7)
    np.testing.assert_allclose(result.x11[on], 0.5, atol=1e-9)


def test_robot_and_strategy_swap_symmetries():
    # Swapping the robots transposes the grid; swapping the strategies negates both initial
    # opinions (relative to z_i2 = 0) and turns x11 into 1 - x11.
    result = steady_state_selection(6.0, z_grid(13))
    x = result.x11
    np.testing.assert_allclose(x, x.T, atol=1e-10)
    np.testing.assert_allclose(x + x[::-1, ::-1], 1.0, atol=1e-10)


def test_arbitrary_values_and_the_single_cell_case():
    y = consensus_value(4.0)
    result = steady_state_selection(4.0, np.array([-0.3, 2.0]))
    # Cells: (-0.3, -0.3) below, (-0.3, 2) above, (2, -0.3) above, (2, 2) above.
    np.testing.assert_allclose(result.x11, [[sigmoid(-y), sigmoid(y)], [sigmoid(y), sigmoid(y)]], atol=1e-7)
    single = steady_state_selection(4.0, np.array([0.0]))
    np.testing.assert_allclose(single.x11, [[0.5]], atol=1e-12)


def test_pitchfork_point_reports_no_convergence():
    # At u = 2 the consensus direction decays only like y^3 / 12: far from steady state by t = 40.
    result = steady_state_selection(2.0, z_grid(7), t_final=10.0, max_time=40.0)
    assert not result.converged
    assert result.t_end == 40.0
    assert result.residual > 1e-8
    assert "tol" in result.reason
    assert np.all(np.abs(result.x11 - 0.5) < 0.2)


def test_invalid_arguments():
    with pytest.raises(ValueError):
        steady_state_selection(10.0, np.zeros((2, 2)))
    with pytest.raises(ValueError):
        steady_state_selection(10.0, z_grid(5), d=0.0)
    with pytest.raises(ValueError):
        steady_state_selection(10.0, z_grid(5), t_final=-1.0)
