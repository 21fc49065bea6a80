"""On a map's world the MPC holds only the walls within reach (control/mpc.py, _local_walls):
every wall a robot could reach is always in its set (against a brute-force scan of all boxes),
and a controller with the set decides as one with every wall (same verdicts on random states)."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from nodnav.control import ControlRequest
from nodnav.control.mpc import BSplineMPC
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import MPCParams

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "building" / "building-218.yaml"


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(str(EXAMPLE))


def _box_distance(p, boxes):
    dx = np.maximum(np.maximum(boxes[:, 0] - p[0], p[0] - boxes[:, 2]), 0.0)
    dy = np.maximum(np.maximum(boxes[:, 1] - p[1], p[1] - boxes[:, 3]), 0.0)
    return np.hypot(dx, dy)


def test_every_wall_within_reach_is_in_the_set_along_a_walk(scenario):
    world, robot = scenario.world, scenario.robots[0]
    assert world.wall_grid is not None and len(world.obstacle_array) > 300
    mpc = BSplineMPC(world, robot, MPCParams())
    boxes = world.obstacle_array
    rng = np.random.default_rng(4)
    p = np.array(robot.origin, dtype=float)
    sizes = []
    for _ in range(400):
        v = rng.normal(0.0, robot.max_speed, 2)
        mpc._local_walls(world.wall_grid, p, v)
        reach = mpc.wall_reach(v)
        # The hand bound: radius + V T + V^2 / (2 d) + 0.1 with V >= the speed limit.
        assert reach >= robot.radius + robot.max_speed * mpc.horizon + robot.max_speed**2 / (2 * robot.max_accel) + 0.1
        within = {tuple(b) for b in boxes[_box_distance(p, boxes) <= reach]}
        assert within <= {tuple(b) for b in mpc.obstacles}
        sizes.append(len(mpc.obstacles))
        p = p + rng.normal(0.0, 0.15, 2)  # steps of a control step or more, any direction
    assert max(sizes) < len(boxes) / 2  # the point: far fewer rows


@pytest.mark.parametrize("seed", range(2))
def test_same_verdicts_as_with_every_wall_on_random_states(scenario, seed):
    world, robot = scenario.world, scenario.robots[1]
    rng = np.random.default_rng(seed)
    times = np.linspace(0.1, MPCParams().horizon, 10)
    checked = 0
    while checked < 25:
        p0 = rng.uniform(world.bounds_array[:2], world.bounds_array[2:])
        if world.clearance(p0[None])[0] < robot.radius + 0.02:
            continue
        v0 = rng.normal(0.0, 0.5, 2)
        v0 *= min(1.0, robot.max_speed / np.hypot(*v0))
        goal = p0 + rng.normal(0.0, 2.0, 2)
        ref = p0 + (goal - p0) * (times / times[-1])[:, None]
        req = ControlRequest(position=p0, velocity=v0, reference=ref, sample_times=times,
                             others=np.zeros((0, len(times), 2)), other_radii=np.zeros(0))
        local = BSplineMPC(world, robot, MPCParams()).control(req)
        full = BSplineMPC(world, robot, replace(MPCParams(), local_walls=False)).control(req)
        assert local.success == full.success
        assert local.info.get("fallback") == full.info.get("fallback")
        np.testing.assert_allclose(local.planned_positions, full.planned_positions, atol=1e-6)
        checked += 1
