"""Passing orders, their indices, projections and the consistency weights A^{jl} (Section III-B)."""

from itertools import permutations

import numpy as np
import pytest

from nodnav.decision.strategies import (
    consistency_weights,
    order_label,
    passing_orders,
    project_order,
    projected_order_ids,
    strategy_index,
    strategy_label,
)


def test_three_robot_strategies_are_the_papers_s1_to_s6():
    # Section IV: S3 = (2,1,3), S4 = (2,3,1) put robot 2 first; S3 and S5 put robot 1 second;
    # S4 and S6 put robot 1 last. Lexicographic order in the paper's 1-based notation:
    expected = ["(1,2,3)", "(1,3,2)", "(2,1,3)", "(2,3,1)", "(3,1,2)", "(3,2,1)"]
    orders = passing_orders(3)
    assert orders.shape == (6, 3)
    assert [order_label(o) for o in orders] == expected
    assert [strategy_label(j) for j in range(6)] == ["S1", "S2", "S3", "S4", "S5", "S6"]
    second = {strategy_label(j) for j, o in enumerate(orders) if o[1] == 0}
    last = {strategy_label(j) for j, o in enumerate(orders) if o[2] == 0}
    assert second == {"S3", "S5"} and last == {"S4", "S6"}


def test_two_robot_strategies_match_fig2():
    # Fig. 2 caption: S1 : (1,2) and S2 : (2,1).
    assert [order_label(o) for o in passing_orders(2)] == ["(1,2)", "(2,1)"]


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
def test_orders_are_all_permutations_and_index_inverts_them(n):
    orders = passing_orders(n)
    assert len(orders) == int(np.prod(range(1, n + 1)))
    assert len({tuple(o) for o in orders}) == len(orders)
    assert all(sorted(o) == list(range(n)) for o in orders)
    assert [strategy_index(o) for o in orders] == list(range(len(orders)))
    # Lexicographic: each row is smaller than the next as a tuple.
    assert all(tuple(a) < tuple(b) for a, b in zip(orders[:-1], orders[1:]))


def test_strategy_index_rejects_non_permutations():
    with pytest.raises(ValueError):
        strategy_index((0, 0, 1))
    with pytest.raises(ValueError):
        passing_orders(0)


def test_projection_keeps_the_relative_order():
    assert project_order((2, 0, 3, 1), [1, 2]) == (2, 1)
    assert project_order((2, 0, 3, 1), [0, 1, 2, 3]) == (2, 0, 3, 1)
    assert project_order((2, 0, 3, 1), []) == ()


def test_projected_order_ids_group_by_projection():
    orders = passing_orders(3)
    ids = projected_order_ids(orders, [0, 1])
    # Robot 1 (index 0) before robot 2 (index 1) in S1, S2, S5; after it in S3, S4, S6.
    assert ids[0] == ids[1] == ids[4]
    assert ids[2] == ids[3] == ids[5]
    assert ids[0] != ids[2]


def test_consistency_weights_hand_example():
    orders = passing_orders(3)
    A = consistency_weights(orders, robot=0, players=[1])
    first = np.array([1, 1, 0, 0, 1, 0], dtype=float)  # robot 1 before robot 2
    expected = np.outer(first, first) + np.outer(1 - first, 1 - first)
    np.testing.assert_array_equal(A, expected)


@pytest.mark.parametrize("n", [2, 3, 4])
def test_all_robots_as_players_gives_identity(n):
    orders = passing_orders(n)
    for i in range(n):
        others = [k for k in range(n) if k != i]
        np.testing.assert_array_equal(consistency_weights(orders, i, others), np.eye(len(orders)))


@pytest.mark.parametrize("n", [3, 4])
def test_consistency_classes_have_equal_size(n):
    # Every projected-order class of m = |N_i| + 1 robots holds N_r! / m! strategies; this is why
    # the literal R(A zbar) of eq. (5) differs from A R(zbar) by the same constant for every j.
    orders = passing_orders(n)
    for size in range(0, n):
        players = list(range(1, size + 1))
        A = consistency_weights(orders, 0, players)
        expected = len(orders) / np.prod(range(1, size + 2))
        np.testing.assert_array_equal(A.sum(axis=1), expected)
        np.testing.assert_array_equal(A, A.T)


def test_no_players_makes_every_strategy_consistent():
    orders = passing_orders(3)
    np.testing.assert_array_equal(consistency_weights(orders, 1, []), np.ones((6, 6)))


@pytest.mark.parametrize("perm", list(permutations(range(4)))[::5])
def test_consistency_weights_are_invariant_under_relabelling(perm):
    # Renaming robots by pi maps strategy j to sigma(j) = index of pi(order_j); the weights of
    # robot pi(i) with players pi(N_i) are those of robot i with N_i, re-indexed by sigma.
    orders = passing_orders(4)
    pi = np.array(perm)
    sigma = np.array([strategy_index(pi[o]) for o in orders])
    for i, players in [(0, [2]), (1, [0, 3]), (3, [0, 1, 2])]:
        A = consistency_weights(orders, i, players)
        B = consistency_weights(orders, int(pi[i]), [int(pi[k]) for k in players])
        np.testing.assert_array_equal(B[np.ix_(sigma, sigma)], A)
