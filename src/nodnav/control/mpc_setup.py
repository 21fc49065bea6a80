"""What is fixed for one robot's MPC controller: its body, settings, the spline's knots and the
linear maps on its control points (:class:`MPCSetup`), shared by the problems of
:mod:`nodnav.control.mpc_problem`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodnav.control import bspline
from nodnav.control.base import STEP_FRACTIONS
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import World

DEGREE = 3
"""The paper's third-order (cubic) B-spline."""


def initial_state_nullspace(knots: np.ndarray, degree: int) -> np.ndarray:
    """``T`` (``(n, n - 2)``): the curves with ``p(0) = 0`` and ``v(0) = 0`` are exactly ``c = T z``.

    The initial position and velocity (appendix) are linear in the first control points; the
    first two are solved for, and ``z`` are the remaining ``n - 2`` control points. Every curve
    with ``p(0) = p0``, ``v(0) = v0`` is the straight line ``p0 + v0 tau`` (control points
    ``p0 + v0 xi_k``, :func:`~nodnav.control.bspline.greville_abscissae`) plus such a curve.
    """
    d0 = np.vstack([bspline.basis_derivative([0.0], knots, degree, 0),
                    bspline.basis_derivative([0.0], knots, degree, 1)])
    return np.vstack([-np.linalg.solve(d0[:, :2], d0[:, 2:]), np.eye(d0.shape[1] - 2)])


@dataclass(frozen=True, eq=False)
class MPCSetup:
    """What is fixed for one robot's controller: its body and settings, the spline's knots and the
    linear maps on its control points."""

    robot: RobotSpec
    """The robot."""
    settings: MPCParams
    """The controller's parameters."""
    horizon: float
    """T_MPC (s)."""
    dt: float
    """Control step (s)."""
    knots: np.ndarray
    """Uniform knots of the cubic spline over the horizon."""
    nullspace: np.ndarray
    """Curves with zero initial position and velocity, :func:`initial_state_nullspace`."""
    greville: np.ndarray
    """Greville abscissae: the control points of the line ``tau -> tau``."""
    cost_hessian: np.ndarray
    """Gram matrix of the tracking cost (position plus ``w_2`` velocity) on the control points."""
    obstacles: np.ndarray
    """Wall rectangles ``(M, 4)``."""
    pieces: np.ndarray
    """Convex pieces of polygon walls ``(P, K, 2)`` (:attr:`nodnav.scenario.world.World.piece_array`)."""
    world_bounds: np.ndarray
    """World bounds ``(x0, y0, x1, y1)``."""
    b_step: np.ndarray
    """Position one step ahead, as a row on the control points."""
    b_substeps: np.ndarray
    """Positions within the step (:data:`~nodnav.control.base.STEP_FRACTIONS`)."""
    bv_step: np.ndarray
    """Velocity one step ahead."""
    rates: np.ndarray
    """Points whose hulls hold the velocity (after ``v(0)``) and the acceleration."""
    n_speed: int
    """How many of :attr:`rates` are velocity points."""
    shift: np.ndarray
    """Moves a plan's control points on by one step."""

    @staticmethod
    def of(world: World, robot: RobotSpec, params: MPCParams) -> "MPCSetup":
        """The setup of ``robot``'s controller in ``world``."""
        horizon, dt = float(params.horizon), float(params.dt)
        knots = bspline.uniform_knots(horizon, params.segments, DEGREE)
        cost_hessian = (bspline.gram_matrix(knots, DEGREE, 0, 0.0, horizon)
                        + params.w2 * bspline.gram_matrix(knots, DEGREE, 1, 0.0, horizon))
        # Points whose hulls hold the velocity (after v(0)) and the acceleration, for the exact check.
        d1 = bspline.velocity_hull_operator(knots)[1:]
        # Moving a plan on by one step: least-squares fit of p(tau + dt) (the last span's
        # polynomial continues past the horizon).
        fit = np.linspace(0.0, horizon, 4 * params.segments + 1)
        shift = np.linalg.lstsq(bspline.basis(fit, knots, DEGREE), bspline.basis(fit + dt, knots, DEGREE),
                                rcond=None)[0]
        return MPCSetup(
            robot=robot, settings=params, horizon=horizon, dt=dt, knots=knots,
            nullspace=initial_state_nullspace(knots, DEGREE), greville=bspline.greville_abscissae(knots, DEGREE),
            cost_hessian=cost_hessian, obstacles=world.obstacle_array, pieces=world.piece_array,
            world_bounds=world.bounds_array,
            b_step=bspline.basis_derivative([dt], knots, DEGREE, 0)[0],
            # Where the robot passes within a step: the spline is curved, the chord is not it.
            b_substeps=bspline.basis_derivative(dt * STEP_FRACTIONS, knots, DEGREE, 0),
            bv_step=bspline.basis_derivative([dt], knots, DEGREE, 1)[0],
            rates=np.vstack([d1, bspline.derivative_control_operator(knots, DEGREE, 2)]), n_speed=len(d1),
            shift=shift)
