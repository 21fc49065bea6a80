"""PRM* roadmaps in the joint configuration space (appendix), their validity rules and their cache.

A configuration of ``n`` robots is a point ``x = (p_1, ..., p_n)`` of R^{2n}. The appendix calls
it valid when every pair of robots is at least ``2 r_robot`` apart; here it is valid when

1. every robot lies in free space: ``world.clearance(p_i) >= r_i``;
2. every pair is at least ``r_a + r_b + margin`` apart (the margin is the planner's reserve);
3. the passing order can still hold (below).

Passing order at the level of a configuration
---------------------------------------------
Robots are relabelled by their rank in the passing order: rank 0 passes first. Each robot has a
crossing direction ``d`` (+1 left to right, -1 right to left, 0 it does not cross; see
:func:`nodnav.planning.base.crossing_directions`) and, at every configuration, a *stage* that
depends on its x-coordinate only: BEFORE the corridor, INSIDE it (between the entrances,
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

Why one roadmap serves many scenarios and orders
------------------------------------------------
The rules above depend on the robots only through their radii and directions *listed by rank*.
The roadmap for a request is therefore keyed by ``(world, radii by rank, directions by rank,
margin, varsigma, size, seed, format version)`` and not by the scenario or the order: every
order of every scenario with the same direction pattern reuses it. With equal radii that is at
most 2^n roadmaps for n crossing robots (4 + 8 + 16 for 2..4 robots in the paper's world), where
the paper builds one roadmap per strategy (n! of them); in the closed loop, robots that have
left the corridor no longer cross and lead the order, which adds 2^n - 1 patterns
(:func:`direction_patterns`). ``varsigma`` is in the key because the stored per-vertex
proximity penalty depends on it.

Building
--------
Roadmaps are grown with OMPL's ``og.PRMstar`` (k-nearest PRM*, k = e (1 + 1/dim) log V). Three
hooks make that exact, fast and reproducible:

* the motion validator is exact (:func:`_motion_ok`): pairwise distance along a straight edge is
  a quadratic in the edge parameter, a disc moving along a segment stays clear of a rectangle iff
  the segment-rectangle distance is at least its radius, and stages change only where an
  x-coordinate crosses an entrance; OMPL's default discrete checking admits invalid edges;
* the valid-state sampler mixes uniform samples with *corridor lane* samples: one crossing robot
  (or a train of consecutive same-direction robots) on the corridor's axis band, and 1 m beyond
  each entrance, while the others stand still at an *anchor* placement (robots earlier in the
  order after the corridor, later ones before it) shared by many consecutive samples. In
  R^{2n} the corridor is a narrow passage that uniform samples almost never chain through; lane
  samples sharing an anchor differ in the crossing robots only, so they chain at PRM*'s
  k-nearest scale. The mixture keeps a uniform component, so PRM*'s sampling-density
  assumption still holds;
* the build grows the roadmap with ``growRoadmapPtc`` until a vertex count is reached (not a
  wall-clock time as ``constructRoadmap`` does), after ``ou.RNG.setSeed`` and with a NumPy
  generator seeded from the key, so a key always yields the same roadmap.

After export every edge is checked again with the vectorised :func:`edges_valid`; an edge that
fails is dropped and counted (none should). Roadmaps are stored as ``.npz`` under a name derived
from the key's hash, with the key and a SHA-256 checksum inside; a file that does not parse, has
another key, fails its checksum or holds non-finite numbers is logged and rebuilt. Writes go to a
temporary file that is renamed into place, so concurrent processes never see a partial file;
temporary files that killed writers left behind are deleted once they are 15 minutes old.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import logging
import math
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nodnav.compiled import compiled as _njit
from nodnav.geometry import TOL, segment_clearance, segment_clearance_one
from nodnav.scenario.world import World

log = logging.getLogger(__name__)

FORMAT_VERSION = 2
"""Version of the roadmap construction and file layout; part of every key (bump it whenever
either changes, so that stale cached roadmaps are rebuilt)."""
ROADMAP_SEED = 1
"""Seed of every roadmap build (part of the key)."""
BEFORE, INSIDE, AFTER = 0, 1, 2
"""Stages of a robot relative to the corridor, along its crossing direction."""

UNIFORM_FRACTION = 0.5
"""Share of uniform samples in the sampler mixture (the rest are corridor lane samples)."""
ANCHOR_REUSE = 24
"""Lane samples that share one anchor placement of the other robots."""
LANE_OVERHANG = 1.0
"""How far beyond each entrance lane samples reach (m)."""
TRAIN_SLACK = 1.0
"""Robots of a train on the lane keep one separation plus up to this much more between them (m)."""


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


def proximity_penalty(configs: np.ndarray, radii: np.ndarray, varsigma: float) -> np.ndarray:
    """Phi_proximity of the appendix (PRM* cost), shape ``configs.shape[:-1]``.

    ``Phi(x) = sum_{a < b} 1 / max(||p_a - p_b|| - (r_a + r_b), varsigma)``; with equal radii
    ``r_a + r_b = 2 r_robot`` as in the paper. ``configs`` is ``(..., 2n)``.
    """
    r = np.asarray(radii, dtype=float)
    x = np.asarray(configs, dtype=float)
    p = x.reshape(x.shape[:-1] + (len(r), 2))
    a, b = pair_indices(len(r))
    gap = np.linalg.norm(p[..., a, :] - p[..., b, :], axis=-1) - (r[a] + r[b])
    return np.sum(1.0 / np.maximum(gap, varsigma), axis=-1)


def stages(x: np.ndarray, directions: np.ndarray, world: World) -> np.ndarray:
    """Stage (BEFORE, INSIDE, AFTER) of each robot from its x-coordinate, shape of ``x`` ``(..., n)``.

    INSIDE is the closed interval between the entrances (as :meth:`World.in_corridor`); AFTER is
    beyond the far entrance along the robot's direction. Robots with direction 0 are BEFORE or
    INSIDE.
    """
    x = np.asarray(x, dtype=float)
    d = np.asarray(directions)
    c = world.corridor
    inside = (x >= c.x_min) & (x <= c.x_max)
    after = ((d > 0) & (x > c.x_max)) | ((d < 0) & (x < c.x_min))
    return np.where(inside, INSIDE, np.where(after, AFTER, BEFORE))


def order_holds(x: np.ndarray, directions: np.ndarray, world: World) -> np.ndarray:
    """Whether the passing order can still hold at configurations with robot x-coordinates ``x``.

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
    return ok & order_holds(p[..., 0], directions, world)


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
        for bound in (world.corridor.x_min, world.corridor.x_max):
            cols.append((bound - xa) / dx)
        chain = np.flatnonzero(d != 0)
        for p, c in zip(chain[:-1], chain[1:]):
            if d[p] == d[c]:
                cols.append(((xa[:, c] - xa[:, p]) / (dx[:, p] - dx[:, c]))[:, None])
    t = np.concatenate(cols, axis=1) if cols else np.ones((len(xa), 0))
    return np.where(np.isfinite(t) & (t > 0.0) & (t < 1.0), t, 1.0)


