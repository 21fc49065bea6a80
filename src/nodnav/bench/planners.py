"""``nodnav bench planners``: every planner on every built-in scenario in every passing order.

Each query plans from rest at the scenario's origins to its destinations in one order, each
robot within its own speed and acceleration limit (the default, feasible timing). Latency is the
wall time of :meth:`Planner.plan` measured here; for the PRM* planner the roadmaps are obtained
(loaded or built) before the timed queries, and reported separately, so latency is the query
alone. Separation is measured on every successful plan independently of the planner, at a
step five times finer than the plan's.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from dataclasses import dataclass

import numpy as np

from nodnav.decision.strategies import passing_orders
from nodnav.geometry import min_gap, min_pair_distance
from nodnav.planning.base import PlanRequest, crossing_directions, feasible_order

FINE = 5
"""Separation is measured at a step this many times finer than the plan's."""


@dataclass(frozen=True)
class RoadmapSummary:
    """The PRM* roadmaps one robot count needed."""

    n_robots: int
    """Robot count."""
    roadmaps: int
    """Distinct roadmaps (direction patterns) used."""
    from_cache: int
    """How many were loaded from the disk cache (the others were built now)."""
    vertices: float
    """Mean vertices per roadmap."""
    edges: float
    """Mean undirected edges per roadmap."""
    build_seconds: float
    """Total time the roadmaps took to build (s), as recorded with them."""
    obtain_seconds: float
    """Total time to obtain them in this run: load, or build if not cached (s)."""


@dataclass(frozen=True)
class PlannerBenchmark:
    """One planner's results over all queries."""

    planner: str
    """Planner name."""
    queries: int
    """Queries run (scenarios x orders)."""
    successes: int
    """Successful plans."""
    latency_median_ms: float
    """Median query wall time (ms)."""
    latency_p95_ms: float
    """95th percentile of the query wall time (ms)."""
    mean_cost: float
    """Mean cost of successful plans (planner-specific units, see each planner)."""
    mean_duration: float
    """Mean duration of successful plans (s): comparable across planners."""
    min_separation: float
    """Least centre-to-centre distance over all successful plans (m)."""
    min_gap: float
    """Least surface-to-surface gap ``|p_a - p_b| - r_a - r_b`` over all successful plans (m)."""
    failures: tuple[str, ...]
    """``scenario order: reason`` for each failed query."""
    roadmaps: tuple[RoadmapSummary, ...] = ()
    """PRM* only: roadmaps per robot count."""


@dataclass(frozen=True)
class BenchmarkResult:
    """The benchmark of several planners on the same queries."""

    scenarios: tuple[str, ...]
    """Scenarios run."""
    planners: tuple[PlannerBenchmark, ...]
    """One entry per planner."""

    def to_dict(self) -> dict:
        """Plain mapping for JSON (non-finite numbers become ``None``)."""
        def clean(v):
            if isinstance(v, float) and not math.isfinite(v):
                return None
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            if isinstance(v, (list, tuple)):
                return [clean(x) for x in v]
            return v

        return clean(dataclasses.asdict(self))


def _percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def _requests(scenario) -> list[PlanRequest]:
    return [PlanRequest(scenario.world, scenario.origins, np.zeros_like(scenario.origins), scenario.destinations,
                        scenario.radii, scenario.max_speeds, tuple(int(k) for k in order),
                        max_accels=np.array([r.max_accel for r in scenario.robots], dtype=float))
            for order in passing_orders(scenario.n_robots)]


def _roadmap_summaries(planners) -> tuple[RoadmapSummary, ...]:
    reports = [r for p in planners for r in p.roadmap_reports()]
    out = []
    for n in sorted({r.n_robots for r in reports}):
        rs = [r for r in reports if r.n_robots == n]
        ok = [r for r in rs if r.success] or rs
        out.append(RoadmapSummary(n, len(rs), sum(r.from_cache for r in rs),
                                  float(np.mean([r.vertices for r in ok])), float(np.mean([r.edges for r in ok])),
                                  float(sum(r.build_seconds for r in rs)), float(sum(r.seconds for r in rs))))
    return tuple(out)


