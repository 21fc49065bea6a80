"""The paper's evaluation read back from a results database, and ``report.md`` written from it.

Every number of the report comes from the trials stored by :mod:`nodnav.experiments.sweep`,
grouped by the study that ran them (the names are the ``STUDY_*`` constants, which
:mod:`nodnav.experiments.reproduce` uses). Only two things are recomputed when the report is
built, both deterministically: the pure-NOD heatmaps of Fig. 2a/2b (an ODE) and the two snapshot
figures, whose trials are re-run from their stored configuration and seed.

Statistics
----------
A rate ``k / n`` is reported with its 95 % Wilson score interval (:func:`wilson_interval`); a
difference of two rates with Newcombe's hybrid score interval (:func:`newcombe_difference`),
which is built from the two Wilson intervals. Two rates are called different only when their
intervals do not overlap, a conservative rule that the report states wherever it uses it.
"""

from __future__ import annotations

import logging
import math
from collections import defaultdict
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from nodnav.decision.strategies import order_label, passing_orders
from nodnav.experiments.breakdown import breakdown_lines
from nodnav.experiments.scaling_report import section_scaling
from nodnav.experiments.store import OUTCOMES, ResultStore, TrialRecord

log = logging.getLogger(__name__)

#: Two-sided 95 % quantile of the standard normal distribution.
Z95 = 1.959963984540054

STUDY_SUCCESS = "paper-success-rates"
"""Every built-in scenario x every game-player count, NOD with the fast planner (Fig. 3)."""
STUDY_TABLE1 = "paper-table1"
"""3-Robot Case-2 with zero and distance-based initial opinions (Table I)."""
STUDY_TABLE2 = "paper-table2"
"""3-Robot Case-3 without bias and with b = 150 on S3 and S5 (Table II)."""
STUDY_FIG2C = "paper-fig2c"
"""2-Robot Case-2, u = 10, over a grid of given z_11(0), z_21(0) (Fig. 2c)."""
STUDY_METHODS = "methods"
"""Every navigation method on every built-in scenario with its own settings."""
STUDY_PLANNERS = "planners"
"""The success-rate study with every planner compared."""
META_STUDY = "reproduce"
"""Not a study of trials: what ``nodnav reproduce`` asked for and did, stored in the studies table."""

#: Table I of the paper, percent per strategy S1..S6, by initial opinions.
PAPER_TABLE1 = {"zero": (10.0, 21.67, 10.00, 18.33, 6.67, 33.33), "distance": (0.0, 0.0, 40.0, 60.0, 0.0, 0.0)}
#: Table II of the paper, percent per strategy S1..S6, by bias label.
PAPER_TABLE2 = {"": (6.67, 41.67, 8.33, 23.33, 1.67, 18.33), "S3=150,S5=150": (0.0, 0.0, 53.33, 0.0, 46.67, 0.0)}
#: The strategies each paper row's claim is about (1-based): robot 2 first (Table I, eq. (11)),
#: robot 1 second (Table II, bias).
PAPER_CLAIMED_SETS = {("table1", "distance"): (3, 4), ("table2", "S3=150,S5=150"): (3, 5)}
#: The paper's success rates (Fig. 3 and its text): 0 % without game players, "close to 100 %" with any.
PAPER_NEAR_ALL = 100.0
#: How close to 100 % "close to" is taken to be when reading our numbers against the paper.
NEAR_ALL_MARGIN = 10.0
#: A planner difference inside +-this many percentage points counts as "barely matters".
PLANNER_EQUIVALENCE = 10.0

SNAPSHOTS = (
    {"scenario": "3r-case4", "players": 2, "count": 4, "figure": "fig4-3r-case4-snapshots.png",
     "paper": "Fig. 4: 3-Robot Case-4, every robot plays with all others"},
    {"scenario": "4r-case4", "players": 1, "count": 5, "figure": "fig5-4r-case4-snapshots.png",
     "paper": "Fig. 5: 4-Robot Case-4, one game player per robot"},
)


# ---------------------------------------------------------------------------------------------
# Statistics


@dataclass(frozen=True)
class Interval:
    """A rate (or a difference of rates) and its confidence interval, all as fractions in [0, 1]
    (in [-1, 1] for a difference); arrays when the inputs were arrays, NaN where ``n = 0``."""

    rate: np.ndarray | float
    """Point estimate ``k / n``."""
    low: np.ndarray | float
    """Lower end of the interval."""
    high: np.ndarray | float
    """Upper end of the interval."""