def edge_order_holds(xa: np.ndarray, xb: np.ndarray, directions: np.ndarray, world: World) -> np.ndarray:
    """Whether the order rule holds all along straight edges, given robot x-coordinates ``(E, n)``
    at both ends.

    Stages are piecewise constant along an edge and change only where an x-coordinate crosses an
    entrance; the relative position of two consecutive same-direction robots changes only where
    their x-coordinates meet. Checking both ends and one point inside every interval between
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
        ok = np.all(segment_clearance(world, pa, pb) >= need - TOL, axis=1)
        if n > 1:
            ok &= np.all(segment_pair_distance(a, b, n) >= min_separation - TOL, axis=1)
        ok &= edge_order_holds(pa[..., 0], pb[..., 0], directions, world)
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
def _state_ok(x, clear, dirs, sep, box, rects, cx0, cx1):
    """Rules 1-3 at one configuration (scalar :func:`configurations_valid`); ``clear`` is the
    required wall clearance per robot (the radii), ``sep`` the required distance per pair."""
    n = clear.shape[0]
    for i in range(n):
        if segment_clearance_one(x[2 * i], x[2 * i + 1], x[2 * i], x[2 * i + 1], rects, box) < clear[i] - TOL:
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
        xs[i] = x[2 * i]
    return _order_ok(xs, dirs, cx0, cx1)


@_njit
def _motion_ok(xa, xb, clear, dirs, sep, box, rects, cx0, cx1):
    """Rules 1-3 all along one straight edge (scalar :func:`edges_valid`)."""
    n = clear.shape[0]
    for i in range(n):
        if segment_clearance_one(xa[2 * i], xa[2 * i + 1], xb[2 * i], xb[2 * i + 1], rects, box) < clear[i] - TOL:
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
    events = np.ones(3 * n + 1)
    m = 0
    prev = -1
    for i in range(n):
        x0, x1 = xa[2 * i], xb[2 * i]
        if x1 != x0:
            for bound in (cx0, cx1):
                t = (bound - x0) / (x1 - x0)
                if 0.0 < t < 1.0:
                    events[m] = t
                    m += 1
        if dirs[i] != 0:
            if prev >= 0 and dirs[prev] == dirs[i]:
                den = (xb[2 * prev] - xa[2 * prev]) - (x1 - x0)
                if den != 0.0:
                    t = (x0 - xa[2 * prev]) / den
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
            xs[i] = (1.0 - t) * xa[2 * i] + t * xb[2 * i]
        if not _order_ok(xs, dirs, cx0, cx1):
            return False
    for i in range(n):
        xs[i] = xb[2 * i]
    return _order_ok(xs, dirs, cx0, cx1)


@_njit
def _motions_ok(starts, ends, clear, dirs, sep, box, rects, cx0, cx1):
    out = np.empty(starts.shape[0], dtype=np.bool_)
    for e in range(starts.shape[0]):
        out[e] = _motion_ok(starts[e], ends[e], clear, dirs, sep, box, rects, cx0, cx1)
    return out


@dataclass(frozen=True, eq=False)
class CompiledRules:
    """Rules 1-3 for one set of robots as compiled scalar kernels (numba), for OMPL's callbacks
    and for the few edges of a query. Same mathematics as :func:`configurations_valid` and
    :func:`edges_valid`, one state or edge at a time without NumPy's per-call overhead."""

    args: tuple
    """Kernel arguments: clearance, directions, separations, bounds, walls, corridor ends."""

    @staticmethod
    def of(world: World, clearance: np.ndarray, directions: np.ndarray, min_separation: np.ndarray) -> "CompiledRules":
        """Rules for robots (by rank) needing ``clearance`` from walls and ``min_separation`` per pair."""
        return CompiledRules((np.ascontiguousarray(clearance, dtype=np.float64),
                              np.ascontiguousarray(directions, dtype=np.int64),
                              np.ascontiguousarray(min_separation, dtype=np.float64),
                              world.bounds_array, world.obstacle_array,
                              float(world.corridor.x_min), float(world.corridor.x_max)))

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


