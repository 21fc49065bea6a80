"""Motion controllers behind one :class:`~nodnav.control.base.Controller` protocol.

Importing this package registers the built-in controller (:data:`~nodnav.registry.CONTROLLERS`):
``mpc`` (:mod:`nodnav.control.mpc`).
"""

from __future__ import annotations

from nodnav.control.base import Controller, ControlRequest, ControlResult
from nodnav.control.mpc import BSplineMPC
from nodnav.registry import CONTROLLERS
from nodnav.scenario.params import ControllerParams, RobotSpec
from nodnav.scenario.world import World


def make_controller(params: ControllerParams, world: World, robot: RobotSpec) -> Controller:
    """The controller registered as ``params.name`` (:data:`~nodnav.registry.CONTROLLERS`) for one robot.

    Parameters
    ----------
    params : ControllerParams
        The controller's parameters (the class registered under its name).
    world : World
        The environment.
    robot : RobotSpec
        The robot it moves.

    Returns
    -------
    Controller
        A new controller, one per robot (it keeps the robot's previous plan).
    """
    return CONTROLLERS.create(params.name, world, robot, params)


__all__ = ["BSplineMPC", "Controller", "ControlRequest", "ControlResult", "make_controller", "CONTROLLERS"]
