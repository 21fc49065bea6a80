"""The paper's multi-robot planner: PRM* in the joint configuration space (appendix, Section II-B-1).

A request is answered on a precomputed roadmap (:mod:`nodnav.planning.roadmap`): the robots are
relabelled by their rank in the planned order, which selects the roadmap for their radii and
crossing directions; the start and goal configurations are joined to their nearest roadmap
vertices by exactly checked straight edges; Dijkstra's algorithm (``scipy.sparse.csgraph``) finds
the path minimising the appendix's cost

    J = sum_i ||x_i - x_{i+1}|| + w_1 sum_i Phi_proximity(x_i),

and the joint path is timed so that no robot exceeds its speed limit. OMPL builds the roadmaps
but does not answer queries: a live PRM query is an order of magnitude slower than a graph
search on the exported roadmap, and OMPL cannot read a stored roadmap back.

Cost as a graph search
----------------------
The vertex term is moved onto the edges symmetrically: edge ``(u, v)`` weighs
``||u - v|| + w_1 (Phi(u) + Phi(v)) / 2``. A path from ``s`` to ``g`` then weighs
``J - w_1 (Phi(s) + Phi(g)) / 2``; start and goal are fixed, so both have the same minimisers,
the graph is undirected (one CSR matrix per roadmap, kept in memory), and one search from the
goal answers every start (:class:`GoalField`).

Shortcuts
---------
The roadmap path is then shortened greedily: from each kept vertex the path jumps to the
farthest later vertex that a valid straight edge reaches (checked exactly). By the triangle
inequality and ``Phi >= 0`` each jump lowers ``J``, so the result is never worse under the
paper's cost; it removes the detours that a finite roadmap in R^{2n} imposes (robots that
should wait would otherwise wander between roadmap vertices). :attr:`PlanResult.cost` is ``J``
of the returned path, start and goal included; ``info["roadmap_cost"]`` is ``J`` before the
shortcuts.

Timing
------
Each segment of the joint path lasts ``max_i ||dp_i|| / vmax_i`` (appendix: no robot exceeds its
speed limit), rounded up to a whole number of ``dt`` so that every path vertex is a sample of the
trajectory: linear interpolation between samples then reproduces the checked path exactly, and
separation, walls and the order hold at every instant, not only at the samples.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from nodnav.geometry import TOL
from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult, crossing_directions, feasible_order
from nodnav.planning.joint_validity import CompiledRules, pair_indices, separation_thresholds
from nodnav.planning.retiming import feasible_profile
from nodnav.planning.roadmap import (
    BuildReport,
    Roadmap,
    RoadmapKey,
    RoadmapResult,
    make_key,
    prm_star_k,
    proximity_penalty,
)
from nodnav.planning.roadmap_cache import get_roadmap
from nodnav.registry import register_planner
from nodnav.scenario.params import PRMParams
from nodnav.scenario.world import World

GOAL_FIELDS = 64
"""Goal fields (one Dijkstra run each) a planner keeps."""


def path_cost(configs: np.ndarray, radii: np.ndarray, w1: float, varsigma: float) -> float:
    """The appendix's PRM* cost of a joint path ``(N, 2n)``:
    ``sum ||x_i - x_{i+1}|| + w_1 sum Phi_proximity(x_i)`` over all its vertices."""
    x = np.asarray(configs, dtype=float)
    length = float(np.sum(np.linalg.norm(np.diff(x, axis=0), axis=1)))
    return length + w1 * float(np.sum(proximity_penalty(x, radii, varsigma)))


def timed_trajectory(path: np.ndarray, max_speeds: np.ndarray, dt: float, t0: float = 0.0,
                     max_accels: np.ndarray | None = None) -> JointTrajectory:
    """The joint path ``(N, n, 2)`` linearly interpolated in time and sampled every ``dt`` from ``t0``.

    Segment ``j`` lasts ``dt * ceil(max_i ||dp_ij|| / vmax_i / dt)`` (appendix: the fastest robot
    of the segment at most at its speed limit, the others proportionally slower; whole steps so
    that path vertices fall on samples). Zero-length segments are skipped. With ``max_accels``
    every segment is instead driven from rest to rest within every robot's speed and
    acceleration limits (:func:`accelerated_trajectory`).
    """
    p = np.asarray(path, dtype=float)
    if max_accels is not None:
        return accelerated_trajectory(p, np.asarray(max_speeds, dtype=float), np.asarray(max_accels, dtype=float),
                                      dt, t0)
    need = np.max(np.linalg.norm(np.diff(p, axis=0), axis=-1) / np.asarray(max_speeds, dtype=float), axis=1) / dt
    steps = np.ceil(need - 1e-9).astype(int)
    moving = steps > 0
    starts, ends, steps = p[:-1][moving], p[1:][moving], steps[moving]
    seg = np.repeat(np.arange(len(steps)), steps)
    frac = (np.arange(len(seg)) - np.repeat(np.cumsum(steps) - steps, steps)) / np.repeat(steps, steps)
    pos = starts[seg] + frac[:, None, None] * (ends[seg] - starts[seg])
    pos = np.concatenate([pos, p[-1:]], axis=0)
    return JointTrajectory.from_positions(t0 + dt * np.arange(len(pos)), pos)


def accelerated_trajectory(path: np.ndarray, max_speeds: np.ndarray, max_accels: np.ndarray, dt: float,
                           t0: float = 0.0) -> JointTrajectory:
    """The joint path ``(N, n, 2)`` with every segment driven from rest to rest, all robots along
    it together, the fastest discrete trapezoid within every robot's speed and acceleration limit
    (:func:`~nodnav.planning.retiming.feasible_profile` on the segment's progress).

    On segment ``j`` robot ``i`` covers ``l_ij``; progress is measured in seconds at the
    segment's full speed, ``D_j = max_i l_ij / vmax_i``, so a progress rate of 1 puts the limiting
    robot at its speed limit, and the rate may change by ``A_j = min_i a_i D_j / l_ij`` per
    second. Every robot moves along its straight segment, so the joint path, checked valid
    whatever its timing, is kept exactly; resting at each vertex keeps every robot within its
    acceleration limit where the path turns.
    """
    p = np.asarray(path, dtype=float)
    lengths = np.linalg.norm(np.diff(p, axis=0), axis=-1)  # (N - 1, n)
    out = [p[:1]]
    for j in range(len(lengths)):
        moving = lengths[j] > 0
        if not moving.any():
            continue
        span = float(np.max(lengths[j] / max_speeds))
        rate = float(np.min(max_accels[moving] * span / lengths[j][moving]))
        progress, _ = feasible_profile(np.array([0.0, span]), span, 0.0, 1.0, rate, dt)
        frac = np.clip(progress[1:] / span, 0.0, 1.0)
        if not len(frac):  # a segment shorter than the profile resolves (e.g. 1e-13 m): one step to its end
            frac = np.ones(1)
        frac[-1] = 1.0
        out.append(p[j][None] + frac[:, None, None] * (p[j + 1] - p[j])[None])
    pos = np.concatenate(out, axis=0)
    return JointTrajectory.from_positions(t0 + dt * np.arange(len(pos)), pos)


@dataclass(frozen=True, eq=False)
class QueryGraph:
    """A roadmap ready for queries: a k-d tree over its vertices and its symmetric CSR graph."""

    roadmap: Roadmap
    """The roadmap."""
    report: BuildReport
    """How it was obtained (cache or build, times, size)."""
    tree: cKDTree
    """Nearest-neighbour index over the vertices."""
    graph: csr_matrix
    """Weights ``||u - v|| + w_1 (Phi(u) + Phi(v)) / 2`` in both directions, shape ``(V + 1, V + 1)``;
    the last row is left empty for the goal of a query."""
    half_phi: np.ndarray
    """``w_1 Phi(v) / 2`` per vertex."""

    @staticmethod
    def from_roadmap(got: RoadmapResult, w1: float) -> "QueryGraph":
        """Index a roadmap for queries with proximity weight ``w1``."""
        roadmap = got.roadmap
        v = len(roadmap.vertices)
        half_phi = 0.5 * w1 * roadmap.proximity
        i, j = roadmap.edges[:, 0], roadmap.edges[:, 1]
        w = roadmap.edge_lengths() + half_phi[i] + half_phi[j]
        graph = csr_matrix((np.concatenate([w, w]), (np.concatenate([i, j]), np.concatenate([j, i]))),
                           shape=(v + 1, v + 1))
        graph.sort_indices()
        return QueryGraph(roadmap, got.report, cKDTree(roadmap.vertices), graph, half_phi)


@dataclass(frozen=True, eq=False)
class GoalField:
    """Least cost-to-go from every roadmap vertex to one goal configuration (one Dijkstra run).

    The graph is undirected, so a search from the goal gives every vertex's cost to it and a
    shortest-path tree pointing towards it; any start joined to the roadmap is then answered by
    a minimum over its links. In the closed loop the goal of a roadmap and order stays the same
    while the start moves, so fields are kept (the last :data:`GOAL_FIELDS` per planner).
    """

    success: bool
    """Whether the goal could be joined to the roadmap."""
    reason: str
    """Why not."""
    cost: np.ndarray
    """Cost-to-go per vertex ``(V + 1,)`` in :class:`QueryGraph` weights, ``inf`` if cut off;
    the last entry is the goal."""
    toward: np.ndarray
    """Next vertex towards the goal ``(V + 1,)``; the goal itself is index ``V``."""


@dataclass(frozen=True, eq=False)
class SearchResult:
    """A joint path by rank, or why there is none."""

    success: bool
    """Whether a path was found."""
    reason: str
    """Why not."""
    configs: np.ndarray
    """The path ``(N, 2n)``, robots by rank, start and goal included."""
    info: dict
    """Diagnostics."""

    @staticmethod
    def failed(reason: str) -> "SearchResult":
        """No path, and why."""
        return SearchResult(False, reason, np.zeros((0, 0)), {})


@dataclass(frozen=True, eq=False)
class EdgeRules:
    """Which validity thresholds apply to an edge of a query path.

    Start and goal may already be closer to a wall or to another robot than the planner's
    margins (the controller keeps smaller ones); edges leaving or reaching them must only not
    get closer than they already are. Roadmap vertices keep the full margins.
    """

    inner: CompiledRules
    """Between roadmap vertices."""
    start: CompiledRules
    """From the start."""
    goal: CompiledRules
    """Into the goal."""
    both: CompiledRules
    """Straight from start to goal."""

    def pick(self, from_start: bool, to_goal: bool) -> CompiledRules:
        """The rules for an edge that does or does not touch the start and the goal."""
        if from_start:
            return self.both if to_goal else self.start
        return self.goal if to_goal else self.inner


@register_planner("prm")
class PRMStarPlanner:
    """PRM* on cached joint-space roadmaps (appendix); see the module docstring.

    The planner keeps in memory the roadmaps it has used (one query graph per roadmap key) and
    the last :data:`GOAL_FIELDS` goal fields, so a process loads each roadmap from disk at most
    once per planner and a repeated goal costs one k-nearest connection. Share one planner
    between robots: a 4-robot roadmap of 6,000 vertices takes about 5 MB in memory.

    ``PlanResult.info`` holds ``path`` (the joint path ``(N, n, 2)`` that the trajectory
    interpolates, request order), ``direct`` (the straight joint path was valid, no roadmap
    needed) and otherwise ``pattern`` (directions by rank), ``roadmap_vertices``,
    ``roadmap_edges``, ``roadmap_from_cache``, ``start_links``, ``roadmap_path_vertices`` and
    ``roadmap_cost`` (``J`` before shortcuts).
    """

    name = "prm"

    def __init__(self, world: World, params: PRMParams) -> None:
        self.world = world
        self.params = params
        self._keys: dict[tuple, tuple[RoadmapKey, str]] = {}
        self._graphs: dict[str, QueryGraph] = {}
        self._failed: dict[str, BuildReport] = {}
        self._fields: OrderedDict[tuple, GoalField] = OrderedDict()

    def _key(self, radii, directions) -> tuple[RoadmapKey, str]:
        memo = (tuple(float(r) for r in radii), tuple(int(d) for d in directions))
        if memo not in self._keys:
            p = self.params
            key = make_key(self.world, memo[0], memo[1], p.margin, p.varsigma, p.roadmap_vertices)
            self._keys[memo] = (key, key.digest())
        return self._keys[memo]

    def roadmap(self, radii, directions) -> RoadmapResult:
        """The roadmap for robots with these radii and directions by rank, from memory, the disk
        cache, or a new build (then cached); kept in memory for queries."""
        key, digest = self._key(radii, directions)
        if digest in self._graphs:
            qg = self._graphs[digest]
            return RoadmapResult(qg.roadmap, qg.report)
        if digest in self._failed:
            return RoadmapResult(Roadmap.empty(key), self._failed[digest])
        got = get_roadmap(key, self.params.cache_dir)
        if got.success:
            self._graphs[digest] = QueryGraph.from_roadmap(got, self.params.w1)
        else:
            self._failed[digest] = got.report
        return got

    def roadmap_reports(self) -> list[BuildReport]:
        """How each roadmap this planner has used was obtained."""
        return [qg.report for qg in self._graphs.values()] + list(self._failed.values())

    def plan(self, request: PlanRequest) -> PlanResult:
        """Plan the joint trajectory for ``feasible_order(request.order, request.entered)``."""
        t0 = time.perf_counter()
        problem = _check_request(request)
        if problem:
            return PlanResult.failure(request, problem, time.perf_counter() - t0)
        order = tuple(int(k) for k in request.order)
        order_planned = feasible_order(order, request.entered)
        rank = np.array(order_planned, dtype=int)  # rank -> robot index of the request
        pos = np.asarray(request.positions, dtype=float)
        dst = np.asarray(request.destinations, dtype=float)
        radii = np.asarray(request.radii, dtype=float)[rank]
        directions = crossing_directions(self.world, pos, dst)[rank]
        found = self._search(pos[rank].ravel(), dst[rank].ravel(), radii, directions, rank)
        if not found.success:
            return PlanResult.failure(request, found.reason, time.perf_counter() - t0)
        configs = found.configs
        if not len(configs):
            return PlanResult.failure(request, "the joint path has no points", time.perf_counter() - t0)
        joint = np.empty((len(configs), len(rank), 2))
        joint[:, rank] = configs.reshape(len(configs), -1, 2)
        accels = request.max_accels if self.params.timing == "feasible" else None
        trajectory = timed_trajectory(joint, np.asarray(request.max_speeds, dtype=float), self.params.dt,
                                      request.t0, accels)
        if not len(trajectory.times):
            return PlanResult.failure(request, "the timed joint path has no samples", time.perf_counter() - t0)
        cost = path_cost(configs, radii, self.params.w1, self.params.varsigma)
        reason = ""
        if order_planned != order:
            reason = f"order {order} ruled out by entries {tuple(request.entered)}; planned {order_planned}"
        return PlanResult(True, reason, cost, trajectory, order, order_planned, time.perf_counter() - t0,
                          {**found.info, "path": joint})

    def _search(self, start: np.ndarray, goal: np.ndarray, radii: np.ndarray, directions: np.ndarray,
                rank: np.ndarray) -> SearchResult:
        """The joint path from ``start`` to ``goal`` (robots by rank; ``rank`` maps ranks to the
        request's robots, for messages), or why there is none."""
        p = self.params
        n = len(radii)
        sep = separation_thresholds(radii, p.margin)
        a, b = pair_indices(n)
        need_clear, need_sep = {}, {}
        for name, x in (("start", start), ("goal", goal)):
            pts = x.reshape(n, 2)
            clear = self.world.clearance(pts)
            gaps = np.linalg.norm(pts[a] - pts[b], axis=1)
            # A start may be closer to a wall than the radius (the controller tolerates it and
            # the robot can only move away); a goal may not.
            floor = -TOL if name == "start" else radii - TOL
            if np.any(clear < floor):
                return SearchResult.failed(f"{name} configuration puts robot(s) {rank[clear < floor].tolist()} "
                                           + ("inside a wall" if name == "start"
                                              else "closer to a wall than their radius"))
            if np.any(gaps < radii[a] + radii[b] - TOL):
                bad = int(np.argmax(gaps < radii[a] + radii[b] - TOL))
                return SearchResult.failed(f"{name} configuration has robots {rank[a[bad]]} and {rank[b[bad]]} "
                                           "overlapping")
            need_clear[name], need_sep[name] = np.minimum(radii, clear), np.minimum(sep, gaps)
        rules = EdgeRules(
            inner=CompiledRules.of(self.world, radii, directions, sep),
            start=CompiledRules.of(self.world, need_clear["start"], directions, need_sep["start"]),
            goal=CompiledRules.of(self.world, need_clear["goal"], directions, need_sep["goal"]),
            both=CompiledRules.of(self.world, np.minimum(need_clear["start"], need_clear["goal"]), directions,
                                  np.minimum(need_sep["start"], need_sep["goal"])))
        for name, x, r in (("start", start, rules.start), ("goal", goal, rules.goal)):
            if not r.state_ok(x):
                return SearchResult.failed(f"{name} configuration violates the passing order "
                                           f"{tuple(rank.tolist())} (crossing directions {directions.tolist()})")
        if rules.both.motion_ok(start, goal):  # the straight joint path beats any other (Phi >= 0)
            return SearchResult(True, "", np.stack([start, goal]), {"direct": True})
        key, digest = self._key(radii, directions)
        got = self.roadmap(radii, directions)
        if not got.success:
            return SearchResult.failed(f"no roadmap for direction pattern {key.pattern}: {got.report.reason}")
        qg = self._graphs[digest]
        v = len(qg.roadmap.vertices)
        k = min(v, self.params.connect_factor * prm_star_k(v, 2 * n))
        field = self._goal_field(qg, digest, goal, radii, rules.goal, k)
        if not field.success:
            return SearchResult.failed(field.reason)
        s_nbr, s_len = _links(qg, rules.start, start, k, self.params.link_widening)
        if not len(s_nbr):
            return SearchResult.failed(f"start cannot be joined to any of the {v} roadmap vertices")
        phi_s = p.w1 * float(proximity_penalty(start, radii, p.varsigma))
        total = s_len + 0.5 * phi_s + qg.half_phi[s_nbr] + field.cost[s_nbr]
        best = int(np.argmin(total))
        if not np.isfinite(total[best]):
            return SearchResult.failed("start and goal are not connected in the roadmap (too sparse for this request)")
        chain = [int(s_nbr[best])]
        while field.toward[chain[-1]] != v:
            chain.append(int(field.toward[chain[-1]]))
        configs = np.concatenate([start[None], qg.roadmap.vertices[chain], goal[None]])
        short = shortcut(configs, rules)
        info = {"direct": False, "pattern": key.pattern, "roadmap_vertices": v, "roadmap_edges": len(qg.roadmap.edges),
                "roadmap_from_cache": qg.report.from_cache, "start_links": len(s_nbr),
                "roadmap_path_vertices": len(configs),
                "roadmap_cost": path_cost(configs, radii, p.w1, p.varsigma)}
        return SearchResult(True, "", short, info)

    def _goal_field(self, qg: QueryGraph, digest: str, goal: np.ndarray, radii: np.ndarray,
                    rules: CompiledRules, k: int) -> GoalField:
        """The cost-to-go field of ``goal`` on ``qg`` (cached per roadmap and goal)."""
        cache_key = (digest, goal.tobytes())  # the goal's relaxed thresholds follow from it
        if cache_key in self._fields:
            self._fields.move_to_end(cache_key)
            return self._fields[cache_key]
        g_nbr, g_len = _links(qg, rules, goal, k, self.params.link_widening)
        v = len(qg.roadmap.vertices)
        if not len(g_nbr):
            field = GoalField(False, f"goal cannot be joined to any of the {v} roadmap vertices",
                              np.zeros(0), np.zeros(0, dtype=int))
        else:
            phi_g = self.params.w1 * float(proximity_penalty(goal, radii, self.params.varsigma))
            w = g_len + 0.5 * phi_g + qg.half_phi[g_nbr]
            g = qg.graph
            indptr = g.indptr.copy()
            indptr[-1] += len(g_nbr)
            graph = csr_matrix((np.concatenate([g.data, w]), np.concatenate([g.indices, g_nbr.astype(g.indices.dtype)]),
                                indptr), shape=g.shape)
            cost, toward = dijkstra(graph, directed=True, indices=v, return_predecessors=True)
            field = GoalField(True, "", cost, toward)
        self._fields[cache_key] = field
        if len(self._fields) > GOAL_FIELDS:
            self._fields.popitem(last=False)
        return field


def shortcut(configs: np.ndarray, rules: EdgeRules) -> np.ndarray:
    """Greedy shortcuts of a valid joint path ``(N, 2n)``: from each kept vertex jump to the
    farthest later vertex that a valid straight edge reaches. Never raises ``J`` (module
    docstring); the first and last vertices are kept."""
    last = len(configs) - 1
    kept = [0]
    while kept[-1] < last:
        i = kept[-1]
        later = np.arange(i + 1, last + 1)
        ok = np.zeros(len(later), dtype=bool)
        ok[-1] = rules.pick(i == 0, True).motion_ok(configs[i], configs[last])
        if len(later) > 1:
            inner = rules.pick(i == 0, False)
            ok[:-1] = inner.motions_ok(np.broadcast_to(configs[i], (len(later) - 1, configs.shape[1])),
                                       configs[later[:-1]])
        ok[0] = True  # the roadmap edge itself, valid by construction
        kept.append(int(later[np.flatnonzero(ok)[-1]]))
    return configs[kept]


def _links(qg: QueryGraph, rules: CompiledRules, x: np.ndarray, k: int,
           widening: int) -> tuple[np.ndarray, np.ndarray]:
    """Roadmap vertices among the ``k`` nearest to ``x`` that a valid straight edge from ``x``
    reaches, and the edge lengths. If none does, ``widening`` times as many are tried, then
    every vertex."""
    v = len(qg.roadmap.vertices)
    tried = 0
    for count in (min(k, v), min(widening * k, v), v):
        if count <= tried:
            continue
        dist, idx = qg.tree.query(x, k=count)
        dist, idx = np.atleast_1d(dist)[tried:], np.atleast_1d(idx)[tried:]
        tried = count
        ok = rules.motions_ok(np.broadcast_to(x, (len(idx), len(x))), qg.roadmap.vertices[idx])
        if ok.any():
            return idx[ok], dist[ok]
    return np.zeros(0, dtype=int), np.zeros(0)


def _check_request(request: PlanRequest) -> str:
    """Why a request is malformed, or an empty string."""
    pos = np.asarray(request.positions, dtype=float)
    n = pos.shape[0] if pos.ndim == 2 else -1
    if n < 1 or pos.shape != (n, 2):
        return f"positions must have shape (n, 2), got {pos.shape}"
    dst = np.asarray(request.destinations, dtype=float)
    if dst.shape != (n, 2):
        return f"destinations must have shape ({n}, 2), got {dst.shape}"
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(dst))):
        return "positions and destinations must be finite"
    for name in ("radii", "max_speeds"):
        arr = np.asarray(getattr(request, name), dtype=float)
        if arr.shape != (n,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            return f"{name} must be {n} positive numbers"
    if sorted(int(k) for k in request.order) != list(range(n)):
        return f"order {tuple(request.order)} is not a permutation of 0..{n - 1}"
    entered = [int(k) for k in request.entered]
    if len(set(entered)) != len(entered) or any(k < 0 or k >= n for k in entered):
        return f"entered {tuple(request.entered)} must list distinct robots of 0..{n - 1}"
    return ""