# ---------------------------------------------------------------------------------------------
# Keys, roadmaps, reports


@dataclass(frozen=True)
class RoadmapKey:
    """Everything a roadmap depends on; its hash names the cache file."""

    world: World
    """The environment."""
    radii: tuple[float, ...]
    """Robot radii listed by rank in the passing order (m)."""
    directions: tuple[int, ...]
    """Crossing directions listed by rank (+1, -1 or 0)."""
    margin: float
    """Separation kept beyond ``r_a + r_b`` (m)."""
    varsigma: float
    """Safety margin of Phi_proximity (m); the stored penalty depends on it."""
    n_vertices: int
    """Number of roadmap vertices to grow."""
    seed: int = ROADMAP_SEED
    """Seed of the build."""
    version: int = FORMAT_VERSION
    """Construction and file format version."""

    @property
    def n_robots(self) -> int:
        """Number of robots ``n`` (the roadmap lives in R^{2n})."""
        return len(self.radii)

    @property
    def pattern(self) -> str:
        """Directions by rank as text, e.g. ``+-0``."""
        return "".join({1: "+", -1: "-", 0: "0"}[d] for d in self.directions)

    def canonical(self) -> str:
        """A canonical JSON text of the key (floats in shortest round-trip form)."""
        data = dataclasses.asdict(self)
        data["radii"] = [float(r) for r in self.radii]
        data["directions"] = [int(d) for d in self.directions]
        return json.dumps(data, sort_keys=True, separators=(",", ":"))

    def digest(self) -> str:
        """SHA-256 of :meth:`canonical` (hex)."""
        return hashlib.sha256(self.canonical().encode()).hexdigest()

    def filename(self) -> str:
        """Cache file name: robot count, direction pattern and the start of the digest."""
        return f"prm-n{self.n_robots}-{self.pattern}-{self.digest()[:16]}.npz"