def wilson_interval(successes, trials, z: float = Z95) -> Interval:
    """Wilson score interval of a binomial proportion ``k / n`` (Wilson 1927).

    ``centre = (k + z^2/2) / (n + z^2)``, ``half-width = z sqrt(k (n - k) / n + z^2 / 4) / (n + z^2)``:
    the set of ``p`` that a two-sided score test at level ``z`` does not reject. Vectorised over
    ``successes`` and ``trials``; NaN where ``trials == 0``. Unlike the normal approximation it
    stays inside [0, 1] and is not degenerate at ``k = 0`` or ``k = n``.
    """
    k = np.asarray(successes, dtype=float)
    n = np.asarray(trials, dtype=float)
    if np.any(k < 0) or np.any(k > n):
        raise ValueError(f"need 0 <= successes <= trials, got {successes!r} of {trials!r}")
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(n > 0, k / n, np.nan)
        denom = n + z * z
        centre = (k + z * z / 2.0) / denom
        half = z * np.sqrt(np.where(n > 0, k * (n - k) / n, np.nan) + z * z / 4.0) / denom
    # At k = 0 and k = n the ends are exactly 0 and 1; rounding would put them a hair inside.
    low = np.where(k == 0, 0.0, np.clip(centre - half, 0.0, 1.0))
    high = np.where(k == n, 1.0, np.clip(centre + half, 0.0, 1.0))
    low, high = np.where(n > 0, low, np.nan), np.where(n > 0, high, np.nan)
    if rate.ndim == 0:
        return Interval(float(rate), float(low), float(high))
    return Interval(rate, low, high)


def newcombe_difference(k1, n1, k2, n2, z: float = Z95) -> Interval:
    """Difference ``p1 - p2`` of two independent proportions with Newcombe's hybrid score interval.

    With Wilson intervals ``[l_i, u_i]`` of each proportion (Newcombe 1998, method 10):
    ``low = d - sqrt((p1 - l1)^2 + (u2 - p2)^2)``, ``high = d + sqrt((u1 - p1)^2 + (p2 - l2)^2)``.
    """
    a, b = wilson_interval(k1, n1, z), wilson_interval(k2, n2, z)
    d = np.asarray(a.rate) - np.asarray(b.rate)
    low = d - np.sqrt((np.asarray(a.rate) - a.low) ** 2 + (b.high - np.asarray(b.rate)) ** 2)
    high = d + np.sqrt((a.high - np.asarray(a.rate)) ** 2 + (np.asarray(b.rate) - b.low) ** 2)
    if d.ndim == 0:
        return Interval(float(d), float(low), float(high))
    return Interval(d, low, high)


def intervals_separate(a: Interval, b: Interval) -> int:
    """+1 when ``a``'s interval lies wholly above ``b``'s, -1 wholly below, 0 when they overlap or either is empty."""
    if any(math.isnan(float(x)) for x in (a.low, a.high, b.low, b.high)):
        return 0
    if a.low > b.high:
        return 1
    if a.high < b.low:
        return -1
    return 0


def fmt_rate(iv: Interval, n: int | None = None) -> str:
    """``92.5 [81.8, 97.4]`` in percent, with `` (n)`` when ``n`` is given; ``-`` when undefined."""
    if math.isnan(float(iv.rate)):
        return "-"
    text = f"{100 * iv.rate:.1f} [{100 * iv.low:.1f}, {100 * iv.high:.1f}]"
    return f"{text} ({n})" if n is not None else text


def _mean_sd(values) -> tuple[float, float, int]:
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return math.nan, math.nan, 0
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else 0.0, int(v.size)


def _fmt_mean_sd(mean: float, sd: float, n: int, digits: int = 1) -> str:
    if n == 0:
        return "-"
    return f"{mean:.{digits}f} ± {sd:.{digits}f}" if n > 1 else f"{mean:.{digits}f}"


# ---------------------------------------------------------------------------------------------
# Outcome rates


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
                              _mean_sd(r.summary.get("makespan_s") for r in recs if r.outcome == "success"),
                              _mean_sd(r.metrics.get("smoothness_mps") for r in recs if r.outcome == "success")))
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
        worst = max(failures, key=failures.get)
        if failures[worst]:
            out.append(f"{m}: most failures are {worst}s ({failures[worst]} of {pooled(cells)[1]} trials).")
    if reference in methods:
        ref = {r.scenario: r for r in rows if r.method == reference}
        for m in methods:
            if m == reference:
                continue
            higher, lower, same, faster, compared, smoother, both = [], [], [], 0, 0, 0, 0
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


