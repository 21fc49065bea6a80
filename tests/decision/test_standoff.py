"""The standoff convention: who is in a standoff with whom, and which orders it leaves."""

import numpy as np

from nodnav.decision.standoff import STALL_DISTANCE, progress_beyond_best, standoff_partner
from nodnav.decision.strategies import passing_orders, precedence_mask


def test_a_robot_that_wanted_to_go_and_did_not_is_in_a_standoff_with_a_player_that_did_not_either():
    # Players: 0 moved on; 1 and 2 stood still, the plan had 2 go further than 1 (or the robot).
    partner = standoff_partner(0.02, np.array([0.9, 0.0, 0.05]), 0.3, np.array([0.9, 0.1, 0.8]))
    assert partner == 2


def test_two_robots_each_waiting_for_the_other_are_in_a_standoff():
    # "You first": the robot's plan has it wait (no progress) and the player go; it did not.
    assert standoff_partner(0.0, np.array([0.0]), 0.0, np.array([0.9])) == 0


def test_no_standoff_when_the_robot_moved_or_the_plan_had_both_wait():
    assert standoff_partner(0.5, np.array([0.0]), 0.8, np.array([0.0])) == -1  # it got somewhere
    assert standoff_partner(0.0, np.array([0.0]), 2 * STALL_DISTANCE, np.array([0.1])) == -1  # both wait
    assert standoff_partner(0.0, np.array([0.3]), 0.8, np.array([0.8])) == -1  # the player moved on
    assert standoff_partner(0.0, np.zeros(0), 0.8, np.zeros(0)) == -1  # nobody to be held up by


def test_precedence_mask_picks_the_orders_where_one_robot_passes_before_another():
    orders = passing_orders(3)  # lexicographic: (0,1,2) (0,2,1) (1,0,2) (1,2,0) (2,0,1) (2,1,0)
    np.testing.assert_array_equal(precedence_mask(orders, 2, 0), [False, False, False, True, True, True])
    np.testing.assert_array_equal(precedence_mask(orders, 0, 2), ~precedence_mask(orders, 2, 0))


def test_the_partner_is_the_nearest_stalled_player_and_never_one_that_has_arrived():
    # The robot wanted to go (0.8 m) and did not; both players stood, and the plan had neither
    # move (one waits for the robot, one stands at its destination): both tie on the robot's own
    # planned progress. Player 0 is at its destination 2.3 m away, player 1 beside the robot.
    args = (0.0, np.array([0.0, 0.0]), 0.8, np.array([0.0, 0.0]))
    assert standoff_partner(*args) == 0  # without distances the tie goes to the first
    assert standoff_partner(*args, players_distance=np.array([2.3, 0.5])) == 1
    assert standoff_partner(*args, players_arrived=np.array([True, False])) == 1
    assert standoff_partner(*args, players_distance=np.array([0.4, 0.5]), players_arrived=np.array([True, False])) == 1
    assert standoff_partner(0.0, np.array([0.0]), 0.8, np.array([0.0]), players_arrived=np.array([True])) == -1
    # More planned progress still comes first, however far.
    assert standoff_partner(0.0, np.array([0.0, 0.0]), 0.3, np.array([0.9, 0.0]),
                            players_distance=np.array([3.0, 0.5])) == 0


def test_progress_beyond_the_best_over_the_patience():
    # Distances to go (m) of two robots at t - 2, t - 1 and now. Robot 0 came 0.5 m closer each
    # period (steady progress: the same as over the last period alone); robot 1 backed off 0.13 m
    # and came back (x0, x0 + 0.13, x0): over the last period alone it progressed 0.13 m.
    before = np.array([[4.0, 2.30], [3.5, 2.43]])
    now = np.array([3.0, 2.30])
    np.testing.assert_allclose(progress_beyond_best(now, before), [0.5, 0.0])
    np.testing.assert_allclose(progress_beyond_best(now, before[-1]), [0.5, 0.13])  # the period alone
    # A robot that only backs off has negative progress, by how far it is behind its best.
    np.testing.assert_allclose(progress_beyond_best(np.array([2.6]), np.array([[2.3], [2.45]])), [-0.3])


def test_pressing_and_backing_off_in_turn_is_a_standoff_when_judged_against_the_best():
    # Two robots facing each other inside, both going 0.13 m forward in one period and back the
    # next (the plan had the robot go 0.9 m, or the player go 0.9 m). In the period both came
    # forward, judged over the period alone both progressed (0.13 > STALL_DISTANCE): no standoff;
    # judged against the best over the patience neither did.
    own_before, player_before = np.array([[2.0], [2.13]]), np.array([[1.5], [1.63]])
    own_now, player_now = np.array([2.0]), np.array([1.5])
    assert 0.13 > STALL_DISTANCE
    period = (own_before[-1] - own_now)[0], (player_before[-1] - player_now)
    assert standoff_partner(period[0], period[1], 0.9, np.array([0.0])) == -1
    best = progress_beyond_best(own_now, own_before)[0], progress_beyond_best(player_now, player_before)
    assert standoff_partner(best[0], best[1], 0.9, np.array([0.0])) == 0