def make_key(world: World, radii, directions, margin: float, varsigma: float, vertices_per_robot: int,
             seed: int = ROADMAP_SEED) -> RoadmapKey:
    """The key of the roadmap for robots with these radii and directions listed by rank."""
    radii = tuple(float(r) for r in radii)
    return RoadmapKey(world=world, radii=radii, directions=tuple(int(d) for d in directions),
                      margin=float(margin), varsigma=float(varsigma),
                      n_vertices=int(vertices_per_robot) * len(radii), seed=int(seed))


@dataclass(frozen=True, eq=False)
class Roadmap:
    """A roadmap exported to NumPy (vertices by rank, undirected edges ``i < j``).

    OMPL's export omits vertices that no edge reaches, so a roadmap can hold a few vertices
    fewer than its key's ``n_vertices``.
    """

    key: RoadmapKey
    """What it was built for."""
    vertices: np.ndarray
    """Configurations ``(V, 2n)`` (m), robots listed by rank."""
    edges: np.ndarray
    """Undirected edges ``(E, 2)`` (int32), each valid all along."""
    proximity: np.ndarray
    """Phi_proximity at each vertex ``(V,)`` (1/m)."""
    dropped_edges: int = 0
    """Edges OMPL returned that the exact vectorised check removed."""
    build_seconds: float = 0.0
    """Wall time of the OMPL build and the export (s)."""

    def edge_lengths(self) -> np.ndarray:
        """Joint (R^{2n}) length of every edge (m)."""
        return np.linalg.norm(self.vertices[self.edges[:, 1]] - self.vertices[self.edges[:, 0]], axis=1)

    @staticmethod
    def empty(key: RoadmapKey) -> "Roadmap":
        """A roadmap without vertices (what a failed build returns)."""
        dim = 2 * key.n_robots
        return Roadmap(key, np.zeros((0, dim)), np.zeros((0, 2), dtype=np.int32), np.zeros(0))


@dataclass(frozen=True)
class BuildReport:
    """How a roadmap was obtained."""

    success: bool
    """Whether a usable roadmap is available."""
    reason: str
    """Empty on plain success; why it failed, or why a cached file was rebuilt."""
    n_robots: int
    """Robot count."""
    pattern: str
    """Directions by rank, e.g. ``+-``."""
    vertices: int
    """Roadmap vertices."""
    edges: int
    """Roadmap edges (undirected)."""
    dropped_edges: int
    """Edges removed by the exact post-export check."""
    seconds: float
    """Time to obtain it: load time if cached, else build time (s)."""
    build_seconds: float
    """Time the roadmap originally took to build (s), as stored with it."""
    from_cache: bool
    """Whether it was loaded from disk."""
    path: str
    """The cache file."""

    def to_dict(self) -> dict:
        """Plain mapping for JSON."""
        return dataclasses.asdict(self)


@dataclass(frozen=True, eq=False)
class RoadmapResult:
    """A roadmap (empty on failure) and how it was obtained."""

    roadmap: Roadmap
    """The roadmap."""
    report: BuildReport
    """Build or load report; ``report.success`` says whether ``roadmap`` is usable."""

    @property
    def success(self) -> bool:
        """Whether the roadmap is usable."""
        return self.report.success


@dataclass(frozen=True, eq=False)
class LoadResult:
    """Outcome of reading a cache file."""

    success: bool
    """Whether the file held a valid roadmap for the key."""
    reason: str
    """Why not."""
    roadmap: Roadmap
    """The roadmap (empty on failure)."""


# ---------------------------------------------------------------------------------------------
# Sampling and building with OMPL


def robot_boxes(world: World, radii: np.ndarray) -> np.ndarray:
    """Bounds of each robot's centre ``(n, 4)`` as ``(x_min, y_min, x_max, y_max)``: the world
    bounds shrunk by the radius."""
    r = np.asarray(radii, dtype=float)[:, None]
    b = np.asarray(world.bounds, dtype=float)[None, :]
    return b + np.hstack([r, r, -r, -r])