# ---------------------------------------------------------------------------------------------
# The report


@dataclass(frozen=True)
class SnapshotResult:
    """One snapshot figure: which stored trial was re-run and whether it came out the same."""

    scenario: str
    """Scenario name."""
    players: int
    """Game players per robot."""
    success: bool
    """Whether a figure was written."""
    reason: str
    """Why not, or what was re-run."""
    path: Path | str = ""
    """The figure."""
    seed: int = 0
    """Seed of the re-run trial."""
    reproduced: bool = False
    """Whether the re-run gave the stored outcome and simulated time."""


@dataclass(frozen=True)
class ReportResult:
    """What :func:`build_report` wrote."""

    success: bool
    """Whether ``report.md`` was written."""
    reason: str
    """One line: what was written, or why nothing was."""
    path: Path
    """``report.md``."""
    figures: tuple[Path, ...] = ()
    """Every PNG written."""
    missing: tuple[str, ...] = ()
    """Studies the report looked for and did not find."""
    snapshots: tuple[SnapshotResult, ...] = ()
    """The snapshot re-runs."""
    notes: tuple[str, ...] = ()
    """Generated readings, in report order (also in ``report.md``)."""


def _produced(command: str, source: str) -> str:
    return f"*Produced by `{command}` {source}.*"


def _md_table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines


class _Report:
    """Collects the markdown, figures and readings of one report."""

    def __init__(self, store: ResultStore, out: Path, command: str):
        self.store, self.out, self.command = store, out, command
        self.lines: list[str] = []
        self.figures: list[Path] = []
        self.missing: list[str] = []
        self.notes: list[str] = []
        self.studies = store.studies()

    def add(self, *lines: str) -> None:
        self.lines.extend(lines)

    def read(self, sentences: list[str]) -> None:
        self.notes.extend(sentences)
        self.add("", "**Reading (generated from the numbers above).**", "")
        self.add(*(f"- {s}" for s in sentences))
        self.add("")

    def figure(self, path: Path, alt: str, source: str) -> None:
        self.figures.append(path)
        self.add("", f"![{alt}]({path.name})", "", _produced(self.command, source), "")

    def absent(self, study: str, how: str) -> None:
        self.missing.append(study)
        self.add("", f"Not in this database: no trials of study `{study}`. {how}", "")

    def has(self, study: str) -> bool:
        return self.store.count(study) > 0


def _section_overview(rep: _Report, db_path: Path) -> None:
    store = rep.store
    records_n = store.count()
    versions = sorted(store.code_versions()) if records_n else []
    rep.add("# nodnav: the paper's evaluation, reproduced", "",
            f"Generated by `{rep.command}` on {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC from the results "
            f"database `{db_path.name}` ({records_n} trials, code versions {', '.join(versions) or '-'}"
            f"{f'; {store.stale_count()} older rows re-run under a newer version are kept apart' if store.stale_count() else ''}"
            "). Every number below "
            "is read from that database; only the Fig. 2a/2b heatmaps (an ODE) and the two snapshot trials "
            "(re-run from their stored seed) are recomputed, both deterministically. The paper is Alghamdi and Park, "
            "*Opinion-Driven Decision-Making for Multi-Robot Navigation through Narrow Corridors*.", "",
            "Rates are percentages with their 95 % Wilson score interval in brackets and the number of trials in "
            "parentheses. Two rates are called different only when their intervals do not overlap. Strategies "
            "S1..S_{N_s} are the passing orders in lexicographic order, robots numbered from 1 as in the paper.", "")
    meta = rep.studies.get(META_STUDY)
    rep.add("## What was run", "")
    if meta:
        rows = []
        for p in meta.get("parts", []):
            n = store.count(p["study"])
            rows.append([p["title"], f"`{p['study']}`", p["target"], p["seeds"], n,
                         "complete" if p["seeds"] >= p["target"] else f"cut to {p['seeds']} of {p['target']} seeds"])
        rep.add(*_md_table(["part", "study", "trials per cell asked", "trials per cell run", "trials stored", "status"],
                           rows))
        budget = meta.get("budget_s")
        rep.add("", f"`{meta.get('command', 'nodnav reproduce')}` ran with {meta.get('jobs', '?')} worker process(es)"
                f"{'' if not budget else f' and a budget of {budget / 60:.0f} min'}; its trials took "
                f"{meta.get('trials_wall_s', 0) / 60:.1f} min of wall-clock time in "
                f"{len(meta.get('levels', []))} round(s) of seeds (seeds per part and round: "
                f"{'; '.join(', '.join(f'{k} {v}' for k, v in lv.items()) for lv in meta.get('levels', []))}).")
        for line in meta.get("cuts", []):
            rep.add(f"- Cut: {line}")
        for line in meta.get("notes", []):
            rep.add(f"- Note: {line}")
        rep.add("")
    else:
        rep.add("This database was not written by `nodnav reproduce`; the sections below use whichever of its "
                "studies they find.", "")
    known = (STUDY_SUCCESS, STUDY_TABLE1, STUDY_TABLE2, STUDY_FIG2C, STUDY_METHODS, STUDY_PLANNERS)
    studies = sorted(n for n in set(rep.studies) | set(known) if n != META_STUDY and store.count(n))
    listed = ", ".join(f"`{n}` ({store.count(n)} trials)" for n in studies)
    rep.add(f"Studies in the database: {listed or 'none'}.", "")


