"""Resumable parallel sweeps: expand a study's cross product, run what is not stored yet, store results.

Trials run in worker processes (joblib's loky backend, ``jobs`` of them) or on a Dask cluster
(joblib's ``dask`` backend on a ``distributed.Client`` connected to ``scheduler``). Workers only
compute; each result comes back to this process, which commits it to the results database in a
transaction of its own as soon as it arrives. Killing the sweep at any moment therefore loses at
most the trials that were still running, and running it again does only those.

Every trial is seeded by its own seed and nothing else, so the stored results do not depend on
the number of workers or the order in which trials finish.

Code versions
-------------
Every stored trial records the code version that ran it
(:func:`nodnav.provenance.code_version`, computed in the worker). A trial stored by another
code version (or before versions were recorded, ``unknown``) is *stale*: by default it counts as
not stored and is run again under this version, the old row moving to the ``stale_trials``
table, so a study's results never mix versions. With ``allow_mixed`` stale trials count as
stored and are kept as they are. Either way the sweep says so in one line
(:attr:`SweepSummary.notes`, and ``notify`` before any trial runs).
"""

from __future__ import annotations

import itertools
import logging
import math
import time
import traceback
from collections import Counter
from dataclasses import dataclass, field
from typing import Callable

from nodnav.errors import NodnavError
from nodnav.experiments.store import trial_config, trial_key
from nodnav.experiments.study import SweepSpec
from nodnav.heap import freeze_long_lived
from nodnav.provenance import code_version, numerics
from nodnav.scenario.families import FamilyError
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.limits import MAX_STRATEGIES
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.overrides import setting_text
from nodnav.scenario.schema import Scenario, override_scenario, scenario_from_dict, scenario_to_dict
from nodnav.sim.metrics import json_ready

log = logging.getLogger(__name__)

__all__ = ["SweepSpec", "TrialSpec", "Expansion", "TrialOutput", "SweepSummary", "expand", "execute_trial"]


@dataclass(frozen=True)
class TrialSpec:
    """One trial of a sweep: what to simulate, with which seed, under which key."""

    key: str
    """:func:`~nodnav.experiments.store.trial_key` of the configuration and seed."""
    scenario: Scenario
    """The scenario with the sweep's overrides applied."""
    method: str
    """Navigation method."""
    seed: int
    """Trial seed."""
    config: dict = field(repr=False)
    """:func:`~nodnav.experiments.store.trial_config` of the trial."""


@dataclass(frozen=True)
class Expansion:
    """The distinct trials of a sweep, in cross-product order, and the combinations left out."""

    trials: tuple[TrialSpec, ...]
    """Trials, each key once."""
    notes: tuple[str, ...]
    """One line per combination skipped because it does not apply to a scenario."""


@dataclass(frozen=True)
class TrialOutput:
    """What a worker sends back for one trial (JSON-ready)."""

    key: str
    """Trial key."""
    outcome: str
    """The trial's outcome, or ``error``."""
    summary: dict
    """``TrialResult.to_dict()``, or for an error its message, traceback and wall time."""
    metrics: dict
    """``TrialResult.metrics`` (empty for an error)."""
    error: str | None
    """One-line message when the trial raised."""
    code_version: str = ""
    """:func:`~nodnav.provenance.code_version` of the worker that ran the trial."""


@dataclass(frozen=True)
class SweepSummary:
    """What a sweep did."""

    study: str
    """Study name."""
    db_path: str
    """The results database."""
    total: int
    """Distinct trials in the study."""
    done: int
    """Trials run and stored by this sweep."""
    skipped: int
    """Trials already stored, not run again."""
    errors: int
    """Trials of this sweep that raised (stored with outcome ``error``)."""
    outcomes: dict[str, int]
    """Outcomes of the trials run by this sweep."""
    wall_time: float
    """Wall-clock time of the sweep (s)."""
    notes: tuple[str, ...] = ()
    """Combinations that did not apply to a scenario and were left out, and stale trials found."""
    stale: int = 0
    """Trials of the study stored by another code version (re-run unless mixing was allowed)."""

    @property
    def success(self) -> bool:
        """Whether every trial of this sweep ran without raising."""
        return self.errors == 0

    @property
    def reason(self) -> str:
        """One line saying what happened."""
        return (f"{self.study}: {self.done} trials run, {self.skipped} already stored, {self.errors} errors "
                f"({self.total} in the study) in {self.wall_time:.1f} s")


