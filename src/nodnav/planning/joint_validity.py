"""Valid configurations and edges in the joint configuration space of the PRM* roadmaps (appendix).

A configuration of ``n`` robots is a point ``x = (p_1, ..., p_n)`` of R^{2n}. The appendix calls
it valid when every pair of robots is at least ``2 r_robot`` apart; here it is valid when

1. every robot lies in free space: ``world.clearance(p_i) >= r_i``;
2. every pair is at least ``r_a + r_b + margin`` apart (the margin is the planner's reserve);
3. the passing order can still hold (below).

Passing order at the level of a configuration
---------------------------------------------
Robots are relabelled by their rank in the passing order: rank 0 passes first. Each robot has a
crossing direction ``d`` (+1 from the first mouth's side to the second's, the paper's left to
right, -1 the other way, 0 it does not cross; see
:func:`nodnav.planning.base.crossing_directions`) and, at every configuration, a *stage* that
depends on its coordinate along the passage's axis only (x for the paper's corridor): BEFORE the
corridor, INSIDE it (between the entrances,
inclusive), or AFTER it, read along its own direction. Taking the crossing robots (``d != 0``) in
rank order, a configuration respects the order when, for each robot and its predecessor:

* same direction: the robot is not further along than its predecessor
  (``stage <= stage of predecessor``), and when both are inside the predecessor is strictly
  ahead (single file, in order);
* opposite directions: the robot is BEFORE, or its predecessor is AFTER (a robot enters against
  the traffic only once the corridor is clear of the robot before it).

A robot with ``d = 0`` must never be inside. Along any continuous path of such configurations the
robots first enter the corridor in rank order (a robot can only turn INSIDE while its
predecessor is already INSIDE or AFTER, and strictly ahead or gone), and at most one direction
is ever inside the corridor (a chain argument: between two inside robots of opposite directions
there is a direction change whose predecessor must be AFTER, and stages cannot increase back
along the ranks). Edges are checked exactly (:func:`edges_valid`), so every roadmap path, and
its linear interpolation in time, keeps all three rules at every instant.

The rules come twice: vectorised over many configurations or edges (:func:`configurations_valid`,
:func:`edges_valid`), and as compiled scalar kernels for OMPL's callbacks and the few edges of a
query (:class:`CompiledRules`); the roadmap module (:mod:`nodnav.planning.roadmap`) builds with
both.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from nodnav.compiled import compiled as _njit
from nodnav.geometry import TOL, segment_clearance_one, segment_is_clear
from nodnav.scenario.world import World
from nodnav.wall_grid import segment_clear_one_indexed

BEFORE, INSIDE, AFTER = 0, 1, 2
"""Stages of a robot relative to the corridor, along its crossing direction."""


# ---------------------------------------------------------------------------------------------
# Validity rules, vectorised


@functools.lru_cache(maxsize=16)
def pair_indices(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Index arrays ``(a, b)`` of the ``n (n - 1) / 2`` unordered pairs ``a < b`` (read-only;
    memoised because queries need them many times)."""
    a, b = np.triu_indices(n, 1)
    a.flags.writeable = False
    b.flags.writeable = False
    return a, b


def separation_thresholds(radii: np.ndarray, margin: float) -> np.ndarray:
    """Required distance of each pair, ``r_a + r_b + margin`` (m), shape ``(n (n - 1) / 2,)``."""
    r = np.asarray(radii, dtype=float)
    a, b = pair_indices(len(r))
    return r[a] + r[b] + margin



def stages(x: np.ndarray, directions: np.ndarray, world: World) -> np.ndarray:
    """Stage (BEFORE, INSIDE, AFTER) of each robot from its coordinate along the passage's axis
    (:meth:`World.along`; the paper's x), shape of ``x`` ``(..., n)``.

    INSIDE is the closed interval between the entrances (as :meth:`World.in_corridor`); AFTER is
    beyond the far entrance along the robot's direction. Robots with direction 0 are BEFORE or
    INSIDE.
    """
    x = np.asarray(x, dtype=float)
    d = np.asarray(directions)
    s0, s1 = world.passage.s_start, world.passage.s_end
    inside = (x >= s0) & (x <= s1)
    after = ((d > 0) & (x > s1)) | ((d < 0) & (x < s0))
    return np.where(inside, INSIDE, np.where(after, AFTER, BEFORE))


