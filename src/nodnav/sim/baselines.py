"""Other navigation methods, run through the same simulator as ``nod`` (issue 6).

Every method below is chosen by name (``nodnav run --method NAME``) and differs from ``nod``
only in how the robots decide, except ``orca``, which also moves them differently:

``no-coordination``
    The paper's ``|N_i| = 0`` case (Section IV, "Effectiveness of Game Reduction Technique"):
    NOD agents with no game players. Each robot plans its own path alone; with no other robot
    in its plan, its MPC predicts every other robot from observation only (held still where it
    is seen, as the paper says, see :meth:`PlannedMethod.predictions`).
``independent``
    No social term (u = 0) and no re-sampling: each robot keeps its own preferred order from the
    first decision on (see :class:`IndependentMethod` for what "preferred" means).
``closest-first``
    A fixed convention without communication: robots pass in the order of their distance to the
    entrance they approach (d_{i,corridor} of eq. (10)) at the start, ties to the lower robot
    number.
``oracle``
    A central coordinator plans every passing order from the true initial state with the same
    planner and gives everyone the one with the smallest planned makespan: the bound that
    communication buys.
``orca``
    Reactive collision avoidance with ORCA (the RVO2 library, ``pyrvo``; extra
    ``nodnav[baselines]``), the walls given to RVO2 as obstacle polygons, each robot's preferred
    velocity pointing along its shortest route through the corridor.

The fixed-order methods re-plan their one order every opinion period from each robot's own
view, with the game players of eqs. (6)-(7), through the shared planner and plan cache, and
track it with the same MPC as ``nod``. Methods without opinions report NaN opinions and
probabilities; ``strategy`` is the index of the order a robot follows, or -1 for ``orca``.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from nodnav.control import ControlResult
from nodnav.decision.games import strategy_order
from nodnav.decision.opinion import strategy_probabilities
from nodnav.decision.players import conflict_likelihood
from nodnav.decision.strategies import passing_orders, strategy_index
from nodnav.errors import NodnavError
from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult, relabel
from nodnav.planning.visibility import VisibilityGraph
from nodnav.registry import register_method
from nodnav.scenario.limits import MAX_GAME, MAX_STRATEGIES
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import World
from nodnav.sim.agent import Decision, NODAgent, RobotView
from nodnav.sim.agent_queries import approach_sides, clearing_plan, players_in_sight
from nodnav.sim.methods import PlannedMethod, passage_nod_agent
from nodnav.sim.metrics import arrival_times
from nodnav.sim.order_plans import NO_OPINION, closest_first_order, plan_for_order
from nodnav.sim.passage_baselines import ClosestFirstPassage
from nodnav.sim.sensing import OcclusionLimit
from nodnav.sim.several import PassageAgent

#: Where ORCA puts a robot the observer does not know of (limited sight), from the observer (m):
#: beyond any neighbour distance, so that it constrains nothing.
UNKNOWN_OFFSET = np.array([1e4, 1e4])

log = logging.getLogger(__name__)

# ---------------------------------------------------------------------------------------------
# Pure functions


def planned_makespan(plan: PlanResult, destinations: np.ndarray, tolerance: float) -> float:
    """Time (s, after the plan's start) at which the last robot of ``plan`` comes within
    ``tolerance`` of its destination, as the simulator measures arrival; ``inf`` if the plan
    failed or a robot never arrives."""
    if not plan.success:
        return float("inf")
    traj = plan.trajectory
    arrival = arrival_times(traj.times, traj.positions, np.asarray(destinations, dtype=float), tolerance)
    if np.isnan(arrival).any():
        return float("inf")
    return float(arrival.max() - traj.times[0])


def best_strategy(makespans: np.ndarray, costs: np.ndarray) -> int:
    """Index of the smallest makespan; ties go to the smaller cost, then to the lower index."""
    makespans = np.asarray(makespans, dtype=float)
    costs = np.asarray(costs, dtype=float)
    # Makespans are sums of time steps: round away floating-point noise before comparing.
    return int(np.lexsort((np.arange(len(makespans)), costs, np.round(makespans, 9)))[0])


def fixed_preference_probabilities(z0: np.ndarray, bias: np.ndarray, eta: float) -> np.ndarray:
    """Probabilities with which a robot without a social term picks its order once, eq. (3) on
    ``z_i(0) + b_i``: its initial opinion plus its bias, the two individual terms of eq. (1)
    that remain when u = 0."""
    return strategy_probabilities(np.asarray(z0, dtype=float) + np.asarray(bias, dtype=float), eta)


def route_trajectory(points: np.ndarray, speed: float, dt: float, t0: float) -> JointTrajectory:
    """One robot driving along a polyline ``(V, 2)`` at constant ``speed``, sampled every ``dt``
    from ``t0``; the last sample is the end of the polyline."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    length = s[-1]
    steps = int(np.ceil(length / (speed * dt) - 1e-9)) if length > 0 else 0
    times = t0 + dt * np.arange(steps + 1)
    along = np.minimum(speed * dt * np.arange(steps + 1), length)
    xy = np.stack([np.interp(along, s, pts[:, 0]), np.interp(along, s, pts[:, 1])], axis=-1)
    return JointTrajectory.from_positions(times, xy[:, None, :])


def preferred_velocity(position: np.ndarray, waypoint: np.ndarray, remaining: float, max_speed: float,
                       dt: float) -> np.ndarray:
    """Velocity ``(2,)`` towards ``waypoint`` at ``max_speed``, or slower when the ``remaining``
    route is shorter than one step ``dt`` at that speed (so the robot stops at its goal)."""
    d = np.asarray(waypoint, dtype=float) - np.asarray(position, dtype=float)
    dist = float(np.hypot(*d))
    if dist == 0.0:
        return np.zeros(2)
    return d * (min(max_speed, remaining / dt) / dist)


def next_waypoint(points: np.ndarray, position: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """The first vertex of a route ``(V, 2)`` from ``position`` that is not ``position`` itself."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    far = np.linalg.norm(pts - np.asarray(position, dtype=float), axis=1) > eps
    return pts[np.argmax(far)] if far.any() else pts[-1]


def wall_polygons(world: World) -> list[np.ndarray]:
    """Obstacles for RVO2: every wall rectangle counter-clockwise (``(4, 2)``), then every wall
    polygon counter-clockwise (RVO2 takes non-convex ones), then the world boundary clockwise
    (RVO2's convention for a polygon that encloses the agents)."""
    polys = [np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float) for x0, y0, x1, y1 in world.obstacles]
    for poly in world.polygons:
        p = np.array(poly, dtype=float)
        area2 = np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
        polys.append(p if area2 > 0 else p[::-1].copy())
    x0, y0, x1, y1 = world.bounds
    polys.append(np.array([[x0, y0], [x0, y1], [x1, y1], [x1, y0]], dtype=float))
    return polys




# ---------------------------------------------------------------------------------------------
# Methods built on the planner and the MPC


@register_method("no-coordination", help="the paper's |N_i| = 0 case: each robot plans alone and treats the others as "
                 "obstacles")
class NoCoordinationMethod(PlannedMethod):
    """The paper's ``|N_i| = 0`` case: NOD agents with no game players (Section IV).

    A robot's plan holds itself alone, so every passing order gives it the same path; its MPC
    predicts no other robot along a plan, only from what it observes: held still at its
    observed position, the paper's static obstacle (plus whatever
    :meth:`PlannedMethod.predictions` adds for every method).
    """

    name = "no-coordination"

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        super().__init__(scenario, rngs, planner)
        self.agents: list = [NODAgent(scenario, i, rngs[i], self.plans, n_players=0) for i in range(scenario.n_robots)]
        if self.passages is not None:
            self.agents = self.passage_agents(passage_nod_agent(self.passages, rngs, n_players=0))

    def decide_robot(self, i: int, view: RobotView) -> Decision:
        return self.agents[i].decide(view)


def enumerable(scenario: Scenario, method: str) -> None:
    """Refuse, in one line, a method that weighs every one of the N_r! orders beyond the bound."""
    if math.factorial(scenario.n_robots) > MAX_STRATEGIES:
        raise NodnavError(f"method '{method}' weighs all {scenario.n_robots}! passing orders; it supports at most "
                          f"{MAX_GAME} robots ({MAX_STRATEGIES} orders), this scenario has {scenario.n_robots}")


def one_passage(scenario: Scenario, method: str) -> None:
    """Refuse, in one line, a method that weighs whole passing orders of one passage in a world
    of several (docs/several-passages.md)."""
    if len(scenario.world.passages) > 1:
        raise NodnavError(f"method '{method}' follows one passing order of one passage; this world has "
                          f"{len(scenario.world.passages)} passages (use nod, no-coordination, closest-first or orca)")


class FixedOrderMethod(PlannedMethod):
    """Robots that each follow one passing order, chosen once at the first decision.

    Subclasses implement :meth:`choose`. At every period each robot selects its game players
    with eqs. (6)-(7) from its own view, plans its order projected onto itself and them, and
    tracks that plan with its MPC, exactly as a NOD robot tracks the plan of its sampled
    strategy.
    """

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        super().__init__(scenario, rngs, planner)
        self.n_strategies = math.factorial(scenario.n_robots)
        self._graphs: dict = {}  # visibility graphs for clearing the way, by radius
        self.sides = approach_sides(scenario)
        self.strategies: dict[int, int] = {}
        """Index of the order each robot follows, set at the first decision."""

    def choose(self, views: dict[int, RobotView]) -> dict[int, int]:
        """Each robot's strategy index, from the views at the first decision."""
        raise NotImplementedError

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        self.plans.clear()
        if not self.strategies:
            self.strategies = self.choose(views)
        self.decisions = {i: self.decide_robot(i, view) for i, view in views.items()}
        return self.decisions

    def players(self, i: int, view: RobotView) -> tuple[int, ...]:
        """Robot ``i``'s game players, eqs. (6)-(7) on its observed positions."""
        d_corr = self.scenario.world.corridor_distance(view.positions, self.sides)
        L = conflict_likelihood(view.positions, d_corr, self.scenario.opinion.delta)
        return players_in_sight(L, view, i, self.scenario.n_players)

    def decide_robot(self, i: int, view: RobotView) -> Decision:
        players = self.players(i, view)
        robots = (i, *players)
        strategy = self.strategies[i]
        order = strategy_order(strategy, self.scenario.n_robots)
        plan = plan_for_order(self.scenario, self.plans, view, robots, order)
        if not plan.success:  # nothing to follow: get out of everybody's way
            canonical = tuple(sorted(robots))
            plan = relabel(clearing_plan(self.scenario, view, canonical, i, plan, self._graphs),
                           [canonical.index(k) for k in robots])
        return Decision(strategy=strategy, robots=robots, plan=plan, opinions=NO_OPINION, probabilities=NO_OPINION,
                        players=players, game=tuple(range(self.scenario.n_robots)), order=order)


@register_method("independent", help="no social term (u = 0): each robot keeps the order its own initial opinion and "
                 "bias prefer")
class IndependentMethod(FixedOrderMethod):
    """Every robot keeps its own preferred order: no social term (u = 0) and no communication.

    With u = 0, eq. (1) leaves each robot only its initial opinion z_i(0) (from the scenario:
    zero, distance-based (10)-(11) or given) and its bias b_i. At the first decision the robot
    draws its order once, with its own generator, from eq. (3) applied to ``z_i(0) + b_i`` --
    with no bias this is exactly the draw a NOD robot makes at t = 0 -- and keeps it to the end.
    Re-sampling every period instead would, with z_i(0) = 0, make every robot pick a new order
    uniformly at random each second: that measures dithering, not the absence of coupling. So
    with the paper's zero initial opinions each robot commits to an order chosen uniformly at
    random, and with distance-based ones mostly to the closest-first order.
    """

    name = "independent"

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        enumerable(scenario, self.name)
        one_passage(scenario, self.name)
        super().__init__(scenario, rngs, planner)

    def choose(self, views: dict[int, RobotView]) -> dict[int, int]:
        out = {}
        for i in views:
            everyone = tuple(range(self.scenario.n_robots))
            z0 = NODAgent(self.scenario, i, self.rngs[i], self.plans, social=False).initial_opinions(everyone)
            x = fixed_preference_probabilities(z0, self.scenario.opinion.bias_vector(self.n_strategies),
                                               self.scenario.opinion.eta)
            out[i] = int(self.rngs[i].choice(len(x), p=x))
        return out


@register_method("closest-first", help="a fixed convention: order by distance to the entrance at the start, ties to "
                 "the lower number")
class ClosestFirstMethod(FixedOrderMethod):
    """A social convention without communication: nearest to its entrance goes first.

    Each robot ranks everyone by the distance d_{k,corridor} of eq. (10) to the entrance they
    approach, as it observes them at the first decision, nearest first; distances that round to
    the same multiple of ``baselines.closest_first_tie`` go to the lower robot number. Without
    observation noise every robot computes the same order; with noise, near ties may be broken
    differently, as they would be by real robots that do not talk.
    """

    name = "closest-first"

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        super().__init__(scenario, rngs, planner)
        self.agents: list[PassageAgent] | None = None
        if self.passages is not None:  # the convention at each passage of several (docs/several-passages.md)
            passages = self.passages

            def make(one: Scenario, k: int, i: int) -> ClosestFirstPassage:
                return ClosestFirstPassage(one, i, passages.plans[k], passages.sides[k])

            self.agents = self.passage_agents(make, arrived=False)  # as measured best (docs/several-passages.md)

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        if self.agents is None:
            return super().decide(views)
        self.plans.clear()
        if self.passages is not None:
            self.passages.clear()
        self.decisions = {i: self.agents[i].decide(view) for i, view in views.items()}
        return self.decisions

    def choose(self, views: dict[int, RobotView]) -> dict[int, int]:
        world = self.scenario.world
        tie = self.scenario.baselines.closest_first_tie
        # A robot not in sight at the first decision is ranked last (limited sight, docs/sensing.md).
        return {i: strategy_index(closest_first_order(np.where(view.seen, world.corridor_distance(
            view.positions, self.sides), np.inf), tie)) for i, view in views.items()}


@register_method("oracle", help="a central coordinator gives everyone the order with the smallest planned makespan")
class OracleMethod(FixedOrderMethod):
    """A central coordinator gives every robot the order with the smallest planned makespan.

    At the first decision (t = 0) the coordinator collects every robot's own state (exact in its
    own view), plans all N_r! orders for all robots with the trial's planner, and picks the
    order whose plan brings the last robot to its destination first (:func:`planned_makespan`;
    ties to the smaller total arrival time, then the lower index). Everyone follows that order
    to the end: the robots always agree, which is the upper bound that communication buys.
    """

    name = "oracle"

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        enumerable(scenario, self.name)
        one_passage(scenario, self.name)
        super().__init__(scenario, rngs, planner)
        self.orders = passing_orders(scenario.n_robots)
        self.makespans = np.full(len(self.orders), np.nan)
        """Planned makespan of every order from the initial state (s), once chosen."""

    def choose(self, views: dict[int, RobotView]) -> dict[int, int]:
        s = self.scenario
        robots = sorted(views)
        positions = np.stack([views[i].positions[i] for i in robots])
        velocities = np.stack([views[i].velocities[i] for i in robots])
        # Robots that report being in the corridor already, in index order as the simulator logs them at t = 0.
        entered = tuple(i for i in robots if i in views[i].entered)
        t0 = views[robots[0]].t
        costs = np.empty(len(self.orders))
        for j, order in enumerate(self.orders):
            request = PlanRequest(world=s.world, positions=positions, velocities=velocities,
                                  destinations=s.destinations, radii=s.radii, max_speeds=s.max_speeds,
                                  order=tuple(int(k) for k in order), entered=entered, t0=t0,
                                  max_accels=np.array([r.max_accel for r in s.robots], dtype=float))
            plan = self.plans.plan(request)
            self.makespans[j] = planned_makespan(plan, s.destinations, s.sim.goal_tolerance)
            costs[j] = plan.cost
        best = best_strategy(self.makespans, costs)
        log.debug("oracle: makespans %s, order %s", np.round(self.makespans, 2), self.orders[best])
        return {i: best for i in robots}


# ---------------------------------------------------------------------------------------------
# ORCA


@register_method("orca", help="reactive collision avoidance with ORCA (RVO2), walls as obstacles; needs "
                 "nodnav[baselines]")
class OrcaMethod:
    """Reactive collision avoidance with ORCA (RVO2), no passing order and no planner.

    Each robot, at every control step, loads the positions and velocities of every robot as it
    observes them into an RVO2 simulator holding the walls (:func:`wall_polygons`), sets its own
    preferred velocity towards the next vertex of its shortest route to its destination around
    the walls (:class:`~nodnav.planning.visibility.VisibilityGraph`, clearance radius plus
    ``baselines.orca_route_margin``), and lets RVO2 compute its new velocity; it then moves at that velocity for
    one step. RVO2 has no acceleration limit (its agents are holonomic single integrators).
    ``planner`` is accepted for the common interface and ignored.
    """

    name = "orca"

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None):
        try:
            import pyrvo
        except ImportError:
            raise NodnavError("method 'orca' needs the RVO2 bindings: pip install 'nodnav[baselines]'") from None
        self.scenario = scenario
        self.params = params = scenario.baselines
        self.dt = scenario.controller.dt
        n = scenario.n_robots
        horizon = scenario.controller.horizon
        samples = scenario.controller.samples
        self.sample_times = horizon * np.arange(1, samples + 1) / samples
        self.rvo = pyrvo.RVOSimulator()
        self.rvo.set_time_step(self.dt)
        for r in scenario.robots:
            self.rvo.add_agent(tuple(r.origin), params.orca_neighbor_dist, max(n - 1, 1), params.orca_time_horizon,
                               params.orca_time_horizon_obst, r.radius + params.orca_radius_margin, r.max_speed)
        self.polygons = wall_polygons(scenario.world)
        self.obstacle_ids = [self.rvo.add_obstacle([tuple(map(float, v)) for v in poly]) for poly in self.polygons]
        """RVO2 number of the first vertex of each polygon of :attr:`polygons`."""
        self.rvo.process_obstacles()
        self.graphs = {r: VisibilityGraph(scenario.world, r, params.orca_route_margin)
                       for r in set(scenario.radii.tolist())}
        self.decisions: dict[int, Decision] = {}
        sensing = scenario.sensing
        self.occlusion = OcclusionLimit(scenario) if sensing.limited and sensing.occlusion_speed else None
        """With limited sight, each robot's speed limit from the places it cannot see, as the
        planned methods get it (docs/sensing.md): RVO2's own speed limit for that robot's step."""

    def route(self, i: int, position: np.ndarray) -> np.ndarray:
        """Robot ``i``'s shortest route ``(V, 2)`` from ``position`` to its destination; the straight
        segment when there is none (RVO2 then keeps it off the walls as far as it can)."""
        goal = self.scenario.destinations[i]
        path = self.graphs[float(self.scenario.radii[i])].shortest_path(position, goal)
        return path.points if path.success else np.array([position, goal], dtype=float)

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        """No decision to make: each robot's 'plan' is its route driven at full speed (recorded
        for inspection; a robot with no route around the walls counts as a plan failure)."""
        s, out = self.scenario, {}
        for i, view in views.items():
            path = self.graphs[float(s.radii[i])].shortest_path(view.positions[i], s.destinations[i])
            if path.success:
                speed = float(s.max_speeds[i])
                traj = route_trajectory(path.points, speed, self.dt, view.t)
                plan = PlanResult(True, "", path.length / speed, traj, (0,), (0,), 0.0, {"route": path.points})
            else:
                request = PlanRequest(world=s.world, positions=view.positions[[i]], velocities=view.velocities[[i]],
                                      destinations=s.destinations[[i]], radii=s.radii[[i]],
                                      max_speeds=s.max_speeds[[i]], order=(0,), t0=view.t)
                plan = PlanResult.failure(request, f"no route around the walls: {path.reason}")
            out[i] = Decision(strategy=-1, robots=(i,), plan=plan, opinions=NO_OPINION, probabilities=NO_OPINION,
                              players=())
        self.decisions = out
        return out

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        """Every robot's ORCA velocity from its own view, applied for one step."""
        out = {}
        n = self.scenario.n_robots
        for i, view in views.items():
            start = time.perf_counter()
            p = view.positions[i]
            known = view.known
            for k in range(n):
                # A robot i does not know of is put far beyond every neighbour distance.
                where = view.positions[k] if known[k] else view.positions[i] + UNKNOWN_OFFSET
                self.rvo.set_agent_position(k, tuple(map(float, where)))
                self.rvo.set_agent_velocity(k, tuple(map(float, view.velocities[k])))
                # Only robot i's new velocity is used; the others' preferred velocities do not enter it.
                self.rvo.set_agent_pref_velocity(k, tuple(map(float, view.velocities[k])))
            route = self.route(i, p)
            remaining = float(np.linalg.norm(np.diff(np.vstack([p, route]), axis=0), axis=1).sum())
            speed = float(self.scenario.max_speeds[i])
            if self.occlusion is not None:  # RVO2 bounds the new velocity by the agent's max speed
                speed = self.occlusion.speed(i, p, speed)
                self.rvo.set_agent_max_speed(i, speed)
            v_pref = preferred_velocity(p, next_waypoint(route, p), remaining, speed, self.dt)
            self.rvo.set_agent_pref_velocity(i, tuple(map(float, v_pref)))
            self.rvo.do_step()
            v = np.array(self.rvo.get_agent_velocity(i).to_tuple(), dtype=float)
            out[i] = ControlResult(success=True, reason="", velocity=v, next_position=p + v * self.dt, next_velocity=v,
                                   planned_positions=p + v * self.sample_times[:, None],
                                   solve_time=time.perf_counter() - start,
                                   info={"preferred_velocity": v_pref,
                                         "orca_lines": self.rvo.get_agent_num_orca_lines(i)})
        return out
