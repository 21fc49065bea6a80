"""The MPC benchmark's situation: references that keep the robots apart and clear of the walls."""

import numpy as np

from nodnav.bench.mpc import benchmark_mpc, queue_references
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import MPCParams, RobotSpec

ROBOT = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))  # radius 0.2, 1 m/s, 2 m/s^2
PARAMS = MPCParams()


def test_benchmark_situation_is_consistent_and_runs():
    scenario = load_scenario("4r-case1")
    grid = np.arange(0.0, 30.0, 0.02)
    refs = queue_references(scenario.world, scenario.origins, scenario.destinations[[2, 3, 0, 1]], 0.8, 1.2, grid)
    gaps = np.linalg.norm(refs[:, :, None] - refs[:, None], axis=-1) + 10.0 * np.eye(4)
    assert gaps.min() > 2 * ROBOT.radius + PARAMS.safety_margin
    assert scenario.world.clearance(refs).min() >= ROBOT.radius
    result = benchmark_mpc(duration=2.0)
    assert result.solves == 4 * 20
    assert result.infeasible == 0
    assert result.min_separation > 0.0 and result.min_clearance >= -1e-9
    assert 0.0 < result.median <= result.p95 <= result.max
