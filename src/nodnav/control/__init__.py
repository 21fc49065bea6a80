"""Motion controllers behind one :class:`~nodnav.control.base.Controller` protocol.

Importing this package registers the built-in controller (:data:`~nodnav.registry.CONTROLLERS`):
``mpc`` (:mod:`nodnav.control.mpc`).
"""

from __future__ import annotations

import inspect

from nodnav.control.base import Controller, ControlRequest, ControlResult
from nodnav.control.mpc import BSplineMPC, SharedSetups
from nodnav.registry import CONTROLLERS
from nodnav.scenario.params import ControllerParams, RobotSpec
from nodnav.scenario.world import World


def make_controller(params: ControllerParams, world: World, robot: RobotSpec,
                    shared: SharedSetups | None = None) -> Controller:
    """The controller registered as ``params.name`` (:data:`~nodnav.registry.CONTROLLERS`) for one robot.

    Parameters
    ----------
    params : ControllerParams
        The controller's parameters (the class registered under its name).
    world : World
        The environment.
    robot : RobotSpec
        The robot it moves.
    shared : SharedSetups, optional
        One per trial: lets the controllers of robots with the same body share their set-up. It
        is passed only to controllers whose constructor takes a ``shared`` keyword.

    Returns
    -------
    Controller
        A new controller, one per robot (it keeps the robot's previous plan).
    """
    factory = CONTROLLERS.get(params.name).factory
    takes_shared = factory is not None and "shared" in inspect.signature(factory).parameters
    if shared is not None and takes_shared:
        return CONTROLLERS.create(params.name, world, robot, params, shared=shared)
    return CONTROLLERS.create(params.name, world, robot, params)


__all__ = ["BSplineMPC", "Controller", "ControlRequest", "ControlResult", "make_controller", "CONTROLLERS",
           "SharedSetups"]
