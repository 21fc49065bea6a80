"""The MPC's constraint rows: where they are sampled, how they are inflated, and their compiled loops.

Separation and walls at every instant. The horizon is cut into intervals no longer than
``settings.max_interval`` whose ends include every sample time (:func:`constraint_grid`), so
predictions are linear on each interval. At every interval end, a half-plane
``n^T (p(tau_e) - x(tau_e)) >= R'`` with ``n`` the unit vector from the other robot (or from the
nearest point of the wall rectangle, or of the convex piece of a polygon wall) to the
linearisation point there: the previous plan moved on by one step, or the reference when there is
none. A half-plane outside a disc (or a convex rectangle or piece) implies the true non-convex
constraint at the sample; between samples, a chord whose ends are ``R'`` from a point and which
moves by ``delta`` stays ``sqrt(R'^2 - delta^2 / 4)`` from it, and the curve leaves its chord by at
most ``max_accel dt^2 / 8`` (:func:`chord_inflation`);
``R'`` is inflated accordingly. Every accepted plan is therefore safe at every instant with
respect to the predictions. The linearisation trajectory satisfies its own tangent half-planes,
so a feasible previous plan stays feasible.

Recursive feasibility. A finite horizon alone lets the plan arrive at a robot or a wall with a
speed it can no longer shed; so at the end of the horizon the gap along each normal must exceed
the distance needed to stop, imposed through secants (an inner approximation,
:func:`stopping_rows`).

Already inside a margin (another robot's prediction closer than ``r_i + r_j + margin``, or a
wall closer than ``r_i``), the plan is only required not to get closer than now, separately for
every prediction (:func:`group_state`).

Speed and acceleration are bounded by inscribed regular polygons (:func:`polygon_normals`) on
points whose convex hull contains the derivative over the whole horizon.

The per-row geometry (requirements per wall and robot, half-planes, the exact check of a plan)
runs as compiled scalar loops (numba; the same code runs, slowly, without it): a few hundred rows
cost less there than the dozens of small array operations each would take in NumPy.
"""

from __future__ import annotations

import numpy as np

from nodnav.compiled import compiled
from nodnav.control.braking import _tail_clearance_kernel, hypot_axis, tail_rows
from nodnav.geometry import piece_closest_point_one, piece_signed_distance_one


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



@compiled
def separation_rows(lin, x_now, boxes, pieces, n_walls, p0, v0, contact, need, cold, keep_arrangement, eps_end,
                    delta_sq, group_point, group_wv, term_offset, vel, far, away, dyn_phi, dyn_line, rows, lower,
                    row0):
    """Write the wall and separation rows (see :meth:`~nodnav.control.mpc_problem.MPCProblem.write_separation`)
    into ``rows[row0:]`` (``[alpha_x phi, alpha_y phi]``) and ``lower[row0:]`` (QP coordinates)."""
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
            if g < boxes.shape[0]:  # the wall rectangle's nearest point to the linearisation point
                qx = min(max(lin[e, 0], boxes[g, 0]), boxes[g, 2])
                qy = min(max(lin[e, 1], boxes[g, 1]), boxes[g, 3])
            elif g < n_walls:  # the convex wall piece's nearest point
                qx, qy = piece_closest_point_one(lin[e, 0], lin[e, 1], pieces[g - boxes.shape[0]])
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


@compiled
def plan_extremes(values, n_points, n_speed, boxes, pieces, bounds, preds):
    """What the exact check of a plan (:meth:`~nodnav.control.mpc_problem.MPCProblem.violation`)
    compares, as a compiled loop.

    ``values`` stacks the plan's positions at the ``n_points`` check times, then the points whose
    hulls hold its velocity (``n_speed``) and its acceleration. Returns the smallest clearance of
    the positions (the world's signed distance, as :meth:`World.clearance`: to the bounds
    ``(x0, y0, x1, y1)``, the rectangles ``boxes`` and the convex pieces ``pieces``), the closest
    distance to each prediction ``preds`` ``(m, n_points, 2)``, the largest speed and the largest acceleration.
    """
    clear = np.inf
    for i in range(n_points):
        x, y = values[i, 0], values[i, 1]
        c = min(min(x - bounds[0], bounds[2] - x), min(y - bounds[1], bounds[3] - y))
        for b in range(boxes.shape[0]):
            dx = max(boxes[b, 0] - x, x - boxes[b, 2])
            dy = max(boxes[b, 1] - y, y - boxes[b, 3])
            c = min(c, hypot_axis(max(dx, 0.0), max(dy, 0.0)) + min(max(dx, dy), 0.0))
        for b in range(pieces.shape[0]):
            c = min(c, piece_signed_distance_one(x, y, pieces[b]))
        clear = min(clear, c)
    closest = np.full(preds.shape[0], np.inf)
    for j in range(preds.shape[0]):
        # The minimum of the distances, exactly; a distance is at least its larger coordinate
        # difference, so starting from the point nearest in squares, most need no hypot call.
        first, least = 0, np.inf
        for i in range(n_points):
            dx, dy = values[i, 0] - preds[j, i, 0], values[i, 1] - preds[j, i, 1]
            sq = dx * dx + dy * dy
            if sq < least:
                first, least = i, sq
        best = np.inf
        for k in range(n_points):
            i = (first + k) % n_points
            dx, dy = values[i, 0] - preds[j, i, 0], values[i, 1] - preds[j, i, 1]
            if max(abs(dx), abs(dy)) < best:
                best = min(best, np.hypot(dx, dy))
        closest[j] = best
    fastest, hardest = 0.0, 0.0
    for i in range(n_points, values.shape[0]):
        if i < n_points + n_speed:
            fastest = max(fastest, np.hypot(values[i, 0], values[i, 1]))
        else:
            hardest = max(hardest, np.hypot(values[i, 0], values[i, 1]))
    return clear, closest, fastest, hardest


