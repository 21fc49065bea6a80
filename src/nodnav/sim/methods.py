"""Navigation methods behind one interface: how each robot decides and how it moves.

A method is built per trial. At every opinion period the simulator calls :meth:`Method.decide`
with each robot's own view; at every control step it calls :meth:`Method.act`, which returns
each robot's next state. ``nod`` is the paper's method; the baselines reuse the same planner
and MPC wherever they can, so that only the decision rule differs.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from nodnav.control import ControlRequest, ControlResult, make_controller
from nodnav.planning import make_planner
from nodnav.scenario.schema import Scenario
from nodnav.sim.agent import Decision, NODAgent, PlanCache, RobotView

#: Number of MPC constraint samples over the horizon.
MPC_SAMPLES = 8


def braking_extrapolation(positions: np.ndarray, velocities: np.ndarray, decel: np.ndarray,
                          times: np.ndarray) -> np.ndarray:
    """Where robots moving at ``velocities`` are at ``times`` if they brake at once along their
    velocity with deceleration ``decel`` until they stop, ``(n, K, 2)``."""
    speed = np.linalg.norm(velocities, axis=1)
    heading = np.divide(velocities, speed[:, None], out=np.zeros_like(velocities), where=speed[:, None] > 0)
    tau = np.minimum(times[None, :], (speed / decel)[:, None])  # (n, K): braking time so far
    travelled = speed[:, None] * tau - 0.5 * decel[:, None] * tau * tau
    return positions[:, None, :] + heading[:, None, :] * travelled[..., None]


class Method(Protocol):
    """A decentralised navigation method for every robot of a trial."""

    name: str

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        """Each robot's decision for the coming period, from its own view only."""
        ...

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        """Each robot's motion over the next control step."""
        ...


class PlannedMethod:
    """Shared machinery: a planner (with a per-round plan cache) and one MPC per robot."""

    name = "planned"

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        self.scenario = scenario
        self.rngs = rngs
        self.plans = PlanCache(planner if planner is not None else make_planner(scenario.planner, scenario.world))
        self.controllers = [make_controller(scenario.controller, scenario.world, r) for r in scenario.robots]
        self.decisions: dict[int, Decision] = {}
        horizon = scenario.controller.horizon
        self.sample_times = horizon * np.arange(1, MPC_SAMPLES + 1) / MPC_SAMPLES
        self._offsets = np.concatenate([[0.0], self.sample_times])
        n = scenario.n_robots
        self._others = [[k for k in range(n) if k != i] for i in range(n)]
        # Radii of the others, once for each of the three predictions of every other robot.
        self._other_radii = [np.tile(np.delete(scenario.radii, i), 3) for i in range(n)]
        # Where the others would be if they braked now is where they can at least be: an
        # evasive plan may intrude into the other predictions, never into that one.
        self._firm = np.repeat([False, False, True], n - 1)
        accel = np.array([r.max_accel for r in scenario.robots])
        self._decel = [np.delete(accel, i) for i in range(n)]

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        """Run every robot's decision rule; subclasses implement :meth:`decide_robot`."""
        self.plans.clear()
        self.decisions = {i: self.decide_robot(i, view) for i, view in views.items()}
        return self.decisions

    def decide_robot(self, i: int, view: RobotView) -> Decision:
        """One robot's decision."""
        raise NotImplementedError

    def predictions(self, i: int, t: float, view: RobotView) -> np.ndarray:
        """Where robot ``i`` expects every other robot over the MPC horizon ``(3 (N_r - 1), K, 2)``.

        The first ``N_r - 1`` rows are the paper's predictions: a game player follows its path in
        ``i``'s selected joint plan, displaced so that it starts from where it is observed now
        (the plan is up to a period old); any other robot is held still at its observed position
        (appendix). The paper's predictions are what the others *should* do if they agree with
        ``i``; while they do not (yet), they may be doing something else. So every other robot is
        also kept clear of where it is actually going, in the two ways its motion can continue
        that matter most: at its observed velocity (the next ``N_r - 1`` rows: a robot that keeps
        coming) and braking at once along it (the last ``N_r - 1`` rows: a robot ahead that stops,
        which a follower trusting the first two would run into).
        """
        return self._predictions(i, view, self._planned(i, t))

    def _planned(self, i: int, t: float) -> np.ndarray:
        """Robot ``i``'s selected joint plan at ``t`` and at the MPC sample times after it ``(1 + K, n_plan, 2)``."""
        return self.decisions[i].plan.trajectory.positions_at(t + self._offsets)

    def _predictions(self, i: int, view: RobotView, planned: np.ndarray) -> np.ndarray:
        """:meth:`predictions` from the plan's samples (:meth:`_planned`)."""
        others = self._others[i]
        now = view.positions[others]
        pred = np.repeat(now[:, None, :], len(self.sample_times), axis=1)
        for m, k in enumerate(self.decisions[i].robots[1:], start=1):
            pred[others.index(k)] += planned[1:, m] - planned[0, m]
        v = view.velocities[others]
        moving = now[:, None, :] + v[:, None, :] * self.sample_times[None, :, None]
        return np.concatenate([pred, moving, braking_extrapolation(now, v, self._decel[i], self.sample_times)])

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        """Every robot's MPC tracks its own path in its selected plan."""
        out = {}
        for i, view in views.items():
            planned = self._planned(i, t)
            request = ControlRequest(position=view.positions[i], velocity=view.velocities[i], reference=planned[1:, 0],
                                     sample_times=self.sample_times, others=self._predictions(i, view, planned),
                                     other_radii=self._other_radii[i], firm=self._firm)
            out[i] = self.controllers[i].control(request)
        return out


class NODMethod(PlannedMethod):
    """The paper's opinion-driven navigation: every robot runs Algorithm 1."""

    name = "nod"

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        super().__init__(scenario, rngs, planner)
        self.agents = [NODAgent(scenario, i, rngs[i], self.plans) for i in range(scenario.n_robots)]

    def decide_robot(self, i: int, view: RobotView) -> Decision:
        return self.agents[i].decide(view)


#: Every method by name: ``nod`` is a class here; the baselines (:mod:`nodnav.sim.baselines`,
#: which imports this module) are named by class and imported when one is made.
METHODS = {"nod": NODMethod, "no-coordination": "NoCoordinationMethod", "independent": "IndependentMethod",
           "closest-first": "ClosestFirstMethod", "oracle": "OracleMethod", "orca": "OrcaMethod"}


def make_method(name: str, scenario: Scenario, rngs: list[np.random.Generator], planner=None) -> Method:
    """The method called ``name`` for one trial."""
    if name not in METHODS:
        from nodnav.errors import NodnavError

        raise NodnavError(f"unknown method '{name}'; choose one of {', '.join(METHODS)}")
    cls = METHODS[name]
    if isinstance(cls, str):
        from nodnav.sim import baselines

        cls = getattr(baselines, cls)
    return cls(scenario, rngs, planner)
