"""The B-spline model predictive controller of the paper's appendix, solved with OSQP.

Problem (appendix, "Model Predictive Control"), for robot ``i`` over ``[t, t + T_MPC]``:

    minimise   integral ||p(tau) - p^PRM(tau)||^2 + w_2 ||v(tau)||^2 dtau
    subject to p(t) = p_{i,t},  v(t) = v_{i,t}
               ||p(tau) - p_j^pred(tau)|| >= r_i + r_j + margin   for every other robot j
               p(tau) in free space (walls and world bounds, inflated by r_i)
               ||v(tau)|| <= max_speed,  ||a(tau)|| <= max_accel

with ``p`` a uniform cubic B-spline (``settings.segments`` knot spans over the horizon). The
appendix's equations are unnumbered; docstrings below refer to them by name.

How it becomes a short sequence of small convex QPs:

* Equalities by elimination. ``p(0)`` and ``v(0)`` are linear in the first three control
  points; the first two are solved for, so the initial state holds to machine precision. The
  QP's variables are the other control points, as deviations from the straight line
  ``p0 + v0 tau`` (which meets both equalities).
* The cost exactly. The reference (like every prediction) is piecewise linear between the
  request's samples, extrapolated back to ``tau = 0`` along its first segment and held after the
  last; the spline is cubic on each knot span, so the integrand is a polynomial of degree at most
  6 between merged breakpoints, which a 4-point Gauss-Legendre rule per piece integrates exactly.
* Speed and acceleration: inscribed regular polygons on points whose convex hull contains the
  derivative over the whole horizon (Bezier points of the velocity, control points of the
  acceleration), so the bounds hold on the whole curve.
* Separation and walls at every instant. The horizon is cut into intervals no longer than
  ``settings.max_interval`` whose ends include every sample time, so predictions are linear on
  each interval. At every interval end, a half-plane ``n^T (p(tau_e) - x(tau_e)) >= R'`` with ``n``
  the unit vector from the other robot (or from the nearest point of the wall rectangle) to the
  linearisation point there: the previous plan moved on by one step, or the reference when there
  is none. A half-plane outside a disc (or a convex rectangle) implies the true non-convex
  constraint at the sample; between samples, a chord whose ends are ``R'`` from a point and which
  moves by ``delta`` stays ``sqrt(R'^2 - delta^2 / 4)`` from it, and the curve leaves its chord by
  at most ``max_accel dt^2 / 8``; ``R'`` is inflated accordingly. Every accepted plan is
  therefore safe at every instant with respect to the predictions. The linearisation trajectory
  satisfies its own tangent half-planes, so a feasible previous plan stays feasible. A second QP,
  re-linearised about the first solution (SQP), is solved when the first moved far from its
  linearisation points.
* Recursive feasibility. A finite horizon alone lets the plan arrive at a robot or a wall with a
  speed it can no longer shed; so at the end of the horizon the gap along each normal must exceed
  the distance needed to stop, imposed through secants (an inner approximation, see
  :func:`stopping_rows`).
* Already inside a margin (another robot closer than ``r_i + r_j + margin``, or a wall closer
  than ``r_i``), the plan is only required not to get closer than now; overlapping already is
  infeasible.
* Solver accuracy. OSQP stops at a primal residual of at most ``eps (1 + max |A x|)``; every
  inequality is tightened by that much (``slack``), so a ``solved`` answer satisfies the
  untightened constraints. An unfinished answer (``solved inaccurate``, iteration limit) is used
  only if its residual is checked to be that small too. Every solution is then checked exactly
  (true distances and clearances at a fine step, derivative bounds) before it is used.

The OSQP problem is set up once per (number of other robots, sample times) with a fixed sparsity
pattern; later steps only update ``q``, ``l``, ``u`` and the values of ``A`` and warm-start from
the previous plan moved on by one step. When no QP gives an acceptable plan, the robot brakes
along its current velocity at ``max_accel`` and the result says so.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import osqp
from scipy import sparse

from nodnav.control import bspline
from nodnav.control.base import ControlRequest, ControlResult
from nodnav.scenario.schema import ControllerParams, RobotSpec
from nodnav.scenario.world import World

logger = logging.getLogger(__name__)

DEGREE = 3
"""The paper's third-order (cubic) B-spline."""


