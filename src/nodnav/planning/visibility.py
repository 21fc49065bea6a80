"""Shortest paths of a disc robot among walls (boxes and polygons): visibility graphs (polylines and
arc-length grids are :mod:`nodnav.planning.polylines`; the distances they are built on are :mod:`nodnav.geometry`'s).

A disc robot of radius ``r`` fits at a point when the point is at least ``r`` from every wall
and from the world's boundary, i.e. when it lies outside every wall grown by ``r`` (a rounded
rectangle). Shortest paths among rounded rectangles wrap around their arcs; here every arc is
replaced by the two vertices of a circumscribing octagon (a rectangle with 45-degree chamfers
whose chamfer is tangent to the arc), so a shortest path is a polyline through such vertices,
found on a visibility graph. Visibility is decided with exact segment-to-rectangle and
segment-to-point distances, never by sampling, so a polyline returned here is collision-free
along its whole length. Other robots standing still are discs, handled the same way (a disc is
a rectangle of zero size). A polygon wall's convex corners are chamfered the same way
(:func:`chamfered_polygon_vertices`: the arc around a corner is circumscribed by pieces of at
most 45 degrees, which gives the octagon's vertices for a right angle).

The walls-only graph of one (world, radius, inflation) never changes, so
:class:`VisibilityGraph` builds it once and keeps its all-pairs shortest paths; a query without
discs then costs a few vectorised distance evaluations, and many such queries are answered
together by :meth:`VisibilityGraph.shortest_paths`. The latest answers are remembered, with and
without discs (keyed by the discs the path had to go around).
"""

from __future__ import annotations

import copy
import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import shortest_path

from nodnav.compiled import compiled as _compiled
from nodnav.geometry import TOL, segment_is_clear
from nodnav.planning.disc_checks import _crosses_any, disc_violations  # noqa: F401 (imported from here)
from nodnav.planning.disc_search import (
    FOUND,
    NEEDS_EXITS,
    add_crossed,
    disc_search,
    discs_met,
    edge_keeps_clear,
    octagons_into,
)
from nodnav.planning.graph_search import shortest_chain
from nodnav.planning.memo import remember, remembered_property
from nodnav.planning.polylines import polyline_length
from nodnav.planning.wall_paths import NONE, segments_to_check, walls_answers
from nodnav.scenario.world import World

#: tan(pi/8): where the chamfer of a circumscribing octagon meets the rectangle's sides.
_TAN_EIGHTH = math.sqrt(2.0) - 1.0

#: No octagon exits given to :func:`~nodnav.planning.disc_search.disc_search` (it computes them).
_NO_EXITS = np.zeros((0, 2))


def chamfered_vertices(boxes: np.ndarray, inflation: np.ndarray | float) -> np.ndarray:
    """Vertices of the octagons that circumscribe each box grown by ``inflation``, ``(B * 8, 2)``.

    Each corner arc of radius ``R`` around corner ``W`` is replaced by the chamfer tangent to it
    at 45 degrees, which meets the grown sides at ``W + R (1, tan(pi/8))`` and
    ``W + R (tan(pi/8), 1)`` (and mirror images). A box of zero size gives the regular octagon
    circumscribing a disc of radius ``R``. Vertices are listed counter-clockwise per box.
    """
    bx = np.asarray(boxes, dtype=float).reshape(-1, 4)
    r = np.broadcast_to(np.asarray(inflation, dtype=float), (len(bx),))[:, None]
    t = _TAN_EIGHTH * r
    x0, y0, x1, y1 = bx[:, 0:1], bx[:, 1:2], bx[:, 2:3], bx[:, 3:4]
    xs = np.hstack([x1 + r, x1 + r, x1 + t, x0 - t, x0 - r, x0 - r, x0 - t, x1 + t])
    ys = np.hstack([y0 - t, y1 + t, y1 + r, y1 + r, y1 + t, y0 - t, y0 - r, y0 - r])
    return np.stack([xs, ys], axis=-1).reshape(-1, 2)


