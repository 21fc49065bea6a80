"""The MPC's QP: everything fixed for a controller and for a set of sample times, and one step's data.

The QP (appendix, "Model Predictive Control"; the controller is :mod:`nodnav.control.mpc`):

* Equalities by elimination. ``p(0)`` and ``v(0)`` are linear in the first three control
  points; the first two are solved for (:func:`initial_state_nullspace`), so the initial state
  holds to machine precision. The QP's variables are the other control points, as deviations
  from the straight line ``p0 + v0 tau`` (which meets both equalities).
* The cost exactly. The reference (like every prediction) is piecewise linear between the
  request's samples (:func:`interpolation_matrix`), extrapolated back to ``tau = 0`` along its
  first segment and held after the last; the spline is cubic on each knot span, so the
  integrand is a polynomial of degree at most 6 between merged breakpoints, which a 4-point
  Gauss-Legendre rule per piece integrates exactly.
* The rows: a box, speed and acceleration polygons, and per wall and per other robot a
  half-plane at every interval end plus terminal stopping rows (:mod:`nodnav.control.mpc_rows`).
  Every inequality is tightened by the solver's primal tolerance, and every solution is checked
  exactly (true distances and clearances at a fine step, derivative bounds,
  :meth:`MPCProblem.violation`) before it is used.

Everything fixed for one robot's controller is :class:`~nodnav.control.mpc_setup.MPCSetup`;
everything fixed for a (number of other robots, sample times) pair is precomputed once in
:class:`MPCProblem`: the static constraint rows, the Hessians and the map from the reference to
the cost's gradient. A step (:class:`StepData`) only writes the new half-planes and bounds.
"""

from __future__ import annotations

import math

import numpy as np

from nodnav.control import bspline
from nodnav.control.base import STEP_FRACTIONS
from nodnav.control.braking import tail_clearance, tail_decel
from nodnav.control.interpolation import interpolation_matrix, slope_matrix
from nodnav.control.mpc_braking import WallsAround
from nodnav.control.mpc_fused import scratch_shapes, scratch_space, sparse_rows
from nodnav.control.mpc_plan import plan_after_qp, plan_after_qp_braking
from nodnav.control.mpc_rows import (
    chord_inflation,
    constraint_grid,
    gradient_into,
    plan_check,
    polygon_normals,
    step_rows,
    step_state,
    stopping_rows,
    tracking_rows,
)
from nodnav.control.mpc_setup import DEGREE, MPCSetup, initial_state_nullspace
from nodnav.control.mutual_braking import MAX_SAMPLES, SAMPLE_STEP, BrakingPartners
from nodnav.control.qp import SolverEffort
from nodnav.control.step_data import StepData

__all__ = ["DEGREE", "MPCProblem", "MPCSetup", "StepData", "initial_state_nullspace"]  # the setup's names, as before


