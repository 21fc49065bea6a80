"""How the simulator judges that robots still make progress (the deadlock rule, issue 19 item 3).

A trial is a deadlock when no robot has made progress for ``sim.deadlock_time``. Before issue 19
progress meant only one thing: a robot's distance to go through the passage's mouths
(:func:`~nodnav.scenario.world.distance_to_go`) fell below its best so far by
``sim.progress_epsilon``. A robot that backs out of the passage to let another through moves
*away* from its goal by that measure, for many seconds when it must back out of a long passage,
so the trial was called a deadlock while the robots were carrying out a sound plan.

With ``sim.progress: plan`` (default) a robot also makes progress when it advances along the
plan it follows: the route its own reference takes (:attr:`Decision.own_trajectory`) from where
it stood at the decision. A cursor walks forward along that route, to the nearest point of the
route within reach of where the robot now is (never backwards, so a route that goes out and comes
back the same way is followed leg by leg), and every ``progress_epsilon`` the cursor gains counts
as progress. Only successful plans count: a robot that clears the way because no order could be
planned, or that stands in a standoff, makes no progress, so a standoff still ends the trial as a
deadlock. ``sim.progress: straight`` is the rule before issue 19.
"""

from __future__ import annotations

import numpy as np

from nodnav.compiled import compiled

#: A robot farther than this from every point of its plan's route ahead of its cursor (m) is not
#: following it; its cursor stays.
OFF_ROUTE = 0.5