@dataclass(frozen=True)
class MPCSettings:
    """Numerical choices of the controller (not in the paper; the defaults are the tested ones)."""

    segments: int = 8
    """Knot spans of the cubic B-spline over the horizon (one per 0.1 s for T_MPC = 0.8 s)."""
    max_interval: float = 0.05
    """Longest time between separation / wall constraint samples (s)."""
    speed_polygon_sides: int = 16
    """Sides of the inscribed polygon bounding the velocity (98 % of the limit across a face)."""
    accel_polygon_sides: int = 8
    """Sides of the inscribed polygon bounding the acceleration (92 % of the limit across a face)."""
    terminal_pieces: int = 4
    """Secants approximating the stopping-distance parabola of the terminal constraint."""
    terminal_decel: float = 0.7
    """Fraction of the available deceleration assumed by the terminal constraint (headroom for
    the approximations of the next step)."""
    sqp_iterations: int = 2
    """QPs solved per step at most (each re-linearised about the previous QP's solution)."""
    sqp_tolerance: float = 0.02
    """A further QP is solved when the solution moved farther than this from its linearisation (m)."""
    eps: float = 2e-4
    """OSQP absolute and relative tolerance (every inequality is tightened to absorb it)."""
    max_iter: int = 10000
    """OSQP iteration limit per QP (hard steps need thousands; stopping early makes poor plans)."""
    check_every: int = 5
    """OSQP checks its termination criteria every this many iterations."""
    check_tolerance: float = 1e-4
    """Violation of a constraint, checked exactly, that makes a solution unacceptable (m, m/s, m/s^2)."""
    contact_tolerance: float = 1e-3
    """Penetration of the current state into a robot or wall beyond which the robot brakes at once (m)."""


# ---------------------------------------------------------------------------------------------
# Pure helpers


