"""The NOD model: eqs. (1)-(3), (5), (8), (9), against hand values and analytical properties."""

from itertools import permutations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nodnav.decision.opinion import (
    generalized_opinion_rate,
    opinion_rate,
    opinion_update,
    relative_opinions,
    saturation,
    selection_probabilities,
    social_sum,
    step_size,
    strategy_probabilities,
)
from nodnav.decision.players import conflict_likelihood, game_player_mask
from nodnav.decision.strategies import consistency_weights, passing_orders, strategy_index


@pytest.fixture
def rng():
    return np.random.default_rng(20240611)


# --- eq. (2) and (9) -------------------------------------------------------------------------

def test_relative_opinions_hand_values():
    z = np.array([[3.0, 0.0, -6.0], [1.0, 1.0, 1.0]])
    # means -1 and 1
    np.testing.assert_allclose(relative_opinions(z), [[4.0, 1.0, -5.0], [0.0, 0.0, 0.0]])


def test_relative_opinions_sum_to_zero_and_ignore_shifts(rng):
    z = rng.normal(size=(4, 6)) * 10
    zbar = relative_opinions(z)
    np.testing.assert_allclose(zbar.sum(axis=1), 0.0, atol=1e-12)
    shift = rng.normal(size=(4, 1)) * 100
    np.testing.assert_allclose(relative_opinions(z + shift), zbar, atol=1e-12)


def test_saturation_values_and_symmetry():
    assert saturation(0.0) == 0.5
    x = np.linspace(-5, 5, 41)
    np.testing.assert_allclose(saturation(x) + saturation(-x), 1.0, atol=1e-15)
    # R(a) - R(-a) = tanh(a): the identity behind the two-robot reduction.
    np.testing.assert_allclose(saturation(x) - saturation(-x), np.tanh(x), atol=1e-15)
    assert np.all(np.diff(saturation(x)) > 0)
    assert saturation(-1e3) == 0.0 and saturation(1e3) == 1.0
    np.testing.assert_allclose(saturation(np.log(3) / 2), 0.75)  # tanh(ln(3)/2) = 1/2


# --- eq. (3) ---------------------------------------------------------------------------------

def test_two_strategy_softmax_is_a_sigmoid():
    z = np.array([[2.0, -1.0], [0.0, 0.0]])
    x = strategy_probabilities(z, eta=1.5)
    np.testing.assert_allclose(x[0, 0], 1.0 / (1.0 + np.exp(-3.0 / 1.5)))
    np.testing.assert_allclose(x[1], [0.5, 0.5])


def test_softmax_hand_value_three_strategies():
    x = strategy_probabilities(np.array([0.0, np.log(2.0), np.log(5.0)]))
    np.testing.assert_allclose(x, [1 / 8, 2 / 8, 5 / 8])


def test_softmax_is_stable_for_huge_opinions():
    z = np.array([[3000.0, 2999.0, -4000.0], [-5000.0, -5000.0, -5001.0]])
    x = strategy_probabilities(z)
    assert np.all(np.isfinite(x))
    np.testing.assert_allclose(x.sum(axis=1), 1.0)
    e = np.exp(1.0)
    np.testing.assert_allclose(x[0], [e / (e + 1), 1 / (e + 1), 0.0], atol=1e-300)
    np.testing.assert_allclose(x[1], [e / (2 * e + 1), e / (2 * e + 1), 1 / (2 * e + 1)])


def test_softmax_ignores_shifts_and_rejects_bad_eta(rng):
    z = rng.normal(size=(3, 6))
    np.testing.assert_allclose(strategy_probabilities(z + 7.0, 0.3), strategy_probabilities(z, 0.3))
    with pytest.raises(ValueError):
        strategy_probabilities(z, 0.0)


# --- eq. (1) ---------------------------------------------------------------------------------

def test_opinion_rate_hand_computed_two_robots():
    # z_1 = (2, 0): zbar_1 = (1, -1); z_2 = (0, 4): zbar_2 = (-2, 2).
    z = np.array([[2.0, 0.0], [0.0, 4.0]])
    u, d, b = 3.0, 0.5, np.array([[0.1, 0.0], [0.0, -0.2]])
    R = lambda a: 0.5 * (np.tanh(a) + 1)  # noqa: E731
    expected = np.array([
        [-0.5 * (2.0 - 3.0 * R(-2.0) - 0.1), -0.5 * (0.0 - 3.0 * R(2.0) - 0.0)],
        [-0.5 * (0.0 - 3.0 * R(1.0) - 0.0), -0.5 * (4.0 - 3.0 * R(-1.0) + 0.2)],
    ])
    np.testing.assert_allclose(opinion_rate(z, u, d, b), expected, rtol=1e-14)