def sample_candidates(rng: np.random.Generator, key: RoadmapKey, count: int) -> np.ndarray:
    """Candidate configurations ``(count, 2n)`` from the sampler mixture (module docstring).

    A share :data:`UNIFORM_FRACTION` is uniform in every robot's box. The rest are corridor lane
    samples in blocks of :data:`ANCHOR_REUSE`. A block picks a *train*: a crossing robot and
    0 or more of its immediate predecessors in the order that travel the same direction (the
    length is uniform among the possibilities). The last robot of the train is at a random point
    of the band ``|y - y_c| <= w/2 - r`` from :data:`LANE_OVERHANG` before one entrance to as
    far beyond the other, each robot ahead of it one separation plus up to
    :data:`TRAIN_SLACK` further along; the others keep one anchor placement for the whole block,
    drawn uniformly in the room the order puts them in while the train crosses (earlier crossing
    robots after the corridor, later ones before it, non-crossing robots anywhere). The caller
    keeps the valid ones.
    """
    n = key.n_robots
    d = np.asarray(key.directions, dtype=int)
    radii = np.asarray(key.radii, dtype=float)
    box = robot_boxes(key.world, radii)
    out = rng.uniform(box[:, :2], box[:, 2:], size=(count, n, 2))
    crossing = np.flatnonzero(d != 0)
    n_lane = int(round(count * (1.0 - UNIFORM_FRACTION))) if len(crossing) else 0
    c = key.world.corridor
    yc = 0.5 * (c.y_min + c.y_max)
    for lo in range(0, n_lane, ANCHOR_REUSE):
        rows = slice(lo, min(lo + ANCHOR_REUSE, n_lane))
        m = rows.stop - rows.start
        pos = int(rng.integers(len(crossing)))
        run = 1
        while run <= pos and d[crossing[pos - run]] == d[crossing[pos]]:
            run += 1
        train = crossing[pos - int(rng.integers(run)):pos + 1]  # the last is the robot picked
        anchor = rng.uniform(box[:, :2], box[:, 2:])
        for j in crossing:
            if j in train:
                continue
            # Earlier robots wait after the corridor, later ones before it, along their direction.
            after = j < train[0]
            go_right = (d[j] > 0) == after
            xlo, xhi = (c.x_max, box[j, 2]) if go_right else (box[j, 0], c.x_min)
            anchor[j, 0] = rng.uniform(min(xlo, xhi), max(xlo, xhi))
        out[rows] = anchor
        x = rng.uniform(c.x_min - LANE_OVERHANG, c.x_max + LANE_OVERHANG, size=m)
        for i, j in enumerate(train[::-1]):
            if i:
                ahead = train[::-1][i - 1]
                gap = radii[j] + radii[ahead] + key.margin + rng.uniform(0.0, TRAIN_SLACK, size=m)
                x = x + d[j] * gap
            half = max(0.5 * c.width - radii[j], 0.0)
            out[rows, j, 0] = x
            out[rows, j, 1] = rng.uniform(yc - half, yc + half, size=m)
    return out.reshape(count, 2 * n)


def prm_star_k(n_vertices: int, dim: int) -> int:
    """Neighbours PRM* connects a new vertex to: ``ceil(e (1 + 1/dim) log V)`` (OMPL's PRMstar)."""
    return int(math.ceil(math.e * (1.0 + 1.0 / dim) * math.log(max(n_vertices, 2))))


