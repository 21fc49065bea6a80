"""Conflict likelihood (6) and game-player selection (7)."""

from itertools import combinations

import numpy as np
import pytest

from nodnav.decision.players import conflict_likelihood, game_player_mask, select_game_players


@pytest.fixture
def three():
    # Pairwise distances d01 = 5, d02 = 10, d12 = 5 (3-4-5 triangles); corridor distances 1, 2, 0.
    positions = np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 8.0]])
    return positions, np.array([1.0, 2.0, 0.0])


def test_conflict_likelihood_hand_values(three):
    L = conflict_likelihood(*three, delta=1.0)
    # L01 = 1/(5+1) + 1/(1+2+1) = 5/12; L02 = 1/(10+1) + 1/(1+0+1) = 13/22; L12 = 1/6 + 1/3 = 1/2.
    expected = np.array([[0, 5 / 12, 13 / 22], [5 / 12, 0, 1 / 2], [13 / 22, 1 / 2, 0]])
    np.testing.assert_allclose(L, expected, rtol=1e-14)


def test_delta_scales_the_offsets(three):
    L = conflict_likelihood(*three, delta=0.5)
    np.testing.assert_allclose(L[0, 1], 1 / 5.5 + 1 / 3.5, rtol=1e-14)


def test_symmetric_bounded_zero_diagonal():
    rng = np.random.default_rng(7)
    p, c = rng.uniform(-6, 6, size=(6, 2)), rng.uniform(0, 4, size=6)
    L = conflict_likelihood(p, c, delta=1.0)
    np.testing.assert_array_equal(L, L.T)
    np.testing.assert_array_equal(np.diag(L), 0.0)
    assert np.all(L <= 2.0) and np.all(L[~np.eye(6, dtype=bool)] > 0)
    # The bound 2/delta is reached by two robots at the same spot inside the corridor.
    np.testing.assert_allclose(conflict_likelihood(np.zeros((2, 2)), np.zeros(2))[0, 1], 2.0)


def test_closer_means_more_likely_conflict():
    c = np.array([1.0, 1.0])
    far = conflict_likelihood(np.array([[0.0, 0.0], [4.0, 0.0]]), c)[0, 1]
    near = conflict_likelihood(np.array([[0.0, 0.0], [1.0, 0.0]]), c)[0, 1]
    near_entrance = conflict_likelihood(np.array([[0.0, 0.0], [4.0, 0.0]]), np.array([0.0, 0.0]))[0, 1]
    assert near > far and near_entrance > far


def test_selection_hand_example(three):
    L = conflict_likelihood(*three)
    assert select_game_players(L, 0, 1) == (2,)  # 13/22 > 5/12
    assert select_game_players(L, 1, 1) == (2,)  # 1/2 > 5/12
    assert select_game_players(L, 2, 1) == (0,)  # 13/22 > 1/2
    assert select_game_players(L, 1, 2) == (0, 2)
    assert select_game_players(L, 1, 0) == ()


def test_ties_go_to_the_lower_index():
    # Robots 1, 2, 3 all at distance 1 from robot 0, same corridor distance: exact ties.
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    L = conflict_likelihood(positions, np.full(4, 2.0))
    assert L[0, 1] == L[0, 2] == L[0, 3]
    assert select_game_players(L, 0, 1) == (1,)
    assert select_game_players(L, 0, 2) == (1, 2)


def test_selection_maximises_the_sum_over_all_subsets():
    rng = np.random.default_rng(11)
    for _ in range(20):
        n = int(rng.integers(2, 7))
        L = conflict_likelihood(rng.uniform(-6, 6, (n, 2)), rng.uniform(0, 3, n))
        for i in range(n):
            for k in range(n):
                chosen = select_game_players(L, i, k)
                others = [j for j in range(n) if j != i]
                best = max(sum(L[i, j] for j in s) for s in combinations(others, k))
                assert len(chosen) == k and i not in chosen
                assert list(chosen) == sorted(chosen)
                np.testing.assert_allclose(sum(L[i, j] for j in chosen), best, rtol=1e-14)


def test_mask_agrees_with_selection():
    rng = np.random.default_rng(3)
    L = conflict_likelihood(rng.uniform(-6, 6, (5, 2)), rng.uniform(0, 3, 5))
    for k in range(5):
        mask = game_player_mask(L, k)
        np.testing.assert_array_equal(mask.sum(axis=1), k)
        assert not mask.diagonal().any()
        for i in range(5):
            assert tuple(np.flatnonzero(mask[i])) == select_game_players(L, i, k)


def test_bad_arguments_are_rejected():
    L = np.zeros((3, 3))
    with pytest.raises(ValueError):
        select_game_players(L, 0, 3)
    with pytest.raises(ValueError):
        select_game_players(L, 3, 1)
    with pytest.raises(ValueError):
        conflict_likelihood(np.zeros((3, 2)), np.zeros(3), delta=0.0)
    with pytest.raises(ValueError):
        conflict_likelihood(np.zeros((3, 2)), np.zeros(2))


def test_robots_in_the_corridor_are_chosen_only_when_too_few_others_are_left():
    from nodnav.decision.players import undecided_first

    L = np.array([[0.0, 0.9, 0.5, 0.2],
                  [0.9, 0.0, 0.3, 0.1],
                  [0.5, 0.3, 0.0, 0.4],
                  [0.2, 0.1, 0.4, 0.0]])
    ranked = undecided_first(L, [1])  # robot 1 has entered
    assert select_game_players(ranked, 0, 1) == (2,)  # robot 1 was robot 0's likeliest conflict
    assert select_game_players(ranked, 0, 2) == (2, 3)
    assert select_game_players(ranked, 0, 3) == (1, 2, 3)
    assert select_game_players(ranked, 2, 1) == (0,)  # among the undecided, eq. (6)'s order holds