def order_holds(x: np.ndarray, directions: np.ndarray, world: World) -> np.ndarray:
    """Whether the passing order can still hold at configurations with robot coordinates ``x``
    along the passage (:meth:`World.along`).

    ``x`` is ``(..., n)`` with robots listed by rank; ``directions`` ``(n,)``. The rule is the one
    in the module docstring: for consecutive crossing robots, same direction means
    ``stage <= stage of predecessor`` and strictly behind it when both are inside; opposite
    directions mean BEFORE or predecessor AFTER; robots with direction 0 are never inside.
    """
    x = np.asarray(x, dtype=float)
    d = np.asarray(directions, dtype=int)
    s = stages(x, d, world)
    ok = ~np.any((s == INSIDE) & (d == 0), axis=-1)
    chain = np.flatnonzero(d != 0)
    for p, c in zip(chain[:-1], chain[1:]):
        sp, sc = s[..., p], s[..., c]
        if d[p] == d[c]:
            behind = d[p] * (x[..., p] - x[..., c]) > 0
            ok &= (sc <= sp) & ~((sp == INSIDE) & (sc == INSIDE) & ~behind)
        else:
            ok &= (sc == BEFORE) | (sp == AFTER)
    return ok


def _as_points(configs: np.ndarray, n: int) -> np.ndarray:
    x = np.asarray(configs, dtype=float)
    return x.reshape(x.shape[:-1] + (n, 2))


def configurations_valid(world: World, configs: np.ndarray, radii: np.ndarray, directions: np.ndarray,
                         min_separation: np.ndarray, min_clearance: np.ndarray | None = None) -> np.ndarray:
    """Rules 1-3 of the module docstring at configurations ``(..., 2n)``, shape ``(...)``.

    ``min_separation`` is the required distance per pair (:func:`separation_thresholds`);
    ``min_clearance`` the required wall clearance per robot (default: the radii).
    """
    r = np.asarray(radii, dtype=float)
    p = _as_points(configs, len(r))
    need = r if min_clearance is None else np.asarray(min_clearance, dtype=float)
    ok = np.all(world.clearance(p) >= need - TOL, axis=-1)
    a, b = pair_indices(len(r))
    if len(a):
        ok &= np.all(np.linalg.norm(p[..., a, :] - p[..., b, :], axis=-1) >= min_separation - TOL, axis=-1)
    return ok & order_holds(world.along(p), directions, world)