def build_roadmap(key: RoadmapKey, max_seconds: float = 3600.0) -> RoadmapResult:
    """Grow the roadmap for ``key`` with OMPL's PRM* and export it (no cache involved).

    Deterministic for a key: OMPL is seeded through ``ou.RNG.setSeed`` before any sampler
    exists, the sampler draws from a NumPy generator seeded from the key, and growth stops on a
    vertex count. ``max_seconds`` only guards against a world in which valid configurations
    cannot be found; reaching it is a failure.
    """
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    t0 = time.perf_counter()
    n = key.n_robots
    dim = 2 * n
    world = key.world
    radii = np.asarray(key.radii, dtype=float)
    dirs = np.asarray(key.directions, dtype=np.int64)
    sep = separation_thresholds(radii, key.margin)
    rules = CompiledRules.of(world, radii, dirs, sep)
    seed = int.from_bytes(hashlib.sha256(key.canonical().encode()).digest()[:4], "little") % (2**31 - 2) + 1

    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)  # reseeding a running generator logs a (harmless) error
    ou.RNG.setSeed(seed)
    ou.setLogLevel(level)

    space = ob.RealVectorStateSpace(dim)
    bounds = ob.RealVectorBounds(dim)
    for i, (x0, y0, x1, y1) in enumerate(robot_boxes(world, radii)):
        bounds.setLow(2 * i, x0)
        bounds.setHigh(2 * i, x1)
        bounds.setLow(2 * i + 1, y0)
        bounds.setHigh(2 * i + 1, y1)
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda s: rules.state_ok(np.array(s[0:dim])))

    class ExactMotionValidator(ob.MotionValidator):
        def checkMotion(self, s1, s2):
            return rules.motion_ok(np.array(s1[0:dim]), np.array(s2[0:dim]))

    rng = np.random.default_rng([key.seed, seed])
    pending: list[np.ndarray] = []

    class LaneSampler(ob.ValidStateSampler):
        def sample(self, state):
            for _ in range(1000):
                if pending:
                    state[0:dim] = pending.pop().tolist()
                    return True
                cand = sample_candidates(rng, key, 4096)
                ok = configurations_valid(world, cand, radii, dirs, sep)
                pending.extend(cand[ok][::-1])
            return False

    validator = ExactMotionValidator(si)
    samplers: list = []  # the Python objects must outlive OMPL's references to them

    def allocate(si_):
        samplers.append(LaneSampler(si_))
        return samplers[-1]

    si.setMotionValidator(validator)
    si.setValidStateSamplerAllocator(allocate)
    si.setup()
    planner = og.PRMstar(si)
    planner.setProblemDefinition(ob.ProblemDefinition(si))
    planner.setup()
    deadline = t0 + max_seconds
    target = key.n_vertices
    planner.growRoadmapPtc(ob.PlannerTerminationCondition(
        lambda: planner.milestoneCount() >= target or time.perf_counter() > deadline))
    count = planner.milestoneCount()
    if count < target:
        return RoadmapResult(Roadmap.empty(key), _report(key, False, f"grew only {count} of {target} vertices "
                                                          f"in {max_seconds:.0f} s", time.perf_counter() - t0))
    data = ob.PlannerData(si)
    planner.getPlannerData(data)
    vertices = np.array([data.getVertex(i).getState()[0:dim] for i in range(data.numVertices())],
                        dtype=float).reshape(-1, dim)
    pairs = [(i, j) for i in range(data.numVertices()) for j in data.getEdges(i) if i < j]
    edges = np.array(pairs, dtype=np.int32).reshape(-1, 2)
    if not len(edges):
        return RoadmapResult(Roadmap.empty(key), _report(key, False, f"no valid edge among {count} vertices",
                                                          time.perf_counter() - t0))
    keep = edges_valid(world, vertices[edges[:, 0]], vertices[edges[:, 1]], radii, dirs, sep)
    dropped = int(np.count_nonzero(~keep))
    if dropped:
        log.warning("roadmap %s: the exact check dropped %d of %d OMPL edges", key.filename(), dropped, len(edges))
    seconds = time.perf_counter() - t0
    roadmap = Roadmap(key, vertices, edges[keep], proximity_penalty(vertices, radii, key.varsigma),
                      dropped, seconds)
    return RoadmapResult(roadmap, _report(key, True, "", seconds, roadmap))


def _report(key: RoadmapKey, success: bool, reason: str, seconds: float, roadmap: Roadmap | None = None,
            from_cache: bool = False, path: str = "") -> BuildReport:
    rm = roadmap if roadmap is not None else Roadmap.empty(key)
    return BuildReport(success=success, reason=reason, n_robots=key.n_robots, pattern=key.pattern,
                       vertices=len(rm.vertices), edges=len(rm.edges), dropped_edges=rm.dropped_edges,
                       seconds=seconds, build_seconds=rm.build_seconds, from_cache=from_cache, path=path)


# ---------------------------------------------------------------------------------------------
# The cache


def resolve_cache_dir(cache_dir: str | os.PathLike = "") -> Path:
    """The roadmap cache directory: ``cache_dir`` if given, else ``$NODNAV_CACHE``, else
    ``~/.cache/nodnav``."""
    if str(cache_dir):
        return Path(cache_dir).expanduser()
    env = os.environ.get("NODNAV_CACHE", "")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "nodnav"


def _checksum(key_text: str, vertices: np.ndarray, edges: np.ndarray, proximity: np.ndarray) -> str:
    h = hashlib.sha256(key_text.encode())
    for a in (vertices, edges, proximity):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


#: A ``.tmp-*.npz`` file in the cache older than this was left by a writer that was killed (s).
STALE_TEMPORARY_AGE = 900.0


