"""Multi-robot path planners behind one :class:`~nodnav.planning.base.Planner` protocol.

Importing this package registers the built-in planners (:data:`~nodnav.registry.PLANNERS`):
``fast`` (:mod:`nodnav.planning.prioritized`) and ``prm`` (:mod:`nodnav.planning.prm`).
"""

from __future__ import annotations

from nodnav.planning.base import JointTrajectory, Planner, PlanRequest, PlanResult
from nodnav.planning.prioritized import PrioritizedPlanner
from nodnav.planning.prm import PRMStarPlanner
from nodnav.registry import PLANNERS
from nodnav.scenario.params import PlannerParams
from nodnav.scenario.world import World


def make_planner(params: PlannerParams, world: World) -> Planner:
    """The planner registered as ``params.name`` (:data:`~nodnav.registry.PLANNERS`) for ``world``.

    Parameters
    ----------
    params : PlannerParams
        The planner's parameters (the class registered under its name).
    world : World
        The environment it plans in.

    Returns
    -------
    Planner
        A new planner instance; share it between the robots of a trial (it remembers answers).
    """
    return PLANNERS.create(params.name, world, params)


__all__ = ["JointTrajectory", "Planner", "PlanRequest", "PlanResult", "PRMStarPlanner", "PrioritizedPlanner",
           "make_planner", "PLANNERS"]
