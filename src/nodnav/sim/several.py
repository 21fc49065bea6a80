"""Several passages: each robot's route, the passages on it, and the one-passage view of each.

A world may hold several single-file passages (docs/several-passages.md). The paper's machinery
(game players (7), opinions (1)-(6), eq. (4)'s estimation, the planners) reasons about one
passage; it is kept as it is and run on a per-passage *view*: the same walls with that passage
alone (:meth:`~nodnav.scenario.world.World.with_passage`), and each robot's destination replaced
by the end of the stretch of its route on the passage's far side (its *local goal*).

- :func:`robot_route`: a robot's shortest route around the walls (the visibility graph) and the
  passages it crosses, in order, with the side it enters each from and its local goal there;
- :class:`PassageViews`: the trial's routes and, per passage, the one-passage scenario, the
  approach sides and a plan cache;
- :class:`PassageAgent`: one robot, with one one-passage decider per passage on its route; it
  plays the game of the next passage on its route, among the robots it sees whose next passage
  it is, and drives alone once it has no passage left.

Everything a robot infers about another's route it infers from what the paper lets it know: the
other's destination (and where it started), and where it sees it now.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable, Protocol

import numpy as np
from numpy.typing import ArrayLike

from nodnav.errors import NodnavError
from nodnav.planning.base import Planner, PlanRequest
from nodnav.planning.visibility import VisibilityGraph
from nodnav.scenario.params import plan_reuse
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import INSIDE, LEFT, RIGHT, World
from nodnav.sim.agent_queries import approach_sides
from nodnav.sim.plan_cache import PlanCache
from nodnav.sim.views import Decision, RobotView

#: Spacing of the samples along a route at which passages are looked for (m).
ROUTE_STEP = 0.02

#: A local goal is put this far back (m, along the route) from where the route leaves the far
#: side of its passage (only when it leaves it before its destination).
GOAL_SETBACK = 0.3


@dataclass(frozen=True)
class RobotRoute:
    """One robot's route through a world with several passages."""

    points: np.ndarray
    """The route's polyline ``(V, 2)`` from the origin to the destination (m)."""
    passages: tuple[int, ...]
    """Indices of ``world.passages`` the route crosses, in the order it crosses them."""
    entry_sides: tuple[int, ...]
    """The side (``LEFT`` or ``RIGHT``, in that passage's frame) it enters each from."""
    goals: tuple[tuple[float, float], ...]
    """Its local goal beyond each: the destination if the route stays on the passage's far side
    from there on, else the last point before it leaves that side (less :data:`GOAL_SETBACK`)."""

    @property
    def length(self) -> float:
        """Length of the route (m)."""
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).sum())

    def to_go(self, position: np.ndarray) -> float:
        """Length (m) still to go along the route from ``position``: the distance to the route's
        nearest point and the route beyond it (a measure of progress, not a plan)."""
        a, b = self.points[:-1], self.points[1:]
        if not len(a):
            return float(np.linalg.norm(np.asarray(position) - self.points[0]))
        ab = b - a
        seg = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18)
        w = np.clip(np.einsum("ij,ij->i", np.asarray(position) - a, ab) / seg, 0.0, 1.0)
        near = a + w[:, None] * ab
        lengths = np.sqrt(seg)
        after = np.concatenate([np.cumsum(lengths[::-1])[::-1][1:], [0.0]])
        total = np.linalg.norm(np.asarray(position) - near, axis=1) + (1.0 - w) * lengths + after
        return float(total.min())


def _samples(points: np.ndarray) -> np.ndarray:
    """Points along a polyline at most :data:`ROUTE_STEP` apart, its vertices included."""
    out = [points[:1]]
    for a, b in zip(points[:-1], points[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / ROUTE_STEP)))
        out.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    return np.vstack(out)


