"""The result of one trial (:func:`~nodnav.sim.simulator.run_trial`): its outcome, figures and history."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nodnav.sim.failure import failure_class
from nodnav.sim.history import History
from nodnav.sim.metrics import json_ready


@dataclass
class TrialResult:
    """The outcome and figures of one trial; ``history`` holds everything that happened."""

    outcome: str
    """One of ``success``, ``collision``, ``deadlock``, ``timeout``."""
    sim_time: float
    """Simulated time when the trial ended (s)."""
    wall_time: float
    """Wall-clock time the trial took (s)."""
    makespan: float
    """Time at which the last robot arrived (s); NaN unless every robot arrived."""
    min_separation: float
    """Smallest centre-to-centre distance between any two robots during the trial, exact between steps (m)."""
    collisions: int
    """Number of robot pairs or robot-wall contacts found at the step that ended the trial."""
    entry_order: tuple[int, ...]
    """Robots (0-based) in the order they entered the corridor."""
    strategy: int
    """Index (0-based) of the realised passing order among all strategies; -1 if incomplete."""
    consensus: bool
    """Whether the robots' selections agreed on the order of the robots still to enter, at the
    last decision when at least two had not entered the corridor."""
    time_to_goal: tuple[float, ...]
    """Time each robot first reached its destination (s); NaN if it did not."""
    mpc_infeasible: int
    """Number of control steps at which an MPC found no feasible trajectory and braked."""
    plan_failures: int
    """Number of selected plans that failed (the robot then held its position)."""
    history: History = field(repr=False)
    """The full record."""
    metrics: dict = field(default_factory=dict)
    """Further per-trial metrics (see :mod:`nodnav.sim.metrics`)."""
    collision_kind: str = ""
    """What the collision that ended the trial was between: ``robot-robot``, ``wall``, or empty."""

    @property
    def success(self) -> bool:
        """Whether every robot reached its destination without collision."""
        return self.outcome == "success"

    def to_dict(self) -> dict:
        """A JSON-ready summary with robots and strategies numbered from 1, as the paper does."""
        def num(x):
            return None if x is None or not np.isfinite(x) else round(float(x), 6)

        return {
            "scenario": self.history.scenario.name,
            "method": self.history.method,
            "seed": self.history.seed,
            "outcome": self.outcome,
            "success": self.success,
            "sim_time_s": num(self.sim_time),
            "wall_time_s": num(self.wall_time),
            "makespan_s": num(self.makespan),
            "min_separation_m": num(self.min_separation),
            "collisions": self.collisions,
            "corridor_entry_order": [k + 1 for k in self.entry_order],
            "strategy": self.strategy + 1 if self.strategy >= 0 else None,
            "consensus": self.consensus,
            "time_to_goal_s": [num(x) for x in self.time_to_goal],
            "mpc_infeasible": self.mpc_infeasible,
            "plan_failures": self.plan_failures,
            "collision_kind": self.collision_kind or None,
            "failure_class": failure_class(self),
            **{k: v for k, v in json_ready(self.metrics).items() if k not in ("makespan_s", "time_to_goal_s",
                                                                           "min_separation_m")},
        }
