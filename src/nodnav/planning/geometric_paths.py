"""The fast planner's geometric paths: the shortest polyline for one robot, cut into cells.

Step 3 of :mod:`nodnav.planning.prioritized` (its module docstring): a robot's path around the
walls, the robots after it standing and the destinations of those before it (giving up those
discs in turn when no path keeps clear of them), cut into cells of at most half a step with the
full-speed moves the walls allow. Everything here depends only on the world, the robot's radius
and step and the discs, so it is memoised across the orders the closed loop asks for.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from nodnav.geometry import TOL, segment_is_clear
from nodnav.planning.disc_checks import corner_cuts_of
from nodnav.planning.fast_state import Cut, Route, Track, cut_zones, grid_and_corners
from nodnav.planning.memo import remember, remember_within
from nodnav.planning.visibility import VisibilityGraph
from nodnav.scenario.world import World

if TYPE_CHECKING:
    from nodnav.scenario.params import FastPlannerParams

#: How many visibility graphs the planners of one process share (a trial needs one per radius).
SHARED_GRAPHS = 8

#: Graphs of more vertices than this (a map's walls) are not kept between planners: their
#: all-pairs tables grow with the square of it (400 vertices: about 2 MB).
SHARED_VERTICES = 400

#: The graphs by (world, radius, inflation): a graph depends on nothing else, and the planners
#: of a sweep's trials, one per trial, ask for the same ones. Never queried themselves: each
#: planner gets a copy with memos of its own (:meth:`VisibilityGraph.with_own_memos`).
_SHARED_GRAPHS: dict[tuple, VisibilityGraph] = {}


class GeometricPaths:
    """Geometric paths of :class:`~nodnav.planning.prioritized.PrioritizedPlanner`, which owns the memos."""

    if TYPE_CHECKING:  # set by PrioritizedPlanner.__init__
        params: FastPlannerParams
        _graphs: dict[tuple[int, float], VisibilityGraph]
        _tracks: dict[tuple, Track]
        _cuts: dict[tuple, Cut]
        _world_ids: dict[int, tuple[World, int]]
        _world_tokens: dict[World, int]

        def _stay_geometry(self, world: World) -> np.ndarray: ...

    def world_token(self, world: World) -> int:
        """A small integer standing for ``world`` in the memos' keys (equal worlds share one):
        a World hashes all its walls, and the keys are hashed thousands of times per round."""
        hit = self._world_ids.get(id(world))
        if hit is not None and hit[0] is world:
            return hit[1]
        tokens = self._world_tokens
        token = tokens.setdefault(world, len(tokens))  # never forgotten: a trial has a few worlds
        self._world_ids[id(world)] = (world, token)  # holding the world keeps its id its own
        return token

    @property
    def wall_margin(self) -> float:
        """Extra clearance kept from walls where there is room: half the pair margin (m)."""
        return 0.5 * self.params.margin

    def graph(self, world: World, radius: float) -> VisibilityGraph:
        """The visibility graph for robots of ``radius`` in ``world`` (built once, then kept)."""
        key = (self.world_token(world), float(radius))
        g = self._graphs.get(key)
        if g is None:
            # The wall margin where there is room: in a passage that leaves a robot less than
            # twice the margin beside the centreline, half of what it leaves (issue 19).
            room = 0.5 * world.passage.width - float(radius)
            inflation = min(self.wall_margin, max(0.0, 0.5 * room))
            # Every trial's planner needs the same few graphs: built once per process, each
            # planner with memos of its own (a trial's answers never come from another's).
            shared = (world, float(radius), inflation)
            built = _SHARED_GRAPHS.get(shared)
            if built is None:
                built = VisibilityGraph(world, radius, inflation)
                if len(built.vertices) <= SHARED_VERTICES:
                    remember_within(_SHARED_GRAPHS, shared, built, SHARED_GRAPHS)
            g = built.with_own_memos()
            remember(self._graphs, key, g)
        return g

    def _track(self, world: World, radius: float, step: float, start: np.ndarray, goal: np.ndarray,
               centres: np.ndarray, rads: np.ndarray, n_later: int) -> Track:
        """The robot's prepared path (memoised: the closed loop asks the same from every order)."""
        key = (self.world_token(world), radius, step, start.tobytes(), goal.tobytes(), centres.tobytes(),
               rads.tobytes(), n_later)
        track = self._tracks.get(key)
        if track is None:
            route = self._route(world, radius, start, goal, centres, rads, n_later)
            track = self._prepare(world, radius, step, route)
            remember(self._tracks, key, track)
        return track

    def _route(self, world: World, radius: float, start: np.ndarray, goal: np.ndarray,
               centres: np.ndarray, rads: np.ndarray, n_later: int) -> Route:
        """The geometric path, keeping clear of later robots' positions and earlier robots'
        destinations if possible, else of the destinations only, else of the walls only."""
        graph = self.graph(world, radius)
        path = graph.shortest_path(start, goal, centres, rads)
        if path.success:  # the common case: no set of discs given up
            return Route(path, centres, rads, detour=False)
        # Give up the later robots' positions, then every disc (each only if it leaves any out).
        attempts, c, r = [], centres, rads
        if n_later:
            attempts.append((centres[n_later:], rads[n_later:]))
        if len(attempts[-1][0] if attempts else centres):
            attempts.append((np.zeros((0, 2)), np.zeros(0)))
        for c, r in attempts:
            path = graph.shortest_path(start, goal, c, r)
            if path.success:
                break
        # At least one set of discs was given up: a detour where later robots were kept clear of.
        return Route(path, c, r, detour=bool(n_later))

    def _prepare(self, world: World, radius: float, step: float, route: Route) -> Track:
        """The path cut into cells (:meth:`_cut`), with the full-speed moves that would cut a
        corner closer to a standing robot than the polyline comes removed."""
        cut = self._cut(world, radius, step, route.path.points)
        ok2 = cut.ok2
        if len(cut.corners) and len(route.centres):
            bad, count = corner_cuts_of(cut.cells, cut.corners, route.path.points,
                                        np.ascontiguousarray(route.centres, dtype=float),
                                        np.ascontiguousarray(route.radii, dtype=float))
            if count:
                ok2 = ok2.copy()
                ok2[cut.corners[bad]] = False
        return Track(route, cut.cells, cut.arc, ok2, cut.inside, cut.entry, cut.doors, cut.segments)

    def _cut(self, world: World, radius: float, step: float, path: np.ndarray) -> Cut:
        """Cut a path into cells of at most half a step and find the full-speed moves the walls
        allow (memoised by path: many disc sets give the same path).

        A move ``c -> c+2`` leaves the polyline only where it cuts a corner; there the straight
        chord must keep the robot's radius from the walls (or not go deeper than its ends
        already are). The polyline keeps ``g = min(radius + wall margin, end clearance)`` from
        the walls (the least clearance of its two ends), and no point of a chord is farther
        from the polyline than the corner is from the chord (``h``), so ``g - h >= radius``
        settles most corners without computing distances.
        """
        key = (self.world_token(world), radius, step, path.tobytes())
        cut = self._cuts.get(key)
        if cut is not None:
            return cut
        poly = np.ascontiguousarray(path, dtype=float).reshape(-1, 2)
        # arc_length_grid, then the corners and each chord's distance from its middle cell
        # (none for fewer than three cells), in one compiled call.
        cells, arc, corners, height = grid_and_corners(poly, float(step / 2.0))
        n = len(cells)
        ok = np.zeros(n, dtype=bool)
        if n >= 3:
            ok[:n - 2] = True
            if len(corners):
                end_clearance = float(world.clearance(path[[0, -1]]).min())
                good = min(radius + self.wall_margin, end_clearance) - height >= radius
                unsure = np.nonzero(~good)[0]
                if len(unsure):
                    au, bu = cells[corners[unsure]], cells[corners[unsure] + 2]
                    limit = np.minimum(radius, np.minimum(world.clearance(au), world.clearance(bu)))
                    good[unsure] = segment_is_clear(world, au, bu, limit - TOL)
                ok[corners] = good
        # World.on_line (a robot waiting in a bay is out of the single file) and in_door_zone of
        # both entrances with their operations, each zone's entry_cell and the path's
        # polyline_segments, in one compiled call.
        inside, entry, left, right, segments = cut_zones(cells, self._stay_geometry(world), poly)
        cut = Cut(cells, arc, ok, corners, inside, int(entry), (int(left), int(right)), segments)
        remember(self._cuts, key, cut)
        return cut
