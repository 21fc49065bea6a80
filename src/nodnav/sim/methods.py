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

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        """Run every robot's decision rule; subclasses implement :meth:`decide_robot`."""
        self.plans.clear()
        self.decisions = {i: self.decide_robot(i, view) for i, view in views.items()}
        return self.decisions

    def decide_robot(self, i: int, view: RobotView) -> Decision:
        """One robot's decision."""
        raise NotImplementedError

    def predictions(self, i: int, t: float, view: RobotView) -> np.ndarray:
        """Where robot ``i`` expects every other robot over the MPC horizon ``(2 (N_r - 1), K, 2)``.

        The first ``N_r - 1`` rows are the paper's predictions: a game player follows its path in
        ``i``'s selected joint plan, displaced so that it starts from where it is observed now
        (the plan is up to a period old); any other robot is held still at its observed position
        (appendix). The last ``N_r - 1`` rows extrapolate every other robot at its observed
        velocity. The paper's predictions are what the others *should* do if they agree with
        ``i``; while they do not (yet), they may be doing something else, and keeping clear of
        what they are actually doing is what keeps every pair apart in the meantime.
        """
        decision = self.decisions[i]
        others = [k for k in range(self.scenario.n_robots) if k != i]
        now = view.positions[others]
        pred = np.repeat(now[:, None, :], len(self.sample_times), axis=1)
        traj = decision.plan.trajectory
        planned_now = traj.positions_at(t)
        ahead = traj.positions_at(t + self.sample_times)  # (K, n_plan, 2)
        for m, k in enumerate(decision.robots[1:], start=1):
            pred[others.index(k)] += ahead[:, m] - planned_now[m]
        moving = now[:, None, :] + view.velocities[others][:, None, :] * self.sample_times[None, :, None]
        return np.concatenate([pred, moving])

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        """Every robot's MPC tracks its own path in its selected plan."""
        out = {}
        radii = self.scenario.radii
        for i, view in views.items():
            traj = self.decisions[i].plan.trajectory
            reference = traj.positions_at(t + self.sample_times)[:, 0]
            others_radii = np.delete(radii, i)
            request = ControlRequest(position=view.positions[i], velocity=view.velocities[i], reference=reference,
                                     sample_times=self.sample_times, others=self.predictions(i, t, view),
                                     other_radii=np.concatenate([others_radii, others_radii]))
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
