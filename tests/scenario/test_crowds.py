"""Crowds at the doors: the built-ins beyond the paper (5 to 8 robots) and the benchmark's
head-on crowd of any size (:mod:`nodnav.scenario.crowds`)."""

import math

import numpy as np
import pytest

from nodnav.scenario.catalogue import PAPER_SCENARIOS, crowd_scenarios
from nodnav.scenario.crowds import door_crowd
from nodnav.scenario.files import builtin_names
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.solvable import check_scenario
from nodnav.scenario.validity import is_two_room_world
from nodnav.scenario.world import LEFT, RIGHT


def test_the_paper_and_the_crowds_share_out_the_builtins():
    assert sorted(PAPER_SCENARIOS + crowd_scenarios()) == builtin_names()
    assert all(load_scenario(n).n_robots <= 4 for n in PAPER_SCENARIOS)
    assert sorted({load_scenario(n).n_robots for n in crowd_scenarios()}) == [5, 6, 7, 8]


def _traffic(scenario) -> str:
    """The families' words: an even split is head-on, all in one room one-sided, else mixed."""
    sides = scenario.world.side_of(scenario.origins)
    left, right = int((sides == LEFT).sum()), int((sides == RIGHT).sum())
    return "one-sided" if min(left, right) == 0 else "head-on" if left == right else "mixed"


@pytest.mark.parametrize("name", crowd_scenarios())
def test_crowd_builtins_are_fair_crowds_in_the_papers_corridor(name):
    s = load_scenario(name)
    assert name.startswith(f"{s.n_robots}r-") and name.endswith(_traffic(s))
    assert s.game_players == 2  # all players is refused above 6 robots
    c = s.world.corridor
    assert (c.x_min, c.x_max, c.width) == (-3.0, 3.0, pytest.approx(0.7)) and is_two_room_world(s.world)
    assert np.all(s.radii == 0.2) and np.all(s.max_speeds == 1.0)
    # A crowd at each door it starts from: at least two robots within 1.5 m of the mouth's centre.
    sides = s.world.side_of(s.origins)
    for side, mouth in ((LEFT, (-3.0, 0.0)), (RIGHT, (3.0, 0.0))):
        if (sides == side).any():
            near = np.linalg.norm(s.origins[sides == side] - mouth, axis=1) < 1.5
            assert near.sum() >= min(2, (sides == side).sum())
    # Destinations spread in the far room: no two within a robot's length of each other.
    d = s.destinations
    gaps = np.linalg.norm(d[:, None] - d[None], axis=-1) + 10 * np.eye(len(d))
    assert gaps.min() >= 1.0
    # At least the generated families' time limit (every robot crossing in turn, with slack).
    routes = [np.linalg.norm(o - (3.0 * np.sign(o[0]), 0.0)) + 6.0 + np.linalg.norm(e - (3.0 * np.sign(e[0]), 0.0))
              for o, e in zip(s.origins, s.destinations)]
    assert s.time_limit >= math.ceil(20 + 1.5 * (max(routes) + s.n_robots * (6.0 + 0.8)))


def test_crowd_builtins_cover_every_kind_of_traffic():
    assert {_traffic(load_scenario(n)) for n in crowd_scenarios()} == {"head-on", "one-sided", "mixed"}


@pytest.mark.parametrize("n", range(2, 11))
def test_door_crowd_is_valid_and_solvable_for_every_count(n):
    s = door_crowd(n)
    verdict = check_scenario(s)
    assert verdict.ok, verdict.reason
    sides = s.world.side_of(s.origins)
    assert (sides == LEFT).sum() == math.ceil(n / 2) and (sides == RIGHT).sum() == n // 2
    assert s.n_players == min(2, n - 1)


def test_door_crowd_by_hand():
    s = door_crowd(5, "all")
    assert s.game_players is None and s.name == "door-crowd-5"
    # Left: a pair abreast 0.6 m from the wall and one behind on the axis; right: a pair.
    np.testing.assert_allclose(s.origins, [[-3.6, 0.45], [-3.6, -0.45], [-4.35, 0.0], [3.6, 0.45], [3.6, -0.45]])
    # Destinations 3 m into the far room, spread over [-1.8, 1.8], top to top.
    np.testing.assert_allclose(s.destinations, [[6.0, 1.8], [6.0, -1.8], [6.0, 0.0], [-6.0, 1.8], [-6.0, -1.8]])
    # Two robots: routes 0.6 + 6 + 3 = 9.6 m; ceil(20 + 1.5 (9.6 + 2 x 6.8)) = 55 s.
    assert door_crowd(2).time_limit == 55.0
    with pytest.raises(ValueError):
        door_crowd(1)
