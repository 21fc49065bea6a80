"""The plans of a recorded trial, by replaying it: a history holds states and decisions, not plans.

A trial is a deterministic function of its scenario, method and seed, so running it again with
the same code gives the same history bit for bit (``tools/same_histories.py`` checks this) and,
on the way, the plans the robots followed. :func:`replay_plans` re-runs the trial, keeps each
robot's own reference path at every decision, and checks that the replay drove exactly the
recorded positions; a history written by another code version does not replay, and then there
are no plans (the result says why) rather than plans of another trial.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nodnav.errors import NodnavError
from nodnav.sim.history import History
from nodnav.sim.simulator import Simulation


@dataclass(frozen=True)
class RobotPlan:
    """One robot's own reference path from one decision."""

    robot: int
    """Robot index (0-based)."""
    decision_time: float
    """Time of the decision that made the plan (s)."""
    times: np.ndarray
    """Sample times ``(K,)`` (s, simulated)."""
    positions: np.ndarray
    """Planned positions ``(K, 2)`` (m)."""


@dataclass(frozen=True)
class Plans:
    """Every robot's plan at every decision of a trial, or why there are none."""

    success: bool
    """Whether the replay drove the recorded positions exactly (else ``plans`` is empty)."""
    reason: str
    """One line: what was replayed, or why the plans are missing."""
    plans: tuple[RobotPlan, ...] = field(default=())
    """Plans in decision order, robots in index order within a decision."""


class _RecordingPlans:
    """The trial's method, keeping each robot's own reference path at every decision; the
    simulator sees the same method (it calls only ``name``, ``decide`` and ``act``)."""

    def __init__(self, method, sim: Simulation, plans: list[RobotPlan]):
        self.inner, self.name, self.sim, self.plans = method, method.name, sim, plans

    def decide(self, views):
        decisions = self.inner.decide(views)
        for i in sorted(decisions):
            trajectory = decisions[i].plan.trajectory
            own = trajectory.positions[:, 0] if trajectory.positions.size else np.zeros((0, 2))
            self.plans.append(RobotPlan(int(i), float(self.sim.t), np.asarray(trajectory.times, dtype=float).copy(),
                                        np.asarray(own, dtype=float).copy()))
        return decisions

    def act(self, t, views):
        return self.inner.act(t, views)


def replay_plans(history: History) -> Plans:
    """Re-run ``history``'s trial and collect the plans (module docstring); a few seconds to a minute."""
    try:
        sim = Simulation(history.scenario, history.method, history.seed)
    except NodnavError as exc:  # e.g. a plugin's method that is not installed here
        return Plans(False, f"cannot replay the trial ({exc}); plans left out")
    plans: list[RobotPlan] = []
    sim.method = _RecordingPlans(sim.method, sim, plans)
    while not sim.step():
        pass
    recorded = np.asarray(history.positions, dtype=float)
    replayed = np.asarray(sim.history.positions, dtype=float)
    if recorded.shape != replayed.shape or not np.array_equal(recorded, replayed):
        return Plans(False, "the trial does not replay to the recorded positions (recorded by another code "
                     "version?); plans left out")
    return Plans(True, f"replayed {history.scenario.name} seed {history.seed} ({history.method}): "
                 f"{len(plans)} plans", tuple(plans))
