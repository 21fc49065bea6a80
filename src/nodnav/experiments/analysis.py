"""The paper's tables read from a results database: outcome rates, strategy frequencies,
the closed-loop grid of Fig. 2c, and the methods comparison (numbers only; the words are
:mod:`nodnav.reporting.report`'s)."""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from nodnav.experiments.statistics import (
    Interval,
    fmt_rate,
    intervals_separate,
    mean_sd,
    newcombe_difference,
    wilson_interval,
)
from nodnav.experiments.store import OUTCOMES, ResultStore, TrialRecord


@dataclass(frozen=True)
class RateCell:
    """The outcomes of the trials of one group (a scenario and a game-player count, a method, ...)."""

    key: tuple
    """The group, e.g. ``("3r-case2", 2)``."""
    counts: dict[str, int]
    """Trials per outcome (outcomes with none left out)."""

    @property
    def trials(self) -> int:
        """Number of trials."""
        return int(sum(self.counts.values()))

    def rate(self, outcome: str = "success") -> Interval:
        """Share of trials with ``outcome`` and its Wilson interval."""
        return wilson_interval(self.counts.get(outcome, 0), self.trials)


def rate_cells(store: ResultStore, study: str, by=("scenario", "players"), **filters) -> list[RateCell]:
    """Outcome counts of ``study`` grouped by the columns ``by``, in the database's order."""
    return [RateCell(key, counts) for key, counts in store.outcome_counts(by=by, study=study, **filters).items()]


def pooled(cells: list[RateCell], outcome: str = "success") -> tuple[int, int]:
    """Total trials with ``outcome`` and total trials over ``cells``."""
    return sum(c.counts.get(outcome, 0) for c in cells), sum(c.trials for c in cells)


# ---------------------------------------------------------------------------------------------
# Strategy frequencies (Tables I and II)


@dataclass(frozen=True)
class StrategyFrequencies:
    """How often each passing order was realised in a set of trials."""

    label: str
    """What the trials have in common, e.g. ``distance``."""
    counts: np.ndarray
    """``(N_s,)`` trials whose robots entered the corridor in the order of strategy ``S_{j+1}``."""
    trials: int
    """Trials in the set."""

    @property
    def realised(self) -> int:
        """Trials in which every robot entered the corridor (so a passing order was realised)."""
        return int(self.counts.sum())

    @property
    def incomplete(self) -> int:
        """Trials that ended before every robot had entered the corridor."""
        return self.trials - self.realised

    @property
    def share(self) -> Interval:
        """Share of each strategy among the realised orders, with Wilson intervals ``(N_s,)``."""
        return wilson_interval(self.counts, np.full(self.counts.shape, self.realised))

    def set_share(self, strategies) -> Interval:
        """Share of the realised orders that are one of ``strategies`` (1-based numbers)."""
        return wilson_interval(int(self.counts[[j - 1 for j in strategies]].sum()), self.realised)


def strategy_frequencies(records: list[TrialRecord], n_strategies: int, label: str = "") -> StrategyFrequencies:
    """Count the realised passing order (the stored ``strategy``, 1-based) of every trial.

    A trial without a complete corridor entry order (``strategy`` null) counts in ``trials`` but
    in no strategy.
    """
    counts = np.zeros(n_strategies, dtype=int)
    for r in records:
        s = r.summary.get("strategy")
        if s is not None:
            if not 1 <= int(s) <= n_strategies:
                raise ValueError(f"trial {r.key[:12]}: strategy {s} outside S1..S{n_strategies}")
            counts[int(s) - 1] += 1
    return StrategyFrequencies(label=label, counts=counts, trials=len(records))


def table_rows(store: ResultStore, study: str, column: str, values, n_robots: int) -> list[StrategyFrequencies]:
    """One :class:`StrategyFrequencies` per value of ``column`` (``init`` or ``bias``) in ``study``."""
    n_s = math.factorial(n_robots)
    return [strategy_frequencies(store.records(study, **{column: v, "method": "nod"}), n_s, label=v) for v in values]


