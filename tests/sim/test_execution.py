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


def _waits(patience: float):
    from types import SimpleNamespace
    from typing import cast

    from nodnav.scenario.schema import Scenario
    from nodnav.sim.execution import WaitRelease

    scenario = SimpleNamespace(n_robots=2, sim=SimpleNamespace(progress_epsilon=0.2),
                               execution=SimpleNamespace(wait_patience=patience))
    return WaitRelease(cast(Scenario, scenario))  # only the fields WaitRelease reads


def _held_follower(patience: float, leader_speed: float, steps: int) -> PlanExecution:
    """The follower (robot 1) executing the queue while the leader stays at its start, or sways
    across the queue's line by ``leader_speed`` (m) every second, which gets it nowhere along the plan."""
    from types import SimpleNamespace

    queue = _queue()  # the follower's plan lists the follower (scenario robot 1) first
    plan = JointTrajectory.from_positions(queue.times, queue.positions[:, ::-1])
    ex = PlanExecution(plan, (1, 0), np.array([0.2, 0.2]), _settings())
    waits = _waits(patience)
    rows = np.array([1, 0])
    for k in range(steps):
        sway = leader_speed * ((k // 10) % 2)  # a step of that size across the line every second
        positions = np.array([[1.0, sway], [0.0, 0.0]])  # scenario order: robot 0 leader, robot 1 follower
        velocities = np.zeros((2, 2))
        ex.observe(positions[rows])
        waits.check(1, 0.1 * k, ex, rows, SimpleNamespace(positions=positions, velocities=velocities))
        ex.advance()
    return ex


def test_a_robot_held_by_a_standing_robot_in_a_standing_plan_stops_waiting_after_the_patience():
    # The follower may drive 0.5 m (to one conflict distance, 0.45 m, behind the standing leader,
    # within a 0.1 m sample) and is held there. Its wait begins at the first step (t = 0); the
    # step at t = 3 s, the 31st, releases it.
    assert _held_follower(3.0, 0.0, 30).gates[0] == 5
    released = _held_follower(3.0, 0.0, 31)
    assert released.gates[0] == len(released.sample_times) - 1  # nothing holds it any more
    assert len(released.blockers()) == 0


def test_a_robot_held_by_a_moving_robot_or_with_no_patience_waits_as_before():
    # A leader that moves 0.3 m across the line (more than sim.progress_epsilon, 0.2 m) within
    # every 3 s starts the wait anew each time: the follower waits for it as before.
    assert _held_follower(3.0, 0.3, 60).gates[0] == 5
    assert _held_follower(0.0, 0.0, 60).gates[0] == 5
