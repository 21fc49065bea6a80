"""What a control step does with a QP's solution, in one compiled call: the plan's control points,
its values (one stacked map: check points, rates, ``p(T), v(T)``, the controller's outputs) and
the exact check of :meth:`~nodnav.control.mpc_problem.MPCProblem.violation`.

The two matrix products run as plain loops here, so their sums are taken in index order and not
in BLAS's (fused multiply-adds, blocking): the results agree with the NumPy expressions to the
last bits only (tests/control/test_plan_kernel.py: 1e-12 relative), which is why the step's
products moved here cost the bitwise equality of the histories (docs/performance-7-step.md).
"""

from __future__ import annotations

import numpy as np

from nodnav.compiled import compiled
from nodnav.control.mpc_braking import _straight_slack_kernel
from nodnav.control.mpc_rows import plan_check


@compiled
def plan_values(z, p0, v0, greville, free_map, b_post):
    """Control points ``c`` ``(n, 2)`` of the line ``p0 + v0 tau`` plus the deviation
    ``free_map @ [z_x, z_y]`` (``z`` stacks the coordinates), and ``b_post @ c``."""
    c = np.empty((free_map.shape[0], 2))
    post = np.empty((b_post.shape[0], 2))
    plan_values_into(z, p0, v0, greville, free_map, b_post, c, post)
    return c, post


@compiled
def plan_values_into(z, p0, v0, greville, free_map, b_post, c, post):
    """:func:`plan_values` written into ``c`` and ``post`` (every entry)."""
    n, nz = free_map.shape
    for i in range(n):
        for d in range(2):
            s = 0.0
            for k in range(nz):
                s += free_map[i, k] * z[d * nz + k]
            c[i, d] = (p0[d] + greville[i] * v0[d]) + s
    for r in range(b_post.shape[0]):
        for d in range(2):
            s = 0.0
            for i in range(n):
                s += b_post[r, i] * c[i, d]
            post[r, d] = s


@compiled
def plan_passes(clear, short, fastest, hardest, tail, need_clear, tol, separation, max_speed, max_accel):
    """Whether the exact check's values pass: every test of
    :meth:`~nodnav.control.mpc_problem.MPCProblem._verdict`, the same comparisons of the same
    numbers (``short`` is ``-inf`` without others and ``tail`` ``inf`` without a braking tail,
    :func:`~nodnav.control.mpc_rows.plan_check`, so those tests pass there as the verdict's skip them)."""
    return not (clear < need_clear - tol or (separation and short > tol) or need_clear - tail > tol
                or fastest > max_speed + tol or hardest > max_accel + tol)


@compiled
def plan_after_qp(z, p0, v0, greville, free_map, b_post, n_check_rates, n_points, n_speed, boxes, pieces, bounds,
                  next_row, dt, tol, max_speed, max_accel, preds, need_others, tail_decel, need_clear, separation, c,
                  post):
    """:func:`plan_values` into ``c`` and ``post`` (the caller's new arrays: numba would box
    each returned array through a Python call), then :func:`~nodnav.control.mpc_rows.plan_check`
    of the plan (its check points and rates are ``post[:n_check_rates]``, then ``p(T), v(T)``)
    and :func:`plan_passes` of its values. ``post`` has one row more than ``b_post``: the
    velocity command ``(post[next_row] - p0) / dt`` (the step's end, the NumPy expression's
    operations). Returns whether the plan passes, then the check's six values."""
    plan_values_into(z, p0, v0, greville, free_map, b_post, c, post)
    last = b_post.shape[0]
    for d in range(2):
        post[last, d] = (post[next_row, d] - p0[d]) / dt
    clear, short, worst, fastest, hardest, tail = plan_check(
        post[:n_check_rates], n_points, n_speed, boxes, pieces, bounds, preds, need_others,
        post[n_check_rates:n_check_rates + 2], tail_decel)
    passes = plan_passes(clear, short, fastest, hardest, tail, need_clear, tol, separation, max_speed, max_accel)
    return passes, clear, short, worst, fastest, hardest, tail


@compiled
def plan_after_qp_braking(z, p0, v0, greville, free_map, b_post, n_check_rates, n_points, n_speed, boxes, pieces,
                          bounds, next_row, dt, tol, max_speed, max_accel, preds, need_others, tail_decel, need_clear,
                          decel, limit, i, positions, velocities, decels, radii, keeps, seen, turn, convention,
                          partners_dt, step, max_samples, c, post, out):
    """:func:`plan_after_qp` (with separation), then the mutual braking check's usual case for the
    plan's next state (``post[next_row]``, ``post[next_row + 1]``: position and velocity), as
    :func:`~nodnav.control.mpc_braking.fallback_conflict` makes it
    (:func:`~nodnav.control.mpc_braking._straight_slack_kernel`, towards the partners ``i`` to
    ``partners_dt``: :class:`~nodnav.control.mutual_braking.BrakingPartners`' fields in order;
    slacks into ``out``): :func:`plan_after_qp`'s seven values, whether straight braking is the
    fallback and the smallest slack's index."""
    passes, clear, short, worst, fastest, hardest, tail = plan_after_qp(
        z, p0, v0, greville, free_map, b_post, n_check_rates, n_points, n_speed, boxes, pieces, bounds, next_row, dt,
        tol, max_speed, max_accel, preds, need_others, tail_decel, need_clear, True, c, post)
    straight, j = _straight_slack_kernel(post[next_row], post[next_row + 1], decel, boxes, pieces, bounds, limit, i,
                                         positions, velocities, decels, radii, keeps, seen, turn, convention,
                                         partners_dt, step, max_samples, out)
    return passes, clear, short, worst, fastest, hardest, tail, straight, j