def route_crossings(world: World, points: np.ndarray) -> RobotRoute:
    """The passages a route ``points`` ``(V, 2)`` crosses, in order: those whose clear rectangle
    (between the mouths, within half the width of the centreline) it passes through, entering
    from one side and leaving on the other."""
    pts = np.asarray(points, dtype=float)
    samples = _samples(pts)
    found = []
    for k, g in enumerate(world.passages):
        s = g.along(samples)
        inside = (g.side_of_along(s) == INSIDE) & (np.abs(g.across(samples) - g.t_centre) <= 0.5 * g.width + 1e-9)
        if not inside.any():
            continue
        first, last = int(np.argmax(inside)), len(inside) - 1 - int(np.argmax(inside[::-1]))
        side = g.side_of_along(s)
        before, after = side[:first][side[:first] != INSIDE], side[last + 1:][side[last + 1:] != INSIDE]
        if not len(before) or not len(after) or before[-1] == after[0]:
            continue  # starts or ends inside, or dips in and comes back: no crossing
        entry, exit_ = int(before[-1]), int(after[0])
        # Where the route is first beyond the far mouth (it may turn off the centreline between
        # the wall's end and the mouth's line), and whether it comes back across that line later.
        out = last + 1 + int(np.argmax(side[last + 1:] == exit_))
        leaves = np.flatnonzero(side[out:] != exit_)
        if len(leaves):  # the route comes back: stop short of that
            stop = out + int(leaves[0]) - 1 - int(round(GOAL_SETBACK / ROUTE_STEP))
            at = samples[max(stop, out)]
            goal = (float(at[0]), float(at[1]))
        else:
            goal = (float(pts[-1, 0]), float(pts[-1, 1]))
        found.append((first, k, entry, goal))
    found.sort()
    return RobotRoute(points=pts, passages=tuple(k for _, k, _, _ in found),
                      entry_sides=tuple(e for _, _, e, _ in found), goals=tuple(g for _, _, _, g in found))


def robot_route(world: World, origin: ArrayLike, destination: ArrayLike, radius: float,
                graphs: dict[float, VisibilityGraph]) -> RobotRoute:
    """A robot's shortest route around the walls (:class:`VisibilityGraph` for its radius) and
    the passages it crosses; one line when no route fits it."""
    graph = graphs.get(float(radius))
    if graph is None:
        graph = graphs[float(radius)] = VisibilityGraph(world, radius)
    path = graph.shortest_path(np.asarray(origin, dtype=float), np.asarray(destination, dtype=float))
    if not path.success:
        raise NodnavError(f"a robot of radius {radius:g} m has no route from {np.asarray(origin).tolist()} to "
                          f"{np.asarray(destination).tolist()} "
                          f"that fits it: {path.reason}")
    return route_crossings(world, path.points)


def trial_routes(scenario: Scenario) -> list[RobotRoute]:
    """Every robot's route (:func:`robot_route`), one visibility graph per radius. Computed by
    each trial (its method's :class:`PassageViews`; the simulator takes them from there, see
    :func:`team_routes`): nothing is kept between trials."""
    graphs: dict[float, VisibilityGraph] = {}
    return [robot_route(scenario.world, r.origin, r.destination, r.radius, graphs) for r in scenario.robots]


def team_routes(method: object, scenario: Scenario) -> list[RobotRoute]:
    """The routes the trial's method (or a member of its team) has computed for ``scenario``,
    else computed now: the simulator's and the robots' routes are the same objects, computed
    once per trial (a route costs seconds on a map)."""
    for member in (method, *getattr(method, "members", {}).values()):
        views = getattr(member, "passages", None)
        if isinstance(views, PassageViews) and views.scenario is scenario:
            return views.routes
    return trial_routes(scenario)


def passage_sides(scenario: Scenario, routes: list[RobotRoute], k: int) -> np.ndarray:
    """The side each robot approaches passage ``k`` from ``(N_r,)``: where its route enters it,
    else (a robot whose route does not cross it) as the one-passage code says."""
    sides = approach_sides(replace(scenario, world=scenario.world.with_passage(k))).copy()
    for j, route in enumerate(routes):
        if k in route.passages:
            sides[j] = route.entry_sides[route.passages.index(k)]
    return sides