@compiled
def group_state(pred, n_end, p0, speed, intervals, boxes, pieces, full, eps0, reach):
    """The per-group quantities of a step's :class:`~nodnav.control.mpc_problem.StepData` as a compiled loop.

    ``pred`` holds each other robot's prediction at 0 and at the ``n_end`` interval ends first
    (then more); ``speed`` bounds the robot's own speed at each end. Returns ``x_now``
    ``(G, N, 2)``, the unit vectors ``away`` ``(G, 2)``, ``dist_now`` ``(G,)``, ``need`` ``(G,)``,
    ``delta_sq`` ``(G, N)`` and ``far`` ``(G,)`` as documented on :class:`~nodnav.control.mpc_problem.StepData`.
    """
    n_groups = boxes.shape[0] + pieces.shape[0] + pred.shape[0]
    x_now = np.empty((n_groups, n_end, 2))
    away = np.empty((n_groups, 2))
    dist_now = np.empty(n_groups)
    need = np.empty(n_groups)
    delta_sq = np.empty((n_groups, n_end))
    far = np.zeros(n_groups, dtype=np.bool_)
    group_state_into(pred, n_end, p0, speed, intervals, boxes, pieces, full, eps0, reach, x_now, away, dist_now, need,
                     delta_sq, far)
    return x_now, away, dist_now, need, delta_sq, far


