"""A built-in turned and moved as a whole plays out the same (issue 20, item 1).

The turned world has its box walls as turned rectangles (polygon walls), its boundary as the box
around the turned boundary with wall triangles in the corners, and its passage at the angle.
3r-case4 has no tie between robots, so its trial turned back is the same trial to rounding: the
same outcome and entry order and trajectories within 1e-9 m over the whole trial (see
TOLERANCE). The
controller's speed and acceleration polygons are world-fixed (faces across the axes), so they
are given 24 sides here, which turning by 30, 90, 135 or 180 degrees maps onto themselves; with
the default 16 and 8 sides a turn by 30 degrees changes the speed limit by up to 2 % in some
directions, a different (equally valid) robot. Every built-in at every angle is
``tools/rotation_check.py`` (docs/passages.md gives its figures).
"""

from __future__ import annotations

import pytest

from nodnav.scenario.loading import load_scenario
from nodnav.sim.rotation import compare_rotated

SIDES = {"controller.speed_polygon_sides": 24, "controller.accel_polygon_sides": 24}


#: Largest distance (m) between the trial and its turned copy, turned back. Every turn is exact to
#: rounding (measured: 30 degrees 3.9e-12 m, 90 1.2e-12, 135 6.7e-12, 180 7.2e-12, over the whole
#: trial). A tie used to be broken by the last bits of coordinates and so differently in a turned
#: world: a shortest path around discs stepping or not through an octagon exit at its start (a
#: repeated vertex, now dropped; planning/visibility.py). Equally near escape spots on a ring
#: are still told apart by their lengths' last bits (docs/execution.md); 3r-case4 does not meet
#: such a tie.
TOLERANCE = {30.0: 1e-9, 90.0: 1e-9, 135.0: 1e-9, 180.0: 1e-9}


@pytest.mark.parametrize("angle", [30.0, 90.0, 135.0, 180.0])
def test_a_turned_trial_is_the_same_trial(angle):
    c = compare_rotated(load_scenario("3r-case4").with_overrides(**SIDES), angle, shift=(1.5, -2.0))
    assert c.outcomes == ("success", "success")
    assert c.order_match == "same"
    assert c.max_distance < TOLERANCE[angle]
    assert c.makespan_difference == 0.0


def test_a_symmetric_scenario_turned_keeps_outcome_and_order():
    # 2r-case1 is symmetric (its robots equally far from their entrances): rounding breaks the
    # tie, so the trajectories part after a few seconds, but not the outcome or the order.
    c = compare_rotated(load_scenario("2r-case1"), 90.0, shift=(1.5, -2.0))
    assert c.agrees
