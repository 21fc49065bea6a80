"""What any results database holds: success and failure classes by scenario or family, players and method.

This is the first section of every report (:func:`nodnav.reporting.report.build_report`), for a
plain sweep, a family sweep or the paper's evaluation alike. Trials of a generated family
(scenario ``FAMILY:SEED``) are grouped under their family; every failed one is listed with the
command that redoes it. Rates carry 95 % Wilson score intervals (SciPy's ``binomtest``).
"""

from __future__ import annotations

import re
import shlex
from collections import Counter, defaultdict
from dataclasses import dataclass

from nodnav.experiments.statistics import wilson_interval
from nodnav.experiments.store import ResultStore, TrialRecord
from nodnav.reporting.markdown import md_table
from nodnav.scenario.families import redo_spec
from nodnav.sim.failure import FAILURE_CLASSES, classify

#: Failed family trials listed with their command, at most.
MAX_LISTED = 500

_DRAW_NAME = re.compile(r"(?P<family>.+):[0-9]+")


@dataclass(frozen=True)
class Row:
    """One stored trial, reduced to what the breakdown groups and counts."""

    group: str
    """The family of a drawn scenario, else the scenario's name."""
    family: bool
    """Whether ``group`` is a generated family."""
    players: str
    """Game players per robot: ``all`` (N_r - 1) or the number."""
    method: str
    """Navigation method."""
    planner: str
    """Planner name."""
    failure_class: str
    """:data:`~nodnav.sim.failure.FAILURE_CLASSES` key, or ``error``."""
    redo: str | None
    """The command that redoes a trial of a family, else ``None``."""


def trial_class(record: TrialRecord) -> str:
    """The stored failure class, or for trials stored before classes existed, one from the outcome."""
    s = record.summary
    if "failure_class" in s:
        return s["failure_class"]
    return classify(record.outcome, s.get("collision_kind") or "", bool(s.get("consensus")), False)


def redo_command(record: TrialRecord, spec: str) -> str:
    """``nodnav run SPEC --seed S`` with every option of the trial that differs from the defaults."""
    sc = record.config["scenario"]
    words = ["nodnav run", spec, f"--seed {record.seed}"]
    if record.players != record.n_robots - 1:
        words.append(f"--players {record.players}")
    if record.init != "zero":
        words.append(f"--init {record.init}")
    if record.bias:
        words.append(f"--bias {record.bias}")
    if sc["opinion"].get("u", 100.0) != 100.0:
        words.append(f"--u {sc['opinion']['u']:g}")
    if record.planner != "fast":
        words.append(f"--planner {record.planner}")
    if sc["sim"].get("observation_noise", 0.0):
        words.append(f"--noise {sc['sim']['observation_noise']:g}")
    if record.method != "nod":
        words.append(f"--method {record.method}")
    words += [f"--set {shlex.quote(text)}" for text in record.config.get("set", ())]  # the study's set:
    return " ".join(words)


def to_row(record: TrialRecord) -> Row:
    """Group, settings, failure class and (for a family draw) the redo command of one trial."""
    spec = redo_spec(record.scenario, record.config["scenario"].get("description", ""))
    m = _DRAW_NAME.fullmatch(record.scenario)
    group = m["family"] if spec and m else record.scenario
    players = "all" if record.players == record.n_robots - 1 else str(record.players)
    return Row(group, spec is not None, players, record.method, record.planner, trial_class(record),
               redo_command(record, spec) if spec else None)


def fmt_success(k: int, n: int) -> str:
    """``93.8 [85.0, 97.5] (64)``: percent, its 95 % Wilson interval, the number of trials."""
    iv = wilson_interval(k, n)
    return f"{100 * k / n:.1f} [{100 * iv.low:.1f}, {100 * iv.high:.1f}] ({n})"


def _classes_text(counts: Counter) -> str:
    order = list(FAILURE_CLASSES) + sorted(set(counts) - set(FAILURE_CLASSES))
    return ", ".join(f"{c} {counts[c]}" for c in order if c != "success" and counts.get(c)) or "-"


def breakdown_lines(store: ResultStore) -> list[str]:
    """The markdown of the section: success table, failure-class table, failed family trials."""
    rows = [to_row(r) for r in store.records()]
    out = ["## What this database holds", ""]
    if not rows:
        return out + ["No trials yet: run `nodnav sweep` or `nodnav reproduce` into this database.", ""]
    out += [f"{len(rows)} trials. Success is the percentage of trials in which every robot arrived without "
            "contact, with its 95 % Wilson score interval and the number of trials. A generated family's trials "
            "(scenarios `FAMILY:SEED`) are grouped under the family; `players` is the number of game players per "
            "robot (`all`: every other robot).", ""]
    cells: dict[tuple, Counter] = defaultdict(Counter)
    for r in rows:
        cells[(r.group, r.family, r.players, r.method, r.planner)][r.failure_class] += 1
    table = []
    for key in sorted(cells, key=lambda k: (k[0], k[2] != "all", k[2].zfill(3), k[3], k[4])):
        group, family, players, method, planner = key
        counts = cells[key]
        n = sum(counts.values())
        table.append([f"`{group}`" + (" (family)" if family else ""), players, method, planner,
                      fmt_success(counts["success"], n), _classes_text(counts)])
    out += md_table(["scenario or family", "players", "method", "planner", "success % [95 % CI] (trials)",
                   "failures by class"], table)
    out += ["", "### Failure classes", "",
            "Why trials failed, from each trial's outcome (`nodnav.sim.failure`). A deadlock is no robot making "
            "progress for `sim.deadlock_time`; consensus is judged on the order still open.", ""]
    totals = Counter(r.failure_class for r in rows)
    by_group: dict[str, Counter] = defaultdict(Counter)
    for r in rows:
        by_group[r.group][r.failure_class] += 1
    present = [c for c in list(FAILURE_CLASSES) + sorted(set(totals) - set(FAILURE_CLASSES)) if totals.get(c)]
    meaning = {**FAILURE_CLASSES, "error": "the trial raised an exception (stored with its traceback)"}
    out += md_table(["class", "meaning", "trials", "share %"],
                  [[f"`{c}`", meaning.get(c, "-"), totals[c], f"{100 * totals[c] / len(rows):.1f}"] for c in present])
    out += [""]
    out += md_table(["scenario or family", *[f"`{c}`" for c in present]],
                  [[f"`{g}`", *[by_group[g].get(c, 0) for c in present]] for g in sorted(by_group)])
    failed = [r for r in rows if r.redo and r.failure_class != "success"]
    if failed:
        out += ["", "### Failed trials of generated families", "",
                "Each line redoes one trial exactly (the draw and the trial share the seed).", ""]
        out += [f"- `{r.failure_class}`: `{r.redo}`" for r in failed[:MAX_LISTED]]
        if len(failed) > MAX_LISTED:
            out.append(f"- ... and {len(failed) - MAX_LISTED} more (read them from the database's `trials` table)")
    return out + [""]