def _section_success(rep: _Report) -> None:
    from nodnav.viz.report import plot_rate_bars

    rep.add("## Success rates (Fig. 3)", "",
            "Every built-in scenario with every number of game players per robot, zero initial opinions, no "
            "bias, NOD with the fast planner. The paper reports 0 % without game players and success \"close to "
            "100 %\" with any number of them (it gives no per-cell numbers).")
    if not rep.has(STUDY_SUCCESS):
        rep.absent(STUDY_SUCCESS, "Run `nodnav reproduce` to add it.")
        return
    planners = sorted({r for (r,) in rep.store.outcome_counts(by=("planner",), study=STUDY_SUCCESS)})
    planner = "fast" if "fast" in planners else planners[0]
    cells = rate_cells(rep.store, STUDY_SUCCESS, by=("n_robots", "scenario", "players"), method="nod", planner=planner)
    if not cells:
        rep.absent(STUDY_SUCCESS, "It holds no trial of the nod method.")
        return
    scenarios = sorted({c.key[:2] for c in cells})
    max_players = max(c.key[2] for c in cells)
    by = {c.key: c for c in cells}
    rates = np.full((len(scenarios), max_players + 1, 3), np.nan)
    table = []
    for a, (n_r, s) in enumerate(scenarios):
        row = [s]
        for k in range(max_players + 1):
            cell = by.get((n_r, s, k))
            if cell is None:
                row.append("")
                continue
            iv = cell.rate()
            rates[a, k] = (iv.rate, iv.low, iv.high)
            row.append(fmt_rate(iv, cell.trials))
        table.append(row)
    path = plot_rate_bars([s for _, s in scenarios],
                          [f"{k} game player{'s' if k != 1 else ''}" for k in range(max_players + 1)],
                          rates, rep.out / "fig3-success-rates.png",
                          title=f"Success rate per scenario and game players (NOD, {planner} planner)")
    rep.figure(path, "success rates", f"from study `{STUDY_SUCCESS}`")
    rep.add(*_md_table(["scenario"] + [f"k = {k}" for k in range(max_players + 1)], table))
    rep.add("", "*k: game players per robot (k = N_r - 1 is every other robot, the paper's first study).*")
    sentences = []
    some = [c for c in cells if c.key[2] >= 1]
    none = [c for c in cells if c.key[2] == 0]
    if some:
        k, n = pooled(some)
        iv = wilson_interval(k, n)
        worst = min(some, key=lambda c: c.rate().rate)
        below = [c for c in some if c.rate().high < (PAPER_NEAR_ALL - NEAR_ALL_MARGIN) / 100]
        verdict = ("consistent with" if iv.high * 100 >= PAPER_NEAR_ALL - NEAR_ALL_MARGIN and not below
                   else "below")
        sentences.append(f"With at least one game player, {k} of {n} trials succeeded: {fmt_rate(iv)} % pooled "
                         f"(paper: close to 100 %), lowest cell {worst.key[1]} k = {worst.key[2]} at "
                         f"{fmt_rate(worst.rate(), worst.trials)}. Read against 'close to 100 %' taken as "
                         f"at least {PAPER_NEAR_ALL - NEAR_ALL_MARGIN:.0f} %, this is {verdict} the paper"
                         + (f"; {len(below)} cell(s) have their whole interval below that: "
                            + ", ".join(f"{c.key[1]} k = {c.key[2]}" for c in below) if below else "") + ".")
        full = [c for c in some if c.key[2] == c.key[0] - 1]
        reduced = [c for c in some if c.key[2] < c.key[0] - 1]
        if full and reduced:
            kf, nf = pooled(full)
            kr, nr = pooled(reduced)
            d = newcombe_difference(kr, nr, kf, nf)
            sentences.append(f"Game reduction (1 <= k < N_r - 1, {nr} trials) against all players (k = N_r - 1, "
                             f"{nf} trials): {fmt_rate(wilson_interval(kr, nr))} vs "
                             f"{fmt_rate(wilson_interval(kf, nf))} %, difference {100 * d.rate:+.1f} points "
                             f"[{100 * d.low:+.1f}, {100 * d.high:+.1f}] (Newcombe 95 %).")
    if none:
        k, n = pooled(none)
        iv = wilson_interval(k, n)
        sentences.append(f"Without game players, {k} of {n} trials succeeded: {fmt_rate(iv)} % (paper: 0 %). "
                         + ("Every one of them failed, as in the paper." if k == 0 else
                            "Unlike the paper, some succeeded; see the outcomes below."))
        failures = {o: pooled(none, o)[0] for o in OUTCOMES if o != "success"}
        sentences.append("Their outcomes: " + ", ".join(f"{o} {v}" for o, v in failures.items() if v) + ".")
    rep.read(sentences)


