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
def plan_after_qp(z, p0, v0, greville, free_map, b_post, n_check_rates, n_points, n_speed, boxes, pieces, bounds,
                  preds, need_others, tail_decel, c, post):
    """:func:`plan_values` into ``c`` and ``post`` (the caller's new arrays: numba would box
    each returned array through a Python call), then :func:`~nodnav.control.mpc_rows.plan_check`
    of the plan (its check points and rates are ``post[:n_check_rates]``, then ``p(T), v(T)``)."""
    plan_values_into(z, p0, v0, greville, free_map, b_post, c, post)
    return plan_check(post[:n_check_rates], n_points, n_speed, boxes, pieces, bounds, preds, need_others,
                      post[n_check_rates:n_check_rates + 2], tail_decel)


@compiled
def plan_after_qp_braking(z, p0, v0, greville, free_map, b_post, n_check_rates, n_points, n_speed, boxes, pieces,
                          bounds, preds, need_others, tail_decel, c, post, next_row, decel, limit, i, positions,
                          velocities, decels, radii, keeps, seen, turn, convention, dt, step, max_samples, out):
    """:func:`plan_after_qp`, then the mutual braking check's usual case for the plan's next state
    (``post[next_row]``, ``post[next_row + 1]``: position and velocity), as
    :func:`~nodnav.control.mpc_braking.fallback_conflict` makes it
    (:func:`~nodnav.control.mpc_braking._straight_slack_kernel`, slacks into ``out``): the plan
    check's six values, whether straight braking is the fallback and the smallest slack's index."""
    clear, short, worst, fastest, hardest, tail = plan_after_qp(
        z, p0, v0, greville, free_map, b_post, n_check_rates, n_points, n_speed, boxes, pieces, bounds, preds,
        need_others, tail_decel, c, post)
    straight, j = _straight_slack_kernel(post[next_row], post[next_row + 1], decel, boxes, pieces, bounds, limit, i,
                                         positions, velocities, decels, radii, keeps, seen, turn, convention, dt,
                                         step, max_samples, out)
    return clear, short, worst, fastest, hardest, tail, straight, j