def chamfered_polygon_vertices(polygon: np.ndarray, inflation: float) -> np.ndarray:
    """Vertices ``(V, 2)`` circumscribing the polygon grown by ``inflation`` at its convex corners.

    At a convex corner ``W`` the grown polygon follows an arc of radius ``R`` from the outward
    normal of the edge before it to that of the edge after it (the exterior angle ``theta``).
    The arc is cut into ``k = ceil(theta / 45 degrees)`` equal pieces and circumscribed by their
    tangents, whose meeting points ``W + R / cos(theta / 2k) (cos, sin)(phi_1 + (j + 1/2) theta / k)``
    are the vertices: the first and last lie on the grown edges, so consecutive vertices of one
    polygon are joined by segments at least ``R`` from it. Reflex corners give none.
    """
    p = np.asarray(polygon, dtype=float)
    area2 = np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
    if area2 < 0:
        p = p[::-1]
    out = []
    r = float(inflation)
    for i in range(len(p)):
        w, before, after = p[i], p[i - 1], p[(i + 1) % len(p)]
        e1, e2 = w - before, after - w
        # directions of the outward normals (ey, -ex) of the counter-clockwise edges before and after
        n1 = math.atan2(-e1[0], e1[1])
        n2 = math.atan2(-e2[0], e2[1])
        theta = (n2 - n1 + math.pi) % (2.0 * math.pi) - math.pi
        if theta <= 1e-12:
            continue  # reflex or straight: no arc
        k = max(1, math.ceil(theta / (math.pi / 4.0) - 1e-9))
        reach = r / math.cos(theta / (2 * k))
        for j in range(k):
            a = n1 + (j + 0.5) * theta / k
            out.append((w[0] + reach * math.cos(a), w[1] + reach * math.sin(a)))
    return np.array(out, dtype=float).reshape(-1, 2)


def octagon_exits(point: np.ndarray, centres: np.ndarray, radii: np.ndarray, turn: float = 0.0) -> np.ndarray:
    """Where ``point`` leaves, moving straight away from each centre, the regular octagon that
    circumscribes the disc of radius ``radii[j]`` about ``centres[j]`` (:func:`chamfered_vertices`
    of a zero-size box), ``(m, 2)``; ``point`` itself for a disc whose octagon it is not in.

    The octagon's sides have their normals every 45 degrees at the distance ``radii[j]``, so
    along a ray at ``delta`` from the nearest normal its boundary is ``radii[j] / cos(delta)``
    away. A start or goal between a disc and its octagon sees no corner of the octagon without
    cutting the disc; from its exit point the neighbouring corners lie along a side.
    """
    p = np.asarray(point, dtype=float).reshape(2)
    c = np.asarray(centres, dtype=float).reshape(-1, 2)
    r = np.asarray(radii, dtype=float).reshape(-1)
    away = p - c
    d = np.hypot(away[:, 0], away[:, 1])
    angle = np.arctan2(away[:, 1], away[:, 0])
    if turn:  # the octagon turned by ``turn`` (rad)
        angle = angle - turn
    # np.rint is what np.round does for no decimals (halves to even), without its wrappers.
    delta = angle - np.rint(angle / (np.pi / 4.0)) * (np.pi / 4.0)
    boundary = r / np.cos(delta) + 2 * TOL
    inside = (d > 0) & (d < boundary)
    scale = np.where(inside, boundary / np.where(d > 0, d, 1.0), 1.0)
    return c + away * scale[:, None]


@dataclass
class GeometricPath:
    """A collision-free polyline for one disc robot, or why there is none."""

    success: bool
    """Whether a path was found."""
    reason: str
    """Empty on success; otherwise why no path exists."""
    points: np.ndarray
    """Vertices ``(V, 2)`` from start to goal (m); just the start on failure."""

    @remembered_property
    def length(self) -> float:
        """Length of the polyline (m); ``inf`` on failure. Computed when first read: the fast
        planner makes thousands of paths per trial and reads few lengths."""
        return polyline_length(self.points) if self.success else math.inf


