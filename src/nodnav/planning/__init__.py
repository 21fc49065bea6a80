"""Multi-robot path planners behind one :class:`~nodnav.planning.base.Planner` protocol."""

from __future__ import annotations

from nodnav.planning.base import JointTrajectory, Planner, PlanRequest, PlanResult

PLANNERS = ("fast", "prm")


def make_planner(params, world) -> Planner:
    """The planner named ``params.name`` (``fast`` or ``prm``) for ``world``."""
    if params.name == "fast":
        from nodnav.planning.prioritized import PrioritizedPlanner

        return PrioritizedPlanner(world, params)
    if params.name == "prm":
        from nodnav.planning.prm import PRMStarPlanner

        return PRMStarPlanner(world, params)
    raise ValueError(f"unknown planner '{params.name}'; choose one of {', '.join(PLANNERS)}")


__all__ = ["JointTrajectory", "Planner", "PlanRequest", "PlanResult", "make_planner", "PLANNERS"]
