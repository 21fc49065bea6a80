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

import ast
import importlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nodnav.provenance import PACKAGE_VERSION as __version__


def _declared() -> dict[str, tuple[str, str]]:
    """The public names, each with the module and attribute it is, read from the imports under
    ``if TYPE_CHECKING:`` at the end of this file: they are the one declaration, which type
    checkers read as imports and which :func:`__getattr__` follows when a name is first used."""
    tree = ast.parse(Path(__file__).read_text(encoding="utf-8"))
    block = next(node for node in tree.body if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING")
    return {alias.asname or alias.name: (node.module, alias.name)
            for node in block.body if isinstance(node, ast.ImportFrom) and node.module
            for alias in node.names}


#: Where each public name lives: ``name -> (module, attribute)``.
_HOMES = _declared()

__all__ = sorted(_HOMES) + ["__version__"]

# Registering the built-in implementations happens when their layer is imported.
_LAYERS = {"PLANNERS": "nodnav.planning", "CONTROLLERS": "nodnav.control", "METHODS": "nodnav.sim"}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'nodnav' has no attribute {name!r}")
    module, attr = home
    if name in _LAYERS:
        importlib.import_module(_LAYERS[name])
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__


# The public names: add one here and it is importable as ``nodnav.NAME``, listed in ``__all__``
# and checked by tests/test_public_names.py.
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
        BaselineParams,
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
    from nodnav.scenario.world import Corridor, Passage, World, paper_world
    from nodnav.sim.history import History
    from nodnav.sim.methods import Method
    from nodnav.sim.trial_result import TrialResult
    from nodnav.viz.trial import save_animation, save_snapshots
