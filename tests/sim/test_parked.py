"""Which robots done with the corridor join a robot's planning (sim/parked.py), checked against
distances worked out by hand in the world of the regression scenario destination-behind-parked-robots
(corridor x in [-4.925, 4.925], |y| <= 0.628; the right room x in [4.925, 8.5], y in [-3.281, 6.688])."""

from pathlib import Path

import numpy as np

from nodnav.scenario.loading import load_scenario
from nodnav.sim.parked import packed_crossed

WORLD = load_scenario(Path(__file__).parent / "regression" / "destination-behind-parked-robots.yaml").world
R = 0.351      # every robot's radius (m)
MARGIN = 0.05  # the planner's margin: a robot needs 2 R + 2 MARGIN = 0.802 m between two bodies
TOL = 0.15     # goal tolerance (m)


def robots(late=(6.2, 0.5)):
    """Robot 0 at ``late`` going to (6.2, -2.5): from (6.2, 0.5) its way is the straight segment
    x = 6.2 (1.275 m from the nearest wall corner, (4.925, -0.628)). Robots 1-4 parked at their
    destinations, robot 5 on its way to the left room; gaps are centre distances less 2 R = 0.702 m:
    1 at (6.2, -1.4): on the way;
    2 at (7.1, -1.4): 0.9 m from the way, a gap of 0.198 m < 0.802 m: packed round it;
    3 at (8.0, -1.4): 1.8 m from the way (gap 1.098 m), but 0.9 m from robot 2 (gap 0.198 m);
    4 at (7.5, 3.0): 2.818 m from the way's end (6.2, 0.5), 4.4 m from robot 3;
    5 at (5.3, 0.3): 0.9 m from the way, but it has not crossed (its destination is in the left room)."""
    positions = np.array([late, [6.2, -1.4], [7.1, -1.4], [8.0, -1.4], [7.5, 3.0], [5.3, 0.3]])
    destinations = np.array([[6.2, -2.5], [6.2, -1.4], [7.1, -1.4], [8.0, -1.4], [7.5, 3.0], [-8.0, 2.0]])
    return positions, destinations, np.full(6, R)


def test_a_late_robot_plans_the_robots_packed_round_its_way_in_a_chain():
    positions, destinations, radii = robots()
    known = np.ones(6, dtype=bool)
    assert packed_crossed(WORLD, positions, destinations, radii, known, [0], TOL, MARGIN) == [1, 2, 3]
    # A robot it does not see is not planned, and the chain through it breaks.
    known[2] = False
    assert packed_crossed(WORLD, positions, destinations, radii, known, [0], TOL, MARGIN) == [1]


def test_a_parked_robot_plans_the_robot_whose_way_it_closes_off_once_that_one_has_crossed():
    positions, destinations, radii = robots()
    known = np.ones(6, dtype=bool)
    # Robot 3 (packed round robot 0's way through robot 2) plays with robot 4: robot 0 joins, and
    # so do robots 1 and 2 packed round its way.
    assert packed_crossed(WORLD, positions, destinations, radii, known, [3, 4], TOL, MARGIN) == [0, 1, 2]
    # Robot 4 is packed round nobody's way: nothing joins its plan.
    assert packed_crossed(WORLD, positions, destinations, radii, known, [4], TOL, MARGIN) == []
    # Before robot 0 has crossed (still in the left room) its place in the order is not history:
    # it does not join robot 3's plan.
    positions, destinations, radii = robots((-8.0, 2.0))
    assert packed_crossed(WORLD, positions, destinations, radii, known, [3, 4], TOL, MARGIN) == []


def test_nobody_joins_once_every_robot_of_the_room_has_arrived():
    positions, destinations, radii = robots((6.3, -2.5))  # 0.1 m from its destination: arrived
    known = np.ones(6, dtype=bool)
    assert packed_crossed(WORLD, positions, destinations, radii, known, [0], TOL, MARGIN) == []
    assert packed_crossed(WORLD, positions, destinations, radii, known, [3, 4], TOL, MARGIN) == []
