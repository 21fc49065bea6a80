"""``nodnav reproduce``: run the paper's whole evaluation into one results database, then write the report.

The evaluation is a handful of studies (:func:`plan_parts`), each an ordinary resumable study
whose trials are shared with any other study that contains them. All the parts of a round run
in one pool of workers (:func:`~nodnav.experiments.batch.run_studies`): each part's trials the
longest first, the parts in :data:`PARTS` order, every distinct simulation once (the game
reduction's ``entered`` variant is the success rates' trial under another name: it is stored
from that trial's result). Fig. 2c needs initial opinions that a study cannot vary, so its grid
cells are written as scenario files into the output directory and swept like any other scenario.

Time budget
-----------
Trials are run in rounds of seeds. The first round runs seed 1 of every cell. Each later round
gives every cell the same number of trials (up to its part's target): the largest number that
the cost of a trial measured so far (the stored wall time of trials of the same cell, else of
the same robot count) says will fit in the time left, keeping a reserve for the report. When
not even one more seed for every cell fits, one more seed is given to as many parts as fit, in
the order of :data:`PARTS`. The paper's own evaluation (:data:`PAPER_PARTS`) is brought to its
targets before the comparisons of methods and planners get more than their first seed
(:func:`round_parts`). Should the estimates be wrong, no part's trials start once the budget
less the report's reserve is spent. Every cut is therefore as even as the budget allows, the report
says what was cut, and running the same command again continues where it stopped (stored trials
are never run twice). A budget of 0 runs everything in one round.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import time
from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import yaml

from nodnav.errors import NodnavError, shown
from nodnav.experiments.batch import run_studies
from nodnav.experiments.paper import (
    META_STUDY,
    SNAPSHOTS,
    STUDY_FIG2C,
    STUDY_METHODS,
    STUDY_PLANNERS,
    STUDY_SUCCESS,
    STUDY_TABLE1,
    STUDY_TABLE2,
    Snapshot,
)
from nodnav.experiments.scaling import SCALING_TITLE, scaling_spec
from nodnav.experiments.store import ResultStore, canonical_json
from nodnav.experiments.study import SweepSpec, known_methods
from nodnav.experiments.sweep import Expansion, TrialSpec, expand, stale_note
from nodnav.experiments.teams import MIXED_TEAMS_TITLE, mixed_teams_spec
from nodnav.experiments.variants import STUDY_REDUCTION, variant_scenario_files
from nodnav.provenance import PACKAGE_VERSION, code_version
from nodnav.reporting.report import ReportResult, build_report
from nodnav.scenario.catalogue import PAPER_SCENARIOS
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_to_dict
from nodnav.sim.methods import is_pedestrian

log = logging.getLogger(__name__)

#: The parts of the evaluation, in the order they run within a round and get a seed the budget cannot give to all.
PARTS = ("success", "table1", "table2", "fig2c", "methods", "reduction", "planners", "scaling", "mixed-teams")
#: The parts that reproduce the paper; the budget brings them to their targets before the comparisons.
PAPER_PARTS = ("success", "table1", "table2", "fig2c")

#: Wall time assumed for a trial of N_r robots before any has been measured (s).
PRIOR_TRIAL_COST = {2: 8.0, 3: 12.0, 4: 20.0}
#: Estimated round times are multiplied by this before they are compared with the time left.
SAFETY = 1.15
#: Seconds lost per sweep call (worker start-up, the last trial running alone).
SWEEP_OVERHEAD = 4.0
#: Seconds kept for the report beyond the snapshot re-runs (heatmaps, figures).
REPORT_RESERVE = 45.0

FIG2C_SCENARIO = "2r-case2"
FIG2C_U = 10.0
TABLE1_SCENARIO = "3r-case2"
TABLE2_SCENARIO = "3r-case3"
TABLE2_BIAS = (("S3", 150.0), ("S5", 150.0))


@dataclass(frozen=True)
class ReproduceOptions:
    """What ``nodnav reproduce`` runs."""

    out: Path = Path("nodnav-reproduce")
    """Output directory: the results database, the Fig. 2c scenario files, the figures and ``report.md``."""
    trials: int = 40
    """Trials per cell of the success rates, the tables, the methods and the planners."""
    jobs: int = 1
    """Worker processes."""
    methods: tuple[str, ...] = ()
    """Methods to compare; empty means every registered method."""
    planners: tuple[str, ...] = ("fast",)
    """Planners to compare; the comparison runs when one besides ``fast`` is named."""
    budget_minutes: float = 18.0
    """Wall-clock budget of the whole command, report included (min); 0 means no limit."""
    fig2c_grid: int = 5
    """Grid points per axis of Fig. 2c over [-10, 10]."""
    fig2c_trials: int = 2
    """Trials per cell of Fig. 2c."""
    method_trials: int = 20
    """Trials per cell of the methods comparison, at most :attr:`trials` (six methods on every
    scenario: at 20 trials a cell it alone costs as much as the success rates at 40)."""
    scenarios: tuple[str, ...] = ()
    """Scenarios of the success rates, methods and planners; empty means the paper's ten."""
    parts: tuple[str, ...] = PARTS
    """Which parts to run (all of :data:`PARTS` by default; fewer for quick checks)."""
    heatmap_grid: int = 41
    """Grid points per axis of the Fig. 2a/2b heatmaps."""
    rerun_snapshots: bool = True
    """Whether the report re-runs the snapshot trials."""
    db: Path | None = None
    """Results database; ``None`` means ``out/results.sqlite``."""
    command: str = "nodnav reproduce"
    """The command line, quoted in the report."""
    quiet: bool = False
    """No progress bars."""
    allow_mixed: bool = False
    """Count trials stored by another code version as done instead of running them again
    (see :mod:`nodnav.experiments.sweep`)."""

    @property
    def db_path(self) -> Path:
        """The results database."""
        return Path(self.db) if self.db is not None else Path(self.out) / "results.sqlite"


