"""How fast the closed loop runs compared with real time, measured on full trials."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from nodnav.bench.stages import STAGES, StageTimes, measure_stages
from nodnav.heap import freeze_long_lived
from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import Simulation, run_trial


@dataclass(frozen=True)
class SimBenchmark:
    """Real-time factors of a set of trials run one after another in this process (one core)."""

    scenario: str
    """Scenario name."""
    planner: str
    """Planner name."""
    seeds: tuple[int, ...]
    """Trial seeds."""
    sim_times: tuple[float, ...]
    """Simulated time of each trial (s)."""
    wall_times: tuple[float, ...]
    """Wall time of each trial (s)."""
    outcomes: tuple[str, ...]
    """Outcome of each trial."""
    setup_time: float
    """Wall time to load the compiled kernels, paid once per process, not per trial (s)."""
    stages: tuple[StageTimes, ...] = ()
    """Each trial run again with its time split by stage (:mod:`nodnav.bench.stages`); empty if not asked."""
    settings: tuple[str, ...] = ()
    """The scenario settings given on top of the scenario's (``--set KEY=VALUE`` as typed); empty: its own."""

    def stage_seconds(self, cpu: bool = True) -> dict[str, float]:
        """Processor (``cpu``) or wall time per stage summed over the measured trials (s)."""
        return {k: float(sum((t.cpu_seconds if cpu else t.seconds)[k] for t in self.stages)) for k in STAGES}

    @property
    def measuring_overhead(self) -> float:
        """How much longer the measured trials took than the same trials unmeasured (fraction of wall time)."""
        return float(sum(t.wall_time for t in self.stages) / sum(self.wall_times) - 1.0)

    def stages_dict(self) -> dict:
        """The breakdown as JSON-ready figures: per stage processor seconds, their percent of the
        measured trials' processor time and per simulated second, and the wall seconds."""
        cpu_total = sum(t.cpu_time for t in self.stages)
        sim = sum(self.sim_times)
        cpu, wall = self.stage_seconds(cpu=True), self.stage_seconds(cpu=False)
        return {"measured_wall_time_s": sum(t.wall_time for t in self.stages), "measured_cpu_time_s": cpu_total,
                "measuring_overhead": self.measuring_overhead, "sum_of_stages_cpu_s": float(sum(cpu.values())),
                "sum_of_stages_wall_s": float(sum(wall.values())),
                "stages": {k: {"cpu_seconds": cpu[k], "percent": 100.0 * cpu[k] / cpu_total,
                               "cpu_per_sim_second": cpu[k] / sim, "wall_seconds": wall[k],
                               "calls": int(sum(t.calls[k] for t in self.stages))} for k in STAGES}}

    def format_stages(self) -> str:
        """The breakdown as a table."""
        d = self.stages_dict()
        lines = [f"{'stage':<18}{'cpu s':>8}{'percent':>9}{'ms per sim s':>14}{'wall s':>8}{'calls':>8}"]
        for k, v in d["stages"].items():
            lines.append(f"{k:<18}{v['cpu_seconds']:>8.3f}{v['percent']:>8.1f}%{1e3 * v['cpu_per_sim_second']:>14.2f}"
                         f"{v['wall_seconds']:>8.3f}{v['calls'] if k != STAGES[-1] else '':>8}")
        lines.append(f"{'total':<18}{d['measured_cpu_time_s']:>8.3f}{100.0:>8.1f}%"
                     f"{1e3 * d['measured_cpu_time_s'] / sum(self.sim_times):>14.2f}{d['measured_wall_time_s']:>8.3f}")
        lines.append(f"measured trials' wall time {100 * d['measuring_overhead']:+.1f}% against the unmeasured runs "
                     f"(cost of measuring plus the machine's noise); {sum(self.sim_times):.1f} s simulated")
        return "\n".join(lines)

    @property
    def speedups(self) -> np.ndarray:
        """Simulated seconds per wall-clock second, per trial."""
        return np.asarray(self.sim_times) / np.asarray(self.wall_times)

    def to_dict(self) -> dict:
        """JSON-ready figures."""
        return {"scenario": self.scenario, "planner": self.planner, "settings": list(self.settings),
                "seeds": list(self.seeds),
                "sim_time_s": list(self.sim_times), "wall_time_s": list(self.wall_times),
                "outcomes": list(self.outcomes), "setup_time_s": self.setup_time,
                "speedup_median": float(np.median(self.speedups)), "speedup_min": float(self.speedups.min()),
                "speedup_total": float(sum(self.sim_times) / sum(self.wall_times)),
                **({"breakdown": self.stages_dict()} if self.stages else {})}

    def format(self) -> str:
        """A human summary."""
        d = self.to_dict()
        given = f" ({', '.join(self.settings)})" if self.settings else ""
        return (f"{self.scenario} with {self.planner}{given}, {len(self.seeds)} trials: "
                f"{d['speedup_total']:.1f}x real time overall (median {d['speedup_median']:.1f}x, "
                f"slowest {d['speedup_min']:.1f}x); set-up {self.setup_time:.1f} s (compiled kernels); "
                f"outcomes {', '.join(self.outcomes)}"
                + (f"\nwhere the time goes (the same trials run again, timed by stage):\n{self.format_stages()}"
                   if self.stages else ""))


def benchmark_closed_loop(scenario_name: str = "4r-case2", planner: str = "fast", seeds=(1, 2, 3),
                          breakdown: bool = True, players: str = "all", overrides: dict | None = None,
                          settings: tuple[str, ...] = ()) -> SimBenchmark:
    """Run trials of ``scenario_name`` with ``players`` game players per robot (all by default) and time them.

    ``overrides``: scenario settings on top of the scenario's (:func:`~nodnav.scenario.loading.load_scenario`'s),
    e.g. a speed setting measured against its default; ``settings``: the same as typed, for the report.

    Each trial builds its own planner inside its timing, as a sweep's trials do, so no trial
    reuses what another planned. A study also pays a set-up once per worker process: loading
    the compiled (numba) kernels, each at its first call. A throw-away trial (seed 0) run to its
    end does that, and is timed apart as the set-up; one decision period of it (before the
    ninth round) left the kernels first called later in a trial (arrival, waiting, the evasive
    fallback) to the first measured trial, which ran at 88x on 4r-case1 against 104-111x for the
    same trial run again (docs/performance-11.md). After it the long-lived heap is frozen, as a
    sweep worker does after its first trial (:mod:`nodnav.heap`). With ``breakdown``, every
    trial is run once more, right after, with its time split by stage
    (:func:`~nodnav.bench.stages.measure_stages`); the real-time factors come from the
    unmeasured runs.
    """
    game_players = players if players == "all" else int(players)
    scenario = load_scenario(scenario_name, overrides or None).with_overrides(
        game_players=game_players, **{"planner.name": planner})
    start = time.perf_counter()
    warm_up = Simulation(scenario, seed=0)
    while not warm_up.step():
        pass
    del warm_up
    freeze_long_lived()  # as a sweep worker does after its first trial (nodnav.heap)
    setup = time.perf_counter() - start
    results, measured = [], []
    for s in seeds:  # each measured run right after its unmeasured one, so that both see the same machine
        results.append(run_trial(scenario, seed=s))
        if breakdown:
            measured.append(measure_stages(scenario, s))
    stages = tuple(measured)
    return SimBenchmark(scenario=scenario.name, planner=planner, seeds=tuple(seeds),
                        sim_times=tuple(r.sim_time for r in results), wall_times=tuple(r.wall_time for r in results),
                        outcomes=tuple(r.outcome for r in results), setup_time=setup, stages=stages,
                        settings=tuple(settings))