def benchmark_planner(name: str, scenarios, cache_dir: str = "",
                      roadmap_vertices: int | None = None) -> PlannerBenchmark:
    """Run planner ``name`` on every order of every scenario (loaded :class:`Scenario` objects)."""
    from nodnav.planning import make_planner
    from nodnav.planning.prm import PRMStarPlanner

    planners: dict = {}
    latencies, costs, durations, failures = [], [], [], []
    min_sep, gap, queries = math.inf, math.inf, 0
    jobs = []
    for sc in scenarios:
        changes: dict = {"planner.name": name}
        if cache_dir:
            changes["planner.cache_dir"] = cache_dir
        if roadmap_vertices is not None:
            changes["planner.roadmap_vertices"] = roadmap_vertices
        params = sc.with_overrides(**changes).planner
        if (sc.world, params) not in planners:
            planners[(sc.world, params)] = make_planner(params, sc.world)
        planner = planners[(sc.world, params)]
        for req in _requests(sc):
            if isinstance(planner, PRMStarPlanner):  # obtain roadmaps outside the timed query
                rank = list(feasible_order(req.order, req.entered))
                dirs = crossing_directions(sc.world, req.positions, req.destinations)[rank]
                planner.roadmap(req.radii[rank], dirs)
            jobs.append((sc, planner, req))
    for sc, planner, req in jobs:
        queries += 1
        label = f"{sc.name} {tuple(int(k) + 1 for k in req.order)}"
        t0 = time.perf_counter()
        try:
            res = planner.plan(req)
        except Exception as exc:  # a planner must not raise; the benchmark records it and goes on
            failures.append(f"{label}: raised {type(exc).__name__}: {exc}")
            continue
        latencies.append(time.perf_counter() - t0)
        if not res.success:
            failures.append(f"{label}: {res.reason}")
            continue
        costs.append(res.cost)
        tr = res.trajectory
        durations.append(tr.duration)
        t = np.linspace(tr.times[0], tr.times[-1], FINE * (len(tr.times) - 1) + 1)
        p = tr.positions_at(t)
        min_sep = min(min_sep, min_pair_distance(p))
        gap = min(gap, min_gap(p, req.radii))
    ms = [1e3 * x for x in latencies]
    summaries = _roadmap_summaries([p for p in planners.values() if isinstance(p, PRMStarPlanner)])
    return PlannerBenchmark(name, queries, queries - len(failures), _percentile(ms, 50), _percentile(ms, 95),
                            float(np.mean(costs)) if costs else float("nan"),
                            float(np.mean(durations)) if durations else float("nan"),
                            float(min_sep), float(gap), tuple(failures), summaries)


def run_planner_benchmark(planners=("fast", "prm"), scenarios=None, cache_dir: str = "",
                          roadmap_vertices: int | None = None) -> BenchmarkResult:
    """Benchmark ``planners`` on every order of ``scenarios`` (names; default: all built-in).

    ``cache_dir`` and ``roadmap_vertices`` override the scenarios' PRM* settings when given.
    """
    from nodnav.scenario.files import builtin_names
    from nodnav.scenario.loading import load_scenario

    names = tuple(builtin_names() if scenarios is None else scenarios)
    loaded = [load_scenario(n) for n in names]
    return BenchmarkResult(names, tuple(benchmark_planner(p, loaded, cache_dir, roadmap_vertices) for p in planners))


def format_benchmark(result: BenchmarkResult) -> str:
    """A human-readable table of a :class:`BenchmarkResult`."""
    lines = [f"{len(result.scenarios)} scenarios, every passing order, planned from the origins",
             f"{'planner':8} {'success':>9} {'median ms':>9} {'p95 ms':>8} {'mean cost':>9} {'mean dur s':>10} "
             f"{'min sep m':>9} {'min gap m':>9}"]
    for b in result.planners:
        lines.append(f"{b.planner:8} {f'{b.successes}/{b.queries}':>9} {b.latency_median_ms:>9.2f} "
                     f"{b.latency_p95_ms:>8.2f} {b.mean_cost:>9.2f} {b.mean_duration:>10.2f} "
                     f"{b.min_separation:>9.3f} {b.min_gap:>9.3f}")
    lines.append("(cost is planner-specific: fast = sum of arrival times, prm = the paper's PRM* cost J)")
    for b in result.planners:
        if b.roadmaps:
            lines.append(f"{b.planner} roadmaps: {'robots':>6} {'roadmaps':>8} {'cached':>6} {'vertices':>9} "
                         f"{'edges':>9} {'build s':>8} {'obtain s':>8}")
            for r in b.roadmaps:
                lines.append(f"{'':{len(b.planner) + 10}}{r.n_robots:>6} {r.roadmaps:>8} {r.from_cache:>6} "
                             f"{r.vertices:>9.0f} {r.edges:>9.0f} {r.build_seconds:>8.1f} {r.obtain_seconds:>8.2f}")
        for f in b.failures:
            lines.append(f"{b.planner} FAILED {f}")
    return "\n".join(lines)


def main_bench_planners(json_output: bool = False, planners=("fast", "prm"), scenarios=None, cache_dir: str = "",
                        roadmap_vertices: int | None = None) -> str:
    """The text ``nodnav bench planners [--json]`` prints."""
    result = run_planner_benchmark(planners, scenarios, cache_dir, roadmap_vertices)
    return json.dumps(result.to_dict(), indent=2) if json_output else format_benchmark(result)