@dataclass(frozen=True)
class Part:
    """One study of the evaluation."""

    name: str
    """Part name, one of :data:`PARTS`."""
    title: str
    """What it reproduces."""
    spec: SweepSpec
    """The study at its full number of trials."""

    @property
    def target(self) -> int:
        """Trials per cell asked for."""
        return self.spec.trials


@dataclass(frozen=True)
class PartProgress:
    """How far a part got."""

    part: str
    """Part name."""
    study: str
    """Study name."""
    title: str
    """What it reproduces."""
    target: int
    """Trials per cell asked for."""
    seeds: int
    """Trials per cell run (seeds 1..seeds)."""

    @property
    def complete(self) -> bool:
        """Whether every asked-for trial was run."""
        return self.seeds >= self.target


@dataclass(frozen=True)
class ReproduceResult:
    """What :func:`reproduce` did."""

    success: bool
    """Whether the report was written and no trial raised."""
    reason: str
    """One line saying what happened."""
    db_path: Path
    """The results database."""
    report: ReportResult
    """The report."""
    progress: tuple[PartProgress, ...] = ()
    """Each part's target and what was run."""
    errors: int = 0
    """Trials that raised (stored with outcome ``error``)."""
    wall_time: float = 0.0
    """Wall-clock time of the whole command (s)."""
    cuts: tuple[str, ...] = ()
    """What the budget cut, one line each."""

    @property
    def complete(self) -> bool:
        """Whether every part ran all its trials."""
        return all(p.complete for p in self.progress)