class Decider(Protocol):
    """A one-passage decision rule for one robot (a :class:`~nodnav.sim.agent.NODAgent`, ...)."""

    eligible: np.ndarray | None
    """The robots it may play with (set before each decision)."""

    def decide(self, view: RobotView) -> Decision:
        """The robot's decision from its view (restricted to the passage's entries)."""
        ...


class PassageViews:
    """The trial's routes and, for each passage, the one-passage scenario robots reason in."""

    def __init__(self, scenario: Scenario, planner_for: Callable[[World], Planner]):
        self.scenario = scenario
        world = scenario.world
        self.routes = trial_routes(scenario)
        """Each robot's route (:func:`trial_routes`), computed for this trial."""
        n = scenario.n_robots
        self.scenarios: list[Scenario] = []
        self.free: list[Scenario] = []
        self.sides: list[np.ndarray] = []
        for k in range(len(world.passages)):
            view = world.with_passage(k)
            robots = tuple(replace(r, destination=route.goals[route.passages.index(k)]) if k in route.passages else r
                           for r, route in zip(scenario.robots, self.routes))
            self.free.append(replace(scenario, world=view))
            one = replace(scenario, world=view, robots=robots)
            self.scenarios.append(one)
            self.sides.append(passage_sides(scenario, self.routes, k))
        planners = [planner_for(one.world) for one in self.scenarios]
        reuse = plan_reuse(scenario.planner)
        self.plans = [PlanCache(planner, *reuse) for planner in planners]
        """One planner and plan cache per passage (its queries are in that passage's view)."""
        self.free_plans = [PlanCache(planner, *reuse) for planner in planners]
        """Plan caches for robots driving alone to their destinations (no passage left)."""
        self.exits = [tuple(-s for s in route.entry_sides) for route in self.routes]
        self._first = np.zeros(n, dtype=int)
        self._finished: dict[tuple[int, int], Scenario] = {}

    def clear(self) -> None:
        """Forget the round's plans (every decision time)."""
        for cache in (*self.plans, *self.free_plans):
            cache.clear()

    def start(self) -> np.ndarray:
        """How many passages of its route each robot has left behind at the start: none."""
        return self._first.copy()

    def advance(self, stage: np.ndarray, positions: np.ndarray, known: np.ndarray) -> np.ndarray:
        """``stage`` (passages of each robot's route it has left) moved on for the robots seen
        beyond the far mouth of the passage they were crossing, and back for those seen again on
        the near side of the passage they had left (they backed out of the way)."""
        stage = stage.copy()
        passages = self.scenario.world.passages
        for j, route in enumerate(self.routes):
            while known[j] and stage[j] > 0:
                g = passages[route.passages[stage[j] - 1]]
                if int(g.side_of_along(g.along(positions[j]))) != route.entry_sides[stage[j] - 1]:
                    break
                stage[j] -= 1
            while known[j] and stage[j] < len(route.passages):
                g = passages[route.passages[stage[j]]]
                if int(g.side_of_along(g.along(positions[j]))) != self.exits[j][stage[j]]:
                    break
                stage[j] += 1
        return stage

    def current(self, j: int, stage: np.ndarray) -> int:
        """The passage robot ``j`` is heading for or crossing (``world.passages`` index), -1 for none."""
        route = self.routes[j]
        return route.passages[stage[j]] if stage[j] < len(route.passages) else -1

    def players_of(self, k: int, stage: np.ndarray) -> np.ndarray:
        """Which robots' next passage is ``k`` ``(N_r,)``: the robots of its game."""
        return np.array([self.current(j, stage) == k for j in range(len(self.routes))], dtype=bool)

    def previous(self, j: int, stage: np.ndarray) -> int:
        """The passage robot ``j`` left last (``world.passages`` index), -1 for none."""
        return self.routes[j].passages[stage[j] - 1] if stage[j] > 0 else -1

    def eligible(self, i: int, stage: np.ndarray, arrived: bool = True) -> np.ndarray:
        """The robots robot ``i`` may play with ``(N_r,)``: those whose next passage is its own,
        and those heading for the passage it has just left from the side it came out on (they
        are in the room between the two passages, or in that passage coming towards it: it
        meets them before its next passage, and planning with them is what lets two robots
        swap through a small room between two passages). With ``arrived``, also the robots that
        have left every passage behind, the last being its next or previous one."""
        done = self.finished(stage) & arrived
        last = np.array([route.passages[-1] if route.passages else -1 for route in self.routes])
        k = self.current(i, stage)
        if k < 0:  # arrived beyond its last passage: those coming through it, those arrived there
            k = self.last_passage(i)
            out = self.players_of(k, stage) | (done & (last == k))
        else:
            out = self.players_of(k, stage) | (done & (last == k))
            q = self.previous(i, stage)
            if q >= 0:
                out |= self.players_of(q, stage) & (self.sides[q] == -self.sides[q][i])
                out |= done & (last == q)
        out[i] = False
        return out

    def finished(self, stage: np.ndarray) -> np.ndarray:
        """Which robots have left every passage of their route behind ``(N_r,)`` (robots whose
        route crosses none excepted)."""
        return np.array([0 < len(route.passages) <= stage[j] for j, route in enumerate(self.routes)], dtype=bool)

    def settled(self, stage: np.ndarray) -> np.ndarray:
        """Which robots have no passage left on their route ``(N_r,)``: those that have left
        every passage behind, and those whose route crosses none."""
        return np.array([len(route.passages) <= stage[j] for j, route in enumerate(self.routes)], dtype=bool)

    def finished_scenario(self, i: int, k: int) -> Scenario:
        """Passage ``k``'s one-passage scenario with robot ``i`` going to its own destination: its
        view once it has left its last passage ``k`` behind."""
        key = (i, k)
        one = self._finished.get(key)
        if one is None:
            base = self.scenarios[k]
            robots = list(base.robots)
            robots[i] = replace(robots[i], destination=self.scenario.robots[i].destination)
            one = self._finished[key] = replace(base, robots=tuple(robots))
        return one

    def next_distances(self, positions: np.ndarray, stage: np.ndarray) -> np.ndarray:
        """Each robot's distance d_{j,corridor} (eq. (10)) to the entrance of its **own** next
        passage, from the side its route approaches it ``(N_r,)`` (m; infinite with none left).
        Robots met between two passages head for different passages: in one passage's view, a
        robot that has come out of it is measured to the mouth it came in by, now behind it, so
        two robots that meet rank each other by distances to different mouths and disagree
        (closest-first, docs/several-passages.md); measured to each robot's own next passage,
        every observer ranks them alike."""
        out = np.full(len(self.routes), np.inf)
        for j in range(len(self.routes)):
            k = self.current(j, stage)
            if k >= 0:
                out[j] = float(self.scenarios[k].world.corridor_distance(positions[[j]], self.sides[k][[j]])[0])
        return out

    def last_passage(self, j: int) -> int:
        """The last passage on robot ``j``'s route (0 without any): its view once it has none left."""
        return self.routes[j].passages[-1] if self.routes[j].passages else 0

    def to_go(self, positions: np.ndarray) -> np.ndarray:
        """Length still to go along each robot's route ``(N_r,)`` (m)."""
        return np.array([route.to_go(p) for route, p in zip(self.routes, positions)])