def _strategy_section(rep: _Report, title: str, study: str, scenario: str, column: str, paper: dict, labels: dict,
                      table: str, figure: str, intro: str) -> None:
    from nodnav.viz.report import plot_strategy_frequencies

    rep.add(f"## {title}", "", intro)
    if not rep.has(study):
        rep.absent(study, "Run `nodnav reproduce` to add it.")
        return
    n_r = rep.store.records(study)[0].n_robots
    orders = passing_orders(n_r)
    rows = table_rows(rep.store, study, column, list(paper), n_r)
    header = ([labels["header"]] + [f"S{j + 1} {order_label(o)}" for j, o in enumerate(orders)]
              + ["trials", "no complete order"])
    lines = []
    for freq in rows:
        lines.append([f"{labels[freq.label]} (paper)"] + [f"{v:.2f}" for v in paper[freq.label]] + ["", ""])
        sh = freq.share
        lines.append([f"{labels[freq.label]} (ours)"] + [
            f"{100 * sh.rate[j]:.1f} [{100 * sh.low[j]:.0f}, {100 * sh.high[j]:.0f}]" if freq.realised else "-"
            for j in range(len(orders))] + [freq.trials, freq.incomplete])
    path = plot_strategy_frequencies(rows, [paper[f.label] for f in rows],
                                     [f"{labels['header']} = {labels[f.label]}" for f in rows],
                                     rep.out / figure, title=f"{scenario}: realised passing orders")
    rep.figure(path, title, f"from study `{study}`")
    rep.add(*_md_table(header, lines))
    rep.add("", "*Ours: share of the realised passing orders (the order in which the robots entered the corridor), "
            "with its 95 % interval; trials that ended before every robot entered count under 'no complete order'.*")
    sentences = []
    for freq in rows:
        name = f"{labels['header']} = {labels[freq.label]}"
        if not freq.realised:
            sentences.append(f"{name}: no trial realised a complete order.")
            continue
        inside = paper_inside(freq, paper[freq.label])
        used = int(np.sum(freq.counts > 0))
        text = (f"{name}: {freq.realised} trials realised an order; {used} of {len(orders)} strategies occurred "
                f"(paper: {int(np.sum(np.asarray(paper[freq.label]) > 0))}); the paper's percentage lies inside our "
                f"interval for {inside} of {len(orders)} strategies")
        claimed = PAPER_CLAIMED_SETS.get((table, freq.label))
        if claimed:
            iv = freq.set_share(claimed)
            names = " or ".join(f"S{j}" for j in claimed)
            text += (f"; {names} (the paper's only choices) took {fmt_rate(iv)} % of ours (paper: 100 %), "
                     + ("consistent with the paper" if iv.high >= 0.999 else
                        "so other orders also occurred, unlike the paper"))
        sentences.append(text + ".")
    rep.read(sentences)