def check_options(options: ReproduceOptions) -> None:
    """Raise :class:`NodnavError` with one line for the first malformed option."""
    for name in ("trials", "jobs", "fig2c_grid", "fig2c_trials", "heatmap_grid"):
        value = getattr(options, name)
        if isinstance(value, bool) or not isinstance(value, int) or value < (2 if "grid" in name else 1):
            raise NodnavError(f"--{name.replace('_', '-')}: expected a whole number >= {2 if 'grid' in name else 1}, "
                              f"got {shown(value)}")
    if not isinstance(options.method_trials, int) or options.method_trials < 1:
        raise NodnavError(f"--method-trials: expected a whole number >= 1, got {shown(options.method_trials)}")
    if not (options.budget_minutes >= 0 and math.isfinite(options.budget_minutes)):
        raise NodnavError(f"--budget: expected minutes >= 0 (0 for no limit), got {shown(options.budget_minutes)}")
    for p in options.parts:
        if p not in PARTS:
            raise NodnavError(f"--parts: unknown part {shown(p)}; choose from {', '.join(PARTS)}")
    for m in options.methods:
        if m not in known_methods():
            raise NodnavError(f"--methods: unknown method {shown(m)}; choose from {', '.join(known_methods())}")
    from nodnav.planning import PLANNERS

    for p in options.planners:
        if p not in PLANNERS:
            raise NodnavError(f"--planners: unknown planner {shown(p)}; choose from {', '.join(PLANNERS)}")
    for s in options.scenarios:
        load_scenario(s)


def fig2c_scenario_files(directory: Path, grid: int) -> list[Path]:
    """Write one scenario file per cell of the Fig. 2c grid and return their paths.

    Each is 2-Robot Case-2 with ``u = 10`` and the given initial opinions
    ``z_1(0) = (z_11, 0)``, ``z_2(0) = (z_21, 0)`` with ``z_11, z_21`` on
    :func:`~nodnav.decision.heatmap.z_grid`.
    """
    from nodnav.decision.heatmap import z_grid

    directory.mkdir(parents=True, exist_ok=True)
    base = load_scenario(FIG2C_SCENARIO)
    paths = []
    for z11 in z_grid(grid):
        for z21 in z_grid(grid):
            scenario = base.with_overrides(**{"opinion.u": FIG2C_U, "opinion.init": "given",
                                              "opinion.z0": [[float(z11), 0.0], [float(z21), 0.0]],
                                              "description": f"Fig. 2c cell: z_11(0) = {z11:g}, z_21(0) = {z21:g}"})
            path = directory / f"{FIG2C_SCENARIO}_z11={z11:g}_z21={z21:g}.yaml"
            # A JSON round trip turns tuples into lists, which YAML writes plainly.
            path.write_text(yaml.safe_dump(json.loads(json.dumps(scenario_to_dict(scenario))), sort_keys=False))
            paths.append(path)
    return paths


def plan_parts(options: ReproduceOptions) -> tuple[Part, ...]:
    """The studies of the evaluation for ``options``, in :data:`PARTS` order."""
    scenarios = tuple(options.scenarios) or PAPER_SCENARIOS
    max_players = max(load_scenario(s).n_robots for s in scenarios) - 1
    # People are not navigation methods to compare robots by (a team of people is not a robot team).
    methods = tuple(options.methods) or tuple(m for m in known_methods() if not is_pedestrian(m))
    t = options.trials
    planners = tuple(sorted(set(options.planners) | {"fast"}))
    builders = {
        "table1": lambda: Part("table1", "Table I (3-Robot Case-2, initial opinions)", SweepSpec(
            STUDY_TABLE1, (TABLE1_SCENARIO,), init=("zero", "distance"), planners=("fast",), trials=t)),
        "table2": lambda: Part("table2", "Table II (3-Robot Case-3, bias)", SweepSpec(
            STUDY_TABLE2, (TABLE2_SCENARIO,), bias=((), TABLE2_BIAS), planners=("fast",), trials=t)),
        "success": lambda: Part("success", "Fig. 3 success rates", SweepSpec(
            STUDY_SUCCESS, scenarios, players=tuple(range(max_players + 1)), planners=("fast",), trials=t)),
        "fig2c": lambda: Part("fig2c", f"Fig. 2c closed loop ({options.fig2c_grid} x {options.fig2c_grid} grid)",
                              SweepSpec(STUDY_FIG2C, tuple(str(p) for p in fig2c_scenario_files(
                                  Path(options.out) / "fig2c-scenarios", options.fig2c_grid)),
                                  planners=("fast",), trials=options.fig2c_trials)),
        "methods": lambda: Part("methods", f"methods compared ({', '.join(methods)})", SweepSpec(
            STUDY_METHODS, scenarios, planners=("fast",), methods=methods, trials=min(options.method_trials, t))),
        "reduction": lambda: Part("reduction", "game reduction variants", SweepSpec(
            STUDY_REDUCTION, tuple(str(p) for p in variant_scenario_files(
                Path(options.out) / "reduction-scenarios",
                tuple(s for s in scenarios if load_scenario(s).n_robots <= 4))), planners=("fast",), trials=t)),
        "planners": lambda: Part("planners", f"planners compared ({', '.join(planners)})", SweepSpec(
            STUDY_PLANNERS, scenarios, players=tuple(range(max_players + 1)), planners=planners, trials=t)),
        "scaling": lambda: Part("scaling", SCALING_TITLE, scaling_spec(t)),  # nodnav.experiments.scaling
        "mixed-teams": lambda: Part("mixed-teams", MIXED_TEAMS_TITLE, mixed_teams_spec(t)),  # experiments.teams
    }
    # The planner comparison needs a planner besides the fast one, which the other parts use.
    wanted = [p for p in PARTS if p in options.parts and (p != "planners" or len(planners) > 1)]
    return tuple(builders[p]() for p in wanted)


