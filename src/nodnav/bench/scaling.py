"""How the cost of a decision grows with the number of robots and of game players (``nodnav bench scaling``).

For every robot count ``N_r`` and every number ``k`` of game players per robot (``all`` is
``N_r - 1``; refused where ``N_r!`` orders exceed :data:`~nodnav.scenario.limits.MAX_STRATEGIES`),
trials of the head-on door crowd of ``N_r`` robots (:func:`~nodnav.scenario.crowds.door_crowd`,
the same rule for every count, so that only the count changes) run in a fresh worker process
per cell, one cell at a time, single-threaded: one core. Per cell it measures

* **CPU time per decision**: :func:`time.process_time` around :meth:`Method.decide`, the decision
  round of every robot (opinions, game players, planning; not the MPC or the physics);
* **plan queries per decision**: the plan cache's counters
  (:class:`~nodnav.sim.plan_cache.PlanCache`): *requests*, what the robots asked for, and *planner
  calls*, what the planner computed (robots posing the same joint query share one call). Each
  robot asks for every order of its game, ``(k+1)!``, every decision, so requests are exactly
  ``N_r (k+1)!``; planner calls are ``(k+1)!`` per distinct joint query set, between ``(k+1)!``
  and ``N_r (k+1)!`` (``tests/bench/test_scaling.py`` checks both by hand);
* **peak memory**: the worker's peak resident set (``ru_maxrss``) after its trials, and the same
  before them (after loading the compiled kernels with a tiny trial), so that cells never
  share memory and the trials' own growth shows;
* **real-time factor**: simulated time over the wall time of the trials.
"""

from __future__ import annotations

import json
import logging
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from nodnav.control.base import ControlResult
from nodnav.scenario.crowds import door_crowd
from nodnav.scenario.limits import MAX_STRATEGIES
from nodnav.scenario.loading import load_scenario
from nodnav.sim.agent import Decision, RobotView
from nodnav.sim.methods import PlannedMethod
from nodnav.sim.simulator import Simulation, run_trial

log = logging.getLogger(__name__)

#: Environment of a worker: every numerical library on one thread, so a cell uses one core.
ONE_THREAD = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                                     "NUMBA_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")}


@dataclass(frozen=True)
class TrialCost:
    """What one trial's decisions cost, round by round."""

    cpu: np.ndarray
    """CPU time of each decision round, every robot deciding (s)."""
    planner_calls: np.ndarray
    """Plans the planner computed in each round."""
    plan_requests: np.ndarray
    """Plans the robots asked for in each round (answers from the round and plans kept from the one
    before included)."""
    sim_time: float
    """Simulated time of the trial (s)."""
    wall_time: float
    """Wall time of the trial, from building the simulation to its end (s)."""
    outcome: str
    """The trial's outcome."""
    result: object = field(default=None, repr=False)
    """The :class:`~nodnav.sim.trial_result.TrialResult` (with its history), when kept."""


class _TimedDecisions:
    """The trial's method with every decision round timed and its plan queries counted; the
    simulator sees the same method (it calls only ``name``, ``decide`` and ``act``)."""

    def __init__(self, method: PlannedMethod):
        self.inner = method
        self.name = method.name
        self.rounds: list[tuple[float, int, int]] = []
        """CPU time, planner calls and plan requests of each decision round."""

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        plans = self.inner.plans
        calls, asked, cpu = plans.misses, plans.asked, time.process_time()
        out = self.inner.decide(views)
        self.rounds.append((time.process_time() - cpu, plans.misses - calls, plans.asked - asked))
        return out

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        return self.inner.act(t, views)


def measure_trial(scenario, seed: int, keep_result: bool = False) -> TrialCost:
    """Run one ``nod`` trial of ``scenario`` timing every call of :meth:`Method.decide`."""
    start = time.perf_counter()
    sim = Simulation(scenario, "nod", seed)
    if not isinstance(sim.method, PlannedMethod):  # every planning method has a plan cache
        raise TypeError(f"method {sim.method.name!r} does not plan; nothing to measure")
    timed = _TimedDecisions(sim.method)
    sim.method = timed
    while not sim.step():
        pass
    result = sim.result(time.perf_counter() - start)
    rounds = timed.rounds
    cpu, calls, asked = (np.array(c) for c in zip(*rounds)) if rounds else (np.zeros(0),) * 3
    return TrialCost(cpu=cpu.astype(float), planner_calls=calls.astype(int), plan_requests=asked.astype(int),
                     sim_time=result.sim_time, wall_time=result.wall_time, outcome=result.outcome,
                     result=result if keep_result else None)


