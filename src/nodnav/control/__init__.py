"""Motion controllers behind one :class:`~nodnav.control.base.Controller` protocol."""

from __future__ import annotations

from nodnav.control.base import Controller, ControlRequest, ControlResult

CONTROLLERS = ("mpc",)


def make_controller(params, world, robot) -> Controller:
    """The controller named ``params.name`` for one robot (a :class:`~nodnav.scenario.schema.RobotSpec`)."""
    if params.name == "mpc":
        from nodnav.control.mpc import BSplineMPC

        return BSplineMPC(world, robot, params)
    raise ValueError(f"unknown controller '{params.name}'; choose one of {', '.join(CONTROLLERS)}")


__all__ = ["Controller", "ControlRequest", "ControlResult", "make_controller", "CONTROLLERS"]