def test_opinion_rate_three_robots_with_a_mask():
    # A^j_ik = 0 removes exactly one term of the sum in eq. (1).
    z = np.array([[1.0, -1.0], [0.0, 2.0], [3.0, 3.0]])
    zbar = np.array([[1.0, -1.0], [-1.0, 1.0], [0.0, 0.0]])
    A = np.ones((3, 3, 2))
    A[0, 2, 1] = 0.0
    R = 0.5 * (np.tanh(zbar) + 1)
    social = np.array([
        [R[1, 0] + R[2, 0], R[1, 1]],
        [R[0, 0] + R[2, 0], R[0, 1] + R[2, 1]],
        [R[0, 0] + R[1, 0], R[0, 1] + R[1, 1]],
    ])
    u, d = np.array([1.0, 2.0, 4.0]), np.array([1.0, 0.5, 2.0])
    expected = -d[:, None] * (z - u[:, None] * social)
    np.testing.assert_allclose(opinion_rate(z, u, d, 0.0, A), expected, rtol=1e-14)


def test_opinion_rate_ignores_the_diagonal_of_A(rng):
    z = rng.normal(size=(3, 6))
    A = np.ones((3, 3, 6))
    A[np.arange(3), np.arange(3)] = 0.0
    np.testing.assert_array_equal(opinion_rate(z, 5.0, 1.0, 0.0, A), opinion_rate(z, 5.0, 1.0, 0.0))


def test_two_robot_two_strategy_reduction(rng):
    # y_i = z_i1 - z_i2 obeys dy_1/dt = -d (y_1 - u tanh(y_2 / 2)) (b = 0), since
    # R(y/2) - R(-y/2) = tanh(y/2).
    u, d = 7.0, 1.3
    for _ in range(20):
        z = rng.normal(size=(2, 2)) * 5
        y = z[:, 0] - z[:, 1]
        rate = opinion_rate(z, u, d, 0.0)
        dy = rate[:, 0] - rate[:, 1]
        np.testing.assert_allclose(dy, -d * (y - u * np.tanh(y[::-1] / 2)), rtol=1e-12, atol=1e-12)


def test_equilibrium_of_eq1_is_u_times_social_plus_bias(rng):
    # At z* = u S(z*) + b the rate vanishes. With d = 1 an Euler step of length 1 is the map
    # z -> u S(z) + b, a contraction here (|R'| <= 1/2, the centring (2) has max-norm < 2, two other
    # robots: Lipschitz constant < 0.4 * 2 * 0.5 * 2 = 0.8), so iterating it finds z*.
    u, b = 0.4, rng.normal(size=(3, 6))
    z = np.zeros((3, 6))
    for _ in range(200):
        z = z + opinion_rate(z, u, 1.0, b)
    np.testing.assert_allclose(opinion_rate(z, u, 1.0, b), 0.0, atol=1e-12)


def test_relabelling_robots_and_strategies_commutes_with_the_rate(rng):
    z = rng.normal(size=(4, 6)) * 3
    u, d, b = rng.uniform(1, 10, 4), rng.uniform(0.5, 2, 4), rng.normal(size=(4, 6))
    rate = opinion_rate(z, u, d, b)
    for p in [(2, 0, 3, 1), (3, 2, 1, 0)]:
        p = np.array(p)
        np.testing.assert_allclose(opinion_rate(z[p], u[p], d[p], b[p]), rate[p], rtol=1e-13)
    q = rng.permutation(6)
    np.testing.assert_allclose(opinion_rate(z[:, q], u, d, b[:, q]), rate[:, q], rtol=1e-13)


def test_shifting_one_robots_opinions_changes_only_its_own_rate(rng):
    # zbar_k is shift invariant, so the social terms do not change; only -d_k z_k does.
    z = rng.normal(size=(3, 6))
    u, d = 10.0, np.array([1.0, 2.0, 0.5])
    shift = np.array([[0.0], [4.0], [0.0]])
    diff = opinion_rate(z + shift, u, d, 0.0) - opinion_rate(z, u, d, 0.0)
    np.testing.assert_allclose(diff, -d[:, None] * shift * np.ones((1, 6)), atol=1e-12)
    np.testing.assert_allclose(relative_opinions(z + shift), relative_opinions(z), atol=1e-14)
    np.testing.assert_allclose(strategy_probabilities(z + shift), strategy_probabilities(z), atol=1e-14)


