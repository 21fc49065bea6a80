"""Navigation methods behind one interface: how each robot decides and how it moves.

A method is built per trial. At every opinion period the simulator calls :meth:`Method.decide`
with each robot's own view; at every control step it calls :meth:`Method.act`, which returns
each robot's next state. ``nod`` is the paper's method; the baselines reuse the same planner
and MPC wherever they can, so that only the decision rule differs.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Protocol

import numpy as np

from nodnav.control import ControlRequest, ControlResult, SharedSetups, make_controller
from nodnav.control.mutual_braking import CONVENTIONS, RESTART_HEADROOM, BrakingPartners, restart_gap
from nodnav.errors import NodnavError
from nodnav.planning import make_planner
from nodnav.registry import METHODS, register_method
from nodnav.scenario.params import plan_reuse
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import World
from nodnav.sim.agent import Decision, NODAgent, RobotView
from nodnav.sim.execution import ExecutionSettings, PlanExecution, ReactionMargins, WaitRelease
from nodnav.sim.horizon import at_rest_and_clear, gated_step, horizon_predictions
from nodnav.sim.horizon import braking_extrapolation as braking_extrapolation  # re-exported: moved to horizon
from nodnav.sim.horizon import gated_horizon as gated_horizon  # re-exported: moved to horizon
from nodnav.sim.plan_cache import PlanCache
from nodnav.sim.sensing import OcclusionLimit, slowed_reference
from nodnav.sim.several import PassageAgent, PassageViews, several


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
        self.plans = PlanCache(planner if planner is not None else make_planner(scenario.planner, scenario.world),
                               *plan_reuse(scenario.planner))
        shared = SharedSetups()
        self.controllers = [make_controller(scenario.controller, scenario.world, r, shared) for r in scenario.robots]
        self.decisions: dict[int, Decision] = {}
        horizon = scenario.controller.horizon
        samples = scenario.controller.samples
        self.sample_times = horizon * np.arange(1, samples + 1) / samples
        self._offsets = np.concatenate([[0.0], self.sample_times])
        n = scenario.n_robots
        self._others = [[k for k in range(n) if k != i] for i in range(n)]
        self._others_array = [np.array(o, dtype=np.int64) for o in self._others]
        # Radii of the others, once for each of the three predictions of every other robot.
        self._other_radii = [np.tile(np.delete(scenario.radii, i), 3) for i in range(n)]
        # Where the others would be if they braked now is where they can at least be: an
        # evasive plan may intrude into the other predictions, never into that one.
        self._firm = np.repeat([False, False, True], n - 1)
        accel = self._accel = np.array([r.max_accel for r in scenario.robots])
        self._decel = [np.delete(accel, i) for i in range(n)]
        self.dt = scenario.controller.dt
        ex = scenario.execution
        self._execution_settings = ExecutionSettings(
            gated=ex.mode == "gated", dt=scenario.controller.dt, horizon=scenario.opinion.T + horizon, lag=ex.lag,
            margin=scenario.planner.margin, tolerance=ex.tolerance)
        self._executions: dict[int, tuple[Decision, PlanExecution, np.ndarray, np.ndarray, tuple]] = {}
        self.reactions = ReactionMargins(scenario)
        self.keeps_rule = np.ones(n, dtype=bool)
        """Which robots keep the mutual braking rule (:mod:`nodnav.control.mutual_braking`): every
        robot of a trial run by one planned method; a :class:`Team` narrows it to its planned
        methods' robots."""
        self._convention = CONVENTIONS.index(ex.mutual_braking) if ex.mutual_braking != "none" else -1
        self._all_seen = np.ones(n, dtype=bool)
        # Robots standing still take the weak check in turn, one opinion period each (the speed convention).
        self._turn_period = scenario.opinion.T
        self._turn = (math.nan, 0)  # (time, turn) of the last step
        self._radii = scenario.radii
        self._margins: dict[int, tuple[bytes, np.ndarray | None]] = {}  # per robot: (keeps_rule's bytes, margins)
        self._restart_gap = self._convention >= 0 and ex.restart_gap  # read at every step: once here
        # execution.skip_at_rest: per robot (its radius plus the safety margin, the clearance, the tolerance).
        self._rest = None if not ex.skip_at_rest else [
            (float(r.radius + scenario.controller.safety_margin), float(ex.rest_clearance), float(ex.rest_tolerance))
            for r in scenario.robots]
        self.waits = WaitRelease(scenario)
        w = self.waits
        # gated_step's arguments that stay the same for a trial (the arrays are updated in place).
        self._wait_state = (w.patience, w.reach, w.anchors, w.anchored, w.since, w.released_until)
        self._step_constants = [(self._others_array[i], self._decel[i], self.sample_times) for i in range(n)]
        # Limited sight: no faster than a robot can stop short of the places it cannot see.
        sensing = scenario.sensing
        self.occlusion = OcclusionLimit(scenario) if sensing.limited and sensing.occlusion_speed else None
        self.passages = None
        if several(scenario):
            def planner_for(world: World) -> Any:
                return planner if planner is not None else make_planner(scenario.planner, world)

            self.passages = PassageViews(scenario, planner_for)
        """With several passages, the routes and each passage's one-passage view
        (:mod:`nodnav.sim.several`); None with one."""

    def passage_agents(self, make: Callable[[Scenario, int, int], Any], arrived: bool = True) -> list[PassageAgent]:
        """With several passages, every robot's :class:`PassageAgent`, whose decider for passage
        ``k`` is ``make(scenario_k, k, i)`` (``scenario_k`` the passage's one-passage view, or
        that view with robot ``i`` going to its own destination once it has left ``k``, its last,
        behind)."""
        assert self.passages is not None
        views = self.passages

        def maker(i: int) -> Callable[[Scenario, int], Any]:
            return lambda one, k: make(one, k, i)

        return [PassageAgent(views, i, maker(i), arrived) for i in range(self.scenario.n_robots)]

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        """Run every robot's decision rule; subclasses implement :meth:`decide_robot`."""
        self.plans.clear()
        if self.passages is not None:
            self.passages.clear()
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
        return self._horizon(i, t, view)[1]

    def execution(self, i: int) -> PlanExecution:
        """Robot ``i``'s execution of its current decision's plan (a new one after each decision)."""
        return self._held(i)[1]

    def _held(self, i: int) -> tuple[Decision, PlanExecution, np.ndarray, np.ndarray, tuple]:
        """Robot ``i``'s current decision, its execution, the rows of the decision's robots in a
        view, each other robot's column in the decision's plan (-1: not in it) and the
        execution's arguments of :func:`gated_step` up to the step constants, built once per decision."""
        decision = self.decisions[i]
        held = self._executions.get(i)
        if held is None or held[0] is not decision:
            rows = np.array(decision.robots, dtype=np.int64)
            columns = np.array([decision.robots.index(k) if k in decision.robots else -1 for k in self._others[i]],
                               dtype=np.int64)
            ex = PlanExecution(decision.plan.trajectory, decision.robots, self._radii[rows], self._execution_settings)
            # gated_step's arguments from the execution's to the step constants, in one tuple (the
            # arrays are updated in place): unpacked once at each step rather than piece by piece.
            step = () if not self._execution_settings.gated else (
                ex.trajectory.times, ex.trajectory.positions, ex.t0, ex.clocks, ex.samples, ex.dependencies,
                ex.progress, ex.gates, ex.sample_times, rows, self._execution_settings.tolerance, *self._wait_state,
                self._offsets, self.dt, columns, *self._step_constants[i])
            held = self._executions[i] = (decision, ex, rows, columns, step)
        return held

    def _horizon(self, i: int, t: float, view: RobotView) -> tuple[np.ndarray, np.ndarray]:
        """Robot ``i``'s reference (its path in its selected plan at the MPC sample times after
        ``t``, ``(K, 2)``) and :meth:`predictions`; read by precedence or by the clock
        (:mod:`nodnav.sim.execution`)."""
        decision, execution, _, columns, _ = self._held(i)
        if self._execution_settings.gated:
            planned = execution.read(self._offsets)
        else:
            planned = decision.plan.trajectory.positions_at(t + self._offsets)
        others = self._others[i]
        predictions = horizon_predictions(planned, columns, view.positions[others], view.velocities[others],
                                          self._decel[i], self.sample_times)
        return planned[1:, 0], predictions

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        """Every robot's MPC tracks its own path in its selected plan."""
        out = {}
        gated = self._execution_settings.gated
        reactions = self.reactions
        conflicted = reactions.conflicted
        # What is the same for every robot of the step, once: a Team narrows keeps_rule after
        # construction, so its bytes stamp the margins (_margins_of); with exact sensing every
        # robot's view is one object, whose arrays and braking partners are then read once.
        stamp = self.keeps_rule.tobytes() if self._restart_gap else b""
        last = None
        for i, view in views.items():
            _, execution, rows, columns, step = self._held(i)
            if view is not last:
                last, positions, velocities = view, view.positions, view.velocities
                sensed = view.age is not None or view.sigma is not None
                partners = self._partners_shared(t, view, positions, velocities)
            if gated:  # observe, wait, read, predict, advance and widen: one compiled call
                seen = reactions.seen(i, positions, velocities)
                reference, predictions, radii = gated_step(
                    positions, velocities, i, t, *step, *seen, *reactions.constants[i], bool(conflicted[i]),
                    self._other_radii[i])
            else:
                execution.observe(positions[rows])
                self.waits.check(i, t, execution, rows, view)
                reference, predictions = self._horizon(i, t, view)
                execution.advance()
                radii = reactions.radii(i, view, self._other_radii[i])
            if self.occlusion is not None:
                limit = self.scenario.robots[i].max_speed
                cap = self.occlusion.speed(i, positions[i], limit)
                if cap < limit:
                    reference = slowed_reference(positions[i], reference, self.sample_times, cap)
            firm, margins = self._firm, self._margins_of(i, stamp)
            if sensed:
                predictions, radii, firm, margins = self._sensed(i, view, predictions, radii, margins)
            if self._rest is not None and at_rest_and_clear(positions[i], velocities[i], reference,
                                                            predictions, radii, *self._rest[i]):
                out[i] = self._stay(positions[i])
                conflicted[i] = False
                continue
            request = ControlRequest.built(positions[i], velocities[i], reference, self.sample_times, predictions,
                                           radii, firm, None if partners is None else BrakingPartners(i, *partners),
                                           margins)
            result = out[i] = self.controllers[i].control(request)
            conflicted[i] = not result.success
        return out

    def _margins_of(self, i: int, stamp: bytes | None = None) -> np.ndarray | None:
        """The clearance robot ``i`` keeps from each of its predictions (``ControlRequest.margins``):
        the safety margin, and from a robot that keeps the mutual braking rule as ``i`` does at
        least the gap from which either can start again (``execution.restart_gap``); None (the
        controller's margin) when that changes nothing. ``stamp``: ``keeps_rule``'s bytes now (a
        Team narrows it after construction), which the margins kept are checked against; None:
        read here (:meth:`act` reads them once for all its robots)."""
        if not self._restart_gap or not self.keeps_rule[i]:
            return None
        if stamp is None:
            stamp = self.keeps_rule.tobytes()
        cached = self._margins.get(i)
        if cached is None or cached[0] != stamp:
            others = self._others_array[i]
            safety = self.scenario.controller.safety_margin
            restart = restart_gap(self._accel[i], self._accel[others], self.dt) + RESTART_HEADROOM
            margin = np.where(self.keeps_rule[others], np.maximum(safety, restart), safety)
            # Once per prediction, as the radii; None where the safety margin holds throughout. Read-only:
            # the controller checks an array it has seen before only once.
            tiled = None if np.all(margin == safety) else np.tile(margin, 3)
            if tiled is not None:
                tiled.setflags(write=False)
            cached = self._margins[i] = (stamp, tiled)
        return cached[1]

    def _partners(self, i: int, t: float, view: RobotView) -> BrakingPartners | None:
        """What robot ``i``'s next step is checked against (``execution.mutual_braking``): every
        robot's state as ``i`` sees it, and who sees whom now (:mod:`nodnav.control.mutual_braking`)."""
        shared = self._partners_shared(t, view, view.positions, view.velocities)
        return None if shared is None else BrakingPartners(i, *shared)

    def _partners_shared(self, t: float, view: RobotView, positions: np.ndarray,
                         velocities: np.ndarray) -> tuple | None:
        """:meth:`_partners`'s fields after the robot's own index, the same for every robot that
        sees through ``view`` (whose ``positions`` and ``velocities`` the caller has read) at
        ``t``: :meth:`act` reads them once per view; None without the check."""
        if self._convention < 0:
            return None
        seen = self._all_seen if view.age is None else view.age == 0.0
        if t != self._turn[0]:  # the same for every robot of a step: once a step
            self._turn = (t, int(math.floor(t / self._turn_period + 1e-9)) % 2)
        turn = self._turn[1]
        return (positions, velocities, self._accel, self._radii, self.keeps_rule, seen, turn, self._convention,
                self.dt)

    def _stay(self, position: np.ndarray) -> ControlResult:
        """The step of a robot at rest that skips its MPC (``execution.skip_at_rest``): it stays exactly where it is."""
        p = np.array(position, dtype=float)
        return ControlResult(success=True, reason="", velocity=np.zeros(2), next_position=p, next_velocity=np.zeros(2),
                             planned_positions=np.tile(p, (len(self.sample_times), 1)),
                             step_positions=np.tile(p, (4, 1)), info={"fallback": "", "at_rest": True})

    def _sensed(self, i: int, view: RobotView, predictions: np.ndarray, radii: np.ndarray,
                margins: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """Robot ``i``'s predictions, radii and firm flags of the others under limited or noisy
        sight (:mod:`nodnav.sim.sensing`): a robot it does not know of is not predicted; one it
        remembers is held where it was last seen (its observed state holds it still) with its
        radius grown by ``sensing.uncertainty_rate`` times the time since, never beyond the
        present gap less ``execution.reaction_slack`` (a robot is never "inside" an uncertainty
        disc at once, which would leave its MPC no feasible plan). With filtered observations the
        radius also grows by ``sensing.margin_sigmas`` standard deviations of the estimate, so
        the margin is kept from where the robot may be, not only from where it is estimated."""
        others = self._others[i]
        sensing = self.scenario.sensing
        age = np.zeros(len(others)) if view.age is None else view.age[others]
        known = np.isfinite(age)
        remembered = known & (age > 0.0)
        growth = np.where(remembered, sensing.uncertainty_rate * np.where(known, age, 0.0), 0.0)
        if view.sigma is not None:  # k sigma of the filter's position estimate
            growth = growth + sensing.margin_sigmas * view.sigma[others]
        if growth.any():
            gap = (np.linalg.norm(view.positions[others] - view.positions[i], axis=1) - self.scenario.radii[i]
                   - self.scenario.radii[others] - self.scenario.controller.safety_margin)
            allowed = np.clip(np.minimum(growth, gap - self.scenario.execution.reaction_slack), 0.0, None)
            radii = radii + np.tile(allowed, 3)
        keep = np.tile(known, 3)
        return predictions[keep], radii[keep], self._firm[keep], None if margins is None else margins[keep]


@register_method("nod", help="the paper: every robot runs Algorithm 1 (opinions, game players, planning per "
                 "strategy, MPC) (default)")
class NODMethod(PlannedMethod):
    """The paper's opinion-driven navigation: every robot runs Algorithm 1."""

    name = "nod"

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        super().__init__(scenario, rngs, planner)
        self.agents: list[Any] = [NODAgent(scenario, i, rngs[i], self.plans) for i in range(scenario.n_robots)]
        if self.passages is not None:  # one NOD agent per passage on each robot's route
            self.agents = self.passage_agents(passage_nod_agent(self.passages, rngs))

    def decide_robot(self, i: int, view: RobotView) -> Decision:
        return self.agents[i].decide(view)


def passage_nod_agent(passages: PassageViews, rngs: list[np.random.Generator],
                      **options: Any) -> Callable[[Scenario, int, int], NODAgent]:
    """A maker of robot ``i``'s NOD agent for passage ``k`` of several: the paper's agent on the
    passage's one-passage scenario, with the passage's approach sides and plan cache, drawing
    from the robot's own generator."""

    def make(scenario: Scenario, k: int, i: int) -> NODAgent:
        agent = NODAgent(scenario, i, rngs[i], passages.plans[k], **options)
        agent.sides = passages.sides[k]
        return agent

    return make


def make_method(name: str, scenario: Scenario, rngs: list[np.random.Generator], planner=None) -> Method:
    """The method registered as ``name`` (:data:`~nodnav.registry.METHODS`) for one trial."""
    return METHODS.create(name, scenario, rngs, planner)


#: Methods that coordinate every robot of the trial from one place: they cannot run for a subset.
CENTRAL_METHODS = ("oracle",)


def robot_methods(scenario: Scenario, default: str) -> tuple[str, ...]:
    """Each robot's method: its own ``robots[i].method``, else the trial's ``default``."""
    return tuple(r.method or default for r in scenario.robots)


class Team:
    """Robots running different methods in one trial (``robots[i].method``).

    Each method named in the team is built once for the whole trial, exactly as it would be if
    every robot ran it, and is asked to decide and act only for its own robots: a method's
    :meth:`~Method.decide` and :meth:`~Method.act` take the views of the robots it moves and
    return theirs. Every robot still sees every other one (its view holds everyone), and nothing
    tells it who runs what: a NOD robot reads a person's or an ORCA robot's motion through
    eq. (4) as it reads any robot's. Each robot's generator is used by its own method only.
    """

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], names: tuple[str, ...], default: str,
                 planner=None):
        if default in CENTRAL_METHODS:
            other = next(i for i, n in enumerate(names) if n != default)
            raise NodnavError(f"method '{default}' is a central coordinator of every robot of a trial; it cannot run "
                              f"beside robots[{other}].method: {names[other]} (leave out the robots' own methods)")
        for i, name in enumerate(names):
            if name in CENTRAL_METHODS:
                raise NodnavError(f"robots[{i}].method: '{name}' is a central coordinator of every robot of a trial; "
                                  "it cannot run for some robots of a mixed team (run it for all with --method)")
        self.name = default
        self.names = names
        self.members: dict[str, Method] = {m: make_method(m, scenario, rngs, planner) for m in dict.fromkeys(names)}
        self.robots = {m: [i for i, n in enumerate(names) if n == m] for m in self.members}
        # The mutual braking rule is kept by every robot a planned method moves (they share the MPC).
        keeps = np.zeros(len(names), dtype=bool)
        for m, member in self.members.items():
            keeps[self.robots[m]] = isinstance(member, PlannedMethod)
        for member in self.members.values():
            if isinstance(member, PlannedMethod):
                member.keeps_rule = keeps

    def _split(self, views: dict[int, RobotView]) -> dict[str, dict[int, RobotView]]:
        return {m: {i: views[i] for i in robots if i in views} for m, robots in self.robots.items()}

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        """Every method decides for its own robots; the decisions in robot order."""
        out: dict[int, Decision] = {}
        for m, part in self._split(views).items():
            out.update(self.members[m].decide(part))
        return dict(sorted(out.items()))

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        """Every method moves its own robots over the next control step."""
        out: dict[int, ControlResult] = {}
        for m, part in self._split(views).items():
            out.update(self.members[m].act(t, part))
        return dict(sorted(out.items()))


def is_pedestrian(name: str) -> bool:
    """Whether the method registered as ``name`` models a person (its class says ``pedestrian = True``)."""
    entry = METHODS.get(name)
    return bool(getattr(entry.factory, "pedestrian", False))


def make_team(scenario: Scenario, default: str, rngs: list[np.random.Generator], planner=None) -> Method:
    """The trial's method: ``default`` itself when every robot runs it (nothing changes for a
    one-method trial), else a :class:`Team`. An unknown name is one line naming the robot."""
    names = robot_methods(scenario, default)
    for i, name in enumerate(names):
        if scenario.robots[i].method is not None and name not in METHODS:
            try:
                METHODS.get(name)
            except NodnavError as exc:
                raise NodnavError(f"robots[{i}].method: {exc}") from None
    if all(n == default for n in names):
        return make_method(default, scenario, rngs, planner)
    return Team(scenario, rngs, names, default, planner)
