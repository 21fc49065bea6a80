"""The report's section on 5 to 8 robots: success and time against N_r and k.

It reads the trials of the scaling part (:data:`~nodnav.experiments.scaling.STUDY_SCALING`) from
the results database, like every other section. Success rates carry the report's 95 % Wilson
intervals.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from nodnav.experiments.scaling import SCALING_PLAYERS, STUDY_SCALING
from nodnav.experiments.statistics import wilson_interval
from nodnav.experiments.store import OUTCOMES, TrialRecord
from nodnav.reporting.document import ReportDocument
from nodnav.reporting.markdown import md_table

#: Failed trials listed with the command that redoes them, at most.
MAX_LISTED = 30


@dataclass(frozen=True)
class ScalingGroup:
    """The trials of one robot count (or scenario) with one number of game players."""

    key: tuple
    """``(N_r, k)`` or ``(scenario, k)``."""
    records: tuple[TrialRecord, ...]
    """Its trials."""

    @property
    def trials(self) -> int:
        """Number of trials."""
        return len(self.records)

    def count(self, outcome: str) -> int:
        """Trials with ``outcome``."""
        return sum(r.outcome == outcome for r in self.records)

    def _values(self, key: str, successful: bool = False) -> np.ndarray:
        values = [r.summary.get(key) for r in self.records if not successful or r.outcome == "success"]
        return np.array([v for v in values if v is not None and math.isfinite(v)], dtype=float)

    @property
    def makespan(self) -> np.ndarray:
        """Makespans of the successful trials (s)."""
        return self._values("makespan_s", successful=True)

    @property
    def wall(self) -> np.ndarray:
        """Wall time of each trial in its worker process (s)."""
        return self._values("wall_time_s")

    @property
    def realtime_factor(self) -> float:
        """Simulated over wall time, summed over the trials."""
        sim, wall = self._values("sim_time_s").sum(), self.wall.sum()
        return float(sim / wall) if wall > 0 else math.nan


def groups(records: list[TrialRecord], by: str) -> list[ScalingGroup]:
    """The records grouped by ``(n_robots or scenario, players)``, sorted."""
    out: dict[tuple, list[TrialRecord]] = defaultdict(list)
    for r in records:
        out[(getattr(r, by), r.players)].append(r)
    return [ScalingGroup(k, tuple(v)) for k, v in sorted(out.items())]


def _pct(iv) -> str:
    return "-" if math.isnan(float(iv.rate)) else f"{100 * iv.rate:.1f} [{100 * iv.low:.1f}, {100 * iv.high:.1f}]"


def _mean_sd(v: np.ndarray) -> str:
    return "-" if v.size == 0 else f"{v.mean():.1f} ± {v.std(ddof=1):.1f}" if v.size > 1 else f"{v[0]:.1f}"


def readings(by_robots: list[ScalingGroup], records: list[TrialRecord]) -> list[str]:
    """Sentences that read the tables, generated from their numbers alone."""
    out = []
    for k in sorted({g.key[1] for g in by_robots}):
        mine = [g for g in by_robots if g.key[1] == k]
        s, n = sum(g.count("success") for g in mine), sum(g.trials for g in mine)
        collisions = sum(g.count("collision") for g in mine)
        text = (f"k = {k}: {s} of {n} trials succeeded, {_pct(wilson_interval(s, n))} % pooled over "
                f"{', '.join(str(g.key[0]) for g in mine)} robots; {collisions} collision(s)")
        timed = [g for g in mine if g.wall.size and math.isfinite(g.realtime_factor)]
        if len(timed) >= 2:
            first, last = timed[0], timed[-1]
            # Per simulated second, so that longer trials with more robots do not count as slower code.
            growth = first.realtime_factor / last.realtime_factor
            text += (f"; a simulated second took {growth:.2f}x the wall time at {last.key[0]} robots as at "
                     f"{first.key[0]} ({first.realtime_factor:.1f}x real time, then {last.realtime_factor:.1f}x) "
                     f"for {last.key[0] / first.key[0]:.2f}x the robots")
        out.append(text + ".")
    failed = [r for r in records if r.outcome != "success"]
    if failed:
        listed = "; ".join(f"`nodnav run {r.scenario} --seed {r.seed} --players {r.players}` ({r.outcome})"
                           for r in failed[:MAX_LISTED])
        more = f" and {len(failed) - MAX_LISTED} more" if len(failed) > MAX_LISTED else ""
        out.append(f"Failed trials, each redone by its command: {listed}{more}.")
    else:
        out.append("No trial failed.")
    return out


def section_scaling(rep: ReportDocument) -> None:
    """Write the section into ``rep``, the report being built."""
    from nodnav.viz.scaling import plot_scaling_study

    rep.add("## Beyond the paper: 5 to 8 robots", "",
            "The paper stops at 4 robots. The crowd built-ins (5 to 8 robots waiting at the doors: head-on, "
            "one-sided and mixed, in rooms as large as they need) with k = "
            f"{', '.join(map(str, SCALING_PLAYERS))} game players per robot, zero initial opinions, NOD with the fast "
            "planner; all players is refused above 6 robots. Each robot's opinions are over the (k+1)! orders of "
            "its game, so a decision's cost depends on k, not on N_r!.")
    if not rep.has(STUDY_SCALING):
        rep.absent(STUDY_SCALING, "Run `nodnav reproduce --parts scaling` to add it.")
        return
    records = [r for r in rep.store.records(STUDY_SCALING) if r.method == "nod"]
    by_robots = groups(records, "n_robots")
    rows, plotted = [], []
    for g in by_robots:
        iv = wilson_interval(g.count("success"), g.trials)
        rows.append([g.key[0], g.key[1], g.trials, _pct(iv), g.count("collision"), g.count("deadlock"),
                     g.count("timeout"), _mean_sd(g.makespan), _mean_sd(g.wall), f"{g.realtime_factor:.1f}x"])
        plotted.append({"n_robots": g.key[0], "players": g.key[1], "rate": iv.rate, "low": iv.low, "high": iv.high,
                        "makespan": g.makespan.mean() if g.makespan.size else math.nan,
                        "wall": g.wall.mean() if g.wall.size else math.nan})
    rep.add("", *md_table(["robots", "k", "trials", "success %", "collisions", "deadlocks", "timeouts", "makespan (s)",
                         "wall per trial (s)", "real time"], rows), "")
    rep.add("Success pooled over the scenarios of each robot count; makespan over successful trials; wall time of a "
            "trial in its worker process (one core), and simulated over wall time.", "")
    per_scenario = []
    for g in groups(records, "scenario"):
        per_scenario.append([g.key[0], g.key[1], g.trials, _pct(wilson_interval(g.count("success"), g.trials))]
                            + [g.count(o) for o in OUTCOMES if o != "success"] + [_mean_sd(g.makespan)])
    rep.add(*md_table(["scenario", "k", "trials", "success %"] + [f"{o}s" for o in OUTCOMES if o != "success"]
                    + ["makespan (s)"], per_scenario), "")
    path = plot_scaling_study(plotted, rep.out / "scaling-5-8-robots.png")
    rep.figure(path, "success, makespan and wall time against the number of robots",
               f"from the `{STUDY_SCALING}` trials")
    rep.read(readings(by_robots, records))
