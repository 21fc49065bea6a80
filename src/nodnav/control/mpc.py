"""The B-spline model predictive controller of the paper's appendix, solved as small dense QPs.

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
  re-linearised about the first solution (SQP), is solved only after a cold start (no previous
  plan), when the first moved far from its linearisation points; otherwise the next step's
  re-linearisation continues the iteration.
* Recursive feasibility. A finite horizon alone lets the plan arrive at a robot or a wall with a
  speed it can no longer shed; so at the end of the horizon the gap along each normal must exceed
  the distance needed to stop, imposed through secants (an inner approximation, see
  :func:`stopping_rows`).
* Already inside a margin (another robot's prediction closer than ``r_i + r_j + margin``, or a
  wall closer than ``r_i``), the plan is only required not to get closer than now, separately
  for every prediction.
* The solver. About 18 variables and a few hundred inequality rows, many of them degenerate
  (more rows active than variables): DAQP (Arnstroem et al., a dual active-set method for dense
  QPs, MIT licence, :func:`solve_qp`) solves them exactly and detects infeasibility. On 6,126 QPs
  recorded from closed-loop trials it found every optimum and every infeasible problem that a
  reference Goldfarb-Idnani solver found, at a median of 0.10 ms and a 95th percentile of
  0.38 ms; quadprog did as well but is GPL-licensed and slower at the 95th percentile, and OSQP
  (a first-order method) stopped at its iteration limit on a fifth of the feasible problems even
  at its best settings (README, "The MPC's QP solver"). Every inequality is tightened by the
  solver's primal tolerance, and every solution is checked exactly (true distances and
  clearances at a fine step, derivative bounds) before it is used.

When the tracking QP has no solution, the robot does not brake blindly: an evasive QP with the
same dynamics, limits and (hard) wall constraints softens the separation rows of the robots
involved in the conflict (those owning rows of a Farkas certificate of the infeasibility, found
by a small linear program, :func:`infeasibility_certificate`, as DAQP's QP solve returns none) with
non-negative slacks under a large exact (L1) penalty, weighted towards the near future, and so
returns the plan that intrudes least into the others' predicted discs. Which
side to pass a robot on is a non-convex choice: the evasive QP is solved linearised about the
previous plan and about the current arrangement of the robots, and the plan whose true
intrusion comes later is kept (:meth:`BSplineMPC._evasive`). Only if no evasive plan keeps
clear of the walls does the robot brake along its current velocity. Both are reported with
``success=False`` and ``info["fallback"]`` (``"evasive"`` or ``"braking"``).

Everything fixed for a (number of other robots, sample times) pair is precomputed once: the
static constraint rows, the Hessians and the map from the reference to the cost's gradient; a
step only writes the new half-planes and bounds. The per-row geometry (requirements per wall and
robot, half-planes, the exact check) runs as compiled scalar loops (numba; the same code runs,
slowly, without it): a few hundred rows cost less there than the dozens of small array
operations each would take in NumPy.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import daqp
import numpy as np
from scipy.optimize import linprog

from nodnav.compiled import compiled as _compiled
from nodnav.control import bspline
from nodnav.control.base import STEP_FRACTIONS, ControlRequest, ControlResult
from nodnav.registry import register_controller
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import World

logger = logging.getLogger(__name__)


DEGREE = 3
"""The paper's third-order (cubic) B-spline."""


# ---------------------------------------------------------------------------------------------
# Dense convex QP: DAQP, a dual active-set method


_DAQP_REASONS = {-1: "infeasible", -2: "cycling", -3: "unbounded", -4: "iteration limit", -5: "not convex",
                 -6: "overdetermined start", -7: "time limit", -8: "unsupported"}


@dataclass(frozen=True)
class QPSolution:
    """Result of :func:`solve_qp`."""

    success: bool
    """Whether ``x`` is the minimiser."""
    reason: str
    """Empty on success, else why not (``infeasible``: no point satisfies every row)."""
    x: np.ndarray
    """The minimiser (unspecified on failure)."""
    iterations: int
    """Active-set changes the solver made."""


def solve_qp(hessian: np.ndarray, gradient: np.ndarray, rows: np.ndarray, lower: np.ndarray, tol: float,
             bounds: np.ndarray | None = None, start_active: np.ndarray | None = None) -> QPSolution:
    """Minimise ``x^T H x / 2 + g^T x`` subject to ``rows @ x >= lower`` and ``x >= bounds`` (DAQP).

    ``H`` must be positive definite. ``bounds`` (one per variable, optional) are handled by DAQP
    as simple bounds, cheaper than rows. Rows or bounds at ``-inf`` never bind. A row may be
    violated by up to ``tol`` (DAQP's primal tolerance), so callers tighten their rows by it.
    ``start_active`` (a mask over ``bounds``) makes those bounds DAQP's initial working set: a
    guess of the constraints active at the minimiser saves the iterations that would add them.
    """
    low = np.ascontiguousarray(lower if bounds is None else np.concatenate([bounds, lower]), dtype=float)
    # DAQP's constraint flags: 1 active, 2 at the lower bound.
    sense = None if start_active is None else np.concatenate(
        [np.where(start_active, 3, 0), np.zeros(len(lower))]).astype(np.intc)
    x, _, flag, info = daqp.solve(np.ascontiguousarray(hessian, dtype=float), np.ascontiguousarray(gradient,
                                                                                                   dtype=float),
                                  np.ascontiguousarray(rows, dtype=float), np.full(len(low), np.inf), low, sense,
                                  primal_tol=tol)
    return QPSolution(success=flag == 1, reason="" if flag == 1 else _DAQP_REASONS.get(flag, f"DAQP exit flag {flag}"),
                      x=np.asarray(x), iterations=int(info["iterations"]))