def peak_rss_bytes() -> int:
    """This process's peak resident set size so far (bytes; ``ru_maxrss`` is in KiB on Linux)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak if sys.platform == "darwin" else peak * 1024)


def measure_cell(n_robots: int, players: int, seeds, time_limit: float | None = None) -> dict:
    """The figures of one cell, measured in this process (meant to be a fresh worker).

    ``players`` is ``k``; ``time_limit`` (s) shortens the trials when given.
    """
    run_trial(load_scenario("2r-case1").with_overrides(time_limit=0.5), "nod", 1)  # load the compiled kernels
    baseline = peak_rss_bytes()
    scenario = door_crowd(n_robots, players)
    if time_limit is not None:
        scenario = scenario.with_overrides(time_limit=min(time_limit, scenario.time_limit))
    costs = [measure_trial(scenario, s) for s in seeds]
    cpu = np.concatenate([c.cpu for c in costs])
    calls = np.concatenate([c.planner_calls for c in costs])
    asked = np.concatenate([c.plan_requests for c in costs])
    return {"decisions": int(cpu.size), "cpu_mean_s": float(cpu.mean()), "cpu_max_s": float(cpu.max()),
            "planner_calls_mean": float(calls.mean()), "planner_calls_max": int(calls.max()),
            "plan_requests_mean": float(asked.mean()), "plan_requests_max": int(asked.max()),
            "baseline_rss_bytes": baseline, "peak_rss_bytes": peak_rss_bytes(),
            "sim_time_s": float(sum(c.sim_time for c in costs)), "wall_time_s": float(sum(c.wall_time for c in costs)),
            "outcomes": [c.outcome for c in costs], "time_limit_s": scenario.time_limit}


@dataclass(frozen=True)
class ScalingCell:
    """One robot count with one number of game players."""

    n_robots: int
    """N_r."""
    players: str
    """Game players per robot as asked: a number or ``all``."""
    game_size: int
    """Robots in each robot's game, ``k + 1``; ``(k+1)!`` orders."""
    refused: str = ""
    """Why the cell was not run (all players above the size limit), else empty."""
    error: str = ""
    """What went wrong in the worker, else empty."""
    figures: dict = field(default_factory=dict)
    """What :func:`measure_cell` returned."""

    @property
    def measured(self) -> bool:
        """Whether the cell has figures."""
        return bool(self.figures)

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.figures["sim_time_s"] / self.figures["wall_time_s"] if self.measured else math.nan

    def to_dict(self) -> dict:
        """JSON-ready: the cell, its figures and the real-time factor."""
        out = {"n_robots": self.n_robots, "players": self.players, "game_size": self.game_size,
               "orders_per_robot": math.factorial(self.game_size), **self.figures}
        if self.measured:
            out["realtime_factor"] = self.realtime_factor
        if self.refused:
            out["refused"] = self.refused
        if self.error:
            out["error"] = self.error
        return out


@dataclass(frozen=True)
class ScalingBenchmark:
    """Every cell of a scaling benchmark."""

    cells: tuple[ScalingCell, ...]
    """By robot count, then players as asked."""
    seeds: tuple[int, ...]
    """Trial seeds of every cell."""
    wall_time: float
    """Wall time of the whole benchmark, worker start-ups included (s)."""
    time_limit: float | None = None
    """Simulated time after which every trial was cut (s), or ``None``: each ran to its end."""

    @property
    def errors(self) -> int:
        """Cells whose worker failed."""
        return sum(bool(c.error) for c in self.cells)

    def to_dict(self) -> dict:
        """JSON-ready figures."""
        return {"scenario": "door crowd (nodnav.scenario.crowds.door_crowd)", "method": "nod", "planner": "fast",
                "seeds": list(self.seeds), "time_limit_s": self.time_limit, "wall_time_s": self.wall_time,
                "cells": [c.to_dict() for c in self.cells]}

    def format(self) -> str:
        """The table ``nodnav bench scaling`` prints."""
        lines = [f"head-on door crowds (nodnav.scenario.crowds), nod with the fast planner, seeds "
                 f"{', '.join(map(str, self.seeds))}"
                 f"{f', trials cut at {self.time_limit:g} s simulated' if self.time_limit is not None else ''}; "
                 "one worker process per cell on one core",
                 f"{'N_r':>3} {'k':>4} {'orders':>6} {'CPU ms/decision':>15} {'max':>7} {'planner calls':>13} "
                 f"{'requests':>8} {'peak MB':>7} {'(base)':>6} {'real time':>9}  outcomes"]
        for c in self.cells:
            head = f"{c.n_robots:>3} {c.players:>4} {math.factorial(c.game_size):>6}"
            if not c.measured:
                lines.append(f"{head}  {c.refused or 'failed: ' + c.error}")
                continue
            f = c.figures
            lines.append(f"{head} {1e3 * f['cpu_mean_s']:>15.1f} {1e3 * f['cpu_max_s']:>7.0f} "
                         f"{f['planner_calls_mean']:>13.1f} {f['plan_requests_mean']:>8.1f} "
                         f"{f['peak_rss_bytes'] / 2**20:>7.0f} {f['baseline_rss_bytes'] / 2**20:>6.0f} "
                         f"{c.realtime_factor:>8.1f}x  {', '.join(f['outcomes'])}")
        lines.append("CPU ms/decision: one decision round of every robot (opinions, game players, planning), mean and "
                     "max; planner calls and requests: per round (requests = N_r (k+1)!, calls shared between robots "
                     "posing the same joint query); peak MB: the worker's peak resident memory after its trials "
                     "(base: before them); real time: simulated over wall time.")
        lines.append(f"took {self.wall_time:.0f} s")
        return "\n".join(lines)