def test_opinion_rate_batches_over_leading_axes(rng):
    z = rng.normal(size=(5, 7, 2, 3))
    batched = opinion_rate(z, 4.0, 1.0, 0.0)
    for idx in [(0, 0), (3, 6), (4, 2)]:
        np.testing.assert_allclose(batched[idx], opinion_rate(z[idx], 4.0, 1.0, 0.0), rtol=1e-14)


def test_opinion_rate_rejects_wrong_weights():
    with pytest.raises(ValueError):
        opinion_rate(np.zeros((2, 2)), 1.0, 1.0, 0.0, np.ones((2, 2)))


# --- eq. (5) ---------------------------------------------------------------------------------

def literal_eq5_rate(z, u, d, b, players, A):
    """Eq. (5) exactly as printed, with the weight inside the saturation: R(A^{jl} zbar_kl)."""
    n_r = z.shape[0]
    zbar = z - z.mean(axis=1, keepdims=True)
    scores = 0.5 * (np.tanh(A[:, :, None, :] * zbar[None, None, :, :]) + 1.0)  # [i, j, k, l]
    mask = (players & ~np.eye(n_r, dtype=bool)).astype(float)
    social = np.sum(scores.sum(axis=3) * mask[:, None, :], axis=2)
    return -d[:, None] * (z - u[:, None] * social - b)


def test_literal_reference_by_loops_on_one_case(rng):
    # The vectorised reference above, checked once against plain loops over i, j, k, l.
    z, players = rng.normal(size=(3, 6)), np.array([[0, 1, 1], [1, 0, 0], [0, 1, 0]], dtype=bool)
    A = rng.integers(0, 2, size=(3, 6, 6)).astype(float)
    u, d, b = np.array([1.0, 2.0, 3.0]), np.array([1.0, 0.5, 2.0]), rng.normal(size=(3, 6))
    zbar = z - z.mean(axis=1, keepdims=True)
    expected = np.empty_like(z)
    for i in range(3):
        for j in range(6):
            s = sum(0.5 * (np.tanh(A[i, j, m] * zbar[k, m]) + 1.0)
                    for k in range(3) if k != i and players[i, k] for m in range(6))
            expected[i, j] = -d[i] * (z[i, j] - u[i] * s - b[i, j])
    np.testing.assert_allclose(literal_eq5_rate(z, u, d, b, players, A), expected, rtol=1e-13)


def reduced_weights(orders, players):
    return np.stack([consistency_weights(orders, i, np.flatnonzero(players[i])) for i in range(len(players))])


@pytest.mark.parametrize("n_r", [2, 3, 4])
def test_eq5_reduces_exactly_to_eq1_with_all_players(rng, n_r):
    # N_i = all others and A^{jl} = A^j_i delta_jl: eq. (5) is eq. (1) with A[i, k, j] = A^j_i.
    n_s = len(passing_orders(n_r))
    z = rng.normal(size=(n_r, n_s)) * 4
    u, d, b = rng.uniform(1, 20, n_r), rng.uniform(0.5, 2, n_r), rng.normal(size=(n_r, n_s))
    a = rng.integers(0, 2, size=(n_r, n_s)).astype(float)
    A5 = np.stack([np.diag(a[i]) for i in range(n_r)])
    A1 = np.broadcast_to(a[:, None, :], (n_r, n_r, n_s))
    players = ~np.eye(n_r, dtype=bool)
    np.testing.assert_allclose(generalized_opinion_rate(z, u, d, b, players, A5),
                               opinion_rate(z, u, d, b, A1), rtol=1e-13, atol=1e-13)
    # With the consistency weights of Section III-B (the identity here) as well.
    A5 = reduced_weights(passing_orders(n_r), players)
    np.testing.assert_allclose(generalized_opinion_rate(z, u, d, b, players, A5),
                               opinion_rate(z, u, d, b), rtol=1e-13, atol=1e-13)


def test_eq5_hand_example_three_robots_one_player():
    # Robot 0 plays with robot 1 only; A groups {S1, S2, S5} (0 before 1) and {S3, S4, S6}.
    orders = passing_orders(3)
    z = np.array([[0.0] * 6, [6.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0] * 6])
    players = np.array([[False, True, False], [False, False, False], [False, False, False]])
    A = reduced_weights(orders, players)
    zbar1 = np.array([5.0, -1, -1, -1, -1, -1])
    R = 0.5 * (np.tanh(zbar1) + 1)
    group = R[0] + R[1] + R[4], R[2] + R[3] + R[5]
    expected0 = 2.0 * np.array([group[0], group[0], group[1], group[1], group[0], group[1]])
    rate = generalized_opinion_rate(z, 2.0, 1.0, 0.0, players, A)
    np.testing.assert_allclose(rate[0], expected0, rtol=1e-14)
    np.testing.assert_allclose(rate[1], -z[1], rtol=1e-14)  # no players: pure decay