class CostModel:
    """Expected wall time of a trial from the trials stored so far.

    A trial is expected to take the mean stored wall time of the trials of its own cell (same
    configuration, any seed); failing that, of trials with as many robots and the same method
    and planner; then of as many robots; then :data:`PRIOR_TRIAL_COST`.
    """

    def __init__(self, store: ResultStore):
        cell, group, robots = defaultdict(list), defaultdict(list), defaultdict(list)
        for config, n, method, planner, w in store.wall_times():  # the columns, not every summary parsed
            cell[config].append(w)
            group[(n, method, planner)].append(w)
            robots[n].append(w)
        self._cell = {k: sum(v) / len(v) for k, v in cell.items()}
        self._group = {k: sum(v) / len(v) for k, v in group.items()}
        self._robots = {k: sum(v) / len(v) for k, v in robots.items()}

    def __call__(self, trial: TrialSpec) -> float:
        """Expected wall time of ``trial`` (s)."""
        n = trial.scenario.n_robots
        got = self._cell.get(canonical_json(trial.config))
        if got is None:
            got = self._group.get((n, trial.method, trial.scenario.planner.name))
        if got is None:
            got = self._robots.get(n, PRIOR_TRIAL_COST.get(n, 5.0 * n))
        return got


def pending(trials: dict[str, tuple[TrialSpec, ...]], seeds: dict[str, int], stored: set[str]) -> list[TrialSpec]:
    """The distinct trials with seed <= ``seeds[part]`` of every part that are not in ``stored``."""
    out: dict[str, TrialSpec] = {}
    for part, specs in trials.items():
        for t in specs:
            if t.seed <= seeds[part] and t.key not in stored:
                out.setdefault(t.key, t)
    return list(out.values())


def seeds_at(parts: tuple[Part, ...], seeds: int, done: dict[str, int]) -> dict[str, int]:
    """Every part raised to ``seeds`` seeds, never below what it has done nor above its target."""
    return {p.name: max(done[p.name], min(p.target, seeds)) for p in parts}


def round_cost(todo: list[TrialSpec], cost: Callable[[TrialSpec], float], jobs: int, calls: int) -> float:
    """Expected wall time of running ``todo`` on ``jobs`` workers in ``calls`` sweeps (s):
    ``SAFETY * sum(cost) / jobs + SWEEP_OVERHEAD * calls``."""
    return SAFETY * (sum(cost(t) for t in todo) / jobs) + SWEEP_OVERHEAD * calls


def round_parts(parts: tuple[Part, ...], done: dict[str, int]) -> tuple[Part, ...]:
    """The parts a budget round may raise: those of the paper's evaluation still short of their
    target, or, once none is, every part still short of its target."""
    short = tuple(p for p in parts if done[p.name] < p.target)
    return tuple(p for p in short if p.name in PAPER_PARTS) or short