def clean_stale_temporaries(directory: str | os.PathLike, max_age: float = STALE_TEMPORARY_AGE) -> list[Path]:
    """Delete the temporary files of :func:`save_roadmap` in ``directory`` older than ``max_age``
    seconds (a write takes a second; older ones belong to killed writers); the paths deleted."""
    removed = []
    now = time.time()
    for tmp in Path(directory).glob(".tmp-*.npz"):
        try:
            if now - tmp.stat().st_mtime > max_age:
                tmp.unlink()
                removed.append(tmp)
        except OSError:  # gone already, or not ours to delete
            continue
    if removed:
        log.info("removed %d stale temporary roadmap file(s) from %s", len(removed), directory)
    return removed


def save_roadmap(roadmap: Roadmap, directory: str | os.PathLike) -> Path:
    """Write ``roadmap`` atomically into ``directory`` (temp file + ``os.replace``); its path.
    Temporary files that killed writers left behind are removed first."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    clean_stale_temporaries(directory)
    path = directory / roadmap.key.filename()
    key_text = roadmap.key.canonical()
    vertices = np.ascontiguousarray(roadmap.vertices, dtype=np.float64)
    edges = np.ascontiguousarray(roadmap.edges, dtype=np.int32)
    proximity = np.ascontiguousarray(roadmap.proximity, dtype=np.float64)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".tmp-", suffix=".npz")
    try:
        os.chmod(tmp, 0o644)  # a shared cache, not a private temporary file
        with os.fdopen(fd, "wb") as f:
            np.savez(f, key=np.array(key_text), checksum=np.array(_checksum(key_text, vertices, edges, proximity)),
                     vertices=vertices, edges=edges, proximity=proximity,
                     dropped_edges=np.array(roadmap.dropped_edges), build_seconds=np.array(roadmap.build_seconds))
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def load_roadmap(path: str | os.PathLike, key: RoadmapKey) -> LoadResult:
    """Read a cache file and verify it: it parses, holds ``key``, matches its checksum and its
    arrays are consistent. Anything else is reported, never trusted."""
    path = Path(path)
    empty = Roadmap.empty(key)
    if not path.exists():
        return LoadResult(False, "no cached file", empty)
    try:
        with np.load(path, allow_pickle=False) as z:
            key_text = str(z["key"])
            checksum = str(z["checksum"])
            vertices = np.array(z["vertices"])
            edges = np.array(z["edges"])
            proximity = np.array(z["proximity"])
            dropped = int(z["dropped_edges"])
            build_seconds = float(z["build_seconds"])
    except Exception as exc:  # any failure to parse means a damaged file
        return LoadResult(False, f"unreadable ({type(exc).__name__}: {exc})", empty)
    if key_text != key.canonical():
        return LoadResult(False, "stored key differs (stale or foreign file)", empty)
    if checksum != _checksum(key_text, vertices, edges, proximity):
        return LoadResult(False, "checksum mismatch (corrupt file)", empty)
    dim = 2 * key.n_robots
    if (vertices.ndim != 2 or vertices.shape[1] != dim or edges.ndim != 2 or edges.shape[1] != 2
            or proximity.shape != (len(vertices),) or (len(edges) and (edges.min() < 0 or edges.max() >= len(vertices)))
            or not (np.isfinite(vertices).all() and np.isfinite(proximity).all())):
        return LoadResult(False, "inconsistent or non-finite arrays", empty)
    return LoadResult(True, "", Roadmap(key, vertices, edges, proximity, dropped, build_seconds))


def get_roadmap(key: RoadmapKey, cache_dir: str | os.PathLike = "", max_seconds: float = 3600.0) -> RoadmapResult:
    """The roadmap for ``key``: from the cache if a valid file is there, else built and stored."""
    directory = resolve_cache_dir(cache_dir)
    path = directory / key.filename()
    t0 = time.perf_counter()
    loaded = load_roadmap(path, key)
    if loaded.success:
        return RoadmapResult(loaded.roadmap, _report(key, True, "", time.perf_counter() - t0, loaded.roadmap,
                                                     True, str(path)))
    rebuilt = ""
    if path.exists():
        log.warning("roadmap cache %s rejected: %s; rebuilding", path, loaded.reason)
        rebuilt = f"cached file rejected ({loaded.reason}), rebuilt"
    built = build_roadmap(key, max_seconds)
    if not built.success:
        return built
    try:
        save_roadmap(built.roadmap, directory)
    except OSError as exc:
        log.warning("could not store roadmap in %s: %s", directory, exc)
        rebuilt = (rebuilt + "; " if rebuilt else "") + f"not cached ({exc})"
    return RoadmapResult(built.roadmap, dataclasses.replace(built.report, reason=rebuilt, path=str(path)))


def direction_patterns(n: int, exited: bool = True) -> list[tuple[int, ...]]:
    """Direction patterns (by rank) that ``n`` robots crossing the corridor can present.

    Every robot crossing (+1 / -1 each, ``2^n`` patterns) and, with ``exited``, the patterns of
    the closed loop after some robots have passed: robots that have left the corridor no longer
    cross (direction 0) and lead the order (they entered first, :func:`feasible_order`), so a
    prefix of zeros followed by crossing robots (``2^n - 1`` more).
    """
    from itertools import product

    patterns = [tuple(p) for p in product((1, -1), repeat=n)]
    if exited:
        patterns += [(0,) * m + tuple(p) for m in range(1, n + 1) for p in product((1, -1), repeat=n - m)]
    return patterns


def _get_report(key: RoadmapKey, cache_dir: str, max_seconds: float) -> BuildReport:
    return get_roadmap(key, cache_dir, max_seconds).report


def _indexed_report(i: int, key: RoadmapKey, cache_dir: str, max_seconds: float) -> tuple[int, BuildReport]:
    return i, _get_report(key, cache_dir, max_seconds)


def build_all_roadmaps(world: World, radius: float = 0.2, robot_counts=(1, 2, 3, 4), exited: bool = True,
                       vertices_per_robot: int | None = None, margin: float | None = None,
                       varsigma: float | None = None, cache_dir: str = "", n_jobs: int = 2,
                       max_seconds: float = 3600.0, progress=None) -> list[BuildReport]:
    """Build (or load) every roadmap that robots of equal ``radius`` can need in ``world``: all
    :func:`direction_patterns` for every robot count, in parallel processes (joblib).

    Defaults come from :class:`~nodnav.scenario.params.PRMParams`. Reports are returned in
    the order robot count, then pattern. ``progress(report, done, total_vertices)``, if given,
    is called as each roadmap is ready, with the vertices of all roadmaps as the total.
    """
    from joblib import Parallel, delayed

    from nodnav.scenario.params import PRMParams

    defaults = PRMParams()
    vpr = defaults.roadmap_vertices if vertices_per_robot is None else vertices_per_robot
    mg = defaults.margin if margin is None else margin
    vs = defaults.varsigma if varsigma is None else varsigma
    keys = [make_key(world, [radius] * n, p, mg, vs, vpr) for n in robot_counts for p in direction_patterns(n, exited)]
    # Largest first, so that the long builds do not end up last on one worker.
    order = sorted(range(len(keys)), key=lambda i: -keys[i].n_vertices)
    clean_stale_temporaries(resolve_cache_dir(cache_dir))
    total = sum(k.n_vertices for k in keys)
    by_index = {}
    tasks = (delayed(_indexed_report)(i, keys[i], cache_dir, max_seconds) for i in order)
    for i, report in Parallel(n_jobs=n_jobs, return_as="generator_unordered")(tasks):
        by_index[i] = report
        if progress is not None:
            progress(report, keys[i].n_vertices, total)
    return [by_index[i] for i in range(len(keys))]


def format_build_reports(reports: list[BuildReport]) -> str:
    """A table of build reports: one line per robot count, then the total."""
    lines = [f"{'robots':>6} {'roadmaps':>8} {'cached':>6} {'vertices':>9} {'edges':>9} {'dropped':>7} "
             f"{'build s':>8} {'failed':>6}"]
    for n in sorted({r.n_robots for r in reports}):
        rs = [r for r in reports if r.n_robots == n]
        ok = [r for r in rs if r.success]
        lines.append(f"{n:>6} {len(rs):>8} {sum(r.from_cache for r in rs):>6} "
                     f"{int(np.mean([r.vertices for r in ok])) if ok else 0:>9} "
                     f"{int(np.mean([r.edges for r in ok])) if ok else 0:>9} {sum(r.dropped_edges for r in ok):>7} "
                     f"{sum(r.build_seconds for r in ok):>8.1f} {len(rs) - len(ok):>6}")
    lines.append(f"total build time of these roadmaps {sum(r.build_seconds for r in reports):.1f} s "
                 f"(vertices and edges are means per roadmap)")
    lines += [f"failed n={r.n_robots} {r.pattern}: {r.reason}" for r in reports if not r.success]
    return "\n".join(lines)
