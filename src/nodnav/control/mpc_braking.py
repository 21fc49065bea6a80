"""The MPC's side of mutual braking (:mod:`nodnav.control.mutual_braking`): which fallback a plan
leaves the robot with, whether it passes the check, and when no plan can.

A plan is accepted only if the robot's fallback from the plan's next state passes the check
against every robot it is given (:func:`fallback_conflict`). Where the check can be bounded for
every plan at once and the bound is negative (:func:`no_plan_passes`), the MPC brakes without
solving: a crowd of robots stopped short of one another otherwise solves the tracking and
evasive QPs at every step only to refuse their plans.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from nodnav.compiled import compiled
from nodnav.control.braking import Committed, _tail_clearance_kernel, braking_profile, tail_clearance
from nodnav.control.mutual_braking import (
    MAX_SAMPLES,
    SAMPLE_STEP,
    BrakingPartners,
    _deviation_terms,
    _slack_kernel,
    braking_slack,
    passing_bound,
)

BOUND_TOLERANCE = 1e-9
"""How far below zero (m) :func:`passing_bound` must be before the MPC skips solving: rounding
must not skip a plan that would pass."""


class WallsAround(NamedTuple):
    """What the checks read of the robot and its walls."""

    obstacles: np.ndarray
    """The wall boxes near the robot (the MPC's ``obstacles``)."""
    pieces: np.ndarray
    """The world's wall pieces."""
    bounds: np.ndarray
    """The world's bounds."""
    radius: float
    """The robot's radius (m)."""
    max_accel: float
    """Its deceleration when braking (m/s^2)."""
    tolerance: float
    """How far inside its radius a wall may come before braking counts as reaching it (m)."""

    def braking_clearance(self, position: np.ndarray, velocity: np.ndarray) -> float:
        """Smallest clearance (m) of straight braking from ``(position, velocity)``."""
        return tail_clearance(position, velocity, self.max_accel, self.obstacles, self.pieces, self.bounds)


class StraightCheck(NamedTuple):
    """:func:`_straight_slack_kernel`'s answer, made where the plan was checked
    (:meth:`~nodnav.control.mpc_problem.MPCProblem.checked_plan_braking`)."""

    straight: bool
    """Whether straight braking stops clear of the walls (then it is the fallback)."""
    worst: int
    """The index of the smallest slack (-1: none, or not computed)."""
    slack: np.ndarray
    """Every robot's slack ``(N,)`` (m), where ``straight``."""


def fallback_conflict(partners: BrakingPartners, walls: WallsAround, next_state: tuple[np.ndarray, np.ndarray],
                      committed_trajectory: Callable[[], Committed], max_speed: float,
                      checked: StraightCheck | tuple | None = None) -> str:
    """Why the robot's fallback from a plan's next state fails the mutual braking check
    (:func:`braking_slack`) towards a robot of ``partners``; "" when it passes. The fallback is
    what the next step does if it finds no plan: straight braking where that stops clear of the
    walls, else the plan's committed trajectory (read from one step on; made by
    ``committed_trajectory`` only then), moving at most ``max_speed``. ``checked``: the straight
    braking's part made with the plan's check (a :class:`StraightCheck`, or its fields as a tuple)."""
    if checked is None:
        position, velocity = next_state
        out = np.empty(len(partners.positions))
        straight, j = _straight_slack_kernel(position, velocity, walls.max_accel, walls.obstacles, walls.pieces,
                                             walls.bounds, walls.radius - walls.tolerance, partners.robot,
                                             partners.positions, partners.velocities, partners.decels,
                                             partners.radii, partners.keeps_rule, partners.seen, int(partners.turn),
                                             partners.convention, float(partners.dt), SAMPLE_STEP, MAX_SAMPLES, out)
    else:
        straight, j, out = checked
    if straight:  # the usual case: straight braking stops clear of the walls, checked in the same call
        if j < 0 or out[j] >= 0.0:
            return ""
        return (f"its braking from its next step would come {-out[j]:.3f} m too close to robot {j}'s braking "
                "trajectory (mutual braking)")
    position, velocity = next_state
    fallback = None
    if walls.braking_clearance(position, velocity) < walls.radius - walls.tolerance:
        committed = committed_trajectory()
        end_speed = math.hypot(committed.end_velocity[0], committed.end_velocity[1])
        stop = committed.horizon - committed.elapsed + end_speed / committed.decel
        samples = committed.motion(SAMPLE_STEP * np.arange(int(math.ceil(stop / SAMPLE_STEP)) + 1))
        fallback = (samples, SAMPLE_STEP, max_speed + walls.tolerance)
    slack, j = braking_slack(position, velocity, partners, fallback=fallback)
    if j < 0 or slack[j] >= 0.0:
        return ""
    kind = "braking" if fallback is None else "committed trajectory"
    return (f"its {kind} from its next step would come {-slack[j]:.3f} m too close to robot {j}'s braking "
            "trajectory (mutual braking)")


@compiled
def _straight_slack_kernel(p, v, decel, boxes, pieces, bounds, limit, i, positions, velocities, decels, radii, keeps,
                           seen, turn, convention, dt, step, max_samples, out):
    """:meth:`WallsAround.braking_clearance` of ``(p, v)`` and, where it is at least ``limit`` (the
    fallback is straight braking), :func:`~nodnav.control.mutual_braking.braking_slack` of it into
    ``out`` in the same call (the same operations): whether straight braking is the fallback, and
    the index of the smallest slack (-1: none, or not computed)."""
    if _tail_clearance_kernel(p, v, decel, boxes, pieces, bounds) < limit:
        return False, -1
    own = np.zeros((0, 2))
    return True, _slack_kernel(i, p, v, own, 0.0, 0.0, positions, velocities, decels, radii, keeps, seen, turn,
                               convention, dt, step, max_samples, out)


def braking_reach(speed: float, decel: float, dt: float) -> float:
    """``float(braking_deviation(speed, decel, dt, math.inf))``
    (:func:`~nodnav.control.mutual_braking.braking_deviation`), the deviation once fully grown,
    from the compiled scalar terms (the NumPy function's operations: ``min(inf, x)`` is ``x``)."""
    dp, dv = _deviation_terms(speed, decel, dt, True)
    return dp + dv * ((speed + decel * dt) / decel)


def no_plan_passes(partners: BrakingPartners, walls: WallsAround, p0: np.ndarray, v0: np.ndarray,
                   dt: float) -> str:
    """Why no plan from ``(p0, v0)`` can pass the mutual braking check, so that solving for one is
    wasted work; "" if one may.

    The check is bounded from above for every plan at once (:func:`passing_bound`), which holds
    where every plan's fallback is straight braking. The straight braking from any next step
    stays within :func:`~nodnav.control.mutual_braking.braking_deviation` of the braking
    trajectory now at every instant, so its segment is within that distance of the segment now,
    and it stops clear of the walls if the braking now does by that much (otherwise some plan's
    fallback may be its committed trajectory, which the bound does not cover: then the MPC solves
    as usual)."""
    bound, j = passing_bound(p0, v0, partners)
    if bound >= -BOUND_TOLERANCE:
        return ""
    pos, vel = braking_profile(p0, v0, walls.max_accel, np.array([dt]))
    reach = braking_reach(math.hypot(v0[0], v0[1]), walls.max_accel, dt)
    if walls.braking_clearance(pos[0], vel[0]) - reach < walls.radius - walls.tolerance:
        return ""
    return (f"no plan can pass: braking from any next step comes at least {-bound:.3f} m too close to robot "
            f"{j}'s braking trajectory (mutual braking)")