def _section_fig2(rep: _Report, heatmap_grid: int) -> None:
    from nodnav.decision.heatmap import steady_state_selection, z_grid
    from nodnav.viz.heatmap import plot_heatmap
    from nodnav.viz.report import plot_closed_loop_grid

    rep.add("## Fig. 2: strategy selection of two robots over initial opinions", "",
            "Two robots, strategies S1 = (1,2) and S2 = (2,1), z_12(0) = z_22(0) = 0. (a) and (b): the steady-state "
            "limit of x_11 under the pure NOD, eqs. (1) and (3), for u = 1 and u = 10, integrated to convergence "
            f"on a {heatmap_grid} x {heatmap_grid} grid (recomputed, deterministic). The pure NOD predicts x_11 = 1/2 "
            "everywhere for u < 2 and, for u > 2, agreement on S1 when z_11(0) + z_21(0) > 0 and on S2 when it is "
            "negative.")
    sentences = []
    for u, tag in ((1.0, "a"), (10.0, "b")):
        result = steady_state_selection(u, z_grid(heatmap_grid))
        path = plot_heatmap(result, rep.out / f"fig2{tag}-nod-u{u:g}.png")
        rep.figure(path, f"Fig. 2{tag}", f"(recomputed from eqs. (1) and (3), u = {u:g})")
        x = result.x11
        z = result.z_values
        total = z[:, None] + z[None, :]
        if u < 2:
            sentences.append(f"Fig. 2{tag} (u = {u:g}): lim x_11 lies in [{x.min():.4f}, {x.max():.4f}]"
                             f"{'' if result.converged else ' (not converged: ' + result.reason + ')'}; "
                             "no strategy is preferred, as predicted.")
        else:
            pos, neg = total > 1e-12, total < -1e-12
            sentences.append(f"Fig. 2{tag} (u = {u:g}): lim x_11 > 0.99 on {int((x[pos] > 0.99).sum())} of "
                             f"{int(pos.sum())} cells with z_11(0) + z_21(0) > 0 and < 0.01 on "
                             f"{int((x[neg] < 0.01).sum())} of {int(neg.sum())} with it negative; on the anti-diagonal "
                             f"it is {np.diag(x[:, ::-1]).min():.3f}..{np.diag(x[:, ::-1]).max():.3f}"
                             f"{'' if result.converged else ' (not converged: ' + result.reason + ')'}.")
    rep.add("### Fig. 2c: the closed loop", "")
    if not rep.has(STUDY_FIG2C):
        rep.absent(STUDY_FIG2C, "Run `nodnav reproduce` to add it.")
        rep.read(sentences)
        return
    grid = closed_loop_grid(rep.store.records(STUDY_FIG2C, method="nod"))
    n = len(grid.z_values)
    per_cell = sorted(set(grid.trials.ravel().tolist()))
    rep.add(f"2-Robot Case-2 with u = {grid.u:g}, the initial opinions z_11(0), z_21(0) set on a {n} x {n} grid over "
            f"[{grid.z_values.min():g}, {grid.z_values.max():g}] and {'/'.join(map(str, per_cell))} trial(s) per "
            "cell (a grid and trial count sized to the time budget; the paper does not give its own). Each cell is "
            "the share of trials whose robots entered the corridor in the order S1 = (1,2); grey cells realised no "
            "order.")
    path = plot_closed_loop_grid(grid, rep.out / "fig2c-closed-loop.png")
    rep.figure(path, "Fig. 2c", f"from study `{STUDY_FIG2C}`")
    agree, decided = sign_rule_agreement(grid)
    sentences.append(f"Fig. 2c: {int(grid.trials.sum())} trials, {int(grid.realised.sum())} realised an order. In "
                     f"{agree} of {decided} cells off the anti-diagonal with a majority, the majority order is the one "
                     "the pure NOD selects (S1 when z_11(0) + z_21(0) > 0).")
    rep.read(sentences)


