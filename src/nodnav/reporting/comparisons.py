"""The report's comparisons beyond the paper: planners against each other, and navigation methods."""

from __future__ import annotations

import numpy as np

from nodnav.experiments.analysis import method_rows, methods_reading, pooled, rate_cells
from nodnav.experiments.paper import STUDY_METHODS, STUDY_PLANNERS
from nodnav.experiments.statistics import (
    fmt_mean_sd,
    fmt_rate,
    intervals_separate,
    mean_sd,
    newcombe_difference,
    planner_verdict,
    wilson_interval,
)
from nodnav.reporting.document import ReportDocument
from nodnav.reporting.markdown import md_table
from nodnav.viz.report import plot_rate_bars


def section_planners(rep: ReportDocument) -> None:
    """Success per planner on the same cells, and whether the planner matters (Newcombe difference)."""
    rep.add("## Does the planner matter?", "",
            "The paper says the choice of planner has minimal impact and uses PRM*. The same success-rate study is "
            "run with each planner; trials with the fast planner are shared with the study above.")
    counts = rep.store.outcome_counts(by=("planner",), study=STUDY_PLANNERS) if rep.has(STUDY_PLANNERS) else {}
    planners = sorted(p for (p,) in counts)
    if len(planners) < 2:
        rep.absent(STUDY_PLANNERS, "Run `nodnav reproduce --planners fast,prm` to add it (the prm planner builds "
                   "roadmaps on first use and caches them on disk).")
        return
    cells = {p: {c.key: c for c in rate_cells(rep.store, STUDY_PLANNERS, method="nod", planner=p)} for p in planners}
    keys = sorted(set.intersection(*(set(c) for c in cells.values())))
    if not keys:
        rep.add("", f"The planners {', '.join(planners)} share no scenario and game-player count in study "
                f"`{STUDY_PLANNERS}`: nothing to compare.", "")
        return
    rates = np.full((len(keys), len(planners), 3), np.nan)
    table = []
    for a, key in enumerate(keys):
        row = [key[0], key[1]]
        for b, p in enumerate(planners):
            iv = cells[p][key].rate()
            rates[a, b] = (iv.rate, iv.low, iv.high)
            row.append(fmt_rate(iv, cells[p][key].trials))
        table.append(row)
    path = plot_rate_bars([f"{s}\nk={k}" for s, k in keys], planners, rates, rep.out / "planners-success-rates.png",
                          title="Success rate per planner (NOD)")
    rep.figure(path, "planners", f"from study `{STUDY_PLANNERS}`")
    rep.add(*md_table(["scenario", "k"] + planners, table))
    records = {p: rep.store.records(STUDY_PLANNERS, method="nod", planner=p) for p in planners}
    cost_rows = []
    for p in planners:
        ms = mean_sd(r.summary.get("makespan_s") for r in records[p] if r.success)
        wall = mean_sd(r.summary.get("wall_time_s") for r in records[p])
        cost_rows.append([p, len(records[p]), fmt_mean_sd(*ms), fmt_mean_sd(*wall, digits=2)])
    rep.add("", *md_table(["planner", "trials", "makespan of successes (s)", "wall time per trial (s)"], cost_rows))
    sentences = []
    ref = "fast" if "fast" in planners else planners[0]
    for p in planners:
        if p == ref:
            continue
        k1, n1 = pooled([cells[p][k] for k in keys])
        k2, n2 = pooled([cells[ref][k] for k in keys])
        d = newcombe_difference(k1, n1, k2, n2)
        split = [intervals_separate(cells[p][k].rate(), cells[ref][k].rate()) for k in keys]
        verdict = planner_verdict(d)
        sentences.append(f"{p} vs {ref} over {len(keys)} cells: {fmt_rate(wilson_interval(k1, n1))} vs "
                         f"{fmt_rate(wilson_interval(k2, n2))} % pooled, difference {100 * d.rate:+.1f} points "
                         f"[{100 * d.low:+.1f}, {100 * d.high:+.1f}] (Newcombe 95 %); {verdict}. Cells with "
                         f"non-overlapping intervals: {sum(s != 0 for s in split)} of {len(keys)}.")
    rep.read(sentences)


def section_methods(rep: ReportDocument) -> None:
    """Success, failures, makespan and smoothness per navigation method and scenario."""
    rep.add("## Methods compared", "",
            "Every navigation method on every built-in scenario with the scenario's own settings (all game players, "
            "zero initial opinions, no bias, fast planner). Makespan and smoothness (the mean change of velocity per "
            "control step, docs/metrics.md): mean ± standard deviation over the successful trials, since a robot "
            "stuck in a deadlock stands still and would look smooth.")
    if not rep.has(STUDY_METHODS):
        rep.absent(STUDY_METHODS, "Run `nodnav reproduce` to add it.")
        return
    rows = method_rows(rep.store.records(STUDY_METHODS))
    scenarios = sorted({r.scenario for r in rows})
    methods = sorted({r.method for r in rows})
    by = {(r.scenario, r.method): r for r in rows}
    rates = np.full((len(scenarios), len(methods), 3), np.nan)
    for a, s in enumerate(scenarios):
        for b, m in enumerate(methods):
            if (s, m) in by:
                iv = by[(s, m)].cell.rate()
                rates[a, b] = (iv.rate, iv.low, iv.high)
    path = plot_rate_bars(scenarios, methods, rates, rep.out / "methods-success-rates.png",
                          title="Success rate per method")
    rep.figure(path, "methods", f"from study `{STUDY_METHODS}`")
    table = []
    for r in rows:
        table.append([r.scenario, r.method, r.cell.trials] + [fmt_rate(r.cell.rate(o)) for o in
                                                               ("success", "collision", "deadlock", "timeout")]
                     + [r.cell.counts.get("error", 0), fmt_mean_sd(*r.makespan),
                        fmt_mean_sd(*r.smoothness, digits=3)])
    rep.add(*md_table(["scenario", "method", "trials", "success %", "collision %", "deadlock %", "timeout %", "errors",
                        "makespan (s)", "smoothness (m/s/step)"], table))
    rep.read(methods_reading(rows))
