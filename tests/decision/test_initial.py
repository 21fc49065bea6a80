"""Distance-based initial opinions, eqs. (10)-(11)."""

import numpy as np
import pytest

from nodnav.decision.initial import distance_initial_opinions, order_likelihoods
from nodnav.decision.strategies import passing_orders
from nodnav.scenario.loading import load_scenario


def test_order_likelihoods_hand_values():
    # Distances 1, 2, 3: weights q, q^2, q^3 with q = e^-1.
    q = np.exp(-1.0)
    L = order_likelihoods(np.array([1.0, 2.0, 3.0]), passing_orders(3))
    # S1 = (1,2,3): q/(q+q^2+q^3), q^2/(q^2+q^3), 1.
    np.testing.assert_allclose(L[0], [1 / (1 + q + q**2), 1 / (1 + q), 1.0], rtol=1e-14)
    # S6 = (3,2,1): q^3/(q+q^2+q^3), q^2/(q+q^2), 1.
    np.testing.assert_allclose(L[5], [q**2 / (1 + q + q**2), q / (1 + q), 1.0], rtol=1e-14)
    np.testing.assert_array_equal(L[:, -1], 1.0)


def test_initial_opinions_hand_values():
    q = np.exp(-1.0)
    z = distance_initial_opinions(np.array([1.0, 2.0, 3.0]), passing_orders(3), K2=10.0)
    np.testing.assert_allclose(z[0], 100.0 / ((1 + q + q**2) * (1 + q)), rtol=1e-14)
    np.testing.assert_allclose(z[5], 100.0 * q**3 / ((1 + q + q**2) * (1 + q)), rtol=1e-14)
    assert np.argmax(z) == 0 and np.argmin(z) == 5  # closest first is the most likely order


def test_two_robots_is_a_scaled_sigmoid():
    z = distance_initial_opinions(np.array([0.5, 2.0]), passing_orders(2), K2=10.0)
    np.testing.assert_allclose(z, [10 / (1 + np.exp(-1.5)), 10 / (1 + np.exp(1.5))], rtol=1e-14)


@pytest.mark.parametrize("n", [2, 3, 4])
def test_order_probabilities_sum_to_one(n):
    # prod_l L(i_l | ...) is the probability of the whole order (a sequential softmax), so over all
    # N_r! orders they sum to 1 and the opinions (11) to K2^(N_r - 1).
    d = np.random.default_rng(n).uniform(0, 5, n)
    orders = passing_orders(n)
    np.testing.assert_allclose(order_likelihoods(d, orders).prod(axis=1).sum(), 1.0, rtol=1e-13)
    np.testing.assert_allclose(distance_initial_opinions(d, orders, K2=3.0).sum(), 3.0 ** (n - 1), rtol=1e-13)


def test_equal_distances_give_equal_opinions():
    z = distance_initial_opinions(np.full(3, 2.7), passing_orders(3), K2=10.0)
    np.testing.assert_allclose(z, 100.0 / 6.0, rtol=1e-14)  # (1/3)(1/2) * K2^2


def test_common_offset_and_large_distances_change_nothing():
    orders = passing_orders(4)
    d = np.array([0.3, 1.1, 2.0, 0.7])
    z = distance_initial_opinions(d, orders)
    far = distance_initial_opinions(d + 900.0, orders)
    assert np.all(np.isfinite(far))
    np.testing.assert_allclose(far, z, rtol=1e-10)


def test_three_robot_case_2_prefers_robot_2_first():
    # Table I: robot 2 is closest; robots 1 and 3 are equally far, so S3 = (2,1,3) and
    # S4 = (2,3,1) get the largest and equal initial opinions.
    s = load_scenario("3r-case2")
    sides = s.world.side_of(s.origins)
    d = s.world.corridor_distance(s.origins, sides)
    assert d[1] < d[0] == d[2]
    z = distance_initial_opinions(d, passing_orders(3), K2=10.0)
    top = set(np.flatnonzero(z == z.max()))
    assert top == {2, 3}
    assert z[2] == z[3]
    # By (10): K2 * e^-d2 / (e^-d2 + 2 e^-d1) times K2 / 2.
    e1, e2 = np.exp(-d[0]), np.exp(-d[1])
    np.testing.assert_allclose(z[2], 10 * e2 / (e2 + 2 * e1) * 10 / 2, rtol=1e-13)


def test_shape_mismatch_is_rejected():
    with pytest.raises(ValueError):
        order_likelihoods(np.zeros(3), passing_orders(2))
