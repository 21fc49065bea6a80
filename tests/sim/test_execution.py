"""Executing a joint plan by precedence: a follower waits for a leader that does not move."""

import numpy as np

from nodnav.planning.base import JointTrajectory
from nodnav.sim.execution import ExecutionSettings, PlanExecution


def _settings(gated: bool = True) -> ExecutionSettings:
    return ExecutionSettings(gated=gated, dt=0.1, horizon=3.0, lag=0.3, margin=0.05, tolerance=0.05)


def _queue() -> JointTrajectory:
    # Leader (robot 0) 1 m ahead of the follower (robot 1); both drive along x at 1 m/s.
    t = 0.1 * np.arange(50)
    positions = np.stack([np.stack([1.0 + t, 0 * t], 1), np.stack([t, 0 * t], 1)], axis=1)
    return JointTrajectory.from_positions(t, positions)


def test_the_follower_holds_one_conflict_distance_behind_a_leader_that_stays_put():
    radii = np.array([0.2, 0.2])
    ex = PlanExecution(_queue(), (1, 0), radii, _settings())
    follower = 1
    for _ in range(30):
        ex.observe(np.array([[1.0, 0.0], ex.read(np.zeros(1))[0, follower]]))  # leader never moves
        ex.advance()
    held = ex.read(np.array([0.0, 0.5, 1.0]))[:, follower]
    gap = np.linalg.norm(held - np.array([1.0, 0.0]), axis=1)
    # It may come no closer than the conflict distance 0.2 + 0.2 + 0.05 to where the leader
    # stands, and stops within one sample (0.1 m) of it; the leader's own clock runs on.
    assert np.all(gap >= 0.45 - 1e-9) and np.all(gap <= 0.45 + 0.1 + 1e-9)
    assert ex.clocks[0] > 2.9


def test_the_follower_goes_on_as_the_leader_moves():
    ex = PlanExecution(_queue(), (1, 0), np.array([0.2, 0.2]), _settings())
    for _step in range(20):
        where = ex.read(np.zeros(1))[0]
        ex.observe(where)  # everybody where the plan has them
        ex.advance()
    assert np.allclose(ex.clocks, 2.0)


def test_timed_execution_reads_the_plan_by_the_clock():
    ex = PlanExecution(_queue(), (1, 0), np.array([0.2, 0.2]), _settings(gated=False))
    for _ in range(7):
        ex.observe(np.array([[1.0, 0.0], [0.0, 0.0]]))
        ex.advance()
    assert np.allclose(ex.read(np.array([0.0]))[0], [[1.7, 0.0], [0.7, 0.0]])
