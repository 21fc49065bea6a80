"""Opinions over the orders of a robot's game: orders, class sizes, carrying across games, bias."""

import math
from itertools import permutations

import numpy as np
import pytest

from nodnav.decision.games import (
    carry_opinions,
    class_size,
    game_bias,
    game_orders,
    log_mean_exp,
    selections_agree,
    strategy_order,
)
from nodnav.decision.strategies import passing_orders, strategy_index


def test_game_orders_are_the_permutations_of_the_game_in_lexicographic_order_of_places():
    orders = game_orders((1, 4, 6))
    assert [tuple(o) for o in orders] == [(1, 4, 6), (1, 6, 4), (4, 1, 6), (4, 6, 1), (6, 1, 4), (6, 4, 1)]


def test_class_size_counts_the_strategies_that_project_onto_an_order_of_the_game():
    n, game = 5, (0, 2, 3)
    counts = {}
    for order in permutations(range(n)):
        key = tuple(k for k in order if k in game)
        counts[key] = counts.get(key, 0) + 1
    assert set(counts.values()) == {class_size(n, len(game))} == {20.0}


def test_strategy_order_inverts_strategy_index():
    for n in (1, 3, 5):
        for j, order in enumerate(passing_orders(n)):
            assert strategy_order(j, n) == tuple(order) and strategy_index(order) == j


def test_carrying_opinions_keeps_the_probability_of_every_order_of_the_shared_robots():
    eta = 1.0
    old, new = (0, 1, 2), (1, 2, 3)
    z = np.array([3.0, -1.0, 0.5, 2.0, 0.0, 1.0])  # over the orders of robots 0, 1, 2
    carried = carry_opinions(z, old, new, eta)
    # Probability of each order of the shared robots {1, 2} before and after.
    def shared(zs, game):
        x = np.exp(zs / eta) / np.exp(zs / eta).sum()
        out = {}
        for p, o in zip(x, game_orders(game)):
            key = tuple(k for k in o if k in (1, 2))
            out[key] = out.get(key, 0.0) + p
        return out
    before, after = shared(z, old), shared(carried, new)
    assert before.keys() == after.keys()
    for key in before:
        assert after[key] == pytest.approx(before[key])
    # Robot 3 is new: wherever it goes, the orders of 1 and 2 being the same, the opinion is.
    for a, b in [((1, 2, 3), (1, 3, 2)), ((3, 2, 1), (2, 3, 1))]:
        ia = [tuple(o) for o in game_orders(new)].index(a)
        ib = [tuple(o) for o in game_orders(new)].index(b)
        assert carried[ia] == carried[ib]
    np.testing.assert_array_equal(carry_opinions(z, old, old, eta), z)


def test_log_mean_exp_by_hand():
    assert log_mean_exp(np.array([0.0, math.log(3.0)]), 1.0) == pytest.approx(math.log(2.0))
    assert log_mean_exp(np.array([1000.0, 1000.0]), 2.0) == pytest.approx(1000.0)


def test_game_bias_is_the_bias_of_the_strategies_with_every_robot_and_their_log_mean_exp_otherwise():
    bias = {2: 150.0, 4: 150.0}  # S3 and S5 of three robots: (1,0,2) and (2,0,1)
    np.testing.assert_allclose(game_bias(bias, (0, 1, 2), 3, 1.0), [0, 0, 150, 0, 150, 0])
    # Game {0, 1}: order (0, 1) stands for (0,1,2), (0,2,1), (2,0,1) -> biases 0, 0, 150;
    # order (1, 0) for (1,0,2), (1,2,0), (2,1,0) -> 150, 0, 0.
    expected = math.log((2.0 + math.exp(150.0)) / 3.0)
    np.testing.assert_allclose(game_bias(bias, (0, 1), 3, 1.0), [expected, expected])
    np.testing.assert_array_equal(game_bias({}, (0, 1), 3, 1.0), [0.0, 0.0])


def test_selections_agree_when_no_two_put_two_open_robots_in_opposite_orders():
    # Robot 0 chose (0, 1) of its game {0, 1}; robot 1 chose (1, 2) of {1, 2}; robot 2 (0, 2, 1).
    ranks = np.array([[0, 1, -1], [-1, 0, 1], [0, 2, 1]])
    assert selections_agree(ranks, [0, 1])
    assert not selections_agree(ranks, [1, 2])  # robot 1 says 1 before 2, robot 2 says 2 before 1
    assert selections_agree(ranks, [2])
    assert not selections_agree(np.array([[0, 1, -1], [-1, -1, -1], [0, 1, 2]]), [0, 1])  # robot 1 chose none


def test_carry_groups_kept_by_the_caller_give_the_same_carried_opinions():
    """carry_opinions with :func:`carry_groups` passed in: each new order gets eta log mean exp
    (z / eta) of the old orders that put the shared robots alike, worked out here by projecting
    each pair of orders by hand."""
    from nodnav.decision.games import carry_groups, carry_opinions

    rng = np.random.default_rng(2)
    eta = 0.8
    for old, new in [((0, 1, 2), (1, 2, 5)), ((0, 3), (0, 3, 4)), ((1, 2, 3, 4), (2, 4)), ((0, 1), (2, 3))]:
        z = rng.normal(0, 3, len(list(permutations(old))))
        shared = [k for k in new if k in old]
        expected = []
        for order in permutations(new):
            key = [k for k in order if k in shared]
            values = np.array([z[j] for j, o in enumerate(permutations(old)) if [k for k in o if k in shared] == key])
            expected.append(eta * np.log(np.mean(np.exp(values / eta))))
        groups = carry_groups(old, new)
        np.testing.assert_allclose(carry_opinions(z, old, new, eta, groups), expected, rtol=1e-12)
        assert np.array_equal(carry_opinions(z, old, new, eta, groups), carry_opinions(z, old, new, eta))


def test_log_mean_exp_is_numpys_max_and_mean_bit_for_bit():
    from nodnav.decision.games import log_mean_exp

    rng = np.random.default_rng(7)
    for n in [1, 2, 5, 8, 9, 24, 130]:
        values, eta = rng.normal(0, 30, n), float(rng.uniform(0.2, 3.0))
        v = values / eta
        top = v.max()
        assert log_mean_exp(values, eta) == float(eta * (top + np.log(np.mean(np.exp(v - top)))))
