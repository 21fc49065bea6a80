"""How fast the closed loop runs compared with real time, measured on full trials."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

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

    @property
    def speedups(self) -> np.ndarray:
        """Simulated seconds per wall-clock second, per trial."""
        return np.asarray(self.sim_times) / np.asarray(self.wall_times)

    def to_dict(self) -> dict:
        """JSON-ready figures."""
        return {"scenario": self.scenario, "planner": self.planner, "seeds": list(self.seeds),
                "sim_time_s": list(self.sim_times), "wall_time_s": list(self.wall_times),
                "outcomes": list(self.outcomes), "setup_time_s": self.setup_time,
                "speedup_median": float(np.median(self.speedups)), "speedup_min": float(self.speedups.min()),
                "speedup_total": float(sum(self.sim_times) / sum(self.wall_times))}

    def format(self) -> str:
        """A human summary."""
        d = self.to_dict()
        return (f"{self.scenario} with {self.planner}, {len(self.seeds)} trials: "
                f"{d['speedup_total']:.1f}x real time overall (median {d['speedup_median']:.1f}x, "
                f"slowest {d['speedup_min']:.1f}x); set-up {self.setup_time:.1f} s (compiled kernels); "
                f"outcomes {', '.join(self.outcomes)}")


def benchmark_closed_loop(scenario_name: str = "4r-case2", planner: str = "fast", seeds=(1, 2, 3)) -> SimBenchmark:
    """Run trials of ``scenario_name`` with all robots as game players and time them.

    Each trial builds its own planner inside its timing, as a sweep's trials do, so no trial
    reuses what another planned. A study also pays a set-up once per worker process, loading
    the compiled (numba) kernels, which one decision period of a throw-away trial does; that is
    timed apart as the set-up.
    """
    scenario = load_scenario(scenario_name).with_overrides(game_players="all", **{"planner.name": planner})
    start = time.perf_counter()
    warm_up = Simulation(scenario, seed=0)
    for _ in range(warm_up.steps_per_decision + 1):
        warm_up.step()
    setup = time.perf_counter() - start
    results = [run_trial(scenario, seed=s) for s in seeds]
    return SimBenchmark(scenario=scenario.name, planner=planner, seeds=tuple(seeds),
                        sim_times=tuple(r.sim_time for r in results), wall_times=tuple(r.wall_time for r in results),
                        outcomes=tuple(r.outcome for r in results), setup_time=setup)
