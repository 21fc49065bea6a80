"""How the fast planner makes room: robots that get out of the way, and robots that back out.

A prioritised planner plans robots one after the other, and a robot planned early may need a
place where a robot planned later stands. The fast planner (:mod:`nodnav.planning.prioritized`)
lets the later robot move first, to a waiting spot, in one component with four moves:

* :meth:`MakingWay._get_out_of_way`: a robot (``mover``) planned after the one being planned
  (``planned``) moves to a nearby spot clear of the ways on of every robot still to plan, and out
  of its door zone if somebody comes out through it;
* :meth:`MakingWay._move_aside`: how it does so, and, when it cannot, the robots standing on its
  way to the nearest spot it could reach get out of the way first (up to ``cascade`` deep);
* :meth:`MakingWay._make_room`: a robot pinned where only the planned robot's own place would let
  it out gets that room: the planned robot backs off first;
* :meth:`MakingWay._back_out`: a robot that an earlier robot's motion corners anyway backs out
  of the way when its turn comes.

Candidate spots are rings around the robot (``retreat_radii``, ``retreat_angles`` of
:class:`~nodnav.scenario.params.FastPlannerParams`); the ``retreat_tries`` nearest reachable ones
are tried (:meth:`MakingWay._waiting_spots`, :meth:`MakingWay._escape_motions`); where a robot
may wait (rings, the fine grid, bays, door zones) is :mod:`nodnav.planning.waiting_spots`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator
from itertools import islice
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from nodnav.geometry import TOL
from nodnav.planning.disc_checks import disc_violations
from nodnav.planning.fast_state import Attempt, FastPlannerHooks, Layout, Route, State, timed_motion
from nodnav.planning.occupancy import Motion
from nodnav.planning.polylines import polyline_point_distance
from nodnav.planning.timing import dash_clashes
from nodnav.planning.waiting_spots import FINE_GRID, bay_spots, grid_spots, in_door_zone, nearest_ways, ring_spots
from nodnav.scenario.world import World

if TYPE_CHECKING:
    from nodnav.planning.visibility import GeometricPath

logger = logging.getLogger(__name__)

T = TypeVar("T")


def clear_first(items: Iterable[T], clashes: Callable[[T], bool]) -> Iterator[T]:
    """``items``, those for which ``clashes`` is false first, then the others, each in order (a
    stable sort by clash), each item read and checked only when it is needed: the ways a robot
    can dash along without meeting anyone, nearest first, then the others; the first one tried
    is taken most of the time, so the later ways are never computed nor their dashes checked."""
    clashing = []
    for item in items:
        if clashes(item):
            clashing.append(item)
        else:
            yield item
    yield from clashing


class MakingWay(FastPlannerHooks):
    """The fast planner's ways of making room (a mixin of
    :class:`~nodnav.planning.prioritized.PrioritizedPlanner`, whose geometry and timing it uses)."""

    def _get_out_of_way(self, world: World, state: State, mover: int, planned: int, layout: Layout,
                        clear: tuple = (), depth: int = 0) -> dict:
        """How robot ``mover`` (planned after ``planned``) first gets out of ``planned``'s way: to
        a nearby spot clear of the ways on of every robot still to plan and of the polylines
        ``clear``, and out of its door zone if ``planned`` or an earlier robot comes out through
        it (:meth:`_move_aside`). Returns robot -> motion for every robot that moves (empty if
        ``mover`` cannot)."""
        others = [other for other in layout.later if other != mover] + [planned]
        dirs = state.directions
        door = dirs[mover] != 0 and any(dirs[before] == -dirs[mover] for before in [*layout.plans, planned])

        def keep(lay: Layout) -> list:
            # The ways on of the others: from where they stand, or from the spot they got out of
            # the way to (a spot must not block the way on of a robot that moved before).
            ways = []
            for other in others:
                if other in lay.heads:
                    spot = lay.heads[other].samples[-1]
                    way = self.graph(world, state.radii[other]).shortest_paths(
                        spot[None], state.destinations[other][None])[0]
                    ways.append((way.points, state.required[mover, other]))
                else:
                    ways.append((state.natural[other], state.required[mover, other]))
            return ways + list(clear)

        return self._move_aside(world, state, mover, planned, layout, others, keep, door, (planned,), depth)

    def _make_room(self, world: World, state: State, planned: int, blocker: int, layout: Layout) -> dict:
        """How robot ``planned`` first makes room for robot ``blocker`` (planned after it, standing
        in its way) to get out of the way: to a spot clear of ``blocker``'s way, among the walls
        alone, to the nearest spot ``blocker`` could go to were ``planned`` not there
        (:meth:`_move_aside`). Returns robot -> motion for every robot that moves, ``planned``
        included (empty if it cannot)."""
        dirs = state.directions
        others = [other for other in layout.later if other != blocker]
        door = dirs[blocker] != 0 and any(dirs[before] == -dirs[blocker] for before in [*layout.plans, planned])
        clear = [(state.natural[other], state.required[blocker, other]) for other in others
                 if other not in layout.heads]
        way = next((w for _, w in self._waiting_spots(world, state, blocker, layout, others, clear, door)[1]
                    if w.success), None)
        if way is None:
            return {}
        door = dirs[planned] != 0 and any(dirs[before] == -dirs[planned] for before in layout.plans)
        return self._move_aside(world, state, planned, planned, layout, list(layout.later),
                                lambda lay: [(way.points, state.required[blocker, planned])], door, (blocker,), 0)

    def _move_aside(self, world: World, state: State, mover: int, planned: int, layout: Layout, others: list, keep,
                    door: bool, pinned: tuple, depth: int) -> dict:
        """Robot ``mover`` gets out of the way (of ``planned``, which is being planned) to one of
        :meth:`_waiting_spots` among the robots ``others``, keeping clear of ``keep(layout)``.
        When it cannot, the robots standing on its way to the nearest spot it could reach without
        passing one of the ``pinned`` robots get out of the way first, keeping that way clear too
        (up to ``cascade`` deep), and ``mover`` tries again. Returns robot -> motion for every
        robot that moves (empty if ``mover`` cannot)."""
        head = next(self._escape_motions(world, state, mover, layout, others, keep(layout), door), None)
        if head is not None:
            return {mover: head}
        movable = [other for other in others if other not in pinned and other != planned
                   and other not in layout.heads]
        if depth >= self.params.cascade or not movable:
            return {}
        stand = np.array([self._start(state, other, layout) for other in [*pinned, *movable]])
        need = state.required[mover, [*pinned, *movable]]
        gap = np.linalg.norm(stand - state.positions[mover], axis=1)
        for _, way in self._waiting_spots(world, state, mover, layout, others, keep(layout), door)[1]:
            if way.success:
                crossed = disc_violations(way.points, stand, need, gap, np.linalg.norm(stand - way.points[-1], axis=1))
                if not crossed[:len(pinned)].any():
                    break
        else:
            return {}
        moves: dict[int, Motion] = {}
        for other, in_the_way in zip(movable, crossed[len(pinned):]):
            if in_the_way:
                moves.update(self._get_out_of_way(world, state, other, planned,
                                                  Layout(layout.plans, {**layout.heads, **moves}, layout.later),
                                                  ((way.points, state.required[mover, other]),), depth + 1))
        if not moves:
            return {}
        after = Layout(layout.plans, {**layout.heads, **moves}, layout.later)
        head = next(self._escape_motions(world, state, mover, after, others, keep(after), door), None)
        return {**moves, mover: head} if head is not None else {}

    def _back_out(self, world: World, state: State, planned: int, layout: Layout) -> Attempt:
        """Robot ``planned``, cornered by a robot before it, backs out of the way first: to the
        cheapest nearby spot where it can wait for good, then on to its destination."""
        dirs = state.directions
        door = dirs[planned] != 0 and any(dirs[before] == -dirs[planned] for before in layout.plans)
        reason = "cornered by an earlier robot, and no spot nearby to back out to"
        for head in self._escape_motions(world, state, planned, layout, list(layout.later), [], door):
            moved = Layout(layout.plans, {**layout.heads, planned: head}, layout.later)
            track = self._track_for(world, state, planned, moved)
            if not track.route.path.success:
                continue
            attempt = self._time(world, state, planned, track, layout, head)
            if attempt.success:
                logger.debug("fast planner: robot %d backs out to (%.2f, %.2f)", planned, *head.samples[-1])
                return attempt
            reason = f"cornered by an earlier robot; backing out failed too: {attempt.reason}"
        return Attempt(False, reason)

    def _waiting_spots(self, world: World, state: State, mover: int, layout: Layout, others: list, clear: list,
                       door: bool, fine: bool = False) -> tuple[np.ndarray, Iterator[tuple[int, GeometricPath]]]:
        """Spots robot ``mover`` could get out of the way to, and its ways to the ``3 *
        retreat_tries`` nearest among the walls alone, nearest first, each with its spot's index,
        computed as they are asked for (:func:`~nodnav.planning.waiting_spots.nearest_ways`).
        The spots keep the required distance from where the robots ``others`` stand, the given
        distance from the polylines ``clear`` (``(polyline, distance)`` pairs), the required
        distance from every known motion, and, with ``door``, out of its door zone. With
        ``fine``, the candidates are a grid of :data:`FINE_GRID` over the whole world instead of
        the rings (the rings' directions are far apart at large radii, and miss the narrow bands
        a crowded room leaves clear of everybody's way)."""
        pos, req, radius = state.positions[mover], state.required, state.radii[mover]
        graph = self.graph(world, radius)
        if fine:
            spots = grid_spots(world, FINE_GRID)
        else:
            spots = ring_spots(pos, self.params.retreat_radii, self.params.retreat_angles, world.passage.angle)
        spots = np.vstack([spots, bay_spots(world, float(radius), float(graph.clearance))])
        # Out of the passage, or off its line in a bay (a bay is only ever a place to wait in).
        ok = (world.clearance(spots) >= graph.clearance - TOL) & ~world.on_line(spots, float(radius))
        if door:
            ok &= ~in_door_zone(world, spots, state.door[mover], self.params.door_clearance)
        stand = np.array([self._start(state, other, layout) for other in others]).reshape(-1, 2)
        if len(others):
            ok &= (np.linalg.norm(spots[:, None] - stand[None], axis=2) >= req[mover, others] - TOL).all(axis=1)
        for route, distance in clear:
            ok &= polyline_point_distance(route, spots) >= distance - TOL
        for before, motion in layout.fixed(mover):
            ok &= polyline_point_distance(motion.samples, spots) >= req[before, mover] - TOL
        spots = spots[ok]
        return spots, nearest_ways(graph, pos, spots, 3 * self.params.retreat_tries)

    def _escape_motions(self, world: World, state: State, mover: int, layout: Layout, others: list, clear: list,
                        door: bool):
        """Motions by which robot ``mover`` gets out of the way to one of :meth:`_waiting_spots`,
        best first: nearest first among those it can dash to without meeting anyone, then the others;
        when no spot of the rings will do, spots of the fine grid (issue 19)."""
        found = False
        for fine in (False, True):
            if fine and found:
                return
            for motion in self._escape_motions_to(world, state, mover, layout, others, clear, door, fine):
                found = True
                yield motion

    def _escape_motions_to(self, world: World, state: State, mover: int, layout: Layout, others: list,
                           clear: list, door: bool, fine: bool):
        """:meth:`_escape_motions` among the candidate spots of one kind (rings, or the fine grid)."""
        spots, near = self._waiting_spots(world, state, mover, layout, others, clear, door, fine)
        if not len(spots):
            return
        pos, req, radius = state.positions[mover], state.required, state.radii[mover]
        graph = self.graph(world, radius)
        fixed = layout.fixed(mover)
        step = state.max_speeds[mover] * self.params.dt
        horizon = max([motion.last_step for _, motion in fixed] + [0])
        others_at = (np.stack([motion.samples[np.minimum(np.arange(horizon + 1), motion.last_step)]
                               for _, motion in fixed], axis=1) if fixed else np.zeros((horizon + 1, 0, 2)))
        need = req[[before for before, _ in fixed], mover]
        stand = np.array([self._start(state, other, layout) for other in others]).reshape(-1, 2)
        starts_inside = mover in state.inside_robots  # world.in_corridor(pos), computed with the state

        def clashes(near_way: tuple[int, GeometricPath]) -> bool:
            w = near_way[1]
            return not w.success or dash_clashes(w.points, step, others_at, need)

        for q, _ in islice(clear_first(near, clashes), self.params.retreat_tries):
            way = graph.shortest_path(pos, spots[q], stand, req[mover, others])
            if not way.success:
                continue
            track = self._prepare(world, radius, step, Route(way, stand, req[mover, others]))
            if not starts_inside and track.inside.any():
                continue  # it would enter the corridor out of turn
            timing = self._timing(state, mover, track, fixed)
            if timing.success:
                yield timed_motion(track, timing)