@pytest.mark.parametrize("n_r,k", [(3, 1), (4, 1), (4, 2)])
def test_weight_outside_R_differs_from_the_literal_form_by_a_per_robot_constant(rng, n_r, k):
    orders = passing_orders(n_r)
    n_s = len(orders)
    positions = rng.uniform(-5, 5, size=(n_r, 2))
    players = game_player_mask(conflict_likelihood(positions, rng.uniform(0, 3, n_r)), k)
    A = reduced_weights(orders, players)
    u, d, b = rng.uniform(1, 100, n_r), rng.uniform(0.5, 2, n_r), rng.normal(size=(n_r, n_s))
    z = rng.normal(size=(n_r, n_s)) * 3
    diff = literal_eq5_rate(z, u, d, b, players, A) - generalized_opinion_rate(z, u, d, b, players, A)
    # Each of the k players contributes R(0) = 1/2 for the N_s - N_s/(k+1)! strategies l with
    # A^{jl} = 0, whatever j is; in the rate this is multiplied by d_i u_i.
    class_size = n_s / np.prod(range(1, k + 2))
    constant = d * u * k * (n_s - class_size) / 2
    np.testing.assert_allclose(diff, np.broadcast_to(constant[:, None], diff.shape), rtol=1e-12)


@pytest.mark.parametrize("n_r,k", [(3, 1), (4, 2)])
def test_weight_outside_R_gives_the_literal_forms_probabilities_over_time(rng, n_r, k):
    orders = passing_orders(n_r)
    n_s = len(orders)
    positions = rng.uniform(-5, 5, size=(n_r, 2))
    players = game_player_mask(conflict_likelihood(positions, rng.uniform(0, 3, n_r)), k)
    A = reduced_weights(orders, players)
    u, d, b = 10.0 * np.ones(n_r), np.ones(n_r), rng.normal(size=(n_r, n_s))
    z0 = rng.normal(size=(n_r, n_s))
    times = np.linspace(0, 8, 9)
    ours = solve_ivp(lambda t, y: generalized_opinion_rate(y.reshape(n_r, n_s), u, d, b, players, A).ravel(),
                     (0, 8), z0.ravel(), t_eval=times, rtol=1e-10, atol=1e-10)
    literal = solve_ivp(lambda t, y: literal_eq5_rate(y.reshape(n_r, n_s), u, d, b, players, A).ravel(),
                        (0, 8), z0.ravel(), t_eval=times, rtol=1e-10, atol=1e-10)
    x_ours = strategy_probabilities(ours.y.T.reshape(-1, n_r, n_s))
    x_literal = strategy_probabilities(literal.y.T.reshape(-1, n_r, n_s))
    np.testing.assert_allclose(x_ours, x_literal, atol=1e-7)
    # The discrete update (8) keeps the same property exactly, step by step.
    za, zb = z0.copy(), z0.copy()
    for step in range(30):
        alpha = step_size(step)
        ra = generalized_opinion_rate(za, u, d, b, players, A)
        rb = literal_eq5_rate(zb, u, d, b, players, A)
        za, zb = za + alpha * ra, zb + alpha * rb
        np.testing.assert_allclose(strategy_probabilities(za), strategy_probabilities(zb), atol=1e-12)


def test_generalized_rate_ignores_the_diagonal_of_players(rng):
    z = rng.normal(size=(3, 6))
    A = reduced_weights(passing_orders(3), ~np.eye(3, dtype=bool))
    np.testing.assert_array_equal(generalized_opinion_rate(z, 5.0, 1.0, 0.0, np.ones((3, 3), bool), A),
                                  generalized_opinion_rate(z, 5.0, 1.0, 0.0, ~np.eye(3, dtype=bool), A))