@compiled
def group_state_into(pred, n_end, p0, speed, intervals, boxes, pieces, full, eps0, reach, x_now, away, dist_now, need,
                     delta_sq, far):
    """:func:`group_state` written into the given arrays (every entry of each is written)."""
    n_boxes, n_others = boxes.shape[0], pred.shape[0]
    n_walls = n_boxes + pieces.shape[0]
    n_groups = n_walls + n_others
    delta = np.empty(n_end)
    for g in range(n_groups):
        if g < n_walls:
            if g < n_boxes:
                qx = min(max(p0[0], boxes[g, 0]), boxes[g, 2])
                qy = min(max(p0[1], boxes[g, 1]), boxes[g, 3])
            else:  # a convex piece of a polygon wall
                qx, qy = piece_closest_point_one(p0[0], p0[1], pieces[g - n_boxes])
            for e in range(n_end):
                x_now[g, e, 0], x_now[g, e, 1] = qx, qy
                delta[e] = speed[e] * intervals[e]
        else:
            j = g - n_walls
            qx, qy = pred[j, 0, 0], pred[j, 0, 1]
            for e in range(n_end):
                x_now[g, e, 0], x_now[g, e, 1] = pred[j, e + 1, 0], pred[j, e + 1, 1]
                delta[e] = speed[e] * intervals[e] + hypot_axis(pred[j, e + 1, 0] - pred[j, e, 0],
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


# -- One compiled call per stage of a step ---------------------------------------------------------
# A step's set-up, its rows and its exact check each call one kernel below, which runs the loops
# above in turn: the same operations in the same order (the results are bit for bit those of the
# separate calls), without a Python round trip and the small array operations between them.


@compiled
def _finite(a):
    for x in a.flat:
        if not np.isfinite(x):
            return False
    return True


@compiled
def all_finite(p0, v0, ref, others, radii):
    """Whether every entry of the five arrays is finite (a request's validation)."""
    return _finite(p0) and _finite(v0) and _finite(ref) and _finite(others) and _finite(radii)


@compiled
def step_state(pred, p0, now, other_radii, margins, ref, ref_local, alpha_v0, static, n_end, ends, intervals, boxes,
               pieces, bounds, radius, max_speed, max_accel, eps0, reach, contact_tolerance, eps_end, static_base,
               static_line, tail_on, horizon, speed_horizon, accel_horizon, accel_horizon_sq_half, double_decel, x_now,
               away, dist_now, need, delta_sq, far, full, contact, gap, need_box, box_low, box_high):
    """A step's requirements: :func:`group_state` with the clearances it needs, ``full``
    (``radius`` from a wall, ``radius + r_j + margins[j]`` from another robot) and ``contact``
    (``1e-12`` from a wall, ``radius + r_j`` from a robot), the robot's reachable speed at each
    interval end (``min(max_speed, now + max_accel * ends)``), and the box: the distances ``gap``
    to the ``bounds`` ``(x0, y0, x1, y1)``, the clearance kept from each (``min(radius, gap -
    eps0)``) and the allowed corners, written into ``x_now, away, dist_now, need, delta_sq, far,
    full, contact, gap, need_box, box_low, box_high`` (the caller's arrays, every entry: numba
    would box each returned array through a Python call). Returns the smallest clearance to keep
    from any wall or bound, the present clearance from the walls and bounds (the smallest
    ``dist_now`` of a wall and ``gap``), whether any other robot is closer than its
    ``contact`` less ``contact_tolerance``, and the braking tail's weight and reach (``tail_on``;
    else 0, 0): ``top = min(max_speed, now + max_accel T)``, ``top / (2 a_tail)`` and ``radius +
    min(max_speed T, now T + max_accel T^2 / 2) + weight top + 0.1``, with ``speed_horizon``,
    ``accel_horizon``, ``accel_horizon_sq_half`` and ``double_decel`` the products of constants in
    those expressions (the Python expressions' operations, in their order). Writes the static
    rows' bounds into ``static``:
    ``static_base - alpha_v0 * static_line`` (:meth:`~nodnav.control.mpc_problem.MPCProblem.static_lower_base`,
    the NumPy expression's operations, with ``alpha_v0`` its product ``static_alpha @ v0``), the
    box's bounds added to the first ``4 len(eps_end)`` entries (see
    :meth:`~nodnav.control.mpc_problem.MPCProblem.static_lower`), and writes the reference relative
    to ``p0`` (``ref - p0``, the same subtractions as NumPy's) into ``ref_local``. The arguments
    from ``n_end`` on are the problem's (:attr:`~nodnav.control.mpc_problem.MPCProblem.state_constants`)."""
    n_walls = boxes.shape[0] + pieces.shape[0]
    n_groups = n_walls + other_radii.shape[0]
    for g in range(n_walls):
        full[g], contact[g] = radius, 1e-12
    for j in range(other_radii.shape[0]):
        full[n_walls + j] = radius + other_radii[j] + margins[j]
        contact[n_walls + j] = radius + other_radii[j]
    speed = np.empty(ends.shape[0])
    for e in range(ends.shape[0]):
        speed[e] = min(max_speed, now + max_accel * ends[e])
    group_state_into(pred, n_end, p0, speed, intervals, boxes, pieces, full, eps0, reach, x_now, away, dist_now, need,
                     delta_sq, far)
    for d in range(2):
        gap[d] = p0[d] - bounds[d]
        gap[2 + d] = bounds[2 + d] - p0[d]
    need_clear = np.inf
    for d in range(4):
        need_box[d] = min(radius, gap[d] - eps0)
    for g in range(n_walls):
        need_clear = min(need_clear, need[g])
    for d in range(4):
        need_clear = min(need_clear, need_box[d])
    for d in range(2):
        box_low[d] = bounds[d] + need_box[d]
        box_high[d] = bounds[2 + d] - need_box[2 + d]
    box = np.empty(4)
    for d in range(2):
        box[d] = box_low[d] - p0[d]
        box[2 + d] = p0[d] - box_high[d]
    for k in range(static.shape[0]):
        static[k] = static_base[k] - alpha_v0[k] * static_line[k]
    for e in range(eps_end.shape[0]):
        for d in range(4):
            static[4 * e + d] += box[d] + eps_end[e]
    clear_now = np.inf
    for g in range(n_walls):
        clear_now = min(clear_now, dist_now[g])
    for d in range(4):
        clear_now = min(clear_now, gap[d])
    overlap = False
    for g in range(n_walls, n_groups):
        overlap = overlap or dist_now[g] < contact[g] - contact_tolerance
    for k in range(ref.shape[0]):
        for d in range(2):
            ref_local[k, d] = ref[k, d] - p0[d]
    weight, tail_reach = 0.0, 0.0
    if tail_on:
        # |v(T)| <= V: the speed reachable by T from the present one (at most the limit).
        top = min(max_speed, now + accel_horizon)
        weight = top / double_decel
        tail_reach = radius + min(speed_horizon, now * horizon + accel_horizon_sq_half) + weight * top + 0.1
    return need_clear, clear_now, overlap, weight, tail_reach


@compiled
def gradient_into(q_line, v0, weighted_ref, out):
    """The tracking cost's gradient ``[g_x, g_y]``, ``g_d = 2 (q_line v0_d - weighted_ref[:, d])``,
    into ``out`` ``(2 n,)``: the NumPy expression's operations in its order, without its temporaries
    (:meth:`~nodnav.control.mpc_problem.MPCProblem.gradient`; the product ``W ref`` stays NumPy's)."""
    n = q_line.shape[0]
    for d in range(2):
        for i in range(n):
            out[d * n + i] = 2.0 * (q_line[i] * v0[d] - weighted_ref[i, d])


@compiled
def step_rows(lin, cold, need, keep_arrangement, x_now, away, dist_now, contact, delta_sq, far, vel, p0, v0,
              static_lower, tail_weight, tail_reach, box_low, box_high, boxes, pieces, eps_end, group_point, group_wv,
              term_offset, dyn_phi, dyn_line, last_interval, tail_phi, tail_line, tol, rows, lower):
    """Every row's lower bound into ``lower`` and the dynamic rows into ``rows``: the static
    bounds, :func:`separation_rows`, then the braking tail's :func:`~nodnav.control.braking.tail_rows`
    (linearised about ``lin``'s last end with its last interval's velocity; ``-inf`` with no tail).
    The problem's own arrays come last, from ``boxes`` to ``rows``
    (:attr:`~nodnav.control.mpc_problem.MPCProblem.row_constants`)."""
    n_static = static_lower.shape[0]
    n_walls = boxes.shape[0] + pieces.shape[0]
    lower[:n_static] = static_lower
    separation_rows(lin, x_now, boxes, pieces, n_walls, p0, v0, contact, need, cold, keep_arrangement, eps_end,
                    delta_sq, group_point, group_wv, term_offset, vel, far, away, dyn_phi, dyn_line, rows, lower,
                    n_static)
    i0 = n_static + dyn_phi.shape[0]
    if tail_weight <= 0.0:
        lower[i0:] = -np.inf
        return
    n = lin.shape[0]
    lin_v = (lin[n - 1] - lin[n - 2]) / last_interval if n > 1 else v0
    tail_rows(lin[n - 1], lin_v, tail_weight, p0, v0, x_now[:n_walls, x_now.shape[1] - 1], away[:n_walls],
              dist_now[:n_walls], need[:n_walls], tail_reach, boxes, pieces, box_low, box_high, tail_phi, tail_line,
              tol, cold, rows, lower, i0)


@compiled
def tracking_rows(q_line, weighted_ref, gradient, lin, cold, need, keep_arrangement, x_now, away, dist_now, contact,
                  delta_sq, far, vel, p0, v0, static_lower, tail_weight, tail_reach, box_low, box_high, boxes, pieces,
                  eps_end, group_point, group_wv, term_offset, dyn_phi, dyn_line, last_interval, tail_phi, tail_line,
                  tol, rows, lower):
    """A step's first tracking QP in one call: :func:`gradient_into` (into ``gradient``), then
    :func:`step_rows` (the rest of the arguments, in its order)."""
    gradient_into(q_line, v0, weighted_ref, gradient)
    step_rows(lin, cold, need, keep_arrangement, x_now, away, dist_now, contact, delta_sq, far, vel, p0, v0,
              static_lower, tail_weight, tail_reach, box_low, box_high, boxes, pieces, eps_end, group_point, group_wv,
              term_offset, dyn_phi, dyn_line, last_interval, tail_phi, tail_line, tol, rows, lower)


@compiled
def plan_check(values, n_points, n_speed, boxes, pieces, bounds, preds, need_others, tail_end, tail_decel):
    """:func:`plan_extremes`, the largest shortfall from ``need_others`` of the closest distances
    and its first index (``-inf, -1`` without others), and the clearance of the plan's straight
    braking tail from ``tail_end`` (position, velocity at the horizon) when ``tail_decel > 0``
    (``inf`` otherwise)."""
    clear, closest, fastest, hardest = plan_extremes(values, n_points, n_speed, boxes, pieces, bounds, preds)
    short, worst = -np.inf, -1
    for j in range(closest.shape[0]):
        s = need_others[j] - closest[j]
        if s > short:
            short, worst = s, j
    tail = np.inf
    if tail_decel > 0.0:
        tail = _tail_clearance_kernel(tail_end[0], tail_end[1], tail_decel, boxes, pieces, bounds)
    return clear, short, worst, fastest, hardest, tail
