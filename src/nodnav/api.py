"""The functions of the public API (``import nodnav``): load or build a scenario, run a trial,
run a sweep, write a report. Each forwards to the module that does the work; this one only
gives them one documented place.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nodnav.experiments.batch import run_sweep as _run_sweep
from nodnav.experiments.study import SweepSpec, study_from_dict
from nodnav.experiments.sweep import SweepSummary
from nodnav.planning.base import Planner
from nodnav.scenario.loading import load_scenario as _load_scenario
from nodnav.scenario.schema import Scenario, scenario_from_dict
from nodnav.sim.simulator import run_trial as _run_trial
from nodnav.sim.trial_result import TrialResult

if TYPE_CHECKING:  # the report's modules import matplotlib: loaded when a report is built
    from nodnav.reporting.report import ReportResult


def load_scenario(spec: str | Path, overrides: Mapping[str, Any] | None = None) -> Scenario:
    """Load a scenario, validated.

    Parameters
    ----------
    spec : str or Path
        A built-in name (``"3r-case4"``; ``nodnav scenarios`` lists them), a YAML file, or a draw
        of a family as ``"FAMILY:SEED"`` (``"mixed:17"``).
    overrides : mapping, optional
        Scenario keys as a file writes them, and their values, set on top of the file before it
        is validated (what ``--set KEY=VALUE`` does): ``{"planner.name": "prm",
        "robots[1].max_speed": 0.5, "robot_defaults.max_accel": 0.5}``. A family's draw is drawn
        as without them and they apply to it.

    Returns
    -------
    Scenario
        The frozen scenario.

    Raises
    ------
    ScenarioError
        One line naming the key that is wrong and how to fix it.
    """
    return _load_scenario(spec, overrides)


def build_scenario(data: Mapping[str, Any], name: str = "scenario") -> Scenario:
    """Build a scenario in code from the same mapping a scenario file holds.

    Parameters
    ----------
    data : mapping
        The scenario's keys, e.g. ``{"robots": [{"origin": [-5, 0], "destination": [5, 0]},
        {"origin": [5, 0], "destination": [-5, 0]}], "planner": {"name": "fast"}}``; every key
        but ``robots`` is optional.
    name : str
        The scenario's name when ``data`` has none.

    Returns
    -------
    Scenario
        The frozen scenario, validated as a loaded file is.

    Raises
    ------
    ScenarioError
        One line naming the key that is wrong and how to fix it.
    """
    return scenario_from_dict(dict(data), name)


def run_trial(scenario: Scenario | str, method: str = "nod", seed: int = 0, planner: Planner | None = None,
              progress: Callable[[float, float], None] | None = None) -> TrialResult:
    """Simulate one closed-loop trial to its end.

    Parameters
    ----------
    scenario : Scenario or str
        The scenario, or anything :func:`load_scenario` accepts.
    method : str
        A navigation method of :data:`METHODS` (``nod``, the paper's, by default).
    seed : int
        The trial's seed: every random number of the trial comes from it (same seed, same trial).
    planner : Planner, optional
        A planner instance to use instead of the one the scenario names.
    progress : callable, optional
        Called as ``progress(t, time_limit)`` after every control step.

    Returns
    -------
    TrialResult
        The outcome (``success``, ``collision``, ``deadlock`` or ``timeout``), the figures of the
        trial, and its full :class:`History`.
    """
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    return _run_trial(scenario, method, seed, planner, progress)


def run_sweep(study: SweepSpec | Mapping[str, Any], db: str | Path, jobs: int = 1, quiet: bool = True,
              **options: Any) -> SweepSummary:
    """Run many trials into a results database (SQLite), resumably.

    Parameters
    ----------
    study : SweepSpec or mapping
        The study: a :class:`SweepSpec`, or the mapping a study file holds, e.g.
        ``{"name": "mine", "scenarios": ["2r-case1"], "players": [0, "all"], "trials": 10,
        "set": {"sim.observation_noise": 0.01}}`` (``set``: scenario keys set in every scenario).
    db : str or Path
        The results database; trials it holds already are not run again.
    jobs : int
        Local worker processes (with 1, the trials run in this process). After its first trial
        a process that runs the sweep's trials freezes the objects then alive out of the
        garbage collector's full collections, once (:func:`nodnav.heap.freeze_long_lived`).
    quiet : bool
        No progress bar.
    **options
        Passed on to :func:`nodnav.experiments.batch.run_sweep` (``scheduler``, ``retry_errors``,
        ``allow_mixed``, ``trial_fn``, ...).

    Returns
    -------
    SweepSummary
        How many trials ran, were stored already or raised, and their outcomes.
    """
    spec = study if isinstance(study, SweepSpec) else study_from_dict(dict(study), "study")
    return _run_sweep(spec, db, jobs=jobs, quiet=quiet, **options)


def build_report(db: str | Path, out: str | Path, *, heatmap_grid: int = 41, rerun_snapshots: bool = True,
                 command: str = "nodnav report") -> ReportResult:
    """Write ``report.md`` and its figures from a results database.

    Parameters
    ----------
    db : str or Path
        A results database written by :func:`run_sweep` or ``nodnav reproduce``.
    out : str or Path
        The directory to write into.
    heatmap_grid : int
        Grid points per axis of the Fig. 2a/2b heatmaps (they are recomputed).
    rerun_snapshots : bool
        Whether the paper's snapshot trials are re-run for their figures.
    command : str
        The command quoted as the producer of every figure.

    Returns
    -------
    ReportResult
        Whether ``report.md`` was written, where, and what it holds.
    """
    from nodnav.reporting.report import build_report as _build_report

    return _build_report(db, out, command=command, heatmap_grid=heatmap_grid, rerun_snapshots=rerun_snapshots)
