"""The controller interface: track a reference while keeping clear of others and walls.

One controller instance belongs to one robot (it may keep warm-start state between steps).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from nodnav.control.mutual_braking import BrakingPartners

#: Points of a control step at which a controller reports the motion it commands: the fractions
#: 1/4, 2/4, 3/4 and 4/4 of the step (the simulator checks contacts there).
STEP_FRACTIONS = np.array([0.25, 0.5, 0.75, 1.0])


@dataclass(frozen=True)
class ControlRequest:
    """What a robot's controller knows at one control step."""

    position: np.ndarray
    """Current position p_{i,t} ``(2,)`` (m)."""
    velocity: np.ndarray
    """Current velocity v_{i,t} ``(2,)`` (m/s)."""
    reference: np.ndarray
    """Reference positions p^PRM over the horizon ``(K, 2)`` (m), at ``sample_times``."""
    sample_times: np.ndarray
    """Times after now at which ``reference`` and ``others`` are given ``(K,)`` (s), in (0, T_MPC]."""
    others: np.ndarray
    """Predicted positions p^pred_j of the other robots ``(m, K, 2)`` (m); m may be 0."""
    other_radii: np.ndarray
    """Radii of the other robots ``(m,)`` (m)."""
    firm: np.ndarray | None = None
    """Which predictions ``(m,)`` a controller that trades intrusions when it cannot keep clear
    of every prediction must still keep clear of, as of a wall; ``None``: none."""
    braking: BrakingPartners | None = None
    """The robots whose braking trajectories the robot's own braking from its next step must keep
    clear of (:mod:`nodnav.control.mutual_braking`); ``None``: no such check."""
    margins: np.ndarray | None = None
    """Clearance beyond contact to keep from each prediction ``(m,)`` (m); ``None``: the
    controller's own ``safety_margin`` from every one. A controller that keeps no margin may ignore it."""

    @classmethod
    def built(cls, position: np.ndarray, velocity: np.ndarray, reference: np.ndarray, sample_times: np.ndarray,
              others: np.ndarray, other_radii: np.ndarray, firm: np.ndarray | None = None,
              braking: BrakingPartners | None = None, margins: np.ndarray | None = None) -> "ControlRequest":
        """The request the constructor builds, with the same fields, without the frozen
        dataclass's assignment of one field at a time (the closed loop builds one per robot and
        control step)."""
        request = object.__new__(cls)
        request.__dict__.update(position=position, velocity=velocity, reference=reference, sample_times=sample_times,
                                others=others, other_radii=other_radii, firm=firm, braking=braking, margins=margins)
        return request


@dataclass(frozen=True)
class ControlResult:
    """What a controller returns: never ``None``; on failure it still returns a safe command."""

    success: bool
    """Whether the optimisation produced a trajectory satisfying every constraint."""
    reason: str
    """Empty on success; otherwise what went wrong and what the robot did (e.g. braked)."""
    velocity: np.ndarray
    """Velocity command to apply over the next control step ``(2,)`` (m/s)."""
    next_position: np.ndarray
    """Position the robot reaches after one control step if it follows the plan ``(2,)`` (m)."""
    next_velocity: np.ndarray
    """Velocity at the end of the control step ``(2,)`` (m/s)."""
    planned_positions: np.ndarray
    """The controller's planned positions at the request's ``sample_times`` ``(K, 2)`` (m)."""
    solve_time: float = 0.0
    """Wall time of the solve (s)."""
    step_positions: np.ndarray | None = None
    """Positions the robot passes at :data:`STEP_FRACTIONS` of the coming step ``(4, 2)`` (m), the
    last being ``next_position``; ``None`` for motion in a straight line at constant velocity."""
    info: dict = field(default_factory=dict)
    """Controller-specific diagnostics (iterations, solver status)."""

    @classmethod
    def built(cls, success: bool, reason: str, velocity: np.ndarray, next_position: np.ndarray,
              next_velocity: np.ndarray, planned_positions: np.ndarray, solve_time: float,
              step_positions: np.ndarray | None, info: dict) -> "ControlResult":
        """The result the constructor builds, every field given, without the frozen dataclass's
        assignment of one field at a time (a controller returns one per robot and control step,
        as :meth:`ControlRequest.built`)."""
        result = object.__new__(cls)
        result.__dict__.update(success=success, reason=reason, velocity=velocity, next_position=next_position,
                               next_velocity=next_velocity, planned_positions=planned_positions,
                               solve_time=solve_time, step_positions=step_positions, info=info)
        return result


@runtime_checkable
class Controller(Protocol):
    """A robot's motion controller."""

    name: str

    def control(self, request: ControlRequest) -> ControlResult:
        """Compute the command for the next control step."""
        ...