def paper_inside(freq: StrategyFrequencies, paper: tuple[float, ...]) -> int:
    """Number of strategies whose paper percentage lies inside our 95 % interval."""
    sh = freq.share
    p = np.asarray(paper) / 100.0
    return int(np.sum((p >= np.asarray(sh.low) - 1e-12) & (p <= np.asarray(sh.high) + 1e-12)))


# ---------------------------------------------------------------------------------------------
# Fig. 2c


@dataclass(frozen=True)
class ClosedLoopGrid:
    """Fig. 2c: how often the robots realised S1 = (1, 2), per pair of initial opinions."""

    z_values: np.ndarray
    """``(N,)`` grid values of ``z_11(0)`` (rows) and ``z_21(0)`` (columns)."""
    s1: np.ndarray
    """``(N, N)`` trials that realised S1."""
    realised: np.ndarray
    """``(N, N)`` trials that realised a complete order."""
    trials: np.ndarray
    """``(N, N)`` trials run."""
    u: float
    """Attention ``u`` of the trials (NaN when they differ)."""

    @property
    def fraction(self) -> np.ndarray:
        """Share of realised orders that were S1; NaN where no order was realised."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.realised > 0, self.s1 / np.maximum(self.realised, 1), np.nan)


def closed_loop_grid(records: list[TrialRecord]) -> ClosedLoopGrid:
    """Group Fig. 2c trials by their given initial opinions ``z_11(0)`` and ``z_21(0)``."""
    cells: dict[tuple[float, float], list[int]] = defaultdict(lambda: [0, 0, 0])
    us = set()
    for r in records:
        op = r.config["scenario"]["opinion"]
        z0 = op["z0"]
        cell = cells[(float(z0[0][0]), float(z0[1][0]))]
        s = r.summary.get("strategy")
        cell[0] += int(s == 1)
        cell[1] += int(s is not None)
        cell[2] += 1
        us.add(float(op["u"]))
    values = np.array(sorted({a for a, _ in cells} | {c for _, c in cells}), dtype=float)
    index = {v: i for i, v in enumerate(values)}
    arrays = np.zeros((3, len(values), len(values)), dtype=int)
    for (a, c), counts in cells.items():
        arrays[:, index[a], index[c]] = counts
    return ClosedLoopGrid(values, arrays[0], arrays[1], arrays[2], us.pop() if len(us) == 1 else math.nan)


def sign_rule_agreement(grid: ClosedLoopGrid) -> tuple[int, int]:
    """Cells off the anti-diagonal where the majority realised order follows the pure NOD's rule
    (S1 when ``z_11(0) + z_21(0) > 0``, S2 when negative, Fig. 2b), and cells with a majority."""
    z = grid.z_values
    total = z[:, None] + z[None, :]
    frac = grid.fraction
    decided = (np.abs(total) > 1e-12) & np.isfinite(frac) & (np.abs(frac - 0.5) > 1e-12)
    agree = decided & ((frac > 0.5) == (total > 0))
    return int(agree.sum()), int(decided.sum())


# ---------------------------------------------------------------------------------------------
# Methods comparison


@dataclass(frozen=True)
class MethodRow:
    """One method on one scenario."""

    scenario: str
    """Scenario name."""
    method: str
    """Method name."""
    cell: RateCell
    """Outcome counts."""
    makespan: tuple[float, float, int]
    """Mean and standard deviation of the makespan over successful trials (s), and their number."""
    smoothness: tuple[float, float, int]
    """Mean and standard deviation of the smoothness metric over successful trials (m/s per step), and their
    number (a robot stuck in a deadlock stands still, which would look smooth)."""


def method_rows(records: list[TrialRecord]) -> list[MethodRow]:
    """Rates and metrics per (scenario, method), in scenario then method order."""
    groups: dict[tuple[str, str], list[TrialRecord]] = defaultdict(list)
    for r in records:
        groups[(r.scenario, r.method)].append(r)
    rows = []
    for (scenario, method), recs in sorted(groups.items()):
        counts: dict[str, int] = defaultdict(int)
        for r in recs:
            counts[r.outcome] += 1
        rows.append(MethodRow(scenario, method, RateCell((scenario, method), dict(counts)),
                              mean_sd(r.summary.get("makespan_s") for r in recs if r.outcome == "success"),
                              mean_sd(r.metrics.get("smoothness_mps") for r in recs if r.outcome == "success")))
    return rows


def methods_reading(rows: list[MethodRow], reference: str = "nod") -> list[str]:
    """Sentences that read the methods table, generated from its numbers alone."""
    methods = sorted({r.method for r in rows})
    if len(methods) < 2:
        return [f"Only {', '.join(methods) or 'no method'} is in the database: there is nothing to compare."]
    out = []
    pooled_rates = {}
    for m in methods:
        cells = [r.cell for r in rows if r.method == m]
        k, n = pooled(cells)
        pooled_rates[m] = (wilson_interval(k, n), k, n)
    ranking = sorted(methods, key=lambda m: -pooled_rates[m][0].rate)
    out.append("Pooled over the scenarios, success rates rank " + "; ".join(
        f"{m} {fmt_rate(pooled_rates[m][0])} ({pooled_rates[m][1]}/{pooled_rates[m][2]})" for m in ranking) + ".")
    for m in methods:
        cells = [r.cell for r in rows if r.method == m]
        failures = {o: pooled(cells, o)[0] for o in OUTCOMES if o != "success"}
        worst = max(failures, key=lambda outcome: failures[outcome])
        if failures[worst]:
            out.append(f"{m}: most failures are {worst}s ({failures[worst]} of {pooled(cells)[1]} trials).")
    if reference in methods:
        ref = {r.scenario: r for r in rows if r.method == reference}
        for m in methods:
            if m == reference:
                continue
            higher: list[str] = []
            lower: list[str] = []
            same: list[str] = []
            faster = compared = smoother = both = 0
            for r in rows:
                if r.method != m or r.scenario not in ref:
                    continue
                other = ref[r.scenario]
                side = intervals_separate(other.cell.rate(), r.cell.rate())
                (higher if side > 0 else lower if side < 0 else same).append(r.scenario)
                if r.makespan[2] and other.makespan[2]:
                    compared += 1
                    faster += int(r.makespan[0] < other.makespan[0])
                if r.smoothness[2] and other.smoothness[2]:
                    both += 1
                    smoother += int(r.smoothness[0] < other.smoothness[0])
            d = newcombe_difference(pooled_rates[reference][1], pooled_rates[reference][2], pooled_rates[m][1],
                                    pooled_rates[m][2])
            text = (f"{reference} vs {m}: pooled difference {100 * d.rate:+.1f} points [{100 * d.low:+.1f}, "
                    f"{100 * d.high:+.1f}] (Newcombe 95 %); per scenario, {reference}'s success rate is higher on "
                    f"{len(higher)} scenario(s)"
                    f"{' (' + ', '.join(higher) + ')' if higher else ''}, lower on {len(lower)}"
                    f"{' (' + ', '.join(lower) + ')' if lower else ''}, and not distinguishable on {len(same)}")
            if compared:
                text += f"; where both succeeded, {m} had the shorter mean makespan on {faster} of {compared}"
            if both:
                text += (f"; where both succeeded, {m} moved more smoothly (lower mean velocity change) on "
                         f"{smoother} of {both}")
            out.append(text + ".")
        n = int(np.median([r.cell.trials for r in rows]))
        iv = wilson_interval(n / 2, n)
        out.append(f"With a median of {n} trials per cell, a 50 % rate is known only to within "
                   f"{100 * iv.low:.0f}-{100 * iv.high:.0f} %: differences smaller than that width go unnoticed "
                   "under the non-overlap rule.")
    return out