def _section_snapshots(rep: _Report, rerun: bool) -> list[SnapshotResult]:
    rep.add("## Snapshots (Figs. 4 and 5)", "",
            "A successful stored trial (the lowest such seed; the lowest seed if none succeeded) is re-run from "
            "its stored configuration and seed; "
            "trials are reproducible from their seed, and the report checks that the re-run ends with the stored "
            "outcome at the stored time. Top row: robots, trails and game players (arrows to each robot's players); "
            "bottom: each robot's chosen passing order at every decision and its probability.")
    results = []
    for snap in SNAPSHOTS:
        results.append(snap_result := _snapshot(rep, snap, rerun))
        if snap_result.success:
            rep.add("", f"**{snap['paper']}** (seed {snap_result.seed}): {snap_result.reason}")
            rep.figure(Path(snap_result.path), snap["paper"],
                       f"by re-running seed {snap_result.seed} of study `{STUDY_SUCCESS}`")
        else:
            rep.add("", f"**{snap['paper']}**: {snap_result.reason}", "")
    return results


def _snapshot(rep: _Report, snap: dict, rerun: bool) -> SnapshotResult:
    from nodnav.scenario.schema import scenario_from_dict
    from nodnav.sim.simulator import run_trial
    from nodnav.viz.trial import save_snapshots

    stored = rep.store.records(STUDY_SUCCESS, scenario=snap["scenario"], players=snap["players"], method="nod")
    stored = [r for r in stored if r.planner == "fast"] or stored
    if not stored:
        return SnapshotResult(snap["scenario"], snap["players"], False,
                              f"no trial of {snap['scenario']} with {snap['players']} game player(s) is stored.")
    successes = [r for r in stored if r.success]
    # Without a stored success, the lowest seed shows how the method fails here instead.
    record = successes[0] if successes else stored[0]
    caveat = "" if successes else (f"none of the {len(stored)} stored trials succeeded, so this one shows how they "
                                   "fail; ")
    if not rerun:
        return SnapshotResult(snap["scenario"], snap["players"], False,
                              f"{caveat}seed {record.seed} would be re-run; re-runs were switched off for this report.",
                              seed=record.seed)
    scenario = scenario_from_dict(record.config["scenario"])
    result = run_trial(scenario, record.method, record.seed)
    stored_time = record.summary.get("sim_time_s")
    same = result.outcome == record.outcome and stored_time is not None and abs(result.sim_time - stored_time) < 1e-6
    if not same:
        log.warning("%s seed %d re-ran to %s at t = %.1f s, stored: %s at t = %s s", record.scenario, record.seed,
                    result.outcome, result.sim_time, record.outcome, stored_time)
    path = save_snapshots(result.history, rep.out / snap["figure"], count=snap["count"])
    order = ",".join(str(k + 1) for k in result.entry_order)
    reason = (f"{caveat}re-run: {result.outcome} at t = {result.sim_time:.1f} s, corridor entry order ({order}); "
              + ("identical to the stored trial." if same else
                 f"DIFFERS from the stored trial ({record.outcome} at t = {stored_time} s): the trial is not "
                 "reproducible from its seed with this version."))
    return SnapshotResult(snap["scenario"], snap["players"], True, reason, path, record.seed, same)


def _section_planners(rep: _Report) -> None:
    from nodnav.viz.report import plot_rate_bars

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
    rep.add(*_md_table(["scenario", "k"] + planners, table))
    records = {p: rep.store.records(STUDY_PLANNERS, method="nod", planner=p) for p in planners}
    cost_rows = []
    for p in planners:
        ms = _mean_sd(r.summary.get("makespan_s") for r in records[p] if r.success)
        wall = _mean_sd(r.summary.get("wall_time_s") for r in records[p])
        cost_rows.append([p, len(records[p]), _fmt_mean_sd(*ms), _fmt_mean_sd(*wall, digits=2)])
    rep.add("", *_md_table(["planner", "trials", "makespan of successes (s)", "wall time per trial (s)"], cost_rows))
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


def planner_verdict(d: Interval, margin: float = PLANNER_EQUIVALENCE) -> str:
    """What a difference of success rates between two planners says about "the planner barely matters".

    The claim holds when the whole interval of the difference lies within ``+-margin`` percentage
    points, is contradicted when it lies wholly beyond them, and is left open otherwise.
    """
    eq = margin / 100
    if d.low >= -eq and d.high <= eq:
        return (f"the whole interval lies within ±{margin:.0f} points, so at this sample size the paper's claim "
                "that the planner barely matters holds")
    if d.low > eq or d.high < -eq:
        return (f"the whole interval lies beyond ±{margin:.0f} points, so the planner does matter here, against "
                "the paper")
    return (f"the interval reaches beyond ±{margin:.0f} points, so these trials can neither confirm nor refute the "
            "claim")