def infeasibility_certificate(rows: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """Rows that together admit no ``x`` with ``rows @ x >= lower``: the support of a Farkas certificate.

    ``{x : A x >= b}`` is empty exactly when some ``y >= 0`` has ``A^T y = 0`` and ``b^T y > 0``
    (Farkas' lemma). Such a ``y`` (normalised to ``sum y = 1``) is the dual solution of the
    linear program "least uniform relaxation": minimise ``t >= 0`` subject to
    ``A x + t >= b``, positive exactly when the rows conflict. DAQP solves it with proximal
    regularisation (well under a millisecond for the MPC's few hundred rows) and, keeping its
    working set linearly independent, ends at a vertex, whose support is an irreducible
    infeasible subset: few rows. Should DAQP not converge, SciPy's HiGHS solves the dual LP
    (``max b^T y`` over ``A^T y = 0``, ``sum y = 1``, ``y >= 0``) instead, about 8 ms. Returns
    the indices of the rows with ``y > 0`` (empty if the rows are consistent). Rows at ``-inf``
    never take part.
    """
    rows, lower = np.asarray(rows, dtype=float), np.asarray(lower, dtype=float)
    finite = np.flatnonzero(np.isfinite(lower))
    a, b = rows[finite], lower[finite]
    n = a.shape[1]
    # Variables (t, x); t >= 0 is DAQP's simple bound, the first entry of the bound vectors.
    cost = np.zeros(n + 1)
    cost[0] = 1.0
    relaxed = np.hstack([np.ones((len(b), 1)), a])
    low = np.concatenate([[0.0], b])
    tx, _, flag, info = daqp.solve(np.zeros((n + 1, n + 1)), cost, relaxed, np.full(len(low), np.inf), low, None,
                                   eps_prox=1.0)
    if flag == 1:
        if tx[0] <= 0.0:
            return np.zeros(0, dtype=int)
        # DAQP's multipliers of active lower bounds are negative.
        return finite[-np.asarray(info["lam"])[1:] > 1e-12]
    res = linprog(-b, A_eq=np.vstack([a.T, np.ones(len(finite))]), b_eq=np.append(np.zeros(n), 1.0),
                  bounds=(0.0, None), method="highs")
    if res.status != 0 or -res.fun <= 0.0:
        return np.zeros(0, dtype=int)
    return finite[res.x > 1e-12]


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
    d0 = np.vstack([bspline.basis_derivative([0.0], knots, degree, 0),  # type: ignore[arg-type]
                    bspline.basis_derivative([0.0], knots, degree, 1)])  # type: ignore[arg-type]
    return np.vstack([-np.linalg.solve(d0[:, :2], d0[:, 2:]), np.eye(d0.shape[1] - 2)])


# ---------------------------------------------------------------------------------------------
# The controller

@_compiled
def _separation_rows(lin, x_now, boxes, n_walls, p0, v0, contact, need, cold, keep_arrangement, eps_end,
                     delta_sq, group_point, group_wv, term_offset, vel, far, away, dyn_phi, dyn_line, rows, lower,
                     row0):
    """Write the wall and separation rows (see :meth:`BSplineMPC._write_separation`) into
    ``rows[row0:]`` (``[alpha_x phi, alpha_y phi]``) and ``lower[row0:]`` (QP coordinates)."""
    n_groups, n_end = x_now.shape[0], x_now.shape[1]
    n_rows, nz = group_point.shape[0], dyn_phi.shape[1]
    normal = np.empty((n_end, 2))
    point = np.empty((n_end, 2))
    for g in range(n_groups):
        for e in range(n_end):
            if keep_arrangement[g]:  # keep the current arrangement: the direction from the point to p0
                normal[e, 0], normal[e, 1] = away[g, 0], away[g, 1]
                point[e, 0], point[e, 1] = x_now[g, e, 0], x_now[g, e, 1]
                continue
            if g < n_walls:  # the wall rectangle's nearest point to the linearisation point
                qx = min(max(lin[e, 0], boxes[g, 0]), boxes[g, 2])
                qy = min(max(lin[e, 1], boxes[g, 1]), boxes[g, 3])
            else:
                qx, qy = x_now[g, e, 0], x_now[g, e, 1]
            vx, vy = lin[e, 0] - qx, lin[e, 1] - qy
            dist = np.sqrt(vx * vx + vy * vy)
            replace = dist < contact[g]
            if not replace and cold:
                replace = (vx * (p0[0] - qx) + vy * (p0[1] - qy)) / max(dist, 1e-12) < need[g]
            if replace:
                qx, qy = x_now[g, e, 0], x_now[g, e, 1]
                vx, vy = p0[0] - qx, p0[1] - qy
                dist = np.sqrt(vx * vx + vy * vy)
            if dist < 1e-9:
                vx, vy, dist = away[g, 0], away[g, 1], 1.0
            normal[e, 0], normal[e, 1] = vx / dist, vy / dist
            point[e, 0], point[e, 1] = qx, qy
        for r in range(n_rows):
            e = group_point[r]
            ax, ay = normal[e, 0], normal[e, 1]
            qx, qy = point[e, 0], point[e, 1]
            if r < n_end:
                required = np.sqrt((need[g] + eps_end[r]) ** 2 + delta_sq[g, r])
            else:
                required = need[g] + term_offset[r - n_end]
                if g >= n_walls:
                    qx += group_wv[r] * vel[g - n_walls, 0]
                    qy += group_wv[r] * vel[g - n_walls, 1]
            i = g * n_rows + r
            if g < n_walls and far[g]:
                lower[row0 + i] = -np.inf
            else:
                lower[row0 + i] = (ax * (qx - p0[0]) + ay * (qy - p0[1]) + required
                                   - (ax * v0[0] + ay * v0[1]) * dyn_line[i])
            for k in range(nz):
                rows[row0 + i, k] = ax * dyn_phi[i, k]
                rows[row0 + i, nz + k] = ay * dyn_phi[i, k]



@_compiled
def plan_extremes(values, n_points, n_speed, boxes, bounds, preds):
    """What the exact check of a plan (:meth:`BSplineMPC._violation`) compares, as a compiled loop.

    ``values`` stacks the plan's positions at the ``n_points`` check times, then the points whose
    hulls hold its velocity (``n_speed``) and its acceleration. Returns the smallest clearance of
    the positions (the world's signed distance, as :meth:`World.clearance`: to the bounds
    ``(x0, y0, x1, y1)`` and the rectangles ``boxes``), the closest distance to each prediction
    ``preds`` ``(m, n_points, 2)``, the largest speed and the largest acceleration.
    """
    clear = np.inf
    for i in range(n_points):
        x, y = values[i, 0], values[i, 1]
        c = min(min(x - bounds[0], bounds[2] - x), min(y - bounds[1], bounds[3] - y))
        for b in range(boxes.shape[0]):
            dx = max(boxes[b, 0] - x, x - boxes[b, 2])
            dy = max(boxes[b, 1] - y, y - boxes[b, 3])
            c = min(c, np.hypot(max(dx, 0.0), max(dy, 0.0)) + min(max(dx, dy), 0.0))
        clear = min(clear, c)
    closest = np.full(preds.shape[0], np.inf)
    for j in range(preds.shape[0]):
        for i in range(n_points):
            closest[j] = min(closest[j], np.hypot(values[i, 0] - preds[j, i, 0], values[i, 1] - preds[j, i, 1]))
    fastest, hardest = 0.0, 0.0
    for i in range(n_points, values.shape[0]):
        if i < n_points + n_speed:
            fastest = max(fastest, np.hypot(values[i, 0], values[i, 1]))
        else:
            hardest = max(hardest, np.hypot(values[i, 0], values[i, 1]))
    return clear, closest, fastest, hardest


@_compiled
def _group_state(pred, n_end, p0, speed, intervals, boxes, full, eps0, reach):
    """The per-group quantities of :meth:`BSplineMPC._step_data` as a compiled loop.

    ``pred`` holds each other robot's prediction at 0 and at the ``n_end`` interval ends first
    (then more); ``speed`` bounds the robot's own speed at each end. Returns ``x_now``
    ``(G, N, 2)``, the unit vectors ``away`` ``(G, 2)``, ``dist_now`` ``(G,)``, ``need`` ``(G,)``,
    ``delta_sq`` ``(G, N)`` and ``far`` ``(G,)`` as documented on :class:`_StepData`.
    """
    n_walls, n_others = boxes.shape[0], pred.shape[0]
    n_groups = n_walls + n_others
    x_now = np.empty((n_groups, n_end, 2))
    away = np.empty((n_groups, 2))
    dist_now = np.empty(n_groups)
    need = np.empty(n_groups)
    delta_sq = np.empty((n_groups, n_end))
    far = np.zeros(n_groups, dtype=np.bool_)
    delta = np.empty(n_end)
    for g in range(n_groups):
        if g < n_walls:
            qx = min(max(p0[0], boxes[g, 0]), boxes[g, 2])
            qy = min(max(p0[1], boxes[g, 1]), boxes[g, 3])
            for e in range(n_end):
                x_now[g, e, 0], x_now[g, e, 1] = qx, qy
                delta[e] = speed[e] * intervals[e]
        else:
            j = g - n_walls
            qx, qy = pred[j, 0, 0], pred[j, 0, 1]
            for e in range(n_end):
                x_now[g, e, 0], x_now[g, e, 1] = pred[j, e + 1, 0], pred[j, e + 1, 1]
                delta[e] = speed[e] * intervals[e] + np.hypot(pred[j, e + 1, 0] - pred[j, e, 0],
                                                              pred[j, e + 1, 1] - pred[j, e, 1])
        ax, ay = p0[0] - qx, p0[1] - qy
        dist = np.hypot(ax, ay)
        if dist > 1e-9:
            away[g, 0], away[g, 1] = ax / dist, ay / dist
        else:  # exactly on the group's point: push sideways
            away[g, 0], away[g, 1] = 0.0, 1.0
            dist = 1e-9
        dist_now[g] = dist
        need[g] = min(full[g], np.sqrt(max(dist * dist - delta[0] * delta[0] / 4.0, 0.0)) - eps0)
        for e in range(n_end):
            d = max(delta[e], delta[e + 1]) if e + 1 < n_end else delta[e]
            delta_sq[g, e] = d * d / 4.0
        far[g] = g < n_walls and dist > reach
    return x_now, away, dist_now, need, delta_sq, far


class _Problem:
    """Everything fixed for one (number of other robots, sample times): rows, Hessians, maps.

    The QP's variables are ``z = [z_x, z_y]``, the free control points (:func:`initial_state_nullspace`)
    as deviations from the line ``p0 + v0 tau``, in coordinates centred on ``p0``. Every row is a
    functional ``alpha^T phi_f(c)`` of the control points (a position at an interval end, a
    velocity or acceleration control point, a terminal combination) in one-sided form
    ``row @ z >= lower``, in metres: derivative rows are scaled by the knot span (``h``, ``h^2``).
    Order: box rows, speed polygon, acceleration polygon (all static), then one group of
    ``n_end + n_term`` rows per wall and per other robot (normals written at every step).
    """

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

        # Every inequality is tightened by the solver's tolerance, so an accepted solution meets
        # the untightened one. Chord inflation of each interval, and its maximum over the
        # intervals meeting at each end.
        self.tol = s.qp_tolerance
        self.eps = chord_inflation(robot.max_accel, self.intervals) + self.tol
        self.eps_end = np.maximum(self.eps, np.append(self.eps[1:], 0.0))

        # Interpolation of the sampled reference and predictions.
        self.interp_zero = interpolation_matrix(sample_times, 0.0)[0]  # type: ignore[arg-type]
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
        # A plan's next position and velocity and its samples; its check points and the points
        # whose hulls hold its velocity and acceleration.
        self.b_out = np.vstack([ctl.b_step, ctl.bv_step, self.b_samples])
        self.b_check_rates = np.vstack([self.b_check, ctl.rates])
        self.check_weights = horizon / self.check_times

        # Linear functionals on the control points used by constraint rows: positions at the
        # interval ends, velocity and acceleration control points, terminal functionals.
        # Velocity: the hull points after v(0), which the initial state fixes (constraining it
        # would pin the first points to the polygon's face whenever the robot is at the limit).
        d1 = h * bspline.velocity_hull_operator(knots)[1:]
        d2 = h**2 * bspline.derivative_control_operator(knots, DEGREE, 2)
        phi_term = (bspline.basis_derivative([self.term_time], knots, DEGREE, 0)  # type: ignore[arg-type]
                    + self.term_wv[:, None] * bspline.basis_derivative([self.term_time], knots, DEGREE, 1)  # type: ignore[arg-type]
                    + self.term_wa[:, None] * bspline.basis_derivative([self.term_time], knots, DEGREE, 2))  # type: ignore[arg-type]
        phi = np.vstack([self.b_ends, d1, d2, phi_term])
        phi_t = phi @ ctl.nullspace
        phi_line = phi @ ctl.greville  # each functional on the line tau -> tau
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
        self.n_rows = self.n_static + len(dyn_f)
        # The group of every row (-1: static rows).
        self.row_group = np.concatenate([np.full(self.n_static, -1),
                                         np.repeat(np.arange(self.n_groups), self.rows_per_group)])
        # Row alpha^T phi_f is [alpha_x phi_f, alpha_y phi_f]; the dynamic rows are written per QP.
        self.rows = np.zeros((self.n_rows, 2 * self.nz))
        by_coordinate = self.rows.reshape(self.n_rows, 2, self.nz)
        by_coordinate[:self.n_static] = static_alpha[:, :, None] * phi_t[static_f][:, None, :]
        # Each soft group of the evasive QP: one slack per interval end, one for its terminal rows.
        self.slack_of_row = np.concatenate([np.arange(n_end), np.full(n_term, n_end)])
        self.slack_weights = np.append(horizon / self.ends, 1.0) * s.evasive_penalty

        # The cost: z^T P z + 2 (v0 q_line - W ref)^T z per coordinate, up to a constant.
        p_half = ctl.nullspace.T @ ctl.cost_hessian @ ctl.nullspace
        q_line = ctl.nullspace.T @ ctl.cost_hessian @ ctl.greville
        # Cross term integral N(tau) p_ref(tau) dtau = ref_weights @ reference (exact quadrature).
        inner_knots = knots[(knots > 0) & (knots < horizon)]
        nodes, weights = bspline.gauss_legendre(
            np.concatenate([[0.0, horizon], inner_knots, sample_times[sample_times < horizon]]), 4)
        ref_weights = ctl.nullspace.T @ bspline.basis(nodes, knots, DEGREE).T @ (
            weights[:, None] * interpolation_matrix(sample_times, nodes))
        zero = np.zeros_like(p_half)
        self.hessian = np.block([[2.0 * p_half, zero], [zero, 2.0 * p_half]])
        self.q_line, self.ref_weights = q_line, ref_weights

        # The evasive QP (BSplineMPC._elastic) with every other robot softened, variables
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
        return (2.0 * (self.q_line[:, None] * v0 - self.ref_weights @ ref_local)).T.ravel()

    def static_lower(self, p0: np.ndarray, v0: np.ndarray, box_low: np.ndarray, box_high: np.ndarray) -> np.ndarray:
        """Lower bounds of the static rows in the QP's coordinates (centred on ``p0``, relative to
        the line ``v0 tau``): the box ``[box_low, box_high]`` of allowed positions at each end,
        tightened by eps there (convex: chords stay inside), the speed and acceleration polygons."""
        box = np.concatenate([box_low - p0, p0 - box_high])
        static = self.static_base - (self.static_alpha @ v0) * self.static_line
        static[:self.n_box] += (box[None, :] + self.eps_end[:, None]).ravel()
        return static


@dataclass(frozen=True)
class _StepData:
    """The request's data for one step, with the requirements derived from the current state.

    Walls and other robots are handled alike, as ``G`` groups (walls first): each keeps a
    clearance from a point ``x`` at every interval end (a wall's point is the nearest point of its
    rectangle, which depends on the linearisation; another robot's is its prediction).
    """

    p0: np.ndarray
    v0: np.ndarray
    ref_local: np.ndarray
    """Reference relative to ``p0`` ``(K, 2)`` (m)."""
    pred_check: np.ndarray
    """Predicted positions of the others at the check times ``(m, C, 2)`` (m)."""
    x_now: np.ndarray
    """Each group's point at every interval end for a half-plane through the current position:
    the wall's nearest point to ``p0``, or the prediction ``(G, N, 2)`` (m)."""
    away: np.ndarray
    """Unit vector from each group's point at ``tau = 0`` to ``p0`` ``(G, 2)``."""
    dist_now: np.ndarray
    """Current distance to each group's point ``(G,)`` (m)."""
    contact: np.ndarray
    """Distance to a group's point below which a linearisation point gives no direction ``(G,)`` (m)."""
    full: np.ndarray
    """Clearance wanted from each group: r_i from a wall, r_i + r_j + margin from a robot ``(G,)`` (m)."""
    need: np.ndarray
    """Clearance to keep: ``full``, or less where the current state is already closer ``(G,)`` (m)."""
    delta_sq: np.ndarray
    """A quarter of the squared largest relative displacement over the intervals meeting at each
    end ``(G, N)`` (m^2)."""
    velocities: np.ndarray
    """Each other robot's predicted velocity at the end of the horizon ``(m, 2)`` (m/s)."""
    far: np.ndarray
    """Groups out of reach within the horizon ``(G,)``: a wall's rows then constrain nothing."""
    gap_box: np.ndarray
    """Current distance to the bounds x_min, y_min, x_max, y_max ``(4,)`` (m)."""
    need_box: np.ndarray
    """Clearance to keep from the bounds ``(4,)`` (m)."""
    static_lower: np.ndarray
    """Lower bounds of the static rows in the QP's coordinates (:meth:`_Problem.static_lower`)."""
    n_walls: int

    @property
    def need_clear(self) -> float:
        """The smallest clearance the plan has to keep from any wall or bound (m)."""
        return float(min(self.need[:self.n_walls].min(initial=np.inf), self.need_box.min()))


@dataclass
class _Effort:
    """Solver effort spent on one control step (reported in ``ControlResult.info``)."""

    qps: int = 0
    qp_steps: int = 0
    qp_time: float = 0.0
    constraints: int = 0

    def as_info(self) -> dict:
        return {"qps": self.qps, "qp_steps": self.qp_steps, "qp_time": self.qp_time,
                "constraints": self.constraints}


@register_controller("mpc")
class BSplineMPC:
    """Cubic B-spline MPC (paper appendix) for one robot; keeps the previous plan between steps."""

    name = "mpc"

    def __init__(self, world: World, robot: RobotSpec, params: MPCParams = MPCParams()):
        if params.dt <= 0 or params.horizon <= 0 or params.dt > params.horizon:
            raise ValueError(f"need 0 < dt <= horizon, got dt={params.dt}, horizon={params.horizon}")
        self.world = world
        self.robot = robot
        self.params = params
        self.settings = settings = params  # the numerical choices, read as settings.*
        self.horizon = float(params.horizon)
        self.dt = float(params.dt)
        self.knots = bspline.uniform_knots(self.horizon, settings.segments, DEGREE)
        self.nullspace = initial_state_nullspace(self.knots, DEGREE)
        self.greville = bspline.greville_abscissae(self.knots, DEGREE)
        self.cost_hessian = (bspline.gram_matrix(self.knots, DEGREE, 0, 0.0, self.horizon)
                             + params.w2 * bspline.gram_matrix(self.knots, DEGREE, 1, 0.0, self.horizon))
        self.obstacles = world.obstacle_array
        self.b_step = bspline.basis_derivative([self.dt], self.knots, DEGREE, 0)[0]  # type: ignore[arg-type]
        # Where the robot passes within a step: the spline is curved, the chord is not it.
        self.b_substeps = bspline.basis_derivative(self.dt * STEP_FRACTIONS, self.knots, DEGREE, 0)
        self.bv_step = bspline.basis_derivative([self.dt], self.knots, DEGREE, 1)[0]  # type: ignore[arg-type]
        # Points whose hulls hold the velocity (after v(0)) and the acceleration, for the exact check.
        d1 = bspline.velocity_hull_operator(self.knots)[1:]
        self.rates = np.vstack([d1, bspline.derivative_control_operator(self.knots, DEGREE, 2)])
        self.n_speed = len(d1)
        # Moving a plan on by one step: least-squares fit of p(tau + dt) (the last span's
        # polynomial continues past the horizon).
        fit = np.linspace(0.0, self.horizon, 4 * settings.segments + 1)
        self._shift = np.linalg.lstsq(bspline.basis(fit, self.knots, DEGREE),
                                      bspline.basis(fit + self.dt, self.knots, DEGREE), rcond=None)[0]
        self._problems: dict[tuple, _Problem] = {}
        self._valid_times = b""
        self._last_problem: tuple[tuple, _Problem] | None = None
        self._clearance_cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        self._world_bounds = world.bounds_array
        self._bounds = (self._world_bounds[:2], self._world_bounds[2:])
        # Beyond this distance a wall cannot be reached within the horizon.
        self._reach = robot.radius + robot.max_speed * self.horizon + 0.1
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
        """Solve the MPC for one step.

        On success the plan tracks the reference within every constraint. Otherwise
        (``success=False``) the robot follows the evasive plan (``info["fallback"] == "evasive"``,
        the least intrusion into the others' predicted discs, walls and limits kept) or, if there
        is none, brakes along its velocity (``"braking"``). Raises ``ValueError`` only for a
        malformed request (shapes, non-finite values, sample times outside ``(0, horizon]``).
        """
        start = time.perf_counter()
        p0, v0, ref, times, others, other_radii, firm = self._validated(request)
        prob = self._problem(len(others), times)
        data = self._step_data(prob, p0, v0, ref, others, other_radii)
        effort = _Effort()
        r, m_w = self.robot.radius, prob.n_walls
        clearance0 = float(min(data.dist_now[:m_w].min(initial=np.inf), data.gap_box.min()))
        if clearance0 < r - self.settings.contact_tolerance:
            return self._brake(request, prob, start, effort,
                               f"in contact with a wall (clearance {clearance0:.3f} m, radius {r:.3f} m)")

        warm = self._warm_start()
        cold = warm is None
        lin = prob.interp_ends @ ref if cold else prob.b_ends @ warm
        dist0, contact = data.dist_now[m_w:], data.contact[m_w:]
        overlapping = np.flatnonzero(dist0 < contact - self.settings.contact_tolerance)
        if overlapping.size:
            j = int(overlapping[0])
            why = f"overlapping robot {j} ({dist0[j]:.3f} m apart, contact at {contact[j]:.3f} m)"
            conflict = overlapping
        else:
            best, why, conflict = self._track(prob, data, lin, cold, effort)
            if best is not None:
                self._previous, self._braking = best, None
                return self._result(True, "", best, prob, data, start, {"fallback": "", **effort.as_info()})
        logger.debug("MPC at %s: %s", p0, why)
        # With no other robot the evasive QP would be the tracking QP again.
        plan, firm_softened = None, False
        if self.settings.evasive and prob.n_others:
            plan, intrusion, intruded = self._evasive(prob, data, lin, cold, conflict[~firm[conflict]], firm, effort)
            if plan is None and firm.any():
                # Better to intrude into a firm prediction than to brake blindly, into walls too.
                firm_softened = True
                plan, intrusion, intruded = self._evasive(prob, data, lin, cold, conflict, np.zeros_like(firm),
                                                          effort)
        if plan is None:
            return self._brake(request, prob, start, effort, why)
        self._previous, self._braking = plan, None
        return self._result(False, f"infeasible: evasive: {why}", plan, prob, data, start,
                            {"fallback": "evasive", "intrusion": intrusion, "intruded": intruded.tolist(),
                             "firm_softened": firm_softened, **effort.as_info()})

    # -- internals ---------------------------------------------------------------------------

    def _result(self, success: bool, reason: str, c: np.ndarray, prob: _Problem, data: _StepData, start: float,
                info: dict) -> ControlResult:
        out = prob.b_out @ c
        return ControlResult(
            success=success, reason=reason,
            velocity=(out[0] - data.p0) / self.dt,
            next_position=out[0], next_velocity=out[1],
            planned_positions=out[2:],
            solve_time=time.perf_counter() - start,
            info=info,
            step_positions=self.b_substeps @ c,
        )

    def _track(self, prob: _Problem, data: _StepData, lin: np.ndarray, cold: bool, effort: _Effort):
        """The tracking QP (re-linearised once more after a cold start if the solution moved far).

        Returns (control points or None, why not, the other robots involved in the failure: those
        owning rows of an infeasibility certificate (:func:`infeasibility_certificate`), else all).
        """
        best, why, conflict = None, "", np.arange(prob.n_others)
        gradient = prob.gradient(data.v0, data.ref_local)
        for _ in range(self.settings.sqp_iterations):
            lower = self._write_separation(prob, data, lin, cold, data.need)
            sol = self._solve(prob.hessian, gradient, prob.rows, lower, effort)
            if not sol.success:
                why = f"tracking QP {sol.reason}"
                # DAQP can also stop cycling on an infeasible degenerate QP; the LP decides.
                certified = self._certified_conflict(prob, prob.rows, lower, effort)
                if certified is not None and certified.size:
                    conflict = certified
                break
            c = self._control_points(data, sol.x)
            why = self._violation(prob, data, c, separation=True)
            if why:
                break
            best = c
            if not cold:
                break
            moved = prob.b_ends @ c
            if np.max(np.hypot(*(moved - lin).T)) <= self.settings.sqp_tolerance:
                break
            lin, cold = moved, False
        return best, why, conflict

    def _evasive(self, prob: _Problem, data: _StepData, lin: np.ndarray, cold: bool, conflict: np.ndarray,
                 firm: np.ndarray, effort: _Effort):
        """The plan that intrudes least into the other robots' predicted discs.

        Keeping out of a disc is not convex: which side to pass on is a choice. Two
        linearisations are tried (:meth:`_elastic`): the half-planes of the previous plan (pass
        the others as planned), and half-planes that keep the current arrangement (at every end
        the normal points from the other robot's position now to the robot's: back away from a
        robot coming head-on, run ahead of one coming from behind). Both soften the same robots:
        the second starts from the robots the first had to soften. The plan kept is the one
        whose first true intrusion into a disc (at the check times, beyond ``check_tolerance``)
        comes later, the time the others have to react; on a tie, the one whose intrusion summed
        with the penalty's weights (``T_MPC / tau``) is smaller, then the first.

        Returns (control points or None, largest true intrusion (m), the robots whose discs it enters).
        """
        tol = self.settings.check_tolerance
        best, best_score = (None, np.inf, np.zeros(0, dtype=int)), (np.inf, np.inf)
        soft = np.zeros(prob.n_groups, dtype=bool)
        soft[prob.n_walls + np.asarray(conflict, dtype=int)] = True
        for keep_arrangement in (False, True):
            if not soft.any():
                break
            c, soft = self._elastic(prob, data, lin, cold, soft, firm, effort, keep_arrangement)
            if soft is None:
                break  # walls, bounds, limits and firm predictions alone conflict
            if c is None:
                continue
            gap = prob.b_check @ c - data.pred_check
            short = np.maximum(data.full[prob.n_walls:, None] - np.hypot(gap[..., 0], gap[..., 1]), 0.0)
            hit = (short > tol).any(axis=0)
            first = prob.check_times[np.argmax(hit)] if hit.any() else np.inf
            score = (-first, float((short * prob.check_weights).sum()))
            if score < best_score:
                best = (c, float(short.max(initial=0.0)), np.flatnonzero((short > tol).any(axis=1)))
                best_score = score
            if first == np.inf:
                break  # no intrusion at all: nothing can do better
        return best

    def _elastic(self, prob: _Problem, data: _StepData, lin: np.ndarray, cold: bool, soft: np.ndarray,
                 firm: np.ndarray, effort: _Effort, keep_arrangement: bool):
        """The tracking QP with the separation rows of the ``soft`` groups softened.

        Each interval end (and the terminal rows together) of a softened robot gets a slack
        ``s >= 0`` in its rows, costing ``w s + c s^2 / 2`` with ``w``
        (``settings.evasive_penalty``, times ``T_MPC / tau``) far above what tracking could gain,
        so every intrusion that can be avoided is (the L1 penalty is exact), and the nearest ones
        first. Softened robots must keep ``r_i + r_j + margin``, not the relaxed requirement, so
        the plan steers out of their discs; with ``keep_arrangement`` their half-planes keep the
        current arrangement (see :meth:`_write_separation`). Walls, the box, speed and
        acceleration stay hard; the slacks' ``s >= 0`` are simple bounds, active at the solver's
        start.

        If the softened problem is infeasible too, the robots in an infeasibility certificate
        are softened as well, except the request's ``firm`` predictions, which stay hard like
        walls. A row with its own slack can always be met, so it never takes part in a
        certificate: the certificate is computed on the rows kept hard alone (fewer variables),
        and they do not depend on the linearisation of the softened ones. The robots kept hard
        are kept clear whatever that costs in intrusion into the softened ones: softening every
        robot at once instead let the plan trade a late intrusion into an uninvolved robot for a
        smaller early one, and collided more often in closed loop.

        Returns (control points or None if the QP fails or its plan fails the exact check of
        walls, bounds and limits; the softened groups, or None if walls, bounds, limits and firm
        predictions alone conflict).
        """
        n, spg = 2 * prob.nz, len(prob.slack_weights)
        soft = soft.copy()
        gradient = np.concatenate([prob.gradient(data.v0, data.ref_local), prob.slack_gradient])
        while True:
            robots = np.flatnonzero(soft[prob.n_walls:])
            lower = self._write_separation(prob, data, lin, cold, np.where(soft, data.full, data.need),
                                           soft if keep_arrangement else None)
            slacks = (spg * robots[:, None] + np.arange(spg)).ravel()
            var = np.concatenate([np.arange(n), n + slacks])
            rows = np.hstack([prob.rows, prob.slack_columns[:, slacks]])
            sol = self._solve(prob.evasive_hessian[np.ix_(var, var)], gradient[var], rows, lower, effort,
                              bounds=prob.slack_bounds[var], start_active=prob.slack_bounds[var] == 0.0)
            if sol.success:
                c = self._control_points(data, sol.x[:n])
                return (None if self._violation(prob, data, c, separation=False) else c), soft
            hard = np.where(prob.softened_rows(soft), -np.inf, lower)
            certified = self._certified_conflict(prob, prob.rows, hard, effort)
            if certified is None:
                return None, soft  # the solver failed on a problem the certificate finds consistent
            more = prob.n_walls + certified[~firm[certified]]
            if soft[more].all():  # also when the certificate names no robot at all
                return None, None
            soft[more] = True

    def _certified_conflict(self, prob: _Problem, rows: np.ndarray, lower: np.ndarray,
                            effort: _Effort) -> np.ndarray | None:
        """The other robots owning rows of an infeasibility certificate of ``rows @ x >= lower``
        (empty if walls and limits alone conflict), or None if the rows are consistent."""
        t = time.perf_counter()
        support = infeasibility_certificate(rows, lower)
        effort.qp_time += time.perf_counter() - t
        return prob.conflicting_others(support) if support.size else None

    def _solve(self, hessian: np.ndarray, gradient: np.ndarray, rows: np.ndarray, lower: np.ndarray,
               effort: _Effort, bounds: np.ndarray | None = None, start_active: np.ndarray | None = None) -> QPSolution:
        t = time.perf_counter()
        sol = solve_qp(hessian, gradient, rows, lower, self.settings.qp_tolerance, bounds, start_active)
        effort.qp_time += time.perf_counter() - t
        effort.qps += 1
        effort.qp_steps += sol.iterations
        effort.constraints = max(effort.constraints,
                                 len(lower) + (0 if bounds is None else int(np.isfinite(bounds).sum())))
        return sol

    def _control_points(self, data: _StepData, z: np.ndarray) -> np.ndarray:
        """Control points ``(n, 2)`` of the curve with free control points ``z`` (line plus deviation)."""
        return data.p0 + self.greville[:, None] * data.v0 + self.nullspace @ z.reshape(2, -1).T

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
        stamp = times.tobytes()
        if stamp != self._valid_times:  # usually the same times as last step
            if times[0] <= 0 or times[-1] > self.horizon + 1e-9 or (k > 1 and np.diff(times).min() <= 0):
                raise ValueError(f"sample_times must increase within (0, {self.horizon}], got {times}")
            self._valid_times = stamp
        # A sum is finite only if every term is (NaN and infinities propagate).
        if not np.isfinite(p0.sum() + v0.sum() + ref.sum() + others.sum() + radii.sum()):
            raise ValueError("request contains non-finite values")
        firm = np.zeros(len(radii), dtype=bool) if request.firm is None else np.asarray(request.firm, dtype=bool)
        if firm.shape != radii.shape:
            raise ValueError(f"firm must have one flag per prediction {radii.shape}, got {firm.shape}")
        return p0, v0, ref, times, others, radii, firm

    def _problem(self, n_others: int, times: np.ndarray) -> _Problem:
        exact = (n_others, times.tobytes())
        if self._last_problem is not None and self._last_problem[0] == exact:
            return self._last_problem[1]  # the usual case: the same sample times as last step
        key = (n_others, np.round(times, 9).tobytes())
        prob = self._problems.get(key)
        if prob is None:
            prob = self._problems[key] = _Problem(self, n_others, times)
        self._last_problem = (exact, prob)
        return prob

    def _step_data(self, prob: _Problem, p0, v0, ref, others, other_radii) -> _StepData:
        """Predictions at the interval ends and what must be kept from every robot and wall.

        Between two interval ends where the distance is at least ``R'`` the chord stays at least
        ``sqrt(R'^2 - delta^2 / 4)`` from a point (or a convex wall) when it moves by ``delta``,
        and the curve leaves its chord by at most ``eps``; so requiring
        ``R' = sqrt((need + eps)^2 + delta^2 / 4)`` at the ends keeps ``need`` at every instant.
        At ``tau = 0`` the distance is what it is: ``need`` is lowered to what the current state
        allows when it is already inside the margin, for each prediction separately.
        """
        robot, m_w, n_end = self.robot, prob.n_walls, len(prob.ends)
        r = robot.radius
        pred = prob.interp_all @ others                       # (m, 1 + N + C + 1, 2)
        # The robot's own displacement over an interval: at most its reachable speed times it.
        speed = np.minimum(robot.max_speed, math.hypot(v0[0], v0[1]) + robot.max_accel * prob.ends)
        full, contact = self._clearances(m_w, other_radii)
        x_now, away, dist_now, need, delta_sq, far = _group_state(
            pred, n_end, p0, speed, prob.intervals, self.obstacles, full, prob.eps[0], self._reach)
        gap = np.concatenate([p0 - self._bounds[0], self._bounds[1] - p0])
        need_box = np.minimum(r, gap - prob.eps[0])
        return _StepData(
            p0=p0, v0=v0, ref_local=ref - p0, pred_check=pred[:, n_end + 1:-1], x_now=x_now, away=away,
            dist_now=dist_now, contact=contact, full=full, need=need, delta_sq=delta_sq, velocities=pred[:, -1],
            far=far, gap_box=gap, need_box=need_box, n_walls=m_w,
            static_lower=prob.static_lower(p0, v0, self._bounds[0] + need_box[:2], self._bounds[1] - need_box[2:]),
        )

    def _clearances(self, n_walls: int, other_radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Clearance wanted from each group, and the distance under which it is in contact."""
        key = (n_walls, other_radii.tobytes())
        if key not in self._clearance_cache:
            r = self.robot.radius
            self._clearance_cache[key] = (
                np.concatenate([np.full(n_walls, r), r + other_radii + self.params.safety_margin]),
                np.concatenate([np.full(n_walls, 1e-12), r + other_radii]))
        return self._clearance_cache[key]

    def _warm_start(self) -> np.ndarray | None:
        """The previous plan moved on by one step (control points), if there is one."""
        return None if self._previous is None else self._shift @ self._previous

    def _write_separation(self, prob: _Problem, data: _StepData, lin: np.ndarray, cold: bool, need: np.ndarray,
                          keep_arrangement: np.ndarray | None = None) -> np.ndarray:
        """Write the wall and separation rows into ``prob.rows``; return every row's lower bound.

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
        Last come the terminal rows of :func:`stopping_rows`, along the last end's normal (``x``
        the other robot or the wall's nearest point, ``v_x`` its velocity, zero for a wall).
        Bounds are moved to the QP's
        coordinates (centred on ``p0``, relative to the line ``v0 tau``). The loops run compiled
        (:func:`_separation_rows`): a few hundred scalar rows are cheaper there than as dozens of
        small array operations.
        """
        lower = np.empty(prob.n_rows)
        lower[:prob.n_static] = data.static_lower
        marked = np.zeros(prob.n_groups, dtype=bool) if keep_arrangement is None else keep_arrangement
        _separation_rows(lin, data.x_now, self.obstacles, prob.n_walls, data.p0, data.v0, data.contact,
                         np.asarray(need, dtype=float), cold, marked, prob.eps_end, data.delta_sq, prob.group_point,
                         prob.group_wv, prob.term_offset, data.velocities, data.far, data.away, prob.dyn_phi,
                         prob.dyn_line, prob.rows, lower, prob.n_static)
        return lower

    def _violation(self, prob: _Problem, data: _StepData, c: np.ndarray, separation: bool) -> str:
        """Empty if ``c`` satisfies every constraint (``separation``: the others' too) when checked
        exactly (true clearances and distances at the check times, speed and acceleration on
        points whose hulls hold them), else what it violates."""
        tol = self.settings.check_tolerance
        clear, closest, speed, accel = plan_extremes(prob.b_check_rates @ c, len(prob.check_times), self.n_speed,
                                                      self.obstacles, self._world_bounds, data.pred_check)
        if clear < data.need_clear - tol:
            return f"plan comes {1e3 * (data.need_clear - clear):.2f} mm too close to a wall"
        if separation and prob.n_others:
            short = data.need[prob.n_walls:] - closest
            j = int(np.argmax(short))
            if short[j] > tol:
                return f"plan comes {1e3 * short[j]:.2f} mm too close to robot {j}"
        if speed > self.robot.max_speed + tol:
            return f"plan exceeds the speed limit ({speed:.4f} m/s)"
        if accel > self.robot.max_accel + tol:
            return f"plan exceeds the acceleration limit ({accel:.4f} m/s^2)"
        return ""

    def _brake(self, request: ControlRequest, prob: _Problem, start: float, effort: _Effort,
               why: str) -> ControlResult:
        """Decelerate along the current velocity at max_accel; the previous plan is discarded."""
        p0 = np.asarray(request.position, dtype=float)
        v0 = np.asarray(request.velocity, dtype=float)
        self._previous, self._braking = None, (p0, v0)
        pos, vel = braking_profile(p0, v0, self.robot.max_accel, np.concatenate([[self.dt], prob.sample_times]))
        return ControlResult(
            success=False, reason=f"infeasible: braking: {why}",
            velocity=(pos[0] - p0) / self.dt,
            next_position=pos[0], next_velocity=vel[0],
            planned_positions=pos[1:],
            solve_time=time.perf_counter() - start,
            info={"fallback": "braking", **effort.as_info()},
            step_positions=braking_profile(p0, v0, self.robot.max_accel, self.dt * STEP_FRACTIONS)[0],
        )
