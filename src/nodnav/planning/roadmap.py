"""PRM* roadmaps in the joint configuration space (appendix): what they are keyed by, and how they are built.

Which configurations and edges are valid (free space, separation, the passing order) is
:mod:`nodnav.planning.joint_validity`; roadmaps are stored on disk by
:mod:`nodnav.planning.roadmap_cache` and queried by :mod:`nodnav.planning.prm`.

Why one roadmap serves many scenarios and orders
------------------------------------------------
The validity rules depend on the robots only through their radii and directions *listed by
rank*. The roadmap for a request is therefore keyed by ``(world, radii by rank, directions by
rank, margin, varsigma, size, seed, format version)`` and not by the scenario or the order:
every order of every scenario with the same direction pattern reuses it. With equal radii that
is at most 2^n roadmaps for n crossing robots (4 + 8 + 16 for 2..4 robots in the paper's world),
where the paper builds one roadmap per strategy (n! of them); in the closed loop, robots that
have left the corridor no longer cross and lead the order, which adds 2^n - 1 patterns
(:func:`direction_patterns`). ``varsigma`` is in the key because the stored per-vertex
proximity penalty depends on it.

Building
--------
Roadmaps are grown with OMPL's ``og.PRMstar`` (k-nearest PRM*, k = e (1 + 1/dim) log V). Three
hooks make that exact, fast and reproducible:

* the motion validator is exact (:meth:`~nodnav.planning.joint_validity.CompiledRules.motion_ok`):
  pairwise distance along a straight edge is a quadratic in the edge parameter, a disc moving
  along a segment stays clear of a rectangle iff the segment-rectangle distance is at least its
  radius, and stages change only where an x-coordinate crosses an entrance; OMPL's default
  discrete checking admits invalid edges;
* the valid-state sampler mixes uniform samples with *corridor lane* samples
  (:func:`sample_candidates`): one crossing robot (or a train of consecutive same-direction
  robots) on the corridor's axis band, and 1 m beyond each entrance, while the others stand
  still at an *anchor* placement (robots earlier in the order after the corridor, later ones
  before it) shared by many consecutive samples. In R^{2n} the corridor is a narrow passage that
  uniform samples almost never chain through; lane samples sharing an anchor differ in the
  crossing robots only, so they chain at PRM*'s k-nearest scale. The mixture keeps a uniform
  component, so PRM*'s sampling-density assumption still holds;
* the build grows the roadmap with ``growRoadmapPtc`` until a vertex count is reached (not a
  wall-clock time as ``constructRoadmap`` does), after ``ou.RNG.setSeed`` and with a NumPy
  generator seeded from the key, so a key always yields the same roadmap.

After export every edge is checked again with the vectorised
:func:`~nodnav.planning.joint_validity.edges_valid`; an edge that fails is dropped and counted
(none should).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import time
from dataclasses import dataclass

import numpy as np

from nodnav.planning.joint_validity import (
    CompiledRules,
    configurations_valid,
    edges_valid,
    pair_indices,
    separation_thresholds,
)
from nodnav.scenario.world import LEFT, RIGHT, Passage, World

log = logging.getLogger(__name__)

FORMAT_VERSION = 2
"""Version of the roadmap construction and file layout; part of every key (bump it whenever
either changes, so that stale cached roadmaps are rebuilt)."""
ROADMAP_SEED = 1
"""Seed of every roadmap build (part of the key)."""

UNIFORM_FRACTION = 0.5
"""Share of uniform samples in the sampler mixture (the rest are corridor lane samples)."""
ANCHOR_REUSE = 24
"""Lane samples that share one anchor placement of the other robots."""
LANE_OVERHANG = 1.0
"""How far beyond each entrance lane samples reach (m)."""
TRAIN_SLACK = 1.0
"""Robots of a train on the lane keep one separation plus up to this much more between them (m)."""

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
        w = self.world
        if not w.polygons and w.corridor is not None and w.passages == (Passage.of_corridor(w.corridor),):
            # the paper's shorthand world as it was written before passages and polygons existed:
            # the same text, hence the same seed and the same roadmaps
            del data["world"]["passages"], data["world"]["polygons"]
        if not w.map_file:  # a world without a map is written as before maps existed (same seeds)
            del data["world"]["map_file"], data["world"]["map_walls"]
        else:
            # Not the map's path: its walls are the first map_walls boxes of obstacles, and a path
            # (absolute, of one checkout) made each checkout seed and build other roadmaps.
            del data["world"]["map_file"]
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
    g = key.world.passage  # lanes in the passage's frame: s along its axis, t across
    yc = g.t_centre
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
            if g.along_x:  # the room's x range beyond the mouth, as the paper's corridor always had it
                xlo, xhi = (g.s_end, box[j, 2]) if go_right else (box[j, 0], g.s_start)
                anchor[j, 0] = rng.uniform(min(xlo, xhi), max(xlo, xhi))
            else:
                anchor[j] = _anchor_beyond(rng, box[j], g, RIGHT if go_right else LEFT)
        out[rows] = anchor
        x = rng.uniform(g.s_start - LANE_OVERHANG, g.s_end + LANE_OVERHANG, size=m)
        for i, j in enumerate(train[::-1]):
            if i:
                ahead = train[::-1][i - 1]
                gap = radii[j] + radii[ahead] + key.margin + rng.uniform(0.0, TRAIN_SLACK, size=m)
                x = x + d[j] * gap
            half = max(0.5 * g.width - radii[j], 0.0)
            out[rows, j] = g.to_world(x, rng.uniform(yc - half, yc + half, size=m))
    return out.reshape(count, 2 * n)


def _anchor_beyond(rng: np.random.Generator, box: np.ndarray, passage: Passage, side: int,
                   tries: int = 32) -> np.ndarray:
    """A point uniform in ``box`` on ``side`` of the passage (rejection); the last draw if none is."""
    p = rng.uniform(box[:2], box[2:], size=(tries, 2))
    on_side = np.flatnonzero(passage.side_of_along(passage.along(p)) == side)
    return p[on_side[0] if len(on_side) else -1]


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
        return RoadmapResult(Roadmap.empty(key), roadmap_report(key, False, f"grew only {count} of {target} "
                                                                f"vertices in {max_seconds:.0f} s",
                                                                time.perf_counter() - t0))
    data = ob.PlannerData(si)
    planner.getPlannerData(data)
    vertices = np.array([data.getVertex(i).getState()[0:dim] for i in range(data.numVertices())],
                        dtype=float).reshape(-1, dim)
    pairs = [(i, j) for i in range(data.numVertices()) for j in data.getEdges(i) if i < j]
    edges = np.array(pairs, dtype=np.int32).reshape(-1, 2)
    if not len(edges):
        return RoadmapResult(Roadmap.empty(key), roadmap_report(key, False, f"no valid edge among {count} vertices",
                                                                time.perf_counter() - t0))
    keep = edges_valid(world, vertices[edges[:, 0]], vertices[edges[:, 1]], radii, dirs, sep)
    dropped = int(np.count_nonzero(~keep))
    if dropped:
        log.warning("roadmap %s: the exact check dropped %d of %d OMPL edges", key.filename(), dropped, len(edges))
    seconds = time.perf_counter() - t0
    roadmap = Roadmap(key, vertices, edges[keep], proximity_penalty(vertices, radii, key.varsigma),
                      dropped, seconds)
    return RoadmapResult(roadmap, roadmap_report(key, True, "", seconds, roadmap))


def roadmap_report(key: RoadmapKey, success: bool, reason: str, seconds: float, roadmap: Roadmap | None = None,
                   from_cache: bool = False, path: str = "") -> BuildReport:
    """The report of obtaining the roadmap for ``key`` (built, loaded, or failed: ``roadmap`` None)."""
    rm = roadmap if roadmap is not None else Roadmap.empty(key)
    return BuildReport(success=success, reason=reason, n_robots=key.n_robots, pattern=key.pattern,
                       vertices=len(rm.vertices), edges=len(rm.edges), dropped_edges=rm.dropped_edges,
                       seconds=seconds, build_seconds=rm.build_seconds, from_cache=from_cache, path=path)


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