def next_round(parts: tuple[Part, ...], done: dict[str, int], trials: dict[str, tuple[TrialSpec, ...]],
               stored: set[str], cost: Callable[[TrialSpec], float], jobs: int, left: float) -> dict[str, int]:
    """Seeds per part for the next round that :func:`round_cost` expects to take at most ``left`` seconds.

    The most seeds for every cell that fit; if not even one more for every cell fits, one more
    seed for each part in turn (in ``parts`` order) while it fits. ``done`` unchanged when nothing fits.
    """
    def fits(seeds: dict[str, int]) -> bool:
        calls = sum(seeds[p.name] > done[p.name] for p in parts)
        return round_cost(pending(trials, seeds, stored), cost, jobs, calls) <= left

    open_ = [done[p.name] for p in parts if done[p.name] < p.target]
    if not open_:
        return dict(done)
    for s in range(max(p.target for p in parts), min(open_), -1):
        seeds = seeds_at(parts, s, done)
        if fits(seeds):
            return seeds
    best = dict(done)
    for p in parts:
        trial = {**best, p.name: done[p.name] + 1}
        if done[p.name] < p.target and fits(trial):
            best = trial
    return best


def reproduce(options: ReproduceOptions, *, trial_fn: Callable | None = None,
              notify: Callable[[str], None] | None = None) -> ReproduceResult:
    """Run the evaluation of ``options`` into its results database within its budget, then write the report.

    ``trial_fn`` replaces :func:`~nodnav.sim.simulator.run_trial` in the sweeps (see
    :func:`~nodnav.experiments.batch.run_sweep`). Trials stored by another code version are run
    again unless ``options.allow_mixed``; ``notify`` receives that one-line note first.
    """
    start = time.perf_counter()
    check_options(options)
    out = Path(options.out)
    out.mkdir(parents=True, exist_ok=True)
    db = options.db_path
    parts = plan_parts(options)
    expansions = {p.name: expand(p.spec) for p in parts}  # once: every round picks its seeds from these
    trials = {p.name: expansions[p.name].trials for p in parts}
    current = None if options.allow_mixed else code_version()
    with ResultStore(db) as store:
        versions = store.stored_versions(t.key for specs in trials.values() for t in specs)
    stale = Counter(v for _, v in versions.values() if v != code_version())
    if stale and notify is not None:
        notify(stale_note(dict(stale), code_version(), options.allow_mixed))
    budget = 60.0 * options.budget_minutes
    done = {p.name: 0 for p in parts}
    levels: list[dict[str, int]] = []
    errors = 0
    sweep_wall = 0.0

    def run_round(seeds: dict[str, int]) -> None:
        """Every part raised to ``seeds`` in one pool of workers (:func:`~nodnav.experiments.batch.run_studies`)."""
        nonlocal errors, sweep_wall
        raised = [p for p in parts if seeds[p.name] > done[p.name]]
        if budget > 0 and time.perf_counter() - start > budget - REPORT_RESERVE:
            # The estimates were wrong (or there were none yet): start no further part.
            for p in raised:
                log.warning("budget spent: %s stays at %d of %d trials per cell", p.title, done[p.name], p.target)
            levels.append(dict(done))
            return
        runs = [(dataclasses.replace(p.spec, trials=seeds[p.name]),
                 Expansion(tuple(t for t in trials[p.name] if t.seed <= seeds[p.name]), expansions[p.name].notes))
                for p in raised]
        with ResultStore(db) as store:
            cost = CostModel(store)
        batch = run_studies(runs, db, jobs=options.jobs, quiet=options.quiet, trial_fn=trial_fn,
                            allow_mixed=options.allow_mixed, cost=cost,
                            deadline=None if budget <= 0 else start + budget - REPORT_RESERVE)
        errors += batch.errors
        sweep_wall += batch.wall_time
        for summary in batch.studies:
            log.info("%s", summary.reason)
        with ResultStore(db) as store:
            stored = set(store.stored((t.key for p in raised for t in trials[p.name]), current))
        for p in raised:  # the seeds every cell of the part has stored (all of them unless time ran out)
            missing = [t.seed for t in trials[p.name] if t.seed <= seeds[p.name] and t.key not in stored]
            done[p.name] = min(missing) - 1 if missing else seeds[p.name]
        levels.append(dict(done))

    if budget <= 0:
        run_round({p.name: p.target for p in parts})
    else:
        run_round({p.name: 1 for p in parts})  # seed 1 everywhere: measures every cell once
        while any(done[p.name] < p.target for p in parts):
            with ResultStore(db) as store:
                cost = CostModel(store)
                stored = set(store.stored((t.key for specs in trials.values() for t in specs), current))
                reserve = REPORT_RESERVE + sum(_snapshot_cost(store, s) for s in SNAPSHOTS)
            left = budget - (time.perf_counter() - start) - reserve
            tier = round_parts(parts, done)
            best = {**done, **next_round(tier, done, {p.name: trials[p.name] for p in tier}, stored, cost,
                                         options.jobs, left)}
            if best == done:
                break
            run_round(best)
    with ResultStore(db) as store:
        stored = set(store.stored((t.key for specs in trials.values() for t in specs), current))
        remaining = pending(trials, {p.name: p.target for p in parts}, stored)
        progress = tuple(PartProgress(p.name, p.spec.name, p.title, p.target, done[p.name]) for p in parts)
        cuts = []
        if remaining:
            cost = CostModel(store)
            more = sum(cost(t) for t in remaining) / options.jobs / 60.0
            cuts.append(f"the {options.budget_minutes:g}-minute budget ran out: "
                        + "; ".join(f"{p.title} ran {p.seeds} of {p.target} trials per cell" for p in progress
                                    if not p.complete)
                        + f". The {len(remaining)} trials left would take about {more:.0f} min more with "
                        f"{options.jobs} worker(s); running the same command again with a larger --budget (0: no "
                        "limit) continues from the stored trials.")
        notes = []
        if "planners" not in options.parts or len(set(options.planners) | {"fast"}) < 2:
            notes.append("the planner comparison was not run (add --planners fast,prm).")
        skipped = [p for p in PARTS if p not in options.parts]
        if skipped:
            notes.append(f"parts left out of this run: {', '.join(skipped)}.")
        if options.scenarios:
            notes.append(f"scenarios limited to {', '.join(options.scenarios)}.")
        store.save_study(META_STUDY, {
            "kind": "reproduce", "command": options.command, "version": PACKAGE_VERSION, "jobs": options.jobs,
            "trials": options.trials, "budget_s": budget, "trials_wall_s": sweep_wall, "levels": levels,
            "parts": [{"part": p.part, "study": p.study, "title": p.title, "target": p.target, "seeds": p.seeds}
                      for p in progress],
            "cuts": cuts, "notes": notes, "errors": errors})
    report = build_report(db, out, command=options.command, heatmap_grid=options.heatmap_grid,
                          rerun_snapshots=options.rerun_snapshots)
    wall = time.perf_counter() - start
    status = "complete" if not remaining else f"cut by the budget ({len(remaining)} trials not run)"
    planned = len({t.key for specs in trials.values() for t in specs})
    reason = (f"{planned} trials planned, {status}, {errors} errors, "
              f"{wall / 60:.1f} min; {report.reason}")
    return ReproduceResult(report.success and errors == 0, reason, db, report, progress, errors, wall, tuple(cuts))


def _snapshot_cost(store: ResultStore, snap: Snapshot) -> float:
    """Expected wall time of re-running a snapshot trial: the mean of its stored cell (s)."""
    records = store.records(STUDY_SUCCESS, scenario=snap["scenario"], players=snap["players"])
    walls = [r.summary["wall_time_s"] for r in records if r.summary.get("wall_time_s") is not None]
    return sum(walls) / len(walls) if walls else 0.0
