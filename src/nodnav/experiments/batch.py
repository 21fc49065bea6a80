"""Several studies in one pool of workers: every distinct trial run once, stored once per key.

:func:`run_sweep` is this for one study; ``nodnav reproduce`` gives it
all of its parts at once. Compared with running the studies one after another:

- **one pool, no gaps**: the workers go from one study's trials to the next without waiting for
  the slowest trial of each study, and every study is expanded once;
- **each simulation once**: trials whose configurations differ only in the scenario's name (a
  label: ``4r-case2 [entered]``, the game reduction's ``entered`` variant, is 4r-case2 with its own
  settings) have the same :func:`~nodnav.experiments.store.run_key`. One of them is simulated;
  every other is stored from its result under its own key and configuration, with its own name
  in the summary and ``same_run_as`` naming the key simulated. A trial whose twin in one of the
  studies given is already stored (and kept) is stored from it without running at all.
- **the long trials first**: within a study, trials go to the workers in decreasing expected
  cost (``cost``), so that the last trials of the pool are short ones; studies keep their order,
  so the first study is complete first.

Results are stored as they arrive, one transaction per simulated trial and its twins, exactly
as a single sweep does, and a trial's stored row does not depend on which study ran it, the order,
or the number of workers.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import time
from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Sequence

from joblib import Parallel, delayed, parallel_config
from tqdm import tqdm

from nodnav.errors import NodnavError
from nodnav.experiments import sweep
from nodnav.experiments.store import DEFAULT_DB, ResultStore, run_key
from nodnav.experiments.study import SweepSpec
from nodnav.experiments.sweep import Expansion, SweepSummary, TrialSpec, execute_trial, stale_note
from nodnav.provenance import PACKAGE_VERSION

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchSummary:
    """What :func:`run_studies` did."""

    studies: tuple[SweepSummary, ...]
    """One summary per study, in the order given (``wall_time`` is the whole batch's)."""
    simulated: int
    """Trials simulated by this batch."""
    copied: int
    """Trials stored from a twin's result (simulated in this batch or stored before) instead of simulated."""
    errors: int
    """Trials stored by this batch with outcome ``error`` (they raised, or their twin did)."""
    wall_time: float
    """Wall-clock time of the batch (s)."""
    stopped: bool = False
    """Whether ``deadline`` kept studies from starting."""


def _robots_first(trial: TrialSpec) -> float:
    """The default cost estimate: more robots, longer trials."""
    return float(trial.scenario.n_robots)


def run_studies(runs: Sequence[tuple[SweepSpec, Expansion]], db_path: str | Path, jobs: int = 1,
                scheduler: str | None = None, quiet: bool = False, *, trial_fn: Callable | None = None,
                retry_errors: bool = False, connect_timeout: float = 30.0, allow_mixed: bool = False,
                notify: Callable[[str], None] | None = None, cost: Callable[[TrialSpec], float] | None = None,
                deadline: float | None = None) -> BatchSummary:
    """Run every trial of the studies ``runs`` (each a spec and its :func:`~nodnav.experiments.sweep.expand`)
    that ``db_path`` does not hold yet, in one pool of workers, and store each as it arrives.

    The options are those of :func:`run_sweep`. A trial belongs to the
    first study that contains it (the ``study`` column) and is linked to every study that does.
    ``cost(trial)`` orders each study's trials, the most expensive first (default: most robots
    first). With ``deadline`` (a :func:`time.perf_counter` value), no study's trials start once it
    has passed; the trials of a study already started all run.
    """
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise NodnavError(f"jobs: expected a whole number >= 1, got {jobs!r}")
    start = time.perf_counter()
    fn = trial_fn if trial_fn is not None else sweep._default_trial_fn()  # looked up there: tests replace it
    cost = cost or _robots_first
    trials: dict[str, TrialSpec] = {}
    studies_of: dict[str, list[str]] = defaultdict(list)
    for spec, expansion in runs:
        for t in expansion.trials:
            trials.setdefault(t.key, t)
            if spec.name not in studies_of[t.key]:
                studies_of[t.key].append(spec.name)
    rank = {spec.name: i for i, (spec, _) in enumerate(runs)}
    with contextlib.ExitStack() as stack:
        if scheduler is not None:
            stack.enter_context(sweep._dask_client(scheduler, connect_timeout))
            stack.enter_context(parallel_config(backend="dask"))
        store = stack.enter_context(ResultStore(db_path))
        for spec, _ in runs:
            store.save_study(spec.name, spec.to_dict())
        current = sweep.code_version()
        stored = store.stored_versions(trials)
        stale = {spec.name: Counter(stored[t.key][1] for t in expansion.trials
                                    if t.key in stored and stored[t.key][1] != current) for spec, expansion in runs}
        notes = {spec.name: list(expansion.notes) for spec, expansion in runs}
        said: set[str] = set()
        for name, found in stale.items():
            if found:
                notes[name].append(stale_note(dict(found), current, allow_mixed))
                log.info("%s", notes[name][-1])
                if notify is not None and notes[name][-1] not in said:
                    notify(notes[name][-1])
                    said.add(notes[name][-1])
        keep = {k for k, (outcome, v) in stored.items()
                if not (retry_errors and outcome == "error") and (allow_mixed or v == current)}
        for spec, expansion in runs:
            store.link(spec.name, (t.key for t in expansion.trials if t.key in keep))
        todo = [t for t in trials.values() if t.key not in keep]
        # Twins: one simulation per run key; a twin already stored (and not an error) gives its result.
        runs_of = {run_key(t.config, t.seed): t.key for t in trials.values()
                   if t.key in keep and stored[t.key][0] != "error"}
        groups: dict[str, list[TrialSpec]] = {}
        outcome_of: dict[str, str] = {}  # trials stored by this batch
        copied = 0
        for t in todo:
            rk = run_key(t.config, t.seed)
            if rk in runs_of:
                record = store.record(runs_of[rk])
                if record is not None:
                    _store_twin(store, t, studies_of[t.key], record.outcome, record.summary, record.metrics,
                                record.error, record.code_version, runs_of[rk])
                    outcome_of[t.key] = record.outcome
                    copied += 1
                    continue
            groups.setdefault(rk, []).append(t)
        order = sorted(groups.values(), key=lambda g: (rank[studies_of[g[0].key][0]], -cost(g[0])))
        log.info("%d studies: %d trials, %d stored, %d from stored twins, %d to simulate", len(runs), len(trials),
                 len(keep), copied, len(order))
        errors = 0
        stopped = False

        def tasks() -> Iterator:
            nonlocal stopped
            study = None
            for group in order:
                first = group[0]
                owner = studies_of[first.key][0]
                if owner != study:
                    if deadline is not None and time.perf_counter() > deadline:
                        stopped = True
                        log.warning("time is up: the trials of %s and the studies after it do not start", owner)
                        return
                    study = owner
                yield delayed(execute_trial)(fn, first.scenario, first.method, first.seed, first.key)

        if order:
            by_run = {g[0].key: g for g in order}
            bar = stack.enter_context(tqdm(total=sum(len(g) for g in order), unit="trial", file=sys.stderr,
                                           disable=quiet, dynamic_ncols=True, desc=_label(runs), smoothing=0.1))
            # Under the dask backend n_jobs=-1 means every worker thread of the cluster.
            parallel = Parallel(n_jobs=jobs if scheduler is None else -1, return_as="generator_unordered",
                                batch_size=1)
            for out in parallel(tasks()):
                group = by_run[out.key]
                first = group[0]
                version = out.code_version or current
                store.add_trial(key=out.key, study=studies_of[out.key][0], config=first.config, seed=first.seed,
                                outcome=out.outcome, summary=out.summary, metrics=out.metrics,
                                version=PACKAGE_VERSION, error=out.error, code_version=version,
                                also=tuple(studies_of[out.key][1:]))
                for twin in group[1:]:
                    _store_twin(store, twin, studies_of[twin.key], out.outcome, out.summary, out.metrics, out.error,
                                version, out.key)
                copied += len(group) - 1
                outcome_of.update((t.key, out.outcome) for t in group)
                errors += out.error is not None
                bar.update(len(group))
                if out.error:
                    log.warning("%s seed %d: %s", first.scenario.name, first.seed, out.error)
                    bar.set_postfix(errors=errors)
    wall = time.perf_counter() - start
    summaries = []
    for spec, expansion in runs:
        got = Counter(outcome_of[t.key] for t in expansion.trials if t.key in outcome_of)
        summaries.append(SweepSummary(
            study=spec.name, db_path=str(db_path), total=len(expansion.trials), done=sum(got.values()),
            skipped=sum(t.key in keep for t in expansion.trials), errors=got["error"], outcomes=dict(got),
            wall_time=wall, notes=tuple(notes[spec.name]), stale=sum(stale[spec.name].values())))
    errors = sum(o == "error" for o in outcome_of.values())
    return BatchSummary(tuple(summaries), len(outcome_of) - copied, copied, errors, wall, stopped)


def _store_twin(store: ResultStore, trial: TrialSpec, studies: list[str], outcome: str, summary: dict,
                metrics: dict, error: str | None, version: str, simulated: str) -> None:
    """Store ``trial`` from the result of its twin ``simulated`` (same run key): its own key,
    configuration and name, the twin's outcome and figures."""
    store.add_trial(key=trial.key, study=studies[0], config=trial.config, seed=trial.seed, outcome=outcome,
                    summary={**summary, "scenario": trial.scenario.name, "same_run_as": simulated},
                    metrics=metrics, version=PACKAGE_VERSION, error=error, code_version=version,
                    also=tuple(studies[1:]))


def _label(runs: Sequence[tuple[SweepSpec, Expansion]]) -> str:
    names = [spec.name for spec, _ in runs]
    return names[0] if len(names) == 1 else f"{len(names)} studies"


def run_sweep(spec: SweepSpec, db_path: str | Path = DEFAULT_DB, jobs: int = 1, scheduler: str | None = None,
              quiet: bool = False, *, trial_fn: Callable | None = None, retry_errors: bool = False,
              connect_timeout: float = 30.0, allow_mixed: bool = False,
              notify: Callable[[str], None] | None = None) -> SweepSummary:
    """Run every trial of ``spec`` that ``db_path`` does not hold yet and store each result as it arrives.

    ``jobs`` worker processes run trials locally; with ``scheduler`` (a Dask scheduler address
    such as ``tcp://10.0.0.5:8786``, reached within ``connect_timeout`` seconds) they run on that
    cluster instead, whose workers must have nodnav installed. ``trial_fn`` replaces
    :func:`~nodnav.sim.simulator.run_trial` (the workers must be able to unpickle it). Trials
    stored with outcome ``error`` are run again only with ``retry_errors``. Trials stored by
    another code version are run again unless ``allow_mixed`` (module docstring); ``notify``
    receives that one-line note before any trial runs. A progress bar on stderr shows trials
    done, rate and time left unless ``quiet``.
    """
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise NodnavError(f"jobs: expected a whole number >= 1, got {jobs!r}")
    batch = run_studies([(spec, sweep.expand(spec))], db_path, jobs, scheduler, quiet, trial_fn=trial_fn,
                        retry_errors=retry_errors, connect_timeout=connect_timeout, allow_mixed=allow_mixed,
                        notify=notify)
    return batch.studies[0]