def expand(spec: SweepSpec) -> Expansion:
    """Every trial of ``spec``: scenarios x players x init x bias x planners x roles x methods x seeds 1..trials.

    A family (``spec.families``) contributes its draws 1..trials, draw s with seed s only, so that
    ``nodnav run FAMILY:s --seed s`` redoes any of its trials.

    The study's ``overrides`` (``set:``) apply to every scenario as it loads and to every draw
    after it is drawn (the draw itself does not change, so ``nodnav run FAMILY:s --seed s --set
    KEY=VALUE ...`` redoes the trial); a draw they do not fit (``robots[5]`` of a 3-robot draw) is
    left out with a note. Each trial's stored configuration records them under ``set``, as the
    ``KEY=VALUE`` texts ``--set`` takes, in their order (the trial key, a hash of what determines
    the trial, is that of the scenario they give).

    A game-player count outside 0..N_r - 1 or giving games of more than ``MAX_STRATEGIES`` orders
    (``all`` above 6 robots), or a bias naming a strategy beyond N_r!, does not apply to a
    scenario: that combination is left out with a note (and logged). ``all`` is
    N_r - 1 players; combinations that give the same trial are kept once.
    """
    trials: dict[str, TrialSpec] = {}
    notes: Counter[str] = Counter()
    settings = [setting_text(k, v) for k, v in spec.overrides.items()]  # as --set takes them, in order
    for base, label, seeds in _bases(spec, notes):
        n, n_s = base.n_robots, math.factorial(base.n_robots)
        players_axis = []
        for players in spec.players:
            game = n if not isinstance(players, int) else players + 1  # "all", or None: the scenario's own
            if isinstance(players, int) and players > n - 1:
                notes[f"{label}: players {players} skipped ({n} robots allow 0..{n - 1})"] += 1
            elif players is not None and math.factorial(game) > MAX_STRATEGIES:
                notes[f"{label}: players {players} skipped ({game}! orders per robot, more than "
                      f"{MAX_STRATEGIES})"] += 1
            else:
                players_axis.append(players)
        bias_axis = []
        for bias in spec.bias:
            if bias and max(int(s[1:]) for s, _ in bias) > n_s:
                text = ",".join(f"{s}={v:g}" for s, v in bias)
                notes[f"{label}: bias {text} skipped ({n} robots have strategies S1..S{n_s})"] += 1
            else:
                bias_axis.append(bias)
        for players, init, bias, planner in itertools.product(players_axis, spec.init, bias_axis, spec.planners):
            changes: dict = {}
            if players is not None:
                changes["game_players"] = players
            if init is not None:  # initial opinions given in the scenario file give way to the mode
                changes["opinion.init"] = init
                changes["opinion.z0"] = []
            if bias is not None:
                changes["opinion.bias"] = dict(bias)
            if planner is not None:
                changes["planner.name"] = planner
            plain = base.with_overrides(**changes) if changes else base
            for roles in spec.roles:
                scenario = with_roles(plain, roles)
                if scenario is None:
                    notes[f"{label}: roles {dict(roles)} skipped ({n} robots)"] += 1
                    continue
                mapping = scenario_to_dict(scenario)
                for method in spec.methods:
                    config = trial_config(mapping, method)
                    stored = {**config, "set": settings} if settings else config
                    for seed in seeds:
                        key = trial_key(config, seed)
                        trials.setdefault(key, TrialSpec(key, scenario, method, seed, stored))
    lines = tuple(text if count == 1 else f"{text} in {count} draws" for text, count in notes.items())
    for note in lines:
        log.info("%s", note)
    return Expansion(trials=tuple(trials.values()), notes=lines)


