"""How a robot follows its selected joint plan between two decisions: by precedence, or by the clock.

The appendix has each robot track its path of the selected joint plan as a function of time.
With ``execution.mode: gated`` (the default) a robot instead keeps a clock per robot of its plan
(itself and its game players) that runs with real time but stops at the last sample whose
precedences (:mod:`nodnav.planning.dependencies`) are met by what the robot observes: it goes
where another robot of its plan was earlier in the plan only once that robot has actually moved
on. Its MPC reference is its own path read on its own clock, held at that sample; its prediction
of a game player is the player's planned motion read on the player's clock, started from where
the player is seen now. ``timed`` is the paper's literal tracking by the clock.

Only what the robot observes enters: the positions of the robots of its plan. All robots of a
plan that they agree on compute the same precedences, so a follower waits where the plan wants
it to wait for as long as the leader actually needs, and a robot that must first get out of
another's way is waited for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodnav.planning.base import JointTrajectory
from nodnav.planning.dependencies import gate_sample, observed_progress, plan_dependencies


@dataclass(frozen=True)
class ExecutionSettings:
    """What :class:`PlanExecution` needs, derived from the scenario once per trial."""

    gated: bool
    """Whether to execute by precedence (else by the clock, as the appendix)."""
    dt: float
    """Control step: how far the clocks run per step (s)."""
    horizon: float
    """How much plan time after the clocks a robot ever reads (s): the opinion period plus the
    MPC horizon, since a plan is replaced at the next decision."""
    lag: float
    """Least time between the two samples of a precedence (s), see :func:`plan_dependencies`."""
    margin: float
    """Conflict distance beyond the sum of two robots' radii (m)."""
    tolerance: float
    """Distance (m) within which a robot still counts as at the earliest of its nearest samples
    (:func:`observed_progress`)."""


class PlanExecution:
    """One robot's execution of one joint plan over ``robots`` (scenario indices, the robot first),
    from the plan's first sample on."""

    def __init__(self, trajectory: JointTrajectory, robots: tuple[int, ...], radii: np.ndarray,
                 settings: ExecutionSettings):
        self.trajectory = trajectory
        self.robots = robots
        self.settings = settings
        self.t0 = float(trajectory.times[0])
        n = len(robots)
        self.clocks = np.zeros(n)
        if settings.gated:
            # Only the first opinion period and one horizon of the plan are ever read: resample
            # that much at the control step.
            steps = int(np.ceil(settings.horizon / settings.dt)) + 1
            self.sample_times = settings.dt * np.arange(steps)
            self.samples = trajectory.positions_at(self.t0 + self.sample_times)  # (S, n, 2)
            r = np.asarray(radii, dtype=float)
            conflict = r[:, None] + r[None, :] + settings.margin
            lag = max(int(round(settings.lag / settings.dt)), 1)
            self.dependencies = plan_dependencies(self.samples, conflict, lag)
            self.progress = np.zeros(n, dtype=np.int64)
            self.gates = np.full(n, steps - 1, dtype=np.int64)

    def observe(self, positions: np.ndarray) -> None:
        """Update every robot's progress and gate from the observed ``positions`` ``(n, 2)`` of the
        plan's robots (call once per control step, before reading references)."""
        if not self.settings.gated:
            return
        for c in range(len(self.robots)):
            self.progress[c] = observed_progress(self.samples[:, c], positions[c], self.progress[c],
                                                 self.settings.tolerance)
        for c in range(len(self.robots)):
            self.gates[c] = gate_sample(self.dependencies, c, self.progress)

    def limits(self) -> np.ndarray:
        """Plan time (s after the plan's start) at which each robot's clock stops for now."""
        if not self.settings.gated:
            return np.full(len(self.robots), np.inf)
        return self.sample_times[self.gates]

    def read(self, offsets: np.ndarray) -> np.ndarray:
        """Plan positions of every robot at ``offsets`` ``(M,)`` (s) after its clock, each held at
        its limit: ``(M, n, 2)``."""
        when = np.minimum(self.clocks[None, :] + np.asarray(offsets, dtype=float)[:, None], self.limits()[None, :])
        flat = self.trajectory.positions_at(self.t0 + when.reshape(-1)).reshape(len(offsets), -1, len(self.robots), 2)
        columns = np.arange(len(self.robots))
        return flat[:, columns, columns]

    def advance(self) -> None:
        """Run every clock on by one control step, up to its limit."""
        self.clocks = np.minimum(self.clocks + self.settings.dt, np.maximum(self.clocks, self.limits()))
