"""The meet-inside family and bays in drawn corridors (issue 19, item 6)."""

import numpy as np

from nodnav.planning.waiting_spots import bay_spots
from nodnav.scenario.bay_walls import with_bay, without_bays
from nodnav.scenario.draws import draw, draw_generator
from nodnav.scenario.families import load_family
from nodnav.scenario.layout import _Attempt, _Draws
from nodnav.scenario.meeting import TEAM_MAX, MeetingAttempt, attempt_for
from nodnav.scenario.solvable import check_scenario
from nodnav.scenario.validity import is_two_room_world
from nodnav.scenario.world import INSIDE, LEFT, RIGHT, corridor_world


def test_every_meet_inside_draw_has_teams_facing_each_other():
    family = load_family("meet-inside")
    bays = 0
    for seed in range(1, 31):
        s = draw(family, seed)
        start, goal = s.world.side_of(s.origins), s.world.side_of(s.destinations)
        inside = start == INSIDE
        right, left = inside & (goal == RIGHT), inside & (goal == LEFT)
        assert 1 <= right.sum() <= TEAM_MAX and 1 <= left.sum() <= TEAM_MAX
        # Facing: every robot inside heading right is left of every robot inside heading left.
        assert s.origins[right, 0].max() < s.origins[left, 0].min()
        assert 2 <= s.n_robots <= 6
        assert check_scenario(s).ok
        if len(s.world.obstacles) == 4:
            bays += 1
            assert is_two_room_world(s.world)
            r = float(s.radii.max())
            assert len(bay_spots(s.world, r, r)) == 1  # the planner finds the bay from the walls
    assert 5 <= bays <= 25  # probability 0.5 of 30


def test_families_that_keep_the_defaults_draw_as_before():
    d = _Draws(draw_generator(1))
    for name in ("paper-like", "crowded"):
        assert type(attempt_for(load_family(name), d)) is _Attempt
    assert isinstance(attempt_for(load_family("mixed"), d), MeetingAttempt)


def test_a_bay_cut_into_a_wall_and_filled_in_again():
    world = corridor_world(-3.0, 3.0, 0.35, 4.0, 4.0, -2.5, 2.5)
    walls = [list(b) for b in world.obstacles]
    for upper in (True, False):
        cut = with_bay(walls, 3.0, 0.35, -0.4, 0.4, 0.6, upper)
        bayed = type(world)(bounds=world.bounds, obstacles=tuple(map(tuple, cut)), corridor=world.corridor,
                            entrances=world.entrances)
        assert without_bays(bayed).obstacles == world.obstacles
        # The niche is free space: its middle, 0.3 m beyond the wall's face, is 0.3 m from the walls.
        middle = np.array([[0.0, 0.65 if upper else -0.65]])
        assert np.isclose(bayed.clearance(middle)[0], 0.3)
        assert world.clearance(middle)[0] < 0