def segment_pair_distance(start: np.ndarray, end: np.ndarray, n: int) -> np.ndarray:
    """Least distance (m) of every pair of robots while the joint configuration moves linearly.

    ``start``, ``end`` are ``(E, 2n)``; result ``(E, n (n - 1) / 2)``. The squared distance
    ``|c + t e|^2`` is a quadratic in the edge parameter ``t``; its minimum on [0, 1] is at
    ``t* = clip(-c.e / e.e, 0, 1)``.
    """
    pa, pb = _as_points(start, n), _as_points(end, n)
    a, b = pair_indices(n)
    c = pa[:, a] - pa[:, b]
    e = (pb[:, a] - pb[:, b]) - c
    ee = np.sum(e * e, axis=-1)
    t = np.clip(-np.sum(c * e, axis=-1) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
    return np.linalg.norm(c + t[..., None] * e, axis=-1)


def _order_event_times(xa: np.ndarray, xb: np.ndarray, directions: np.ndarray, world: World) -> np.ndarray:
    """Edge parameters in (0, 1) where a stage or the order of two consecutive robots can change,
    padded with 1, shape ``(E, 2n + n - 1)``."""
    d = np.asarray(directions, dtype=int)
    dx = xb - xa
    cols = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for bound in (world.passage.s_start, world.passage.s_end):
            cols.append((bound - xa) / dx)
        chain = np.flatnonzero(d != 0)
        for p, c in zip(chain[:-1], chain[1:]):
            if d[p] == d[c]:
                cols.append(((xa[:, c] - xa[:, p]) / (dx[:, p] - dx[:, c]))[:, None])
    t = np.concatenate(cols, axis=1) if cols else np.ones((len(xa), 0))
    return np.where(np.isfinite(t) & (t > 0.0) & (t < 1.0), t, 1.0)


def edge_order_holds(xa: np.ndarray, xb: np.ndarray, directions: np.ndarray, world: World) -> np.ndarray:
    """Whether the order rule holds all along straight edges, given robot coordinates along the
    passage ``(E, n)`` at both ends (linear along an edge, as x was for the paper's corridor).

    Stages are piecewise constant along an edge and change only where a coordinate crosses an
    entrance; the relative position of two consecutive same-direction robots changes only where
    their coordinates meet. Checking both ends and one point inside every interval between
    those events is therefore exact (an instant at which two events coincide, of probability
    zero, is not examined on its own).
    """
    xa = np.asarray(xa, dtype=float)
    xb = np.asarray(xb, dtype=float)
    events = np.sort(_order_event_times(xa, xb, directions, world), axis=1)
    knots = np.concatenate([np.zeros((len(xa), 1)), events, np.ones((len(xa), 1))], axis=1)
    t = np.concatenate([knots[:, :1], 0.5 * (knots[:, :-1] + knots[:, 1:]), knots[:, -1:]], axis=1)
    x = (1.0 - t[..., None]) * xa[:, None, :] + t[..., None] * xb[:, None, :]
    return np.all(order_holds(x, directions, world), axis=1)


def edges_valid(world: World, start: np.ndarray, end: np.ndarray, radii: np.ndarray, directions: np.ndarray,
                min_separation: np.ndarray, min_clearance: np.ndarray | None = None,
                chunk: int = 20000) -> np.ndarray:
    """Whether straight joint edges ``start -> end`` ``(E, 2n)`` keep rules 1-3 at every instant, ``(E,)``.

    Exact: walls by :func:`nodnav.geometry.segment_clearance`, pairs by :func:`segment_pair_distance`, order by
    :func:`edge_order_holds`. ``min_separation`` per pair and ``min_clearance`` per robot
    (default: the radii) are the required values.
    """
    r = np.asarray(radii, dtype=float)
    n = len(r)
    need = r if min_clearance is None else np.asarray(min_clearance, dtype=float)
    start = np.asarray(start, dtype=float).reshape(-1, 2 * n)
    end = np.asarray(end, dtype=float).reshape(-1, 2 * n)
    out = np.empty(len(start), dtype=bool)
    for lo in range(0, len(start), chunk):
        a, b = start[lo:lo + chunk], end[lo:lo + chunk]
        pa, pb = _as_points(a, n), _as_points(b, n)
        ok = np.all(segment_is_clear(world, pa, pb, need - TOL), axis=1)
        if n > 1:
            ok &= np.all(segment_pair_distance(a, b, n) >= min_separation - TOL, axis=1)
        ok &= edge_order_holds(world.along(pa), world.along(pb), directions, world)
        out[lo:lo + chunk] = ok
    return out


# ---------------------------------------------------------------------------------------------
# The same rules as scalar kernels for OMPL's callbacks (one state or one edge per call)


@_njit
def _stage(x, d, cx0, cx1):
    if cx0 <= x <= cx1:
        return INSIDE
    if (d > 0 and x > cx1) or (d < 0 and x < cx0):
        return AFTER
    return BEFORE


@_njit
def _order_ok(xs, dirs, cx0, cx1):
    prev = -1
    for i in range(xs.shape[0]):
        s = _stage(xs[i], dirs[i], cx0, cx1)
        if dirs[i] == 0:
            if s == INSIDE:
                return False
            continue
        if prev >= 0:
            sp = _stage(xs[prev], dirs[prev], cx0, cx1)
            if dirs[prev] == dirs[i]:
                if s > sp:
                    return False
                if s == INSIDE and sp == INSIDE and dirs[prev] * (xs[prev] - xs[i]) <= 0.0:
                    return False
            elif s != BEFORE and sp != AFTER:
                return False
        prev = i
    return True


@_njit
def _wall_clear(ax, ay, bx, by, want, box, rects, pieces, grid, starts, items, seen, mark):
    """Whether the segment ``(ax, ay) -> (bx, by)`` keeps ``want`` from the walls: through the
    world's wall index when it has one (``grid[3]``, the buckets across, above 0: a map's world;
    :func:`~nodnav.wall_grid.segment_clear_one_indexed`, the full loop's verdict exactly), else
    the full loop over every wall."""
    if grid[3] > 0:
        return segment_clear_one_indexed(ax, ay, bx, by, want, rects, box, pieces, grid[0], grid[1], grid[2],
                                         int(grid[3]), int(grid[4]), starts, items, seen, mark)
    return not segment_clearance_one(ax, ay, bx, by, rects, box, pieces) < want


@_njit
def _state_ok(x, clear, dirs, sep, box, rects, pieces, cx0, cx1, ux, uy, grid, starts, items):
    """Rules 1-3 at one configuration (scalar :func:`configurations_valid`); ``clear`` is the
    required wall clearance per robot (the radii), ``sep`` the required distance per pair."""
    n = clear.shape[0]
    seen = np.zeros(rects.shape[0] if grid[3] > 0 else 0, dtype=np.int64)
    for i in range(n):
        if not _wall_clear(x[2 * i], x[2 * i + 1], x[2 * i], x[2 * i + 1], clear[i] - TOL, box, rects, pieces,
                           grid, starts, items, seen, i + 1):
            return False
    k = 0
    for a in range(n):
        for b in range(a + 1, n):
            dx, dy = x[2 * a] - x[2 * b], x[2 * a + 1] - x[2 * b + 1]
            if math.sqrt(dx * dx + dy * dy) < sep[k] - TOL:
                return False
            k += 1
    xs = np.empty(n)
    for i in range(n):
        xs[i] = _along(x, i, ux, uy)
    return _order_ok(xs, dirs, cx0, cx1)


@_njit
def _along(x, i, ux, uy):
    """Robot ``i``'s coordinate along the passage's axis in configuration ``x``; exactly its x
    for the paper's axis ``(1, 0)``."""
    if ux == 1.0 and uy == 0.0:
        return x[2 * i]
    return x[2 * i] * ux + x[2 * i + 1] * uy


@_njit
def _motion_ok(xa, xb, clear, dirs, sep, box, rects, pieces, cx0, cx1, ux, uy, grid, starts, items):
    """Rules 1-3 all along one straight edge (scalar :func:`edges_valid`)."""
    n = clear.shape[0]
    seen = np.zeros(rects.shape[0] if grid[3] > 0 else 0, dtype=np.int64)
    for i in range(n):
        if not _wall_clear(xa[2 * i], xa[2 * i + 1], xb[2 * i], xb[2 * i + 1], clear[i] - TOL, box, rects, pieces,
                           grid, starts, items, seen, i + 1):
            return False
    k = 0
    for a in range(n):
        for b in range(a + 1, n):
            cx, cy = xa[2 * a] - xa[2 * b], xa[2 * a + 1] - xa[2 * b + 1]
            ex = (xb[2 * a] - xb[2 * b]) - cx
            ey = (xb[2 * a + 1] - xb[2 * b + 1]) - cy
            ee = ex * ex + ey * ey
            t = 0.0
            if ee > 0.0:
                t = min(max(-(cx * ex + cy * ey) / ee, 0.0), 1.0)
            if math.sqrt((cx + t * ex) ** 2 + (cy + t * ey) ** 2) < sep[k] - TOL:
                return False
            k += 1
    sa, sb = np.empty(n), np.empty(n)
    for i in range(n):
        sa[i], sb[i] = _along(xa, i, ux, uy), _along(xb, i, ux, uy)
    events = np.ones(3 * n + 1)
    m = 0
    prev = -1
    for i in range(n):
        x0, x1 = sa[i], sb[i]
        if x1 != x0:
            for bound in (cx0, cx1):
                t = (bound - x0) / (x1 - x0)
                if 0.0 < t < 1.0:
                    events[m] = t
                    m += 1
        if dirs[i] != 0:
            if prev >= 0 and dirs[prev] == dirs[i]:
                den = (sb[prev] - sa[prev]) - (x1 - x0)
                if den != 0.0:
                    t = (x0 - sa[prev]) / den
                    if 0.0 < t < 1.0:
                        events[m] = t
                        m += 1
            prev = i
    knots = np.sort(events[:m])
    xs = np.empty(n)
    last = 0.0
    for j in range(m + 2):
        if j == 0:
            t = 0.0
        elif j <= m:
            t = 0.5 * (last + knots[j - 1])
            last = knots[j - 1]
        else:
            t = 0.5 * (last + 1.0)
        for i in range(n):
            xs[i] = (1.0 - t) * sa[i] + t * sb[i]
        if not _order_ok(xs, dirs, cx0, cx1):
            return False
    return _order_ok(sb, dirs, cx0, cx1)


@_njit
def _motions_ok(starts, ends, clear, dirs, sep, box, rects, pieces, cx0, cx1, ux, uy, grid, buckets, items):
    out = np.empty(starts.shape[0], dtype=np.bool_)
    for e in range(starts.shape[0]):
        out[e] = _motion_ok(starts[e], ends[e], clear, dirs, sep, box, rects, pieces, cx0, cx1, ux, uy, grid, buckets,
                            items)
    return out


def _index_args(world: World) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The world's wall index (:attr:`World.wall_grid`, a map's world) as the kernels take it:
    ``(x0, y0, cell, nx, ny)`` as floats, bucket starts, box indices; without one, counts 0 (the
    kernels then loop over every wall, as they did before the index)."""
    grid = world.wall_grid
    if grid is None:
        return np.zeros(5), np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    x0, y0, cell, nx, ny, starts, items = grid.arrays()
    return np.array([x0, y0, cell, nx, ny], dtype=float), starts, items


@dataclass(frozen=True, eq=False)
class CompiledRules:
    """Rules 1-3 for one set of robots as compiled scalar kernels (numba), for OMPL's callbacks
    and for the few edges of a query. Same mathematics as :func:`configurations_valid` and
    :func:`edges_valid`, one state or edge at a time without NumPy's per-call overhead."""

    args: tuple
    """Kernel arguments: clearance, directions, separations, bounds, wall boxes, convex wall
    pieces, the passage's mouths along its axis, its axis, and the world's wall index (origin,
    bucket side and counts as floats, bucket starts, box indices; counts 0 without one)."""

    @staticmethod
    def of(world: World, clearance: np.ndarray, directions: np.ndarray, min_separation: np.ndarray) -> "CompiledRules":
        """Rules for robots (by rank) needing ``clearance`` from walls and ``min_separation`` per pair."""
        return CompiledRules((np.ascontiguousarray(clearance, dtype=np.float64),
                              np.ascontiguousarray(directions, dtype=np.int64),
                              np.ascontiguousarray(min_separation, dtype=np.float64),
                              world.bounds_array, world.obstacle_array, world.piece_array,
                              float(world.passage.s_start), float(world.passage.s_end),
                              float(world.passage.axis[0]), float(world.passage.axis[1]), *_index_args(world)))

    def state_ok(self, x: np.ndarray) -> bool:
        """Whether configuration ``x`` ``(2n,)`` is valid."""
        return bool(_state_ok(np.ascontiguousarray(x, dtype=np.float64), *self.args))

    def motion_ok(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Whether the straight edge ``a -> b`` is valid all along."""
        return bool(_motion_ok(np.ascontiguousarray(a, dtype=np.float64),
                               np.ascontiguousarray(b, dtype=np.float64), *self.args))

    def motions_ok(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Whether each straight edge ``starts[e] -> ends[e]`` ``(E, 2n)`` is valid all along, ``(E,)``."""
        return _motions_ok(np.ascontiguousarray(starts, dtype=np.float64),
                           np.ascontiguousarray(ends, dtype=np.float64), *self.args)
