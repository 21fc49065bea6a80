"""World geometry against hand computations."""

import numpy as np
import pytest

from nodnav.scenario.world import INSIDE, LEFT, RIGHT, paper_world


@pytest.fixture
def world():
    return paper_world()


def test_paper_layout_is_single_file(world):
    # Entrances as the paper gives them; wide enough for one robot of radius 0.2, not two.
    assert world.entrances == ((-3.0, 0.0), (3.0, 0.0))
    assert 2 * 0.2 < world.corridor.width < 4 * 0.2


def test_clearance_hand_values(world):
    # Centre of the corridor: 0.35 m to either corridor wall.
    assert world.clearance(np.array([0.0, 0.0])) == pytest.approx(0.35)
    # Left room, 1 m from the left boundary at x = -7, far from everything else.
    assert world.clearance(np.array([-6.0, 0.0])) == pytest.approx(1.0)
    # Left of the entrance, nearest the upper wall corner (-3, 0.35): sqrt(0.4^2 + 0.3^2).
    assert world.clearance(np.array([-3.4, 0.05])) == pytest.approx(0.5)
    # 0.1 m deep inside the lower wall block.
    assert world.clearance(np.array([0.0, -0.45])) == pytest.approx(-0.1)


def test_is_free_uses_radius(world):
    pts = np.array([[0.0, 0.0], [0.0, 0.2], [-6.9, 0.0]])
    assert world.is_free(pts, 0.2).tolist() == [True, False, False]


def test_sides(world):
    pts = np.array([[-5.0, 1.0], [0.0, 0.0], [5.0, -1.0]])
    assert world.side_of(pts).tolist() == [LEFT, INSIDE, RIGHT]


def test_corridor_distance_rule(world):
    # Approaching from the left: distance to (-3, 0); zero inside; back to Euclidean after exiting.
    pts = np.array([[-6.0, 4.0 - 4.0], [-4.0, 1.0], [0.0, 0.0], [4.0, 0.0]])
    d = world.corridor_distance(pts, np.full(4, LEFT))
    assert d[0] == pytest.approx(3.0)
    assert d[1] == pytest.approx(np.sqrt(2.0))
    assert d[2] == 0.0
    assert d[3] == pytest.approx(7.0)
    # Approaching from the right, a robot at x = 4 is 1 m from (3, 0).
    assert world.corridor_distance(np.array([4.0, 0.0]), np.array(RIGHT)) == pytest.approx(1.0)


def test_mirror_symmetry(world):
    rng = np.random.default_rng(0)
    pts = rng.uniform([-7, -2.5], [7, 2.5], size=(200, 2))
    mirrored = pts * np.array([-1.0, 1.0])
    assert np.allclose(world.clearance(pts), world.clearance(mirrored))
    assert np.allclose(world.corridor_distance(pts, np.full(200, LEFT)),
                       world.corridor_distance(mirrored, np.full(200, RIGHT)))


def test_paper_world_is_the_two_room_layout_unchanged():
    # The construction paper_world had before corridor_world existed, written out: identical floats.
    rng = np.random.default_rng(3)
    for h, width, depth, height in [(3.0, 0.7, 4.0, 5.0), *rng.uniform(0.1, 9.0, size=(20, 4))]:
        w, ymax, xmax = width / 2.0, height / 2.0, h + depth
        world = paper_world(h, width, depth, height)
        assert world.bounds == (-xmax, -ymax, xmax, ymax)
        assert world.obstacles == ((-h, -ymax, h, -w), (-h, w, h, ymax))
        assert (world.corridor.x_min, world.corridor.x_max, world.corridor.y_min, world.corridor.y_max) == (-h, h, -w,
                                                                                                            w)
        assert world.entrances == ((-h, 0.0), (h, 0.0))


def test_corridor_world_rooms_of_their_own_depth():
    from nodnav.scenario.world import corridor_world

    world = corridor_world(-0.5, 0.5, 0.3, 2.0, 4.0, -1.0, 3.0)  # a 1 m doorway, axis 1 m below mid-height
    assert world.bounds == (-2.5, -1.0, 4.5, 3.0)
    assert world.obstacles == ((-0.5, -1.0, 0.5, -0.3), (-0.5, 0.3, 0.5, 3.0))
    assert world.clearance(np.array([0.0, 0.0])) == pytest.approx(0.3)
    assert world.clearance(np.array([-1.0, 2.0])) == pytest.approx(0.5)  # 0.5 m from the wall's face
