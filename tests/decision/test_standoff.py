"""The standoff convention: who is in a standoff with whom, and which orders it leaves."""

import numpy as np

from nodnav.decision.standoff import STALL_DISTANCE, standoff_partner
from nodnav.decision.strategies import passing_orders, precedence_mask


def test_a_robot_that_wanted_to_move_and_did_not_is_in_a_standoff_with_the_nearest_stalled_player():
    # Players: 0 moved on, 1 stalled but 2 m away, 2 and 3 stalled close by (3 the nearer).
    partner = standoff_partner(0.02, 0.8, np.array([0.9, 0.0, 0.05, 0.01]), np.array([0.1, 2.0, 0.4, 0.2]))
    assert partner == 3


def test_no_standoff_when_the_robot_moved_or_only_waited_as_planned():
    stalled = np.array([0.0]), np.array([0.1])
    assert standoff_partner(0.5, 0.8, *stalled) == -1  # it got somewhere
    assert standoff_partner(0.0, 2 * STALL_DISTANCE, *stalled) == -1  # its plan had it wait
    assert standoff_partner(0.0, 0.8, np.array([0.3]), np.array([0.1])) == -1  # the player moved on
    assert standoff_partner(0.0, 0.8, np.zeros(0), np.zeros(0)) == -1  # nobody to be held up by


def test_precedence_mask_picks_the_orders_where_one_robot_passes_before_another():
    orders = passing_orders(3)  # lexicographic: (0,1,2) (0,2,1) (1,0,2) (1,2,0) (2,0,1) (2,1,0)
    np.testing.assert_array_equal(precedence_mask(orders, 2, 0), [False, False, False, True, True, True])
    np.testing.assert_array_equal(precedence_mask(orders, 0, 2), ~precedence_mask(orders, 2, 0))