def interpolation_matrix(times: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Weights ``W`` (``(len(query), K)``) with ``W @ values`` the piecewise-linear interpolant.

    Linear through ``(times, values)``; before the first sample it continues the first segment
    (the request gives no value at ``tau = 0``), after the last it holds the last value (a plan
    that has ended stands still, as :class:`~nodnav.planning.base.JointTrajectory` does).
    """
    times = np.asarray(times, dtype=float)
    q = np.atleast_1d(np.asarray(query, dtype=float))
    k = len(times)
    w = np.zeros((q.size, k))
    if k == 1:
        w[:, 0] = 1.0
        return w
    qq = np.minimum(q, times[-1])
    idx = np.clip(np.searchsorted(times, qq, side="right") - 1, 0, k - 2)
    frac = (qq - times[idx]) / (times[idx + 1] - times[idx])
    rows = np.arange(q.size)
    w[rows, idx] = 1.0 - frac
    w[rows, idx + 1] += frac
    return w


def slope_matrix(times: np.ndarray, t: float) -> np.ndarray:
    """Weights ``(K,)`` giving the left derivative at ``t`` of the interpolant of :func:`interpolation_matrix`."""
    times = np.asarray(times, dtype=float)
    w = np.zeros(len(times))
    if len(times) == 1 or t > times[-1]:
        return w
    i = int(np.clip(np.searchsorted(times, t, side="left") - 1, 0, len(times) - 2))
    w[i], w[i + 1] = -1.0, 1.0
    return w / (times[i + 1] - times[i])


def constraint_grid(sample_times: np.ndarray, horizon: float, max_interval: float) -> np.ndarray:
    """Times ``0 = g_0 < g_1 < ... = max(horizon, last sample)`` bounding the constraint intervals.

    Every sample time is a grid point (so predictions are linear on each interval) and each gap
    is cut into equal pieces no longer than ``max_interval``.
    """
    b = np.unique(np.concatenate([[0.0], np.asarray(sample_times, dtype=float), [horizon]]))
    pieces = np.maximum(np.ceil(np.diff(b) / max_interval - 1e-9).astype(int), 1)
    parts = [b[k] + (b[k + 1] - b[k]) * np.arange(pieces[k]) / pieces[k] for k in range(len(pieces))]
    return np.concatenate(parts + [b[-1:]])


def chord_inflation(max_accel: float, interval: np.ndarray) -> np.ndarray:
    """Largest distance ``max_accel dt^2 / 8`` between a curve and its chord over ``dt``.

    For ``f`` with ``|f''| <= a`` the linear interpolant between ``f(0)`` and ``f(dt)`` differs
    from ``f`` by at most ``a dt^2 / 8`` (at the middle); applied to ``p(tau)`` along any direction.
    """
    return max_accel * np.asarray(interval, dtype=float) ** 2 / 8.0


def polygon_normals(sides: int) -> np.ndarray:
    """Outward unit normals ``(sides, 2)`` of the regular polygon inscribed in the unit circle.

    The polygon is ``{x : a_s^T x <= cos(pi / sides)}``, with faces (not vertices) across the
    axes: moving along the corridor at the limit then makes one constraint per control point
    active, not two; two would make more active constraints than variables, a degenerate
    problem on which OSQP converges very slowly.
    """
    ang = 2.0 * np.pi * np.arange(sides) / sides
    return np.stack([np.cos(ang), np.sin(ang)], axis=1)


def stopping_rows(span: float, decel: float, max_closing_speed: float,
                  pieces: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients ``(w_v, w_a, const)`` of the terminal rows
    ``n^T (p + w_v v + w_a a)(T) >= n^T x(T) + need + w_v n^T v_x + const``.

    Along the normal ``n`` let ``D`` be the gap beyond what must be kept, ``s = n^T (v_x - v)``
    the closing speed and ``alpha = -n^T a`` the closing acceleration. A C^2 cubic spline cannot
    brake at once: over the next knot span ``h`` its acceleration can only ramp linearly from
    ``alpha`` to ``-decel``, closing ``s h + h^2 (alpha / 3 - decel / 6)`` and leaving the closing
    speed ``s_h = s + (alpha - decel) h / 2``, which braking then cancels in ``s_h^2 / (2 decel)``.
    ``D`` must exceed the sum. The parabola is replaced by the maximum of its secants through
    ``s_k = k max_closing_speed / pieces`` (``beta_k s_h + c_k``, above it on
    ``[0, max_closing_speed]``), which gives one linear row per secant: an inner, polyhedral
    approximation of "able to stop before the gap closes".
    """
    sk = np.linspace(0.0, max_closing_speed, pieces + 1)
    beta = (sk[:-1] + sk[1:]) / (2.0 * decel)
    c = -sk[:-1] * sk[1:] / (2.0 * decel)
    w_v = span + beta
    w_a = span**2 / 3.0 + beta * span / 2.0
    return w_v, w_a, c - decel * span * (span / 6.0 + beta / 2.0)


def nearest_points_on_boxes(points: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Nearest point of each axis-aligned box ``(x0, y0, x1, y1)`` to each point: ``(..., M, 2)``."""
    p = np.asarray(points, dtype=float)[..., None, :]
    b = np.asarray(boxes, dtype=float)
    return np.clip(p, b[:, :2], b[:, 2:])


def braking_profile(position: np.ndarray, velocity: np.ndarray, max_accel: float,
                    times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities ``(len(times), 2)`` when decelerating at ``max_accel`` along ``velocity``.

    The direction never changes and the speed never increases; the robot stops after
    ``|v| / max_accel`` seconds, ``|v|^2 / (2 max_accel)`` further on.
    """
    p = np.asarray(position, dtype=float)
    v = np.asarray(velocity, dtype=float)
    t = np.asarray(times, dtype=float)[:, None]
    speed = float(np.linalg.norm(v))
    if speed == 0.0:
        return np.repeat(p[None], len(t), axis=0), np.zeros((len(t), 2))
    u = v / speed
    tt = np.minimum(t, speed / max_accel)
    travelled = speed * tt - 0.5 * max_accel * tt**2
    return p + travelled * u, np.maximum(speed - max_accel * t, 0.0) * u


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


# ---------------------------------------------------------------------------------------------
# The controller


class _Problem:
    """Everything fixed for one (number of other robots, sample times): matrices and the OSQP solver."""

    def __init__(self, ctl: "BSplineMPC", n_others: int, sample_times: np.ndarray):
        s, robot = ctl.settings, ctl.robot
        knots, horizon = ctl.knots, ctl.horizon
        self.n_others = n_others
        self.n_walls = len(ctl.obstacles)
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

        # Every row is in metres: derivative rows are scaled by the knot span (h, h^2), which
        # keeps OSQP well conditioned. OSQP stops at a primal residual of at most
        # eps (1 + max |A x|); the QP's variables are the deviation from the line p0 + v0 tau, so
        # |A x| is at most a row's value (positions within reach, terminal rows, scaled speeds and
        # accelerations) plus its value on that line. Every inequality is tightened by that.
        reach = robot.max_speed * horizon
        row_bound = max(reach + self.term_wv.max() * robot.max_speed + self.term_wa.max() * robot.max_accel,
                        h * robot.max_speed, h**2 * robot.max_accel)
        self.slack = s.eps * (1.0 + 2.0 * row_bound)
        # Chord inflation of each interval, and its maximum over the intervals meeting at each end.
        self.eps = chord_inflation(robot.max_accel, self.intervals) + self.slack
        self.eps_end = np.maximum(self.eps, np.append(self.eps[1:], 0.0))

        # Interpolation of the sampled reference and predictions.
        self.interp_zero = interpolation_matrix(sample_times, 0.0)[0]
        self.interp_ends = interpolation_matrix(sample_times, self.ends)
        self.slope_end = slope_matrix(sample_times, self.term_time)
        self.check_times = np.sort(np.concatenate([self.ends, self.mids]))
        self.interp_check = interpolation_matrix(sample_times, self.check_times)

        # Curve evaluations (control points -> values).
        self.b_ends = bspline.basis(self.ends, knots, DEGREE)
        self.b_check = bspline.basis(self.check_times, knots, DEGREE)
        self.b_samples = bspline.basis(sample_times, knots, DEGREE)

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
        self.phi_t = phi @ ctl.nullspace
        self.phi_line = phi @ ctl.greville  # each functional on the line tau -> tau
        f_vel = n_end + np.arange(len(d1))
        f_acc = n_end + len(d1) + np.arange(len(d2))
        f_term = n_end + len(d1) + len(d2) + np.arange(len(phi_term))

        # Static rows: box (x and y at each interval end), speed and acceleration polygons.
        v_normals = polygon_normals(s.speed_polygon_sides)
        a_normals = polygon_normals(s.accel_polygon_sides)
        self.n_box = 2 * n_end
        self.static_alpha = np.vstack([np.tile(np.eye(2), (n_end, 1)),
                                       np.tile(v_normals, (len(d1), 1)), np.tile(a_normals, (len(d2), 1))])
        self.static_f = np.concatenate([np.repeat(np.arange(n_end), 2),
                                        np.repeat(f_vel, len(v_normals)), np.repeat(f_acc, len(a_normals))])
        self.static_upper = np.concatenate([
            np.zeros(self.n_box),  # the box bounds depend on the position, set per step
            np.full(len(d1) * len(v_normals), h * robot.max_speed * np.cos(np.pi / s.speed_polygon_sides) - self.slack),
            np.full(len(d2) * len(a_normals), h**2 * brake - self.slack),
        ])

        # Dynamic rows, one group per wall and per other robot: a half-plane at every interval
        # end, then the terminal rows with the last end's normal.
        n_term = len(phi_term)
        self.group_point = np.concatenate([np.arange(n_end), np.full(n_term, n_end - 1)])
        self.group_f = np.concatenate([np.arange(n_end), f_term])
        self.group_wv = np.concatenate([np.zeros(n_end), self.term_wv])
        self.group_const = np.concatenate([np.zeros(n_end), self.term_const])
        n_groups = self.n_walls + n_others
        self.dyn_f = np.tile(self.group_f, n_groups)
        self.n_rows = len(self.static_f) + len(self.dyn_f)

        # The fixed sparsity pattern of A (explicit zeros kept) and where each entry goes in its
        # CSC data, so that a step only scatters the new values of the dynamic rows.
        self.static_a = self.rows(self.static_alpha, self.static_f)
        dyn_pattern = np.abs(self.phi_t[self.dyn_f]) > 0
        mask = np.vstack([self.static_a != 0, np.hstack([dyn_pattern, dyn_pattern])])
        cols, self.csc_rows = np.nonzero(mask.T)
        self.csc_indptr = np.concatenate([[0], np.cumsum(np.bincount(cols, minlength=mask.shape[1]))])
        position = np.zeros(mask.shape, dtype=int)
        position[self.csc_rows, cols] = np.arange(len(cols))
        n_static = len(self.static_f)
        static_mask = mask[:n_static]
        self.static_pos, self.static_vals = position[:n_static][static_mask], self.static_a[static_mask]
        self.dyn_mask = mask[n_static:]
        self.dyn_pos = position[n_static:][self.dyn_mask]

        self.p_half = ctl.nullspace.T @ ctl.cost_hessian @ ctl.nullspace
        self.q_line = ctl.nullspace.T @ ctl.cost_hessian @ ctl.greville
        # Cross term integral N(tau) p_ref(tau) dtau = ref_weights @ reference (exact quadrature).
        inner_knots = knots[(knots > 0) & (knots < horizon)]
        nodes, weights = bspline.gauss_legendre(
            np.concatenate([[0.0, horizon], inner_knots, sample_times[sample_times < horizon]]), 4)
        self.ref_weights = ctl.nullspace.T @ bspline.basis(nodes, knots, DEGREE).T @ (
            weights[:, None] * interpolation_matrix(sample_times, nodes))
        self.solver: osqp.OSQP | None = None

    def rows(self, alpha: np.ndarray, f: np.ndarray) -> np.ndarray:
        """Dense rows over the QP variables ``[z_x, z_y]`` of the functionals ``alpha^T phi_f``."""
        g = self.phi_t[f]
        return np.hstack([alpha[:, :1] * g, alpha[:, 1:] * g])

    def offsets(self, alpha: np.ndarray, f: np.ndarray, v0: np.ndarray) -> np.ndarray:
        """Value ``alpha^T phi_f`` of each row on the straight line ``v0 tau`` (local coordinates)."""
        return (alpha @ v0) * self.phi_line[f]

    def matrix_data(self, dynamic: np.ndarray) -> np.ndarray:
        """CSC data of A given the dense dynamic rows."""
        data = np.empty(len(self.csc_rows))
        data[self.static_pos] = self.static_vals
        data[self.dyn_pos] = dynamic[self.dyn_mask]
        return data


@dataclass(frozen=True)
class _StepData:
    """The request's data for one step, with the requirements derived from the current state."""

    p0: np.ndarray
    v0: np.ndarray
    ref: np.ndarray
    others: np.ndarray
    others0: np.ndarray
    """Predicted positions of the others at ``tau = 0`` (extrapolated) ``(m, 2)``."""
    other_radii: np.ndarray
    pred_ends: np.ndarray
    """Predicted positions of the others at the interval ends ``(m, N, 2)``."""
    delta_others: np.ndarray
    """Largest relative displacement over each interval, robot against each other ``(m, N)`` (m)."""
    delta_walls: np.ndarray
    """Largest displacement of the robot over each interval ``(N,)`` (m)."""
    need_sep: np.ndarray
    """Separation to keep from each other robot: r_i + r_j + margin, or less if already closer (m)."""
    near_now: np.ndarray
    """Nearest point of each wall to the current position ``(M, 2)``."""
    dist_walls: np.ndarray
    """Current distance to each wall ``(M,)`` (m)."""
    need_walls: np.ndarray
    """Clearance to keep from each wall: r_i, or less if already closer ``(M,)`` (m)."""
    gap_box: np.ndarray
    """Current distance to the bounds x_min, y_min, x_max, y_max ``(4,)`` (m)."""
    need_box: np.ndarray
    """Clearance to keep from the bounds ``(4,)`` (m)."""

    @property
    def need_clear(self) -> float:
        """The smallest clearance the plan has to keep from any wall or bound (m)."""
        return float(min(self.need_walls.min(initial=np.inf), self.need_box.min()))


class BSplineMPC:
    """Cubic B-spline MPC (paper appendix) for one robot; keeps warm-start state between steps."""

    name = "mpc"

    def __init__(self, world: World, robot: RobotSpec, params: ControllerParams,
                 settings: MPCSettings = MPCSettings()):
        if params.dt <= 0 or params.horizon <= 0 or params.dt > params.horizon:
            raise ValueError(f"need 0 < dt <= horizon, got dt={params.dt}, horizon={params.horizon}")
        self.world = world
        self.robot = robot
        self.params = params
        self.settings = settings
        self.horizon = float(params.horizon)
        self.dt = float(params.dt)
        self.knots = bspline.uniform_knots(self.horizon, settings.segments, DEGREE)
        self.nullspace = initial_state_nullspace(self.knots, DEGREE)
        self.greville = bspline.greville_abscissae(self.knots, DEGREE)
        self.cost_hessian = (bspline.gram_matrix(self.knots, DEGREE, 0, 0.0, self.horizon)
                             + params.w2 * bspline.gram_matrix(self.knots, DEGREE, 1, 0.0, self.horizon))
        self.obstacles = world.obstacle_array
        self.b_step = bspline.basis_derivative([self.dt], self.knots, DEGREE, 0)[0]
        self.bv_step = bspline.basis_derivative([self.dt], self.knots, DEGREE, 1)[0]
        self.d1 = bspline.velocity_hull_operator(self.knots)[1:]
        self.d2 = bspline.derivative_control_operator(self.knots, DEGREE, 2)
        # Moving a plan on by one step: least-squares fit of p(tau + dt) (the last span's
        # polynomial continues past the horizon).
        fit = np.linspace(0.0, self.horizon, 4 * settings.segments + 1)
        self._shift = np.linalg.lstsq(bspline.basis(fit, self.knots, DEGREE),
                                      bspline.basis(fit + self.dt, self.knots, DEGREE), rcond=None)[0]
        self._problems: dict[tuple, _Problem] = {}
        self._previous: np.ndarray | None = None
        self._braking: tuple[np.ndarray, np.ndarray] | None = None

    def reset(self) -> None:
        """Forget the previous solution (the next step starts cold)."""
        self._previous = None
        self._braking = None

    def motion(self, times: np.ndarray, order: int = 0) -> np.ndarray:
        """The motion chosen at the last control step, ``times`` after it: positions (``order`` 0)
        or velocities (1) ``(len(times), 2)``; the planned spline, or the braking manoeuvre."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        if order not in (0, 1):
            raise ValueError(f"order must be 0 (positions) or 1 (velocities), got {order}")
        if self._braking is not None:
            return braking_profile(*self._braking, self.robot.max_accel, times)[order]
        if self._previous is None:
            raise ValueError("no control step has been taken yet")
        return bspline.evaluate(self._previous, times, self.knots, DEGREE, order)

    # -- public ------------------------------------------------------------------------------

    def control(self, request: ControlRequest) -> ControlResult:
        """Solve the MPC for one step; brake (``success=False``) when it cannot be solved safely.

        Raises ``ValueError`` only for a malformed request (shapes, non-finite values, sample
        times outside ``(0, horizon]``).
        """
        start = time.perf_counter()
        p0, v0, ref, times, others, other_radii = self._validated(request)
        prob = self._problem(len(others), times)
        r = self.robot.radius
        contact = r + other_radii
        others0 = np.einsum("k,mkd->md", prob.interp_zero, others)
        dist0 = np.linalg.norm(p0 - others0, axis=1)
        data = self._step_data(prob, p0, v0, ref, others, others0, other_radii, dist0)
        clearance0 = float(min(data.dist_walls.min(initial=np.inf), data.gap_box.min()))
        overlapping = np.flatnonzero(dist0 < contact - self.settings.contact_tolerance)
        if overlapping.size:
            j = int(overlapping[0])
            return self._brake(request, prob, start, "overlap",
                               f"infeasible: overlapping robot {j} ({dist0[j]:.3f} m apart, "
                               f"contact at {contact[j]:.3f} m): braking")
        if clearance0 < r - self.settings.contact_tolerance:
            return self._brake(request, prob, start, "wall contact",
                               f"infeasible: in contact with a wall (clearance {clearance0:.3f} m, "
                               f"radius {r:.3f} m): braking")

        warm = self._warm_start()
        cold = warm is None
        lin = prob.interp_ends @ ref if cold else prob.b_ends @ warm
        best, best_status, status, iters, qps, osqp_time, why = None, "", "", 0, 0, 0.0, ""
        for _ in range(self.settings.sqp_iterations):
            c, status, it, run = self._solve_qp(prob, data, lin, warm, cold)
            iters, qps, osqp_time = iters + it, qps + 1, osqp_time + run
            why = f"OSQP status '{status}'" if c is None else self._violation(prob, data, c)
            if why:
                break
            best, best_status = c, status
            moved = prob.b_ends @ c
            if np.max(np.linalg.norm(moved - lin, axis=1)) <= self.settings.sqp_tolerance:
                break
            lin, warm, cold = moved, None, False
        info = {"iterations": iters, "qps": qps, "osqp_time": osqp_time, "constraints": prob.n_rows,
                "slack": prob.slack}
        if best is None:
            logger.debug("MPC at %s: %s", p0, why)
            return self._brake(request, prob, start, status or "check failed", f"infeasible: {why}: braking", info)
        self._previous, self._braking = best, None
        next_position = self.b_step @ best
        return ControlResult(
            success=True, reason="",
            velocity=(next_position - p0) / self.dt,
            next_position=next_position, next_velocity=self.bv_step @ best,
            planned_positions=prob.b_samples @ best,
            solve_time=time.perf_counter() - start,
            info={"status": best_status, **info},
        )

    # -- internals ---------------------------------------------------------------------------

    def _validated(self, request: ControlRequest):
        p0 = np.asarray(request.position, dtype=float).reshape(2)
        v0 = np.asarray(request.velocity, dtype=float).reshape(2)
        times = np.asarray(request.sample_times, dtype=float).reshape(-1)
        ref = np.asarray(request.reference, dtype=float)
        k = len(times)
        radii = np.asarray(request.other_radii, dtype=float).reshape(-1)
        others = np.asarray(request.others, dtype=float)
        if others.size == 0:
            others = np.zeros((0, k, 2))
        if k == 0 or ref.shape != (k, 2) or others.shape != (len(radii), k, 2):
            raise ValueError(f"inconsistent request shapes: reference {ref.shape}, sample_times {times.shape}, "
                             f"others {others.shape}, other_radii {radii.shape}")
        if np.any(np.diff(times) <= 0) or times[0] <= 0 or times[-1] > self.horizon + 1e-9:
            raise ValueError(f"sample_times must increase within (0, {self.horizon}], got {times}")
        if not all(np.all(np.isfinite(a)) for a in (p0, v0, ref, others, radii)):
            raise ValueError("request contains non-finite values")
        return p0, v0, ref, times, others, radii

    def _problem(self, n_others: int, times: np.ndarray) -> _Problem:
        key = (n_others, tuple(np.round(times, 9)))
        if key not in self._problems:
            self._problems[key] = _Problem(self, n_others, times)
        return self._problems[key]

    def _step_data(self, prob: _Problem, p0, v0, ref, others, others0, other_radii, dist0) -> _StepData:
        """Predictions at the interval ends and what must be kept from every robot and wall.

        Between two interval ends where the distance is at least ``R'`` the chord stays at least
        ``sqrt(R'^2 - delta^2 / 4)`` from a point (or a convex wall) when it moves by ``delta``,
        and the curve leaves its chord by at most ``eps``; so requiring
        ``R' = sqrt((need + eps)^2 + delta^2 / 4)`` at the ends keeps ``need`` at every instant.
        At ``tau = 0`` the distance is what it is: ``need`` is lowered to what the current state
        allows when it is already inside the margin.
        """
        r = self.robot.radius
        pred_ends = np.einsum("qk,mkd->mqd", prob.interp_ends, others)
        steps = np.diff(np.concatenate([others0[:, None], pred_ends], axis=1), axis=1)  # (m, N, 2)
        # The robot's own displacement over an interval: at most its reachable speed times it.
        speed = np.minimum(self.robot.max_speed, np.linalg.norm(v0) + self.robot.max_accel * prob.ends)
        delta_walls = speed * prob.intervals
        delta_others = delta_walls + np.linalg.norm(steps, axis=-1)
        eps0 = prob.eps[0]

        def allowed(dist_now: np.ndarray, delta0: np.ndarray) -> np.ndarray:
            return np.sqrt(np.maximum(dist_now**2 - delta0**2 / 4.0, 0.0)) - eps0

        near_now = nearest_points_on_boxes(p0, self.obstacles)
        dist_walls = np.linalg.norm(p0 - near_now, axis=-1)
        x0, y0, x1, y1 = self.world.bounds
        gap = np.array([p0[0] - x0, p0[1] - y0, x1 - p0[0], y1 - p0[1]])
        return _StepData(
            p0, v0, ref, others, others0, other_radii, pred_ends, delta_others, delta_walls,
            need_sep=np.minimum(r + other_radii + self.params.safety_margin, allowed(dist0, delta_others[:, 0])),
            near_now=near_now, dist_walls=dist_walls,
            need_walls=np.minimum(r, allowed(dist_walls, delta_walls[0])),
            gap_box=gap, need_box=np.minimum(r, gap - eps0),
        )

    def _warm_start(self) -> np.ndarray | None:
        """The previous plan moved on by one step (control points), if there is one."""
        return None if self._previous is None else self._shift @ self._previous

    def _solve_qp(self, prob: _Problem, data: _StepData, lin: np.ndarray, warm: np.ndarray | None,
                  cold: bool):
        """One convex QP linearised about ``lin`` (positions at the interval ends); returns
        (control points or None, OSQP status, iterations, OSQP time).

        The QP is posed in coordinates centred on the current position (better conditioned).
        """
        p0 = data.p0
        alpha, lower, f = self._halfplanes(prob, data, lin, cold)
        all_alpha = np.vstack([prob.static_alpha, alpha])
        all_f = np.concatenate([prob.static_f, f])
        low = np.concatenate([np.full(len(prob.static_f), -np.inf), lower - alpha @ p0])
        upper = np.concatenate([prob.static_upper, np.full(len(f), np.inf)])
        # Box rows (the bounds are convex: the chord stays inside), plus eps at each end point.
        x0, y0, x1, y1 = self.world.bounds
        need = data.need_box
        e = np.repeat(prob.eps_end, 2)
        low[:prob.n_box] = np.tile([x0 + need[0] - p0[0], y0 + need[1] - p0[1]], len(prob.ends)) + e
        upper[:prob.n_box] = np.tile([x1 - need[2] - p0[0], y1 - need[3] - p0[1]], len(prob.ends)) - e
        offsets = prob.offsets(all_alpha, all_f, data.v0)
        low, upper = low - offsets, upper - offsets

        dynamic = prob.rows(alpha, f)
        a_data = prob.matrix_data(dynamic)
        ref = data.ref - p0
        q = 2.0 * np.concatenate([prob.q_line * data.v0[d] - prob.ref_weights @ ref[:, d] for d in range(2)])
        if prob.solver is None:
            p_mat = sparse.triu(sparse.block_diag([2.0 * prob.p_half, 2.0 * prob.p_half]), format="csc")
            prob.solver = osqp.OSQP()
            # Polishing stays off: OSQP 1.1 prints to stdout from its polish step whatever the
            # verbosity; accuracy comes from the slack in every bound instead.
            a_mat = sparse.csc_matrix((a_data, prob.csc_rows, prob.csc_indptr), shape=(prob.n_rows, p_mat.shape[1]))
            prob.solver.setup(p_mat, q, a_mat, low, upper, verbose=False,
                              eps_abs=self.settings.eps, eps_rel=self.settings.eps, polishing=False,
                              max_iter=self.settings.max_iter, warm_starting=True,
                              check_termination=self.settings.check_every)
        else:
            prob.solver.update(q=q, l=low, u=upper, Ax=a_data)
        if warm is not None:
            dev = warm - self._line(data)
            prob.solver.warm_start(x=np.concatenate([dev[2:, 0], dev[2:, 1]]))
        res = prob.solver.solve(raise_error=False)
        status = str(res.info.status)
        z = np.asarray(res.x)
        # A "solved" answer satisfies the untightened rows by construction (residual <= slack).
        # An unfinished one (inaccurate, iteration limit) is used only if it does too, checked
        # here; either way the exact check follows.
        if status in ("solved inaccurate", "maximum iterations reached") and np.all(np.isfinite(z)):
            az = np.concatenate([prob.static_a @ z, dynamic @ z])
            usable = float(np.max(np.maximum(low - az, az - upper))) <= prob.slack
        else:
            usable = status == "solved"
        if not usable:
            return None, status, int(res.info.iter), float(res.info.solve_time)
        nz = len(z) // 2
        c = self._line(data) + np.stack([self.nullspace @ z[:nz], self.nullspace @ z[nz:]], axis=1)
        return c, status, int(res.info.iter), float(res.info.solve_time)

    def _line(self, data: _StepData) -> np.ndarray:
        """Control points of the straight line ``p0 + v0 tau``, shape ``(n, 2)``."""
        return data.p0 + self.greville[:, None] * data.v0

    def _halfplanes(self, prob: _Problem, data: _StepData, lin: np.ndarray, cold: bool):
        """Normals, lower bounds and functional indices of the wall and separation rows.

        At each interval end, the half-plane through the linearisation point ``lin`` tangent to
        the other robot's disc (or to the wall rectangle, at its nearest point): the linearisation
        trajectory satisfies its own half-planes whenever it is clear, so the previous plan stays
        feasible from one step to the next. A point inside a wall or colliding with another robot
        gives no usable direction; then, and on a ``cold`` start (``lin`` is the reference, not a
        trajectory the robot can follow) wherever the half-plane would exclude the robot's current
        position, the half-plane through the current position is used instead: it keeps the
        robot on the side it is on now. Last come the terminal rows of :func:`stopping_rows`, along
        the last end's normal (``x`` the other robot or the wall's nearest point, ``v_x`` its
        velocity, zero for a wall).
        """
        r = self.robot.radius
        pts, n_end = prob.group_point, len(prob.ends)
        alphas, lowers = [], []

        def required(need: np.ndarray, delta_int: np.ndarray) -> np.ndarray:
            delta_end = np.maximum(delta_int, np.concatenate([delta_int[..., 1:], delta_int[..., -1:]], axis=-1))
            ends = np.sqrt((need[:, None] + prob.eps_end) ** 2 + delta_end**2 / 4.0)
            term = need[:, None] + prob.eps_end[-1] + prob.term_const
            return np.concatenate([ends, term], axis=1)

        if prob.n_walls:
            near = nearest_points_on_boxes(lin, self.obstacles)               # (N, M, 2)
            vec = lin[:, None, :] - near
            dist = np.linalg.norm(vec, axis=-1)
            replace = dist < 1e-12
            if cold:
                gap_now = np.einsum("nmd,nmd->nm", vec, data.p0 - near) / np.where(replace, 1.0, dist)
                replace |= gap_now < data.need_walls
            vec = np.where(replace[..., None], data.p0 - data.near_now[None], vec)
            near = np.where(replace[..., None], data.near_now[None], near)
            normal = (vec / np.linalg.norm(vec, axis=-1, keepdims=True))[pts].transpose(1, 0, 2)  # (M, G, 2)
            need = required(data.need_walls, np.broadcast_to(data.delta_walls, (prob.n_walls, n_end)))
            low = np.einsum("mgd,mgd->mg", normal, near[pts].transpose(1, 0, 2)) + need
            # A wall out of reach within the horizon constrains nothing.
            low[data.dist_walls > r + self.robot.max_speed * self.horizon + 0.1] = -np.inf
            alphas.append(normal.reshape(-1, 2))
            lowers.append(low.ravel())
        if prob.n_others:
            vec = lin[None] - data.pred_ends                                   # (m, N, 2)
            dist = np.linalg.norm(vec, axis=-1)
            replace = dist < (r + data.other_radii)[:, None]
            if cold:
                gap_now = np.einsum("mnd,mnd->mn", vec, data.p0 - data.pred_ends) / np.maximum(dist, 1e-12)
                replace |= gap_now < data.need_sep[:, None]
            vec = np.where(replace[..., None], data.p0 - data.pred_ends, vec)
            now = data.p0 - data.others0
            degenerate = np.linalg.norm(vec, axis=-1) < 1e-9
            vec = np.where(degenerate[..., None], now[:, None, :], vec)
            normal = (vec / np.linalg.norm(vec, axis=-1, keepdims=True))[:, pts]  # (m, G, 2)
            pred_vel = np.einsum("k,mkd->md", prob.slope_end, data.others)
            low = (np.einsum("mgd,mgd->mg", normal, data.pred_ends[:, pts]) + required(data.need_sep, data.delta_others)
                   + prob.group_wv * np.einsum("mgd,md->mg", normal, pred_vel))
            alphas.append(normal.reshape(-1, 2))
            lowers.append(low.ravel())
        if not alphas:
            return np.zeros((0, 2)), np.zeros(0), prob.dyn_f
        return np.vstack(alphas), np.concatenate(lowers), prob.dyn_f

    def _violation(self, prob: _Problem, data: _StepData, c: np.ndarray) -> str:
        """Empty if ``c`` satisfies every constraint when checked exactly, else what it violates."""
        tol = self.settings.check_tolerance
        pts = prob.b_check @ c
        clear = float(self.world.clearance(pts).min())
        if clear < data.need_clear - tol:
            return f"plan comes {1e3 * (data.need_clear - clear):.2f} mm too close to a wall"
        if len(data.others):
            pred = np.einsum("qk,mkd->mqd", prob.interp_check, data.others)
            short = data.need_sep - np.linalg.norm(pts[None] - pred, axis=-1).min(axis=1)
            j = int(np.argmax(short))
            if short[j] > tol:
                return f"plan comes {1e3 * short[j]:.2f} mm too close to robot {j}"
        speed = float(np.linalg.norm(self.d1 @ c, axis=1).max())
        if speed > self.robot.max_speed + tol:
            return f"plan exceeds the speed limit ({speed:.4f} m/s)"
        accel = float(np.linalg.norm(self.d2 @ c, axis=1).max())
        if accel > self.robot.max_accel + tol:
            return f"plan exceeds the acceleration limit ({accel:.4f} m/s^2)"
        return ""

    def _brake(self, request: ControlRequest, prob: _Problem, start: float, status: str, reason: str,
               info: dict | None = None) -> ControlResult:
        """Decelerate along the current velocity at max_accel; the previous plan is discarded."""
        p0 = np.asarray(request.position, dtype=float)
        v0 = np.asarray(request.velocity, dtype=float)
        self._previous, self._braking = None, (p0, v0)
        pos, vel = braking_profile(p0, v0, self.robot.max_accel, np.concatenate([[self.dt], prob.sample_times]))
        return ControlResult(
            success=False, reason=reason,
            velocity=(pos[0] - p0) / self.dt,
            next_position=pos[0], next_velocity=vel[0],
            planned_positions=pos[1:],
            solve_time=time.perf_counter() - start,
            info={"status": status, "braking": True, **(info or {})},
        )