class PassageAgent:
    """Robot ``index`` in a world of several passages: a one-passage decider for each passage on
    its route (``make(k)``), the one of its next passage deciding; with none left, it drives
    alone to its destination.

    The robot keeps, from what it sees, how many passages of each robot's route that robot has
    left behind (:meth:`PassageViews.advance`); the robots of its game are those whose next
    passage is its own. Its decider sees the view restricted to that passage (its entries) and
    is told the robots it may play with (``eligible``)."""

    def __init__(self, views: PassageViews, index: int, make: Callable[[Scenario, int], Decider],
                 arrived: bool = True):
        self.views = views
        self.arrived = arrived
        """Whether the robot plays on beyond its last passage and plays with the robots arrived
        there (else it drives alone there and holds them as obstacles: closest-first)."""
        self.index = index
        self.make = make
        self.stage = views.start()
        self.deciders: dict[int, Decider] = {}
        self.playing = -1
        """The passage whose game the robot played at its last decision, -1 for none."""

    @property
    def passage(self) -> int:
        """The passage whose game this robot plays, -1 for none."""
        return self.views.current(self.index, self.stage)

    def decide(self, view: RobotView) -> Decision:
        """The decision of the passage whose game the robot plays (or of driving alone)."""
        self.stage = self.views.advance(self.stage, view.positions, view.known)
        k, route = self.passage, self.views.routes[self.index]
        if k < 0 and (not route.passages or not self.arrived):
            self.playing = -1
            return drive_alone(self.views, self.index, view)
        if k < 0:  # beyond its last passage: it plays on with the robots it meets there, to its destination
            k = route.passages[-1]
            key, one = len(self.views.scenarios) + k, self.views.finished_scenario(self.index, k)
        else:
            key, one = k, self.views.scenarios[k]
        decider = self.deciders.get(key)
        if decider is None or key != self.playing:  # a game joined (again): it starts afresh
            decider = self.deciders[key] = self.make(one, k)
            if route.passages[0] != key and hasattr(decider, "start_positions"):
                decider.start_positions = view.positions.copy()
        self.playing = key
        decider.eligible = self.views.eligible(self.index, self.stage, self.arrived)
        if hasattr(decider, "settled"):  # NOD's crossed rule: only robots with no passage left are done
            decider.settled = self.views.settled(self.stage)
        if hasattr(decider, "rank_from"):  # closest-first ranks by each robot's own next passage
            decider.rank_from(self.views.next_distances(view.positions, self.stage), self.stage)
        # The entries into this passage of the robots whose next passage it is: a robot met from
        # the passage this one has just left came out of this one and is no longer in its line;
        # between the two, the game's order (not who came through first) says who gives way.
        entered = view.passage_entered[k] if view.passage_entered else view.entered
        ours = self.views.players_of(k, self.stage)
        ours[self.index] = True
        return decider.decide(replace(view, entered=tuple(j for j in entered if ours[j])))


def drive_alone(views: PassageViews, i: int, view: RobotView) -> Decision:
    """Robot ``i``'s decision with no passage left on its route: a plan of itself alone to its
    destination (the others are the MPC's moving obstacles, as for any robot outside a game)."""
    k = views.last_passage(i)
    s = views.free[k]
    request = PlanRequest(world=s.world, positions=view.positions[[i]].copy(), velocities=view.velocities[[i]].copy(),
                          destinations=s.destinations[[i]], radii=s.radii[[i]], max_speeds=s.max_speeds[[i]],
                          order=(0,), entered=(), t0=view.t,
                          max_accels=np.array([s.robots[i].max_accel], dtype=float))
    plan = views.free_plans[k].plan(request)
    return Decision(strategy=-1, robots=(i,), plan=plan, opinions=np.zeros(0), probabilities=np.zeros(0), players=())


def several(scenario: Scenario) -> bool:
    """Whether the scenario's world has several passages."""
    return len(scenario.world.passages) > 1


__all__ = ["LEFT", "RIGHT", "PassageAgent", "PassageViews", "RobotRoute", "drive_alone", "robot_route",
           "route_crossings", "several", "passage_sides", "team_routes", "trial_routes"]