def with_roles(scenario: Scenario, roles: tuple[tuple[str, str], ...]) -> Scenario | None:
    """``scenario`` with ``robots[i].method`` set for the robots ``roles`` names (a number from 1,
    or ``last``); ``None`` when it names a robot the scenario does not have."""
    if not roles:
        return scenario
    raw = scenario_to_dict(scenario)
    for robot, method in roles:
        k = scenario.n_robots if robot == "last" else int(robot)
        if k > scenario.n_robots:
            return None
        raw["robots"][k - 1]["method"] = method
    return scenario_from_dict(raw, scenario.name)


def _bases(spec: SweepSpec, notes: Counter[str]):
    """(scenario, label for notes, seeds) of every scenario of ``spec``, with its overrides; a family's
    draw s runs only seed s, and a draw the overrides do not fit is left out with a note."""
    for name in spec.scenarios:
        base = load_scenario(name, spec.overrides)
        yield base, base.name, range(1, spec.trials + 1)
    for family_spec in spec.families:
        from nodnav.scenario.draws import draw
        from nodnav.scenario.families import load_family

        family = load_family(family_spec)
        examples: dict[str, str] = {}
        for seed in range(1, spec.trials + 1):
            try:
                base = override_scenario(draw(family, seed), spec.overrides)
            except FamilyError:
                raise
            except ScenarioError as exc:  # e.g. robots[5] of a 3-robot draw
                log.info("%s:%d left out: %s", family.name, seed, exc)
                example = examples.setdefault(family.name, f"draw {seed}: {exc}")
                notes[f"{family.name}: draws that the study's set does not fit left out (e.g. {example})"] += 1
                continue
            yield base, family.name, (seed,)


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


def execute_trial(trial_fn: Callable, scenario: Scenario, method: str, seed: int, key: str) -> TrialOutput:
    """Run one trial in a worker; an exception becomes an ``error`` output instead of propagating.

    ``trial_fn(scenario, method, seed)`` returns an object with ``outcome``, ``metrics`` and
    ``to_dict()`` (a :class:`~nodnav.sim.trial_result.TrialResult`).
    """
    start = time.perf_counter()
    try:
        result = trial_fn(scenario, method, seed)
        # After a process's first trial, its long-lived objects (libraries, compiled kernels) are
        # set aside from the collector's full sweeps (nodnav.heap); results are unaffected.
        freeze_long_lived()
        summary = {**json_ready(result.to_dict()), "numerics": numerics()}  # the machine's part of provenance
        return TrialOutput(key=key, outcome=result.outcome, summary=summary,
                           metrics=json_ready(result.metrics), error=None, code_version=code_version())
    except Exception as exc:  # a failing trial is a result to store, not the end of the sweep
        message = _one_line(exc)
        summary = {"outcome": "error", "error": message, "traceback": traceback.format_exc(),
                   "wall_time_s": time.perf_counter() - start,
                   "numerics": numerics()}  # an error too can be the machine's
        return TrialOutput(key=key, outcome="error", summary=summary, metrics={}, error=message,
                           code_version=code_version())


def _default_trial_fn() -> Callable:
    from nodnav.sim.simulator import run_trial

    return run_trial


def stale_note(stale: dict[str, int], current: str, allow_mixed: bool) -> str:
    """The one line that says what a sweep does with ``stale`` trials (count per code version)."""
    found = ", ".join(f"{n} from {v}" for v, n in sorted(stale.items()))
    total = sum(stale.values())
    if allow_mixed:
        return (f"{total} stored trial{'s' if total != 1 else ''} of this study came from another code version "
                f"({found}); --allow-mixed keeps them as results alongside trials of {current}")
    return (f"{total} stored trial{'s' if total != 1 else ''} of this study came from another code version "
            f"({found}); they are run again under {current} (old rows kept in table stale_trials; "
            "--allow-mixed keeps them instead)")


def _dask_client(scheduler: str, timeout: float):
    """A client of the Dask scheduler at ``scheduler``; joblib's dask backend runs on it."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise NodnavError("running on a Dask cluster needs dask and distributed: "
                          "pip install 'nodnav[cluster]'") from None
    try:
        return Client(scheduler, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        raise NodnavError(f"cannot reach the Dask scheduler at {scheduler} ({_one_line(exc)})") from None
