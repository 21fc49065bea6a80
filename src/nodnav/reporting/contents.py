"""What a results database holds, in words: the report's title, the studies it opens with, and the
one line on the paper's sections it does not hold.

A report is written from whatever database it is given: a sweep of one's own, a family sweep,
the paper's evaluation (``nodnav reproduce``) or any mixture. Its title and opening name the
studies found there, each described by what its trials vary (read from the trials themselves,
so a study stored without its specification is described too); the paper's sections appear only
when their studies are there, and the others are named in one line with the ``nodnav
reproduce`` command that adds them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from nodnav.experiments.paper import (
    META_STUDY,
    STUDY_FIG2C,
    STUDY_METHODS,
    STUDY_PLANNERS,
    STUDY_SUCCESS,
    STUDY_TABLE1,
    STUDY_TABLE2,
)
from nodnav.experiments.scaling import STUDY_SCALING
from nodnav.experiments.store import ResultStore, TrialRecord
from nodnav.experiments.teams import STUDY_MIXED_TEAMS
from nodnav.experiments.variants import STUDY_REDUCTION


@dataclass(frozen=True)
class PaperPart:
    """A part of the paper's evaluation: its study, its ``--parts`` name and what the report shows of it."""

    study: str
    """Study name in the database."""
    part: str
    """Its name for ``nodnav reproduce --parts``."""
    shows: str
    """What the report's section(s) on it show."""


#: The parts of the paper's evaluation in report order, with what each adds to a report.
PAPER_PARTS = (
    PaperPart(STUDY_SUCCESS, "success", "the success rates (Fig. 3) and the snapshots (Figs. 4 and 5)"),
    PaperPart(STUDY_TABLE1, "table1", "Table I (initial opinions)"),
    PaperPart(STUDY_TABLE2, "table2", "Table II (bias)"),
    PaperPart(STUDY_FIG2C, "fig2c", "Fig. 2 (strategy selection over initial opinions)"),
    PaperPart(STUDY_PLANNERS, "planners", "the planners compared"),
    PaperPart(STUDY_METHODS, "methods", "the navigation methods compared"),
    PaperPart(STUDY_REDUCTION, "reduction", "the game-reduction variants"),
    PaperPart(STUDY_SCALING, "scaling", "5 to 8 robots"),
    PaperPart(STUDY_MIXED_TEAMS, "mixed-teams", "mixed teams: people and other conventions beside NOD robots"),
)
#: Names listed in full, at most; more are counted.
MAX_NAMES = 4

_DRAW = re.compile(r"(?P<family>.+):[0-9]+")


def study_names(store: ResultStore) -> list[str]:
    """Every study with trials in the database (specified or not), in name order."""
    names = set(store.studies()) | {r.study for r in store.records()}
    return sorted(n for n in names if n != META_STUDY and store.count(n))


def _listed(values: list[str]) -> str:
    shown = values[:MAX_NAMES]
    more = len(values) - len(shown)
    return ", ".join(shown) + (f" and {more} more" if more else "")


def _counted(n: int, singular: str, plural: str | None = None) -> str:
    return f"{n} {singular if n == 1 else (plural or singular + 's')}"


def _axis(values: set[str], singular: str, plural: str | None = None) -> str:
    ordered = sorted(values)
    return f"{_counted(len(ordered), singular, plural)} ({_listed(ordered)})"


def _players(record: TrialRecord) -> str:
    return "all" if record.players == record.n_robots - 1 else str(record.players)