class MPCProblem:
    """Everything fixed for one (number of other robots, sample times): rows, Hessians, maps.

    The QP's variables are ``z = [z_x, z_y]``, the free control points (:func:`initial_state_nullspace`)
    as deviations from the line ``p0 + v0 tau``, in coordinates centred on ``p0``. Every row is a
    functional ``alpha^T phi_f(c)`` of the control points (a position at an interval end, a
    velocity or acceleration control point, a terminal combination) in one-sided form
    ``row @ z >= lower``, in metres: derivative rows are scaled by the knot span (``h``, ``h^2``).
    Order: box rows, speed polygon, acceleration polygon (all static), then one group of
    ``n_end + n_term`` rows per wall and per other robot (normals written at every step).

    The solver sees whitened variables ``y = R z`` per coordinate, with ``R^T R = 2 P`` (the
    Cholesky factor of the cost's Hessian on ``z``): the QP's Hessian is then the identity, for
    which DAQP skips its own factorisation and the product of every row with ``R^{-1}`` (about
    half of its time on these QPs, docs/performance-7-control.md). The rows, the gradient and
    :attr:`free_map` (``z -> c`` deviation, ``nullspace @ R^{-1}``) are built in ``y`` once here,
    so a step costs nothing extra; every row still means the same functional in metres, so the
    solver's primal tolerance keeps its meaning.
    """

    def __init__(self, setup: MPCSetup, n_others: int, sample_times: np.ndarray):
        s, robot = setup.settings, setup.robot
        knots, horizon = setup.knots, setup.horizon
        self.setup = setup
        self.n_others = n_others
        self.n_walls = len(setup.obstacles) + len(setup.pieces)
        self.sample_times = sample_times
        grid = constraint_grid(sample_times, horizon, s.max_interval)
        self.ends = grid[1:]
        self.mids = 0.5 * (grid[1:] + grid[:-1])
        self.intervals = np.diff(grid)
        n_end = len(self.ends)
        h = knots[1] - knots[0]

        # Terminal rows along the last normal (stopping distance, see stopping_rows).
        self.term_time = grid[-1]
        brake = robot.max_accel * np.cos(np.pi / s.accel_polygon_sides)
        self.term_wv, self.term_wa, self.term_const = stopping_rows(
            h, s.terminal_decel * brake, 2.0 * robot.max_speed, s.terminal_pieces)

        # Every inequality is tightened by the solver's tolerance, so an accepted solution meets
        # the untightened one. Chord inflation of each interval, and its maximum over the
        # intervals meeting at each end.
        self.tol = s.qp_tolerance
        self.eps = chord_inflation(robot.max_accel, self.intervals) + self.tol
        self.eps_end = np.maximum(self.eps, np.append(self.eps[1:], 0.0))

        # Interpolation of the sampled reference and predictions.
        self.interp_zero = interpolation_matrix(sample_times, 0.0)[0]
        self.interp_ends = interpolation_matrix(sample_times, self.ends)
        self.slope_end = slope_matrix(sample_times, self.term_time)
        self.check_times = np.sort(np.concatenate([self.ends, self.mids]))
        self.interp_check = interpolation_matrix(sample_times, self.check_times)
        # One product gives every prediction at 0, at the interval ends, at the check times, and
        # its velocity at the end of the horizon.
        self.interp_all = np.vstack([self.interp_zero, self.interp_ends, self.interp_check, self.slope_end])

        # Curve evaluations (control points -> values).
        self.b_ends = bspline.basis(self.ends, knots, DEGREE)
        self.b_check = bspline.basis(self.check_times, knots, DEGREE)
        self.b_samples = bspline.basis(sample_times, knots, DEGREE)
        self.check_weights = horizon / self.check_times

        # Linear functionals on the control points used by constraint rows: positions at the
        # interval ends, velocity and acceleration control points, terminal functionals.
        # Velocity: the hull points after v(0), which the initial state fixes (constraining it
        # would pin the first points to the polygon's face whenever the robot is at the limit).
        d1 = h * bspline.velocity_hull_operator(knots)[1:]
        d2 = h**2 * bspline.derivative_control_operator(knots, DEGREE, 2)
        phi_term = (bspline.basis_derivative([self.term_time], knots, DEGREE, 0)
                    + self.term_wv[:, None] * bspline.basis_derivative([self.term_time], knots, DEGREE, 1)
                    + self.term_wa[:, None] * bspline.basis_derivative([self.term_time], knots, DEGREE, 2))
        phi = np.vstack([self.b_ends, d1, d2, phi_term])
        # The QP's variables are whitened (see the class docstring): z = unwhiten @ y per coordinate.
        p_half = setup.nullspace.T @ setup.cost_hessian @ setup.nullspace
        unwhiten = np.linalg.inv(np.linalg.cholesky(2.0 * p_half).T)
        self.free_map = setup.nullspace @ unwhiten
        phi_t = phi @ self.free_map
        phi_line = phi @ setup.greville  # each functional on the line tau -> tau
        f_vel = n_end + np.arange(len(d1))
        f_acc = n_end + len(d1) + np.arange(len(d2))
        f_term = n_end + len(d1) + len(d2) + np.arange(len(phi_term))
        self.nz = phi_t.shape[1]

        # Static rows: x, y, -x, -y at each interval end (the box), speed and acceleration polygons.
        eye = np.eye(2)
        v_normals = polygon_normals(s.speed_polygon_sides)
        a_normals = polygon_normals(s.accel_polygon_sides)
        self.n_box = 4 * n_end
        static_alpha = np.vstack([np.tile(np.vstack([eye, -eye]), (n_end, 1)),
                                  -np.tile(v_normals, (len(d1), 1)), -np.tile(a_normals, (len(d2), 1))])
        static_f = np.concatenate([np.repeat(np.arange(n_end), 4), np.repeat(f_vel, len(v_normals)),
                                   np.repeat(f_acc, len(a_normals))])
        self.static_base = np.concatenate([
            np.zeros(self.n_box),  # the box bounds depend on the position, set per step
            np.full(len(d1) * len(v_normals), self.tol - h * robot.max_speed * np.cos(np.pi / s.speed_polygon_sides)),
            np.full(len(d2) * len(a_normals), self.tol - h**2 * brake),
        ])
        self.static_alpha = static_alpha
        self.static_line = phi_line[static_f]
        self.n_static = len(static_f)

        # Dynamic rows, one group per wall and per other robot: a half-plane at every interval
        # end, then the terminal rows with the last end's normal.
        n_term = len(phi_term)
        self.group_point = np.concatenate([np.arange(n_end), np.full(n_term, n_end - 1)])
        self.group_wv = np.concatenate([np.zeros(n_end), self.term_wv])
        self.term_offset = self.eps_end[-1] + self.term_const
        self.rows_per_group = n_end + n_term
        self.n_groups = self.n_walls + n_others
        dyn_f = np.tile(np.concatenate([np.arange(n_end), f_term]), self.n_groups)
        self.dyn_phi = phi_t[dyn_f]
        self.dyn_line = phi_line[dyn_f]
        # Last, the rows of the braking tail (:func:`~nodnav.control.braking.tail_rows`): two per
        # wall and four for the box, on p(T) and v(T); they belong to no group (never softened).
        self.n_separation = self.n_static + len(dyn_f)
        self.n_tail = 2 * self.n_walls + 4
        self.n_rows = self.n_separation + self.n_tail
        phi_tail = np.vstack([bspline.basis_derivative([horizon], knots, DEGREE, 0),
                              bspline.basis_derivative([horizon], knots, DEGREE, 1)])
        self.tail_phi = np.ascontiguousarray(phi_tail @ self.free_map)
        self.tail_line = phi_tail @ setup.greville
        # One product of a plan (:meth:`evaluate`): its check points and the points whose hulls hold
        # its velocity and acceleration, p(T) and v(T), its next position, velocity and samples, and
        # its positions within the step (each row as its own product, bit for bit: tested).
        self.b_post = np.vstack([self.b_check, setup.rates, phi_tail, setup.b_step, setup.bv_step, self.b_samples,
                                 setup.b_substeps])
        n_cr = len(self.b_check) + len(setup.rates)
        n_post = len(self.b_post)
        self.post_slices = (slice(0, n_cr), slice(n_cr, n_cr + 2), slice(n_cr + 2, n_post - 4),
                            slice(n_post - 4, n_post))
        self.b_check_rates, self.b_tail, self.b_out, _ = (self.b_post[k] for k in self.post_slices)
        self.tail_decel = tail_decel(robot.max_accel, s.terminal_decel, s.accel_polygon_sides)
        # What the compiled call after a QP reads of the problem (:meth:`checked_plan`), in its
        # arguments' order: passed as one tuple, not looked up attribute by attribute every step.
        # Its values have one row more than b_post's: the velocity command (mpc_plan.plan_after_qp).
        self.plan_shapes = ((len(self.free_map), 2), (n_post + 1, 2))
        self.plan_constants = (setup.greville, self.free_map, self.b_post, n_cr, len(self.check_times), setup.n_speed,
                               setup.obstacles, setup.pieces, setup.world_bounds, n_cr + 2, setup.dt,
                               s.check_tolerance, robot.max_speed, robot.max_accel)
        # The group of every row (-1: static and tail rows).
        self.row_group = np.concatenate([np.full(self.n_static, -1),
                                         np.repeat(np.arange(self.n_groups), self.rows_per_group),
                                         np.full(self.n_tail, -1)])
        # Row alpha^T phi_f is [alpha_x phi_f, alpha_y phi_f]; the dynamic rows are written per QP.
        self.rows = np.zeros((self.n_rows, 2 * self.nz))
        by_coordinate = self.rows.reshape(self.n_rows, 2, self.nz)
        by_coordinate[:self.n_static] = static_alpha[:, :, None] * phi_t[static_f][:, None, :]
        # Each soft group of the evasive QP: one slack per interval end, one for its terminal rows.
        self.slack_of_row = np.concatenate([np.arange(n_end), np.full(n_term, n_end)])
        self.slack_weights = np.append(horizon / self.ends, 1.0) * s.evasive_penalty

        # The cost: z^T P z + 2 (v0 q_line - W ref)^T z per coordinate, up to a constant; in the
        # whitened variables y^T y / 2 + (unwhiten^T ...)^T y.
        q_line = unwhiten.T @ setup.nullspace.T @ setup.cost_hessian @ setup.greville
        # Cross term integral N(tau) p_ref(tau) dtau = ref_weights @ reference (exact quadrature).
        inner_knots = knots[(knots > 0) & (knots < horizon)]
        nodes, weights = bspline.gauss_legendre(
            np.concatenate([[0.0, horizon], inner_knots, sample_times[sample_times < horizon]]), 4)
        ref_weights = unwhiten.T @ setup.nullspace.T @ bspline.basis(nodes, knots, DEGREE).T @ (
            weights[:, None] * interpolation_matrix(sample_times, nodes))
        self.hessian = np.eye(2 * self.nz)
        self.q_line, self.ref_weights = q_line, ref_weights

        # The evasive QP (:func:`~nodnav.control.evasive.elastic_plan`) with every other robot softened, variables
        # [z, slacks] (one softening fewer robots takes a subset): its Hessian, the slack columns
        # of its rows (each row of a robot's group -> that robot's slack for the row's interval
        # end; the static and wall rows have none), the bounds and the slacks' costs.
        n_slack = len(self.slack_weights) * n_others
        self.evasive_hessian = np.zeros((2 * self.nz + n_slack,) * 2)
        self.evasive_hessian[:2 * self.nz, :2 * self.nz] = self.hessian
        self.evasive_hessian[2 * self.nz:, 2 * self.nz:] = s.evasive_curvature * np.eye(n_slack)
        self.slack_columns = np.zeros((self.n_rows, n_slack))
        robot_rows = self.n_static + self.rows_per_group * (self.n_walls + np.arange(n_others))
        self.slack_columns[(robot_rows[:, None] + np.arange(self.rows_per_group)).ravel(),
                           (len(self.slack_weights) * np.arange(n_others)[:, None] + self.slack_of_row).ravel()] = 1.0
        self.slack_bounds = np.concatenate([np.full(2 * self.nz, -np.inf), np.zeros(n_slack)])
        self.slack_gradient = np.tile(self.slack_weights, n_others)
        self.no_group_marked = np.zeros(self.n_groups, dtype=bool)  # write_separation's default
        # What step_rows reads of the problem, in its arguments' order (as plan_constants).
        self.row_constants = (setup.obstacles, setup.pieces, self.eps_end, self.group_point, self.group_wv,
                              self.term_offset, self.dyn_phi, self.dyn_line, self.intervals[-1], self.tail_phi,
                              self.tail_line, self.tol, self.rows)
        # Every other robot's index: a failed step's conflict where no certificate names fewer (read only).
        self.every_other = np.arange(n_others)
        self.every_other.setflags(write=False)
        # A step's per-group state (:func:`~nodnav.control.mpc_rows.step_state` writes it; scratch
        # space like :attr:`rows`): x_now, away, dist_now, need, delta_sq, far, full, contact, then
        # the box's gap, need_box, box_low, box_high.
        # The state's float arrays and the fused set-up's outputs (:attr:`fused_outputs`) are views of
        # one buffer, :attr:`scratch` (the fused set-up's kernel takes it as one argument).
        self.scratch, self.scratch_starts, arrays = scratch_space(scratch_shapes(
            self.n_groups, n_end, n_others, len(self.interp_all), self.n_static, len(sample_times), 2 * self.nz,
            self.n_rows))
        x_now, away, dist_now, need, delta_sq, full, contact, gap, need_box, box_low, box_high = arrays[:11]
        self.state = (x_now, away, dist_now, need, delta_sq, np.zeros(self.n_groups, dtype=bool), full, contact, gap,
                      need_box, box_low, box_high)
        # A step's outputs (scratch space like the state, written again at every step): the predictions
        # at interp_all's times, the static rows' bounds, the reference relative to p0, the
        # linearisation points, the first QP's gradient and bounds; then StepData's views of them.
        self.fused_outputs = tuple(arrays[11:])
        # What step_state reads of the problem, in its arguments' order (as plan_constants): the
        # robot's limits, the wall reach (its radius plus the farthest it can move in the horizon,
        # plus 0.1 m) and the braking tail's products of constants, then the scratch state.
        horizon, v_max, a_max = setup.horizon, robot.max_speed, robot.max_accel
        self.n_end = n_end
        # When braking (BSplineMPC._brake): the step's end, the sample times, the points within the step.
        self.braking_times = np.concatenate([[setup.dt], sample_times, setup.dt * STEP_FRACTIONS])
        self.state_constants = (
            n_end, self.ends, self.intervals, setup.obstacles, setup.pieces, setup.world_bounds, robot.radius, v_max,
            a_max, self.eps[0], robot.radius + v_max * horizon + 0.1, s.contact_tolerance, self.eps_end,
            self.static_base, self.static_line, bool(s.braking_tail), horizon, v_max * horizon, a_max * horizon,
            a_max * horizon**2 / 2, 2.0 * self.tail_decel, *self.state)
        # What the fused set-up reads of the problem (controller.fused_step), in its arguments' order
        # (:func:`~nodnav.control.mpc_fused.step_setup`; row_constants' walls and eps_end are state_constants').
        pred = self.fused_outputs[0]
        self.fused_views = (self.fused_outputs[2], pred[:, n_end + 1:-1], pred[:, -1], self.fused_outputs[1])
        self.fused_constants = (SAMPLE_STEP, MAX_SAMPLES, self.scratch, self.scratch_starts, self.state[5],
                                *sparse_rows(self.interp_all), self.static_alpha, setup.shift,
                                *sparse_rows(self.b_ends), self.interp_ends, self.ref_weights, self.q_line,
                                self.no_group_marked, *self.state_constants[:-len(self.state)],
                                *self.row_constants[3:])
        self.evasive_memo: dict[bytes, tuple] = {}  # (nodnav.control.evasive), by softened robots

    def plain_step_data(self, p0, v0, ref, others, other_radii, margins) -> StepData:
        """Predictions at the interval ends and what must be kept from every robot and wall.

        Between two interval ends where the distance is at least ``R'`` the chord stays at least
        ``sqrt(R'^2 - delta^2 / 4)`` from a point (or a convex wall) when it moves by ``delta``,
        and the curve leaves its chord by at most ``eps``; so requiring
        ``R' = sqrt((need + eps)^2 + delta^2 / 4)`` at the ends keeps ``need`` at every instant.
        At ``tau = 0`` the distance is what it is: ``need`` is lowered to what the current state
        allows when it is already inside the margin, for each prediction separately.
        (``controller.fused_step`` off: the products by BLAS, :func:`~nodnav.control.mpc_rows.step_state` compiled.)
        """
        pred = self.interp_all @ others                       # (m, 1 + N + C + 1, 2)
        # step_state writes static_lower_base(v0) plus the box into static, ref - p0 into ref_local.
        static, ref_local = np.empty(self.n_static), np.empty(ref.shape)
        need_clear, clear_now, overlap, weight, reach = step_state(
            pred, p0, math.hypot(v0[0], v0[1]), other_radii, margins, ref, ref_local, self.static_alpha @ v0, static,
            *self.state_constants)
        return self.step_data(p0, v0, ref_local, pred, static, need_clear, clear_now, overlap, weight, reach)

    def step_data(self, p0, v0, ref_local, pred, static, need_clear, clear_now, overlap, weight, reach) -> StepData:
        """A step's :class:`StepData`: the arrays and values its set-up made (``pred``: the
        predictions at :attr:`interp_all`'s times), with the per-group state in :attr:`state`."""
        x_now, away, dist_now, need, delta_sq, far, full, contact, gap, need_box, box_low, box_high = self.state
        n_end = self.n_end
        # StepData's fields in their order, positionally (a third of the keywords' cost, every step).
        return StepData(
            p0, v0, ref_local, pred[:, n_end + 1:-1], x_now, away, dist_now, contact, full, need, delta_sq,
            pred[:, -1], far, gap, need_box, static, self.n_walls, weight, reach, box_low, box_high, need_clear,
            clear_now, overlap)

    def fused_step_data(self, p0, v0, need_clear, clear_now, overlap, weight, reach) -> StepData:
        """:meth:`step_data` of a fused set-up (:func:`~nodnav.control.mpc_fused.fused_setup`): its
        arrays are :attr:`fused_outputs`, whose views :attr:`fused_views` are made once."""
        x_now, away, dist_now, need, delta_sq, far, full, contact, gap, need_box, box_low, box_high = self.state
        ref_local, pred_check, velocities, static = self.fused_views
        return StepData(
            p0, v0, ref_local, pred_check, x_now, away, dist_now, contact, full, need, delta_sq, velocities, far, gap,
            need_box, static, self.n_walls, weight, reach, box_low, box_high, need_clear, clear_now, overlap)

    def softened_rows(self, soft: np.ndarray) -> np.ndarray:
        """Mask of the rows belonging to the ``soft`` groups (a mask over walls then robots);
        the static rows belong to none."""
        return (self.row_group >= 0) & soft[np.maximum(self.row_group, 0)]

    def conflicting_others(self, rows: np.ndarray) -> np.ndarray:
        """Indices of the other robots owning any of the given rows."""
        group = self.row_group[rows] - self.n_walls
        return np.unique(group[group >= 0])

    def gradient(self, v0: np.ndarray, ref_local: np.ndarray) -> np.ndarray:
        """Gradient at ``z = 0`` of the tracking cost, ``[g_x, g_y]`` with ``g_d = 2 (v0_d q_line - W ref_d)``
        (the Hessian is :attr:`hessian`)."""
        out = np.empty(2 * len(self.q_line))
        gradient_into(self.q_line, v0, self.ref_weights @ ref_local, out)
        return out

    def gradient_plain(self, v0: np.ndarray, ref_local: np.ndarray) -> np.ndarray:
        """:meth:`gradient` in NumPy, the reference its compiled loop is tested against."""
        return (2.0 * (self.q_line[:, None] * v0 - self.ref_weights @ ref_local)).T.ravel()

    def static_lower(self, p0: np.ndarray, v0: np.ndarray, box_low: np.ndarray, box_high: np.ndarray) -> np.ndarray:
        """Lower bounds of the static rows in the QP's coordinates (centred on ``p0``, relative to
        the line ``v0 tau``): the box ``[box_low, box_high]`` of allowed positions at each end,
        tightened by eps there (convex: chords stay inside), the speed and acceleration polygons.
        (A step computes it in :func:`~nodnav.control.mpc_rows.step_state`, the same operations.)"""
        box = np.concatenate([box_low - p0, p0 - box_high])
        static = self.static_lower_base(v0)
        static[:self.n_box] += (box[None, :] + self.eps_end[:, None]).ravel()
        return static

    def static_lower_base(self, v0: np.ndarray) -> np.ndarray:
        """:meth:`static_lower` without the box's bounds (which ``step_state`` adds,
        :func:`~nodnav.control.mpc_rows.step_state`)."""
        return self.static_base - (self.static_alpha @ v0) * self.static_line

    def control_points(self, data: StepData, z: np.ndarray) -> np.ndarray:
        """Control points ``(n, 2)`` of the curve with free control points ``z`` (line plus deviation)."""
        return data.p0 + self.setup.greville[:, None] * data.v0 + self.free_map @ z.reshape(2, -1).T

    def write_separation(self, data: StepData, lin: np.ndarray, cold: bool, need: np.ndarray,
                         keep_arrangement: np.ndarray | None = None) -> np.ndarray:
        """Write the wall and separation rows into :attr:`rows`; return every row's lower bound.

        At each interval end, the half-plane through the linearisation point ``lin`` tangent to
        the disc of radius ``need`` round the other robot's prediction (or to the wall rectangle
        inflated by ``need``, at its nearest point): the linearisation trajectory satisfies its
        own half-planes whenever it is clear, so the previous plan stays feasible from one step to
        the next. A point inside a wall or colliding with another robot gives no usable
        direction; then, and on a ``cold`` start (``lin`` is the reference, not a trajectory the
        robot can follow) wherever the half-plane would exclude the robot's current position, the
        half-plane through the current position is used instead: it keeps the robot on the side
        it is on now. The groups marked ``keep_arrangement`` keep the current arrangement
        instead: at every end the normal is the direction from their point now to the robot.
        Last come the terminal rows of :func:`~nodnav.control.mpc_rows.stopping_rows`, along the
        last end's normal (``x`` the other robot or the wall's nearest point, ``v_x`` its
        velocity, zero for a wall). Bounds are moved to the QP's coordinates (centred on ``p0``,
        relative to the line ``v0 tau``). Then the braking tail's rows
        (:func:`~nodnav.control.braking.tail_rows`; ``-inf`` with ``settings.braking_tail`` off).
        The loops run compiled, all in one call (:func:`~nodnav.control.mpc_rows.step_rows`): a
        few hundred scalar rows are cheaper there than as dozens of small array operations.
        """
        lower = np.empty(self.n_rows)
        marked = self.no_group_marked if keep_arrangement is None else keep_arrangement
        step_rows(lin, cold, np.asarray(need, dtype=float), marked, data.x_now, data.away, data.dist_now, data.contact,
                  data.delta_sq, data.far, data.velocities, data.p0, data.v0, data.static_lower, data.tail_weight,
                  data.tail_reach, data.box_low, data.box_high, *self.row_constants, lower)
        return lower

    def tracking_rows(self, data: StepData, lin: np.ndarray, cold: bool) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`gradient` and :meth:`write_separation` (``data.need``, no group marked) in one compiled
        call (:func:`~nodnav.control.mpc_rows.tracking_rows`): a step's first tracking QP's gradient
        and lower bounds, its rows in :attr:`rows`."""
        gradient, lower = np.empty(2 * self.nz), np.empty(self.n_rows)
        tracking_rows(self.q_line, self.ref_weights @ data.ref_local, gradient, lin, cold, data.need,
                      self.no_group_marked, data.x_now, data.away, data.dist_now, data.contact, data.delta_sq,
                      data.far, data.velocities, data.p0, data.v0, data.static_lower, data.tail_weight,
                      data.tail_reach, data.box_low, data.box_high, *self.row_constants, lower)
        return gradient, lower

    def tail_violation(self, data: "StepData", c: np.ndarray) -> str:
        """Empty if the plan ``c``'s straight braking tail keeps ``need_clear`` from every wall and
        bound (checked exactly, :func:`~nodnav.control.braking.tail_clearance`), else how far it intrudes.
        :meth:`violation` makes the same check within its compiled call (``plan_check``)."""
        if data.tail_weight <= 0.0:
            return ""
        end = self.b_tail @ c
        clear = tail_clearance(end[0], end[1], self.tail_decel, self.setup.obstacles, self.setup.pieces,
                               self.setup.world_bounds)
        short = data.need_clear - clear
        if short > self.setup.settings.check_tolerance:
            return f"plan's braking tail comes {1e3 * short:.2f} mm too close to a wall"
        return ""

    def evaluate(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The plan ``c``'s values in one product: its check points and rates (:meth:`violation`),
        ``p(T), v(T)``, its next position, velocity and samples, its positions within the step."""
        post, (a, b, o, _) = self.b_post @ c, self.post_slices
        return post[a], post[b], post[o], post[-4:]

    def violation(self, data: StepData, c: np.ndarray, separation: bool, post: tuple | None = None) -> str:
        """Empty if ``c`` satisfies every constraint (``separation``: the others' too) when checked
        exactly (true clearances and distances at the check times, speed and acceleration on
        points whose hulls hold them), else what it violates. ``post``: :meth:`evaluate`'s values of ``c``.
        A step checks its QPs' plans within one compiled call instead (:meth:`checked_plan`)."""
        setup = self.setup
        check_rates, tail_end = (post or self.evaluate(c))[:2]
        return self._verdict(data, separation, *plan_check(
            check_rates, len(self.check_times), setup.n_speed, setup.obstacles, setup.pieces,
            setup.world_bounds, data.pred_check, data.need[self.n_walls:], tail_end,
            self.tail_decel if data.tail_weight > 0.0 else 0.0))

    def checked_plan(self, data: StepData, z: np.ndarray, separation: bool) -> tuple[np.ndarray, tuple, str]:
        """The plan of the QP's solution ``z``: :meth:`control_points`, :meth:`evaluate`'s values and
        :meth:`violation`'s verdict, in one compiled call (:func:`~nodnav.control.mpc_plan.plan_after_qp`).
        The values are :meth:`evaluate`'s four, then the velocity command ``(p(dt) - p0) / dt``."""
        c_shape, post_shape = self.plan_shapes
        # New arrays each plan: the plan is kept (committed) and its values are returned.
        c, post = np.empty(c_shape), np.empty(post_shape)
        passes, *checks = plan_after_qp(
            z, data.p0, data.v0, *self.plan_constants, data.pred_check, data.need[self.n_walls:],
            self.tail_decel if data.tail_weight > 0.0 else 0.0, data.need_clear, separation, c, post)
        a, b, o, s = self.post_slices
        return c, (post[a], post[b], post[o], post[s], post[-1]), "" if passes else self._verdict(
            data, separation, *checks)

    def checked_plan_braking(self, data: StepData, z: np.ndarray, partners: BrakingPartners, walls: WallsAround
                             ) -> tuple[np.ndarray, tuple, str, tuple]:
        """:meth:`checked_plan` (with separation) and, in the same compiled call, the mutual braking
        check of the plan's next state towards ``partners`` where straight braking is its
        fallback (a :class:`~nodnav.control.mpc_braking.StraightCheck`'s fields as a plain tuple, for
        :func:`~nodnav.control.mpc_braking.fallback_conflict`)."""
        c_shape, post_shape = self.plan_shapes
        c, post, slack = np.empty(c_shape), np.empty(post_shape), np.empty(len(partners.positions))
        passes, *checks, straight, j = plan_after_qp_braking(
            z, data.p0, data.v0, *self.plan_constants, data.pred_check, data.need[self.n_walls:],
            self.tail_decel if data.tail_weight > 0.0 else 0.0, data.need_clear, walls.max_accel,
            walls.radius - walls.tolerance, *partners, SAMPLE_STEP, MAX_SAMPLES, c, post, slack)
        a, b, o, s = self.post_slices
        return (c, (post[a], post[b], post[o], post[s], post[-1]),
                "" if passes else self._verdict(data, True, *checks), (straight, j, slack))

    def _verdict(self, data: StepData, separation: bool, clear: float, short: float, j: int, speed: float,
                 accel: float, tail: float) -> str:
        setup = self.setup
        tol = setup.settings.check_tolerance
        if clear < data.need_clear - tol:
            return f"plan comes {1e3 * (data.need_clear - clear):.2f} mm too close to a wall"
        if separation and self.n_others and short > tol:
            return f"plan comes {1e3 * short:.2f} mm too close to robot {j}"
        if data.tail_weight > 0.0 and data.need_clear - tail > tol:
            return f"plan's braking tail comes {1e3 * (data.need_clear - tail):.2f} mm too close to a wall"
        if speed > setup.robot.max_speed + tol:
            return f"plan exceeds the speed limit ({speed:.4f} m/s)"
        if accel > setup.robot.max_accel + tol:
            return f"plan exceeds the acceleration limit ({accel:.4f} m/s^2)"
        return ""

    def certified_conflict(self, rows: np.ndarray, lower: np.ndarray, effort: SolverEffort) -> np.ndarray | None:
        """The other robots owning rows of an infeasibility certificate of ``rows @ x >= lower``
        (empty if walls and limits alone conflict), or None if the rows are consistent."""
        support = effort.certificate(rows, lower)
        return self.conflicting_others(support) if support.size else None