def plan_cells(robots, players) -> list[tuple[int, str, int, str]]:
    """The cells ``(N_r, players as asked, k + 1, refusal)`` of ``robots`` x ``players``; numbers of
    players a robot count cannot have (``k >= N_r``) are left out."""
    cells = []
    for n in sorted(set(robots)):
        for p in players:
            k = n - 1 if p == "all" else int(p)
            if k > n - 1:
                continue
            refused = "" if math.factorial(k + 1) <= MAX_STRATEGIES else (
                f"refused: {k + 1}! = {math.factorial(k + 1)} orders per robot, more than {MAX_STRATEGIES} "
                "(scenario/limits.py)")
            cells.append((n, str(p), k + 1, refused))
    return cells


def run_in_worker(n_robots: int, players: int, seeds, time_limit: float | None = None) -> dict:
    """:func:`measure_cell` in a fresh Python process on one thread; raises ``RuntimeError`` with
    the worker's last line of error output if it fails."""
    with tempfile.TemporaryDirectory(prefix="nodnav-scaling-") as tmp:
        out = Path(tmp) / "cell.json"
        job = json.dumps({"n_robots": n_robots, "players": players, "seeds": list(seeds), "time_limit": time_limit})
        done = subprocess.run([sys.executable, "-m", "nodnav.bench.scaling", job, str(out)],
                              env={**os.environ, **ONE_THREAD}, capture_output=True, text=True)
        if done.returncode != 0 or not out.exists():
            last = (done.stderr.strip().splitlines() or [f"exit code {done.returncode}"])[-1]
            raise RuntimeError(last)
        return json.loads(out.read_text())


def benchmark_scaling(robots=range(2, 9), players=("1", "2", "3", "all"), trials: int = 1,
                      time_limit: float | None = None,
                      progress: Callable[[int, int, str], None] | None = None) -> ScalingBenchmark:
    """Measure every cell of ``robots`` x ``players`` with seeds ``1..trials``, one worker per
    distinct game (``k = N_r - 1`` and ``all`` are the same cell, measured once).

    ``progress(done, total, label)`` is called before each cell runs.
    """
    start = time.perf_counter()
    seeds = tuple(range(1, trials + 1))
    planned = plan_cells(robots, players)
    measured: dict[tuple[int, int], dict | str] = {}
    runnable = sorted({(n, g) for n, _, g, refused in planned if not refused})
    for m, (n, g) in enumerate(runnable):
        if progress is not None:
            progress(m, len(runnable), f"N_r = {n}, k = {g - 1}")
        try:
            measured[(n, g)] = run_in_worker(n, g - 1, seeds, time_limit)
        except RuntimeError as exc:
            log.warning("scaling cell N_r = %d, k = %d failed: %s", n, g - 1, exc)
            measured[(n, g)] = str(exc)
    cells = []
    for n, p, g, refused in planned:
        got = measured.get((n, g), {})
        cells.append(ScalingCell(n, p, g, refused=refused, error=got if isinstance(got, str) else "",
                                 figures=got if isinstance(got, dict) else {}))
    return ScalingBenchmark(tuple(cells), seeds, time.perf_counter() - start, time_limit)


def _worker(argv: list[str]) -> int:
    """Entry point of a worker: ``python -m nodnav.bench.scaling JOB_JSON OUT_PATH``."""
    job = json.loads(argv[0])
    figures = measure_cell(job["n_robots"], job["players"], job["seeds"], job.get("time_limit"))
    Path(argv[1]).write_text(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(_worker(sys.argv[1:]))