class VisibilityGraph:
    """Shortest collision-free paths of a disc robot of one radius in one world.

    Vertices are the chamfered-octagon corners of the walls grown by ``radius + inflation``
    that lie in free space; an edge joins two vertices when the segment between them keeps at
    least ``radius + inflation`` from every wall. The start and the goal are joined to vertices
    whose segment keeps ``min(radius + inflation, clearance of the endpoint)`` (a robot already
    squeezed against a wall may leave it but never go closer). Discs (other robots standing
    still) are avoided with the same construction when a query passes them.
    """

    def __init__(self, world: World, radius: float, inflation: float = 0.0):
        self.world = world
        self.radius = float(radius)
        self.inflation = float(inflation)
        self.clearance = self.radius + self.inflation
        walls = world.obstacle_array
        v = chamfered_vertices(walls, self.clearance) if len(walls) else np.zeros((0, 2))
        if world.polygons:
            v = np.vstack([v] + [chamfered_polygon_vertices(np.array(poly), self.clearance) for poly in world.polygons])
        v = v[world.clearance(v) >= self.clearance - TOL] if len(v) else v
        self.vertices = np.unique(np.round(v, 12), axis=0) if len(v) else v
        m = len(self.vertices)
        weights = np.zeros((m, m))
        self._visible = np.zeros((m, m), dtype=bool)
        if m > 1:
            i, j = np.triu_indices(m, 1)
            ok = segment_is_clear(world, self.vertices[i], self.vertices[j], self.clearance - TOL)
            lengths = np.linalg.norm(self.vertices[i] - self.vertices[j], axis=1)
            weights[i[ok], j[ok]] = lengths[ok]
            weights[j[ok], i[ok]] = lengths[ok]
            self._visible[i[ok], j[ok]] = self._visible[j[ok], i[ok]] = True
        if m:
            self._dist, self._pred = shortest_path(weights, method="D", directed=False, return_predecessors=True)
        else:
            self._dist, self._pred = np.zeros((0, 0)), np.zeros((0, 0), dtype=int)
        for a in (self.vertices, self._visible, self._dist, self._pred):
            a.setflags(write=False)  # shared by the copies of with_own_memos
        self._plain: dict[tuple, GeometricPath] = {}
        self._around: dict[tuple, GeometricPath] = {}

    def with_own_memos(self) -> "VisibilityGraph":
        """The same graph (its vertices, edges and all-pairs paths shared, read-only) with memos
        of its own, empty: a planner that reuses another's graph answers as if it had built it."""
        g = copy.copy(self)
        g._plain, g._around = {}, {}
        return g

    def shortest_path(self, start: np.ndarray, goal: np.ndarray, discs: np.ndarray | None = None,
                      disc_radii: np.ndarray | None = None) -> GeometricPath:
        """Shortest collision-free polyline from ``start`` to ``goal``.

        ``discs`` ``(m, 2)`` with ``disc_radii`` ``(m,)`` are round obstacles for the robot's
        centre (another robot's position with the required centre distance). A disc that
        already contains the start may be left, along the first segment and never closer to its
        centre than the start is, but not entered again; likewise a disc containing the goal may
        be entered along the last segment only (:func:`disc_violations`). Discs are added
        lazily, only those the current shortest path violates, so a query that meets no disc
        costs as much as one without.
        """
        start = np.asarray(start, dtype=float).reshape(2)
        goal = np.asarray(goal, dtype=float).reshape(2)
        pair = (start.tobytes(), goal.tobytes())  # shortest_paths for one pair, without its lists
        path = self._plain.get(pair)
        if path is None:
            path = self._walls_only(start[None], goal[None])[0]
            remember(self._plain, pair, path)
        if not path.success or discs is None or not len(discs):
            return path
        centres = np.asarray(discs, dtype=float).reshape(-1, 2)
        radii = np.asarray(disc_radii, dtype=float).reshape(-1)
        if not _crosses_any(path.points, centres, radii, start, goal):
            return path  # the common case, in one compiled call: the path among the walls will do
        # The discs of radius above TOL, their distances from the start and the goal.
        centres, radii, d_start, d_goal = discs_met(centres, radii, start, goal)
        active = np.zeros(len(centres), dtype=bool)
        limits = None  # how close to the walls the path may start and end, once a disc is met
        while True:
            if not add_crossed(_contiguous(path.points), centres, radii, d_start, d_goal, active):
                return path
            key = (start.tobytes(), goal.tobytes(), centres[active].tobytes(), radii[active].tobytes())
            known = self._around.get(key)
            if known is None:
                if limits is None:
                    limits = np.minimum(self.clearance, self.world.clearance(np.array([start, goal]))) - TOL
                known = self._search_with_discs(start, goal, limits[0], limits[1], centres[active], radii[active],
                                                d_start[active], d_goal[active])
                remember(self._around, key, known)
            path = known
            if not path.success:
                return path

    def shortest_paths(self, starts: np.ndarray, goals: np.ndarray) -> list[GeometricPath]:
        """Shortest paths among the walls alone for many start and goal pairs ``(m, 2)`` at once.

        These are asked for again and again (every passing order from one state starts with
        them), so the most recent ones are kept.
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 2)
        goals = np.asarray(goals, dtype=float).reshape(-1, 2)
        # Each row's bytes (what ``row.tobytes()`` gives), cut from the whole array's in one go.
        sb, gb = starts.tobytes(), goals.tobytes()
        keys = [(sb[o:o + 16], gb[o:o + 16]) for o in range(0, 16 * len(starts), 16)]
        missing = [i for i, key in enumerate(keys) if key not in self._plain]
        found = dict(zip(missing, self._walls_only(starts[missing], goals[missing]))) if missing else {}
        paths = [found[i] if i in found else self._plain[key] for i, key in enumerate(keys)]
        for i, path in found.items():
            remember(self._plain, keys[i], path)
        return paths

    # -----------------------------------------------------------------------------------------

    def _fail(self, start: np.ndarray, reason: str) -> GeometricPath:
        return GeometricPath(False, reason, start[None].copy())

    def _walls_only(self, starts: np.ndarray, goals: np.ndarray) -> list[GeometricPath]:
        m = len(starts)
        clear = self.world.clearance(np.vstack([starts, goals]))
        c_start, c_goal = clear[:m], clear[m:]
        # The segments to check (a start's to the vertices once, for many ways from one spot),
        # then each query's answer and path, in two compiled calls around the walls' check.
        a, b, need, one_start = segments_to_check(starts, goals, self.vertices, c_start, c_goal, self.clearance, TOL)
        seen = segment_is_clear(self.world, a, b, need)
        kind, points, offsets, lengths = walls_answers(starts, goals, self.vertices, seen, one_start, self._dist,
                                                       self._pred, c_start, c_goal, self.radius - TOL)
        paths = []
        ends, lengths = offsets.tolist(), lengths.tolist()
        for i, answer in enumerate(kind.tolist()):
            if answer == NONE:
                start, goal = starts[i], goals[i]
                if c_start[i] < 0.0:
                    paths.append(self._fail(start, f"start {_fmt(start)} is inside a wall or outside the world"))
                elif c_goal[i] < self.radius - TOL:
                    paths.append(self._fail(start, f"goal {_fmt(goal)} is not in free space: clearance "
                                                   f"{c_goal[i]:.3f} m < radius {self.radius:.3f} m"))
                else:
                    paths.append(self._fail(start, f"no collision-free path from {_fmt(start)} to {_fmt(goal)}"))
                continue
            path = _path(points[ends[i]:ends[i + 1]])
            if lengths[i] >= 0.0:  # what its length would compute when first read (a short path)
                path.__dict__["length"] = lengths[i]
            paths.append(path)
        return paths

    def _search_with_discs(self, start, goal, thr_start, thr_goal, centres, radii, d_start, d_goal) -> GeometricPath:
        """The shortest path from ``start`` to ``goal`` around the discs, in one compiled call
        (:func:`~nodnav.planning.disc_search.disc_search`) where the world is not turned and has
        no wall index, else :meth:`_search_with_discs_plain` (the same path)."""
        world = self.world
        if world.passage.angle or world.wall_grid is not None:
            return self._search_with_discs_plain(start, goal, thr_start, thr_goal, centres, radii, d_start, d_goal)
        centres = np.ascontiguousarray(centres, dtype=float)
        radii = np.ascontiguousarray(radii, dtype=float)
        args = (start, goal, float(thr_start), float(thr_goal), centres, radii,
                np.ascontiguousarray(d_start, dtype=float), np.ascontiguousarray(d_goal, dtype=float), self.vertices,
                self._visible, self.clearance, world.bounds_array, world.obstacle_array, world.piece_array)
        outcome, points = disc_search(*args, _NO_EXITS)
        if outcome == NEEDS_EXITS:  # a start or goal inside an octagon: NumPy's exits (its rounding)
            exits = np.vstack([octagon_exits(start, centres, radii), octagon_exits(goal, centres, radii)])
            outcome, points = disc_search(*args, exits)
        if outcome != FOUND:
            return self._fail(start, f"no collision-free path from {_fmt(start)} to {_fmt(goal)} "
                                     f"around {len(centres)} standing robot(s)")
        return _path(points)

    def _search_with_discs_plain(self, start, goal, thr_start, thr_goal, centres, radii, d_start,
                                 d_goal) -> GeometricPath:
        """:meth:`_search_with_discs` step by step with NumPy (any world; the reference of
        :func:`~nodnav.planning.disc_search.disc_search`)."""
        centres = np.ascontiguousarray(centres, dtype=float)
        radii = np.ascontiguousarray(radii, dtype=float)
        base = _outside_all(self.vertices, centres, radii)
        turn = self.world.passage.angle  # octagons square with the passage, at any angle
        if turn:
            c, s = math.cos(turn), math.sin(turn)
            offsets = chamfered_vertices(np.zeros((len(centres), 4)), radii).reshape(len(centres), -1, 2)
            ring = (centres[:, None] + offsets @ np.array([[c, s], [-s, c]])).reshape(-1, 2)
        else:  # chamfered_vertices of the zero-size boxes at the centres, in one compiled call
            ring = _disc_octagons(centres, radii)
        # A start or goal inside an octagon but not its disc first steps out of it radially.
        ring = np.vstack([ring, octagon_exits(start, centres, radii, turn), octagon_exits(goal, centres, radii, turn)])
        ring_ok = self.world.clearance(ring) >= self.clearance - TOL
        ring_ok &= _outside_mask(ring, centres, radii)
        nodes = np.vstack([start, goal, self.vertices[base], ring[ring_ok]])
        nb = len(base)
        i, j = _pairs(len(nodes))
        # Edges between two wall vertices were checked against the walls once, at construction.
        known = (i >= 2) & (j < 2 + nb)
        ok = np.zeros(len(i), dtype=bool)
        ok[known] = self._visible[base[i[known] - 2], base[j[known] - 2]]
        rest = np.flatnonzero(~known)
        thr = np.full(len(nodes), self.clearance - TOL)
        thr[0], thr[1] = thr_start, thr_goal
        ok[rest] = segment_is_clear(self.world, nodes[i[rest]], nodes[j[rest]], np.minimum(thr[i[rest]], thr[j[rest]]))
        _keep_clear_of_discs(nodes, i, j, ok, centres, radii, np.ascontiguousarray(d_start, dtype=float),
                             np.ascontiguousarray(d_goal, dtype=float))
        i, j = i[ok], j[ok]
        chain = shortest_chain(len(nodes), i, j, np.linalg.norm(nodes[i] - nodes[j], axis=1), 0, 1)
        if not chain:
            return self._fail(start, f"no collision-free path from {_fmt(start)} to {_fmt(goal)} "
                                     f"around {len(centres)} standing robot(s)")
        return _path(_without_repeats(nodes[chain]))


@_compiled
def _outside_mask(points, centres, radii):
    """Whether each of ``points`` is at least ``radii[j] - TOL`` from every centre ``j``:
    ``(np.linalg.norm(points[:, None] - centres[None], axis=2) >= radii - TOL).all(axis=1)``, a
    norm of two coordinates being ``sqrt(x * x + y * y)`` (see :func:`_outside_all`)."""
    out = np.zeros(points.shape[0], dtype=np.bool_)
    for v in _outside_all(points, centres, radii):
        out[v] = True
    return out


@_compiled
def _keep_clear_of_discs(nodes, i, j, ok, centres, radii, d_start, d_goal):
    """Clear ``ok[e]`` of every edge ``nodes[i[e]] -> nodes[j[e]]`` still allowed that comes
    closer than its limit (less :data:`TOL`) to a centre: the disc's radius, no more than the
    start's distance from it on an edge from the start (``i == 0``), no more than the goal's on
    an edge to the goal (either end 1), as ``_search_with_discs`` computed it with NumPy (the
    distance by :func:`~nodnav.geometry.segment_point_distance`'s operations)."""
    for e in range(i.shape[0]):
        if ok[e] and not edge_keeps_clear(nodes, i[e], j[e], centres, radii, d_start, d_goal):
            ok[e] = False


@_compiled
def _outside_all(vertices, centres, radii):
    """The indices of the ``vertices`` at least ``radii[j] - TOL`` from every centre ``j``, as
    ``np.flatnonzero((np.linalg.norm(vertices[:, None] - centres[None], axis=2) >= radii - TOL).all(axis=1))``
    (a norm of two coordinates is ``sqrt(x * x + y * y)`` in NumPy too)."""
    keep = np.empty(vertices.shape[0], dtype=np.int64)
    k = 0
    for v in range(vertices.shape[0]):
        ok = True
        for j in range(centres.shape[0]):
            dx, dy = vertices[v, 0] - centres[j, 0], vertices[v, 1] - centres[j, 1]
            if not math.sqrt(dx * dx + dy * dy) >= radii[j] - TOL:
                ok = False
                break
        if ok:
            keep[k] = v
            k += 1
    return keep[:k]


@_compiled
def _disc_octagons(centres, radii):
    """:func:`chamfered_vertices` of the zero-size boxes ``(x, y, x, y)`` at ``centres`` grown by
    ``radii``, ``(m * 8, 2)`` (:func:`~nodnav.planning.disc_search.octagons_into`)."""
    out = np.empty((centres.shape[0] * 8, 2))
    octagons_into(centres, radii, out)
    return out


@functools.lru_cache(maxsize=256)
def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.triu_indices(n, 1)``, remembered (read-only): the disc searches ask for the same few sizes."""
    i, j = np.triu_indices(n, 1)
    i.setflags(write=False)
    j.setflags(write=False)
    return i, j


def _without_repeats(points: np.ndarray) -> np.ndarray:
    """``points`` without a vertex within :data:`TOL` of the one before (the start and the goal
    kept). A start on an octagon's edge has an exit node at the start itself, so the shortest
    chain may or may not step through it (a zero-length edge, a tie that rounding breaks, and
    differently in a turned world); without repeats both chains are one path."""
    step = np.hypot(*(points[1:] - points[:-1]).T)
    keep = np.concatenate([[True], step > TOL])
    if not keep[-1]:  # the goal repeats the vertex before it: keep the goal
        before = np.flatnonzero(keep[:-1])[-1]
        keep[-1], keep[before] = True, before == 0
    return points[keep]


def _contiguous(points: np.ndarray) -> np.ndarray:
    """``points`` as a contiguous float array ``(V, 2)`` (itself when it is one: a path's points are)."""
    if points.flags.c_contiguous and points.dtype == np.float64 and points.ndim == 2:
        return points
    return np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))


def _path(points: np.ndarray) -> GeometricPath:
    points.setflags(write=False)
    return GeometricPath(True, "", points)


def _fmt(p: np.ndarray) -> str:
    return f"({p[0]:.3f}, {p[1]:.3f})"
