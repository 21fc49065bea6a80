"""nodnav: opinion-driven multi-robot navigation through narrow corridors.

The names a user needs, importable from here (loaded when first used)::

    import nodnav

    scenario = nodnav.load_scenario("3r-case4")          # or nodnav.build_scenario({...})
    result = nodnav.run_trial(scenario, seed=1)          # a TrialResult; result.history
    nodnav.save_snapshots(result.history, "fig.png")

Scenarios: :func:`load_scenario`, :func:`build_scenario`, :class:`Scenario` and its parameter
classes, :func:`builtin_scenarios`. Trials: :func:`run_trial`, :class:`TrialResult`,
:class:`History` (``History.to_dataframe()``), :func:`save_snapshots`, :func:`save_animation`,
:func:`export_history` (CSV, Parquet, ROS 2 bags). Studies: :func:`run_sweep`,
:class:`SweepSpec`, :class:`SweepSummary`, :func:`build_report`, :class:`ReportResult`.
Plugins: the registries :data:`PLANNERS`, :data:`CONTROLLERS`, :data:`METHODS` and their
decorators :func:`register_planner`, :func:`register_controller`, :func:`register_method`, with
the protocols an implementation meets (:class:`Planner`, :class:`Controller`, :class:`Method`).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from nodnav.provenance import PACKAGE_VERSION as __version__

#: Where each public name lives.
_HOMES = {
    "load_scenario": "nodnav.api", "build_scenario": "nodnav.api", "run_trial": "nodnav.api",
    "run_sweep": "nodnav.api", "build_report": "nodnav.api",
    "Scenario": "nodnav.scenario.schema", "scenario_from_dict": "nodnav.scenario.schema",
    "scenario_to_dict": "nodnav.scenario.schema", "ScenarioError": "nodnav.scenario.fields",
    "builtin_scenarios": ("nodnav.scenario.files", "builtin_names"),
    "RobotSpec": "nodnav.scenario.params", "OpinionParams": "nodnav.scenario.params",
    "PlannerParams": "nodnav.scenario.params", "FastPlannerParams": "nodnav.scenario.params",
    "PRMParams": "nodnav.scenario.params", "ControllerParams": "nodnav.scenario.params",
    "MPCParams": "nodnav.scenario.params", "SimParams": "nodnav.scenario.params",
    "ExecutionParams": "nodnav.scenario.params",
    "World": "nodnav.scenario.world", "Corridor": "nodnav.scenario.world", "paper_world": "nodnav.scenario.world",
    "TrialResult": "nodnav.sim.simulator", "History": "nodnav.sim.history", "Method": "nodnav.sim.methods",
    "SweepSpec": "nodnav.experiments.study", "SweepSummary": "nodnav.experiments.sweep",
    "ResultStore": "nodnav.experiments.store", "ReportResult": "nodnav.reporting.report",
    "save_snapshots": "nodnav.viz.trial", "save_animation": "nodnav.viz.trial",
    "PLANNERS": "nodnav.registry", "CONTROLLERS": "nodnav.registry", "METHODS": "nodnav.registry",
    "register_planner": "nodnav.registry", "register_controller": "nodnav.registry",
    "register_method": "nodnav.registry", "Registry": "nodnav.registry",
    "Planner": "nodnav.planning.base", "PlanRequest": "nodnav.planning.base", "PlanResult": "nodnav.planning.base",
    "JointTrajectory": "nodnav.planning.base",
    "Controller": "nodnav.control.base", "ControlRequest": "nodnav.control.base",
    "ControlResult": "nodnav.control.base",
    "NodnavError": "nodnav.errors",
    "export_history": "nodnav.export",
}

__all__ = sorted(_HOMES) + ["__version__"]

# Registering the built-in implementations happens when their layer is imported.
_LAYERS = {"PLANNERS": "nodnav.planning", "CONTROLLERS": "nodnav.control", "METHODS": "nodnav.sim"}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'nodnav' has no attribute {name!r}")
    module, attr = home if isinstance(home, tuple) else (home, name)
    if name in _LAYERS:
        importlib.import_module(_LAYERS[name])
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__


if TYPE_CHECKING:
    from nodnav.api import build_report, build_scenario, load_scenario, run_sweep, run_trial
    from nodnav.control.base import Controller, ControlRequest, ControlResult
    from nodnav.errors import NodnavError
    from nodnav.experiments.store import ResultStore
    from nodnav.experiments.study import SweepSpec
    from nodnav.experiments.sweep import SweepSummary
    from nodnav.export import export_history
    from nodnav.planning.base import JointTrajectory, Planner, PlanRequest, PlanResult
    from nodnav.registry import (
        CONTROLLERS,
        METHODS,
        PLANNERS,
        Registry,
        register_controller,
        register_method,
        register_planner,
    )
    from nodnav.reporting.report import ReportResult
    from nodnav.scenario.fields import ScenarioError
    from nodnav.scenario.files import builtin_names as builtin_scenarios
    from nodnav.scenario.params import (
        ControllerParams,
        ExecutionParams,
        FastPlannerParams,
        MPCParams,
        OpinionParams,
        PlannerParams,
        PRMParams,
        RobotSpec,
        SimParams,
    )
    from nodnav.scenario.schema import Scenario, scenario_from_dict, scenario_to_dict
    from nodnav.scenario.world import Corridor, World, paper_world
    from nodnav.sim.history import History
    from nodnav.sim.methods import Method
    from nodnav.sim.simulator import TrialResult
    from nodnav.viz.trial import save_animation, save_snapshots