def test_social_sum_per_robot_estimates_by_loops(rng):
    n_r, n_k, n_s = 3, 4, 6
    r = rng.uniform(size=(n_r, n_k, n_s))
    players = rng.integers(0, 2, size=(n_r, n_k)).astype(bool)
    A = rng.integers(0, 2, size=(n_r, n_s, n_s)).astype(float)
    expected = np.zeros((n_r, n_s))
    for i in range(n_r):
        for j in range(n_s):
            expected[i, j] = sum(A[i, j, m] * r[i, k, m] for k in range(n_k) if players[i, k] for m in range(n_s))
    np.testing.assert_allclose(social_sum(r, players, A), expected, rtol=1e-14)
    # Shared scores and a shared weight matrix broadcast to every robot.
    np.testing.assert_allclose(social_sum(r[0], players, A[0]),
                               social_sum(np.broadcast_to(r[0], r.shape), players, np.broadcast_to(A[0], A.shape)))


# --- eq. (8) ---------------------------------------------------------------------------------

def test_step_size_values():
    np.testing.assert_allclose(step_size(np.array([0, 1, 3, 9, 19, 20, 1000])),
                               [1.0, 0.5, 0.25, 0.1, 0.05, 0.05, 0.05])
    assert step_size(3, alpha_min=0.0) == 0.25
    assert step_size(0.0) == 1.0


def test_update_without_social_term_relaxes_geometrically_to_the_bias(rng):
    z0, b = rng.normal(size=(2, 3)) * 5, rng.normal(size=(2, 3))
    d, alpha = np.array([1.0, 0.5]), 0.2
    z = z0
    for _ in range(25):
        z = opinion_update(z, np.zeros_like(z), 0.0, d, b, alpha)
    np.testing.assert_allclose(z - b, (1 - alpha * d[:, None]) ** 25 * (z0 - b), rtol=1e-12)


def test_first_update_with_alpha_one_jumps_to_the_target():
    # alpha(0) = 1 and d = 1: z(T) = u * social + b whatever z(0) was.
    z = np.array([3.0, -2.0, 7.0])
    social, b = np.array([0.2, 0.5, 0.9]), np.array([0.0, 1.0, 0.0])
    np.testing.assert_allclose(opinion_update(z, social, 10.0, 1.0, b, step_size(0)), [2.0, 6.0, 9.0])


def test_update_is_an_euler_step_of_the_rate(rng):
    # With social = the exact social sum, eq. (8) is z + alpha * (eq. (5) rate).
    orders = passing_orders(3)
    players = ~np.eye(3, dtype=bool)
    A = reduced_weights(orders, players)
    z, u, d, b = rng.normal(size=(3, 6)), np.array([1.0, 5.0, 9.0]), np.array([1.0, 2.0, 0.5]), 0.3
    social = social_sum(saturation(relative_opinions(z)), players & ~np.eye(3, dtype=bool), A)
    np.testing.assert_allclose(opinion_update(z, social, u, d, b, 0.3),
                               z + 0.3 * generalized_opinion_rate(z, u, d, b, players, A), rtol=1e-13)


def test_relabelling_commutes_with_the_generalized_rate(rng):
    # Renaming robots by pi and strategies accordingly maps the game to itself.
    orders = passing_orders(3)
    z = rng.normal(size=(3, 6)) * 2
    players = np.array([[False, True, False], [False, False, True], [True, True, False]])
    A = reduced_weights(orders, players)
    rate = generalized_opinion_rate(z, 10.0, 1.0, 0.0, players, A)
    for perm in permutations(range(3)):
        pi = np.array(perm)
        inv = np.argsort(pi)
        sigma = np.array([strategy_index(pi[o]) for o in orders])  # strategy j -> sigma[j]
        # New robot pi[i] is old robot i; new strategy sigma[j] is old strategy j.
        z_new = np.empty_like(z)
        z_new[np.ix_(pi, sigma)] = z
        players_new = players[np.ix_(inv, inv)]
        A_new = reduced_weights(orders, players_new)
        rate_new = generalized_opinion_rate(z_new, 10.0, 1.0, 0.0, players_new, A_new)
        np.testing.assert_allclose(rate_new[np.ix_(pi, sigma)], rate, rtol=1e-12, atol=1e-12)


def test_selection_renormalises_over_the_strategies_with_a_plan():
    x = np.array([0.5, 0.3, 0.2])
    np.testing.assert_allclose(selection_probabilities(x, np.array([False, True, True])), [0.0, 0.6, 0.4])
    np.testing.assert_array_equal(selection_probabilities(x, np.ones(3, dtype=bool)), x)
    np.testing.assert_allclose(selection_probabilities(np.array([1.0, 0.0, 0.0]), np.array([False, True, True])),
                               [0.0, 0.5, 0.5])
    np.testing.assert_array_equal(selection_probabilities(x, np.zeros(3, dtype=bool)), x)