class PlanProgress:
    """Per robot: the route of the plan it follows and how far along it the robot has come."""

    def __init__(self, n: int, epsilon: float):
        self.epsilon = float(epsilon)
        self.routes: list[np.ndarray | None] = [None] * n
        self.arcs: list[np.ndarray] = [np.zeros(1)] * n
        self.cursor = np.zeros(n, dtype=int)
        self.credited = np.zeros(n)
        self._flat: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # the routes end to end, once per follow

    def follow(self, robot: int, route: np.ndarray | None) -> None:
        """Robot ``robot`` follows a new plan whose own positions are ``route`` ``(K, 2)`` (None:
        no plan it can make progress along)."""
        if route is None or len(route) < 2:
            self.routes[robot] = None
            self._flat = None
            return
        self.routes[robot], self.arcs[robot] = route_arcs(np.asarray(route, dtype=float))
        self.cursor[robot] = 0
        self.credited[robot] = 0.0
        self._flat = None

    def advanced(self, positions: np.ndarray, reach: np.ndarray) -> np.ndarray:
        """Which robots have advanced ``epsilon`` further along their plan's route since last
        credited, now that they stand at ``positions`` ``(n, 2)``; ``reach`` ``(n,)`` (m) is how
        far along the route the cursor may look ahead in one step."""
        if self._flat is None:
            self._flat = self._routes_end_to_end()
        points, arcs, bounds = self._flat
        out = np.zeros(len(positions), dtype=bool)
        # Every robot's step of advanced_plain in one compiled call (the same kernel on each route).
        _advance_all(points, arcs, bounds, np.ascontiguousarray(positions, dtype=float),
                     np.ascontiguousarray(reach, dtype=float), self.epsilon, self.cursor, self.credited, out)
        return out

    def end_to_end(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every robot's route and arc lengths one after the other and where each robot's begin
        and end (:func:`_advance_all`'s arguments), laid out once per new plan."""
        if self._flat is None:
            self._flat = self._routes_end_to_end()
        return self._flat

    def advanced_plain(self, positions: np.ndarray, reach: np.ndarray) -> np.ndarray:
        """:meth:`advanced` one robot at a time, the reference its single call is tested against."""
        out = np.zeros(len(positions), dtype=bool)
        for k, points in enumerate(self.routes):
            if points is not None:
                out[k] = _advance_cursor(points, self.arcs[k], positions[k], float(reach[k]), self.epsilon, k,
                                         self.cursor, self.credited)
        return out

    def _routes_end_to_end(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every robot's route and arc lengths one after the other, ``(P, 2)`` and ``(P,)``, and where
        each robot's begin and end ``(n, 2)`` (-1, -1: no route)."""
        bounds = np.full((len(self.routes), 2), -1, dtype=np.int64)
        points, arcs, start = [], [], 0
        for k, route in enumerate(self.routes):
            if route is not None:
                bounds[k] = start, start + len(route)
                start += len(route)
                points.append(route)
                arcs.append(self.arcs[k])
        if not points:
            return np.zeros((0, 2)), np.zeros(0), bounds
        return np.ascontiguousarray(np.concatenate(points)), np.concatenate(arcs), bounds


def route_arcs_plain(route: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The route's points without repeats (a point within 1e-9 m of the one before it is dropped)
    and the arc length at each, ``(P, 2)`` and ``(P,)``: the reference :func:`route_arcs` is tested against."""
    keep = np.concatenate([[True], np.linalg.norm(np.diff(route, axis=0), axis=1) > 1e-9])
    points = np.asarray(route, dtype=float)[keep]
    return points, np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


@compiled
def route_arcs(route):
    """:func:`route_arcs_plain` in one compiled call, with NumPy's operations: each norm is
    ``sqrt(dx * dx + dy * dy)``, the arc lengths a running sum from 0 (``0 + l`` is ``l``)."""
    k = route.shape[0]
    keep = np.empty(k, dtype=np.bool_)
    keep[0] = True
    count = 1
    for e in range(1, k):
        dx, dy = route[e, 0] - route[e - 1, 0], route[e, 1] - route[e - 1, 1]
        keep[e] = np.sqrt(dx * dx + dy * dy) > 1e-9
        if keep[e]:
            count += 1
    points = np.empty((count, 2))
    c = 0
    for e in range(k):
        if keep[e]:
            points[c, 0], points[c, 1] = route[e, 0], route[e, 1]
            c += 1
    arcs = np.empty(count)
    arcs[0] = 0.0
    for e in range(1, count):
        dx, dy = points[e, 0] - points[e - 1, 0], points[e, 1] - points[e - 1, 1]
        arcs[e] = arcs[e - 1] + np.sqrt(dx * dx + dy * dy)
    return points, arcs


@compiled
def _advance_all(points, arcs, bounds, positions, reach, epsilon, cursor, credited, out):
    """:func:`_advance_cursor` of every robot with a route (``bounds[k]``: its rows of ``points``
    and ``arcs``), into ``out``."""
    for k in range(bounds.shape[0]):
        begin, end = bounds[k, 0], bounds[k, 1]
        if begin >= 0:
            out[k] = _advance_cursor(points[begin:end], arcs[begin:end], positions[k], reach[k], epsilon, k,
                                     cursor, credited)


@compiled
def _advance_cursor(points, arc, position, reach, epsilon, k, cursor, credited):
    """One robot's step of :meth:`PlanProgress.advanced` (updates ``cursor[k]`` and
    ``credited[k]``): the cursor moves to the route's point nearest ``position`` (the first of
    equals) within ``reach`` along the route ahead, if it is within :data:`OFF_ROUTE`; whether
    that gains ``epsilon`` over the last credited arc length."""
    c = cursor[k]
    limit = arc[c] + reach
    end = c + 1
    for e in range(arc.shape[0]):  # searchsorted(arc, limit, side="right"), at least c + 1
        if arc[e] > limit:
            end = max(e, c + 1)
            break
    else:
        end = max(arc.shape[0], c + 1)
    best, best_gap = 0, np.inf
    for e in range(c, min(end, points.shape[0])):
        dx, dy = points[e, 0] - position[0], points[e, 1] - position[1]
        gap = np.sqrt(dx * dx + dy * dy)
        if gap < best_gap:
            best, best_gap = e - c, gap
    if best_gap <= OFF_ROUTE:
        cursor[k] = c + best
    if arc[cursor[k]] >= credited[k] + epsilon:
        credited[k] = arc[cursor[k]]
        return True
    return False


@compiled
def sides_changed(positions, along_x, ax, ay, s_start, s_end, sides):
    """Each robot's side of a passage (``LEFT`` -1, ``INSIDE`` 0, ``RIGHT`` 1:
    :meth:`~nodnav.scenario.world.Passage.side_of_along` of :meth:`~nodnav.scenario.world.Passage.along`,
    the same operations) at ``positions`` ``(n, 2)``, written into ``sides`` ``(n,)``; whether any
    differs from what ``sides`` held."""
    changed = False
    for k in range(positions.shape[0]):
        s = positions[k, 0] if along_x else positions[k, 0] * ax + positions[k, 1] * ay
        side = -1 if s < s_start else (1 if s > s_end else 0)
        changed = changed or side != sides[k]
        sides[k] = side
    return changed


@compiled
def judge_progress(positions, destinations, goal_tolerance, t, arrival, to_go, best_to_go, epsilon, follows, points,
                   arcs, bounds, reach, plan_epsilon, cursor, credited):
    """The simulator's arrival and progress judgement after a step without contact, in one call,
    with NumPy's operations element by element: which robots are within ``goal_tolerance`` of
    their ``destinations`` (``sqrt(dx * dx + dy * dy)``, :func:`numpy.linalg.norm`'s), their
    first ``arrival`` set to ``t``; unless all arrived, whose distance ``to_go`` fell ``epsilon``
    below its best (``best_to_go`` updated) and, with ``follows``, whose cursor advanced along
    its plan (:func:`_advance_all` on :class:`PlanProgress`'s routes end to end; ``reach``: how
    far it may look ahead). Updates the arrays in place; returns whether every robot arrived
    and whether any made progress."""
    n = positions.shape[0]
    everyone = True
    for k in range(n):
        dx, dy = positions[k, 0] - destinations[k, 0], positions[k, 1] - destinations[k, 1]
        arrived = np.sqrt(dx * dx + dy * dy) <= goal_tolerance
        if np.isnan(arrival[k]) and arrived:
            arrival[k] = t
        everyone = everyone and arrived
    if everyone:
        return True, False
    improved = np.zeros(n, dtype=np.bool_)
    for k in range(n):
        improved[k] = to_go[k] < best_to_go[k] - epsilon
        if improved[k]:
            best_to_go[k] = to_go[k]
    if follows:
        advanced = np.zeros(n, dtype=np.bool_)
        _advance_all(points, arcs, bounds, positions, reach, plan_epsilon, cursor, credited, advanced)
        for k in range(n):
            improved[k] = improved[k] or advanced[k]
    return False, improved.any()
