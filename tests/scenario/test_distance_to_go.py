"""The compiled distance to go against the plain NumPy computation it replaces, and by hand."""

import math

import numpy as np
import pytest

from nodnav.scenario.loading import load_scenario
from nodnav.scenario.transform import transform_scenario
from nodnav.scenario.world import distance_to_go, distance_to_go_plain, paper_world


def test_distance_to_go_by_hand_in_the_paper_world():
    world = paper_world()  # entrances (-3, 0) and (3, 0)
    points = np.array([[-5.0, 1.0], [0.0, 0.0], [4.0, 0.0], [-5.0, 0.0]])
    dest = np.array([[5.0, 0.0], [5.0, 1.0], [5.0, 0.0], [-6.0, 0.0]])
    side = np.array([-1, -1, -1, -1])
    got = distance_to_go(world, points, dest, side)
    want = [math.hypot(2.0, 1.0) + 6.0 + 2.0,  # before: via both entrances
            3.0 + math.hypot(2.0, 1.0),        # inside: via the far entrance
            1.0,                               # past the corridor: straight
            1.0]                               # no crossing: straight
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("angle", [0.0, 30.0, 123.0])
def test_distance_to_go_equals_the_plain_computation_bit_for_bit(angle):
    world = transform_scenario(load_scenario("4r-case1"), angle).world if angle else load_scenario("4r-case1").world
    rng = np.random.default_rng(3)
    for _ in range(100):
        n = int(rng.integers(1, 6))
        # Broadcast as the agent calls it: windows of positions against one destination each.
        points = rng.uniform(-8.0, 8.0, size=(n, 7, 2))
        dest = rng.uniform(-8.0, 8.0, size=(n, 1, 2))
        side = rng.choice([-1, 0, 1], size=(n, 1))
        assert distance_to_go(world, points, dest, side).tobytes() == \
            distance_to_go_plain(world, points, dest, side).tobytes()
        got = distance_to_go(world, points[:, 0], dest[:, 0], side[:, 0])
        assert got.shape == (n,)
        assert got.tobytes() == distance_to_go_plain(world, points[:, 0], dest[:, 0], side[:, 0]).tobytes()