def _section_methods(rep: _Report) -> None:
    from nodnav.viz.report import plot_rate_bars

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
                     + [r.cell.counts.get("error", 0), _fmt_mean_sd(*r.makespan),
                        _fmt_mean_sd(*r.smoothness, digits=3)])
    rep.add(*_md_table(["scenario", "method", "trials", "success %", "collision %", "deadlock %", "timeout %", "errors",
                        "makespan (s)", "smoothness (m/s/step)"], table))
    rep.read(methods_reading(rows))


def _section_cost(rep: _Report) -> None:
    rep.add("## Cost of a trial", "",
            "Wall-clock time of one trial in a worker process, as stored with each trial (one core per trial).", "")
    records = rep.store.records()
    if not records:
        rep.add("", "No trials stored.", "")
        return
    groups: dict[tuple, list[float]] = defaultdict(list)
    for r in records:
        w = r.summary.get("wall_time_s")
        if w is not None:
            groups[(r.n_robots, r.method, r.planner)].append(float(w))
    rows = []
    for (n, m, p), w in sorted(groups.items()):
        v = np.asarray(w)
        rows.append([n, m, p, len(v), f"{np.median(v):.1f}", f"{v.mean():.1f}", f"{np.percentile(v, 90):.1f}",
                     f"{v.sum() / 60:.1f}"])
    rep.add(*_md_table(["robots", "method", "planner", "trials", "median (s)", "mean (s)", "90th pct (s)",
                        "total (min)"], rows), "")


def build_report(db_path: str | Path, out_dir: str | Path, *, command: str = "nodnav report",
                 heatmap_grid: int = 41, rerun_snapshots: bool = True) -> ReportResult:
    """Write ``report.md`` and its figures into ``out_dir`` from the trials in ``db_path``.

    Sections whose study is missing say so and how to add it. ``command`` is quoted as the
    producer of every figure; ``heatmap_grid`` is the Fig. 2a/2b grid size; with
    ``rerun_snapshots`` false the snapshot trials are not re-run (and no snapshot figure drawn).
    """
    db_path, out = Path(db_path), Path(out_dir)
    report_path = out / "report.md"
    if not db_path.exists():
        return ReportResult(False, f"{db_path}: no such results database", report_path)
    out.mkdir(parents=True, exist_ok=True)
    with ResultStore(db_path) as store:
        rep = _Report(store, out, command)
        _section_overview(rep, db_path)
        rep.add(*breakdown_lines(store))
        _section_success(rep)
        _strategy_section(
            rep, "Table I: initial opinions (3-Robot Case-2)", STUDY_TABLE1, "3r-case2", "init", PAPER_TABLE1,
            {"header": "z_ij(0)", "zero": "0", "distance": "Eq. (11)"}, "table1", "table1-3r-case2.png",
            "Robot 2 is alone on the right and closest to the corridor; robots 1 and 3 are on the left at equal "
            "distance. With the distance-based initial opinions (10)-(11) the paper's robots chose only S3 = (2,1,3) "
            "and S4 = (2,3,1), both letting robot 2 go first. The paper ran 30 trials for that row; the "
            "percentages of its first row are multiples of 1/60.")
        _strategy_section(
            rep, "Table II: bias (3-Robot Case-3)", STUDY_TABLE2, "3r-case3", "bias", PAPER_TABLE2,
            {"header": "bias", "": "0", "S3=150,S5=150": "150 on S3, S5"}, "table2", "table2-3r-case3.png",
            "Robot 1 is alone on the left against robots 2 and 3. With b_ij = 150 for S3 = (2,1,3) and S5 = (3,1,2) "
            "(robot 1 passes second) the paper's robots chose only those two. The paper's percentages are multiples "
            "of 1/60.")
        _section_fig2(rep, heatmap_grid)
        snapshots = _section_snapshots(rep, rerun_snapshots)
        _section_planners(rep)
        _section_methods(rep)
        section_scaling(rep, wilson_interval)  # beyond the paper: 5-8 robots (nodnav.experiments.scaling_report)
        _section_cost(rep)
    report_path.write_text("\n".join(rep.lines).rstrip() + "\n")
    reason = (f"wrote {report_path} with {len(rep.figures)} figures"
              + (f"; missing studies: {', '.join(rep.missing)}" if rep.missing else ""))
    return ReportResult(True, reason, report_path, tuple(rep.figures), tuple(rep.missing), tuple(snapshots),
                        tuple(rep.notes))
