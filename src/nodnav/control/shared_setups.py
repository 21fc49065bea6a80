"""MPC setups and problems shared by the controllers of one trial whose robots have the same body."""

from __future__ import annotations

from nodnav.control.mpc_problem import MPCProblem, MPCSetup
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import World


class SharedSetups:
    """MPC setups, and their problems by number of other robots and sample times, shared by the
    controllers of one trial whose robots have the same body and limits in the same world.

    One object per trial (the method builds it with its controllers), never per process: a
    problem's rows and step state are scratch space that a step writes before it reads them (and
    reads no more once it returns), which is safe only
    while the controllers sharing it step one after another, as one trial's do.
    """

    def __init__(self) -> None:
        self._by_body: dict[tuple, tuple[MPCSetup, dict[tuple, MPCProblem]]] = {}

    def get(self, world: World, robot: RobotSpec, params: MPCParams) -> tuple[MPCSetup, dict[tuple, MPCProblem]]:
        """The setup of a controller of ``robot`` in ``world`` and its problems (the setup's
        ``robot`` is the first such robot; only its radius and limits are read)."""
        key = (id(world), robot.radius, robot.max_speed, robot.max_accel, params)
        shared = self._by_body.get(key)
        if shared is None:
            shared = self._by_body[key] = (MPCSetup.of(world, robot, params), {})
        return shared