def describe_trials(records: list[TrialRecord], seeds_asked: int | None = None) -> str:
    """What a study's trials vary, e.g. ``2 scenarios (2r-case1, 3r-case4) x 2 player settings (1, all)
    x 10 seeds, 40 trials``; settings every trial shares are named after the axes."""
    draws = {(m["family"], r.seed) for r in records if (m := _DRAW.fullmatch(r.scenario))}
    scenarios = {r.scenario for r in records if not _DRAW.fullmatch(r.scenario)}
    axes = []
    if scenarios:
        axes.append(_axis(scenarios, "scenario"))
    for family in sorted({f for f, _ in draws}):  # trial seed s runs draw s: a family's draws are its seeds
        axes.append(f"family `{family}` ({_counted(sum(f == family for f, _ in draws), 'draw')})")
    fixed = []
    players = {_players(r) for r in records}
    if len(players) > 1:
        axes.append(_axis(players, "player setting"))
    else:
        k = next(iter(players))
        fixed.append("every other robot a game player" if k == "all"
                     else f"{_counted(int(k), 'game player')} per robot")
    for values, singular, plural, alone, always in (
            ({r.method for r in records}, "method", None, "method {}", True),
            ({r.planner for r in records}, "planner", None, "{} planner", True),
            ({r.init for r in records}, "initial opinion setting", None, "initial opinions {}", False),
            ({r.bias or "none" for r in records}, "bias", "biases", "bias {}", False)):
        if len(values) > 1:
            axes.append(_axis(values, singular, plural))
        elif always or values - {"zero", "none"}:  # the defaults (zero opinions, no bias) go unsaid
            fixed.append(alone.format(next(iter(values))))
    seeds = len({r.seed for r in records})
    cut = seeds_asked is not None and seeds < seeds_asked
    seeds_text = f"{seeds} of {seeds_asked} seeds" if cut else _counted(seeds, "seed")
    if not scenarios:  # a family sweep only: its draws are its seeds
        seeds_text = f"{seeds} of {seeds_asked} seeds" if cut else ""
    text = " x ".join(axes + [seeds_text] if seeds_text else axes) + f", {_counted(len(records), 'trial')}"
    return text + (f" ({', '.join(fixed)})" if fixed else "")


def study_lines(store: ResultStore) -> list[str]:
    """One markdown bullet per study in the database, saying what it holds."""
    specs = store.studies()
    parts = {p.study: p for p in PAPER_PARTS}
    lines = []
    for name in study_names(store):
        spec = specs.get(name, {})
        asked = spec.get("trials") if isinstance(spec.get("trials"), int) else None
        kind = f"Study `{name}` (the paper's evaluation: {parts[name].shows})" if name in parts else f"Sweep `{name}`"
        lines.append(f"- {kind}: {describe_trials(store.records(name), asked)}.")
    return lines


def report_title(store: ResultStore) -> str:
    """The report's title: what the database holds, in a few words."""
    names = study_names(store)
    present = [p for p in PAPER_PARTS if p.study in names]
    if not names:
        return "# nodnav report: an empty results database"
    if META_STUDY in store.studies():
        if len(present) == len(PAPER_PARTS):
            return "# nodnav: the paper's evaluation, reproduced"
        others = [n for n in names if n not in {p.study for p in PAPER_PARTS}]
        return ("# nodnav: the paper's evaluation, in part: " + "; ".join(p.shows for p in present)
                + (f"; and {_counted(len(others), 'other study', 'other studies')}" if others else ""))
    if len(names) == 1:
        return f"# nodnav report: {'study' if present else 'sweep'} `{names[0]}`"
    return f"# nodnav report: {len(names)} studies ({_listed([f'`{n}`' for n in names])})"


def missing_parts(store: ResultStore) -> list[PaperPart]:
    """The parts of the paper's evaluation the database holds no trial of."""
    return [p for p in PAPER_PARTS if not store.count(p.study)]


def missing_line(missing: list[PaperPart], db_name: str) -> str:
    """The one line naming the paper's sections a database does not hold and the command that adds them."""
    if not missing:
        return "Every part of the paper's evaluation is in this database."
    parts = ",".join(p.part for p in missing)
    planners = " --planners fast,prm" if any(p.study == STUDY_PLANNERS for p in missing) else ""
    return ("Not in this database, of the paper's evaluation: " + "; ".join(p.shows for p in missing)
            + f". `nodnav reproduce --parts {parts}{planners} --db {db_name} --out DIR` adds "
            + ("it" if len(missing) == 1 else "them") + " (resumable, within a time budget: `--budget MIN`).")
