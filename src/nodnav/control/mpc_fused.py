"""A step's whole set-up before its first tracking QP in one compiled call (``controller.fused_step``).

:meth:`~nodnav.control.mpc.BSplineMPC.control` otherwise makes it in Python: the predictions at
the problem's times (``interp_all @ others``), ``static_alpha @ v0``, the compiled
:func:`~nodnav.control.mpc_rows.step_state`, the warm start (``shift @ previous``) and its
linearisation points (``b_ends @ warm``, or ``interp_ends @ ref`` cold), ``ref_weights @
ref_local`` and the compiled :func:`~nodnav.control.mpc_rows.tracking_rows`: two compiled calls of
some forty arguments each, six small BLAS products and their temporaries. Here the products are
plain loops (:func:`product_into`) and the two kernels are called from within: one dispatch.

The loops sum in index order; BLAS may use fused multiply-adds and another order, so each product
agrees with NumPy's to a few units in the last place of the sum of the terms' magnitudes (a sum of
``k`` products is exact to ``k`` roundings, ``k <= 9`` here), and the quantities derived from them
(distances, square roots, minima) to about as many of their own scale. Whatever differs is that
rounding: every constraint and check is the same, computed from values a few ulps apart, and the
exact check of each plan (tolerance ``check_tolerance``, 1e-4 m) is unchanged.
"""

from __future__ import annotations

import math

import numpy as np

from nodnav.compiled import compiled
from nodnav.control.mpc_rows import step_state, tracking_rows
from nodnav.control.mutual_braking import BrakingPartners, _bound_kernel


def no_partners() -> BrakingPartners:
    """No braking partners, as :func:`step_setup`'s arguments (robot -1: no bound made). Its arrays
    are writable, as a request's are, so that the kernel has no specialisation for read-only ones."""
    return BrakingPartners(-1, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool),
                           np.zeros(0, dtype=bool), 0, 0, 0.1)


@compiled
def product_into(a, b, out):
    """``out[i, d] = sum_k a[i, k] b[k, d]`` (``a @ b`` for ``b`` ``(k, 2)``), the sum in index order."""
    for i in range(a.shape[0]):
        for d in range(b.shape[1]):
            s = 0.0
            for k in range(a.shape[1]):
                s += a[i, k] * b[k, d]
            out[i, d] = s


def sparse_rows(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``a``'s non-zero entries row by row, in column order (compressed sparse rows: each row's
    start in the others, their columns and values), for :func:`sparse_product_into`."""
    rows, cols = np.nonzero(a)  # row-major: each row's columns in increasing order
    starts = np.searchsorted(rows, np.arange(a.shape[0] + 1))
    return starts, cols, np.ascontiguousarray(a[rows, cols])


@compiled
def sparse_product_into(starts, cols, values, b, out):
    """:func:`product_into` of the matrix :func:`sparse_rows` made, over its non-zero entries only:
    the same sums bit for bit (the terms left out are exact zeros, ``b`` being finite)."""
    for i in range(starts.shape[0] - 1):
        for d in range(b.shape[1]):
            s = 0.0
            for n in range(starts[i], starts[i + 1]):
                s += values[n] * b[cols[n], d]
            out[i, d] = s


def scratch_space(shapes: tuple[tuple[int, ...], ...]) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """One float64 buffer holding arrays of the given ``shapes`` one after another: the buffer, each
    array's start in it (and the end: ``len(shapes) + 1`` entries) and the arrays (C-contiguous
    views). A compiled call takes the buffer and the starts as two arguments, not one per array
    (numba's dispatch costs about 80 ns per array argument); :func:`scratch_arrays` reads them back."""
    sizes = [math.prod(shape) for shape in shapes]
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    buffer = np.empty(int(starts[-1]))
    return buffer, starts, [buffer[a:b].reshape(shape) for a, b, shape in zip(starts[:-1], starts[1:], shapes)]


def scratch_shapes(n_groups: int, n_end: int, n_others: int, n_pred: int, n_static: int, n_samples: int, n_free: int,
                   n_rows: int) -> tuple[tuple[int, ...], ...]:
    """The shapes of a step's scratch space, in :func:`scratch_arrays`' order: ``step_state``'s
    per-group state but ``far`` (boolean), then the fused set-up's outputs (``n_pred``: the
    predictions' times, ``n_free``: the QP's variables)."""
    g = n_groups
    return ((g, n_end, 2), (g, 2), (g,), (g,), (g, n_end), (g,), (g,), (4,), (4,), (2,), (2,),
            (n_others, n_pred, 2), (n_static,), (n_samples, 2), (n_end, 2), (n_free,), (n_rows,))


@compiled
def scratch_arrays(buffer, starts, n_others, n_pred, n_samples, n_end):
    """The arrays :func:`scratch_space` laid out with :func:`scratch_shapes` (views of ``buffer``; the
    number of groups is ``dist_now``'s length): x_now, away, dist_now, need, delta_sq, full, contact,
    gap, need_box, box_low, box_high, then pred, static, ref_local, lin, gradient, lower."""
    o = starts
    g = o[3] - o[2]
    return (buffer[o[0]:o[1]].reshape((g, n_end, 2)), buffer[o[1]:o[2]].reshape((g, 2)), buffer[o[2]:o[3]],
            buffer[o[3]:o[4]], buffer[o[4]:o[5]].reshape((g, n_end)), buffer[o[5]:o[6]], buffer[o[6]:o[7]],
            buffer[o[7]:o[8]], buffer[o[8]:o[9]], buffer[o[9]:o[10]], buffer[o[10]:o[11]],
            buffer[o[11]:o[12]].reshape((n_others, n_pred, 2)), buffer[o[12]:o[13]],
            buffer[o[13]:o[14]].reshape((n_samples, 2)), buffer[o[14]:o[15]].reshape((n_end, 2)), buffer[o[15]:o[16]],
            buffer[o[16]:o[17]])


@compiled
def step_setup(robot, positions, velocities, decels, radii, keeps, seen, turn, convention, partners_dt, others, p0,
               v0, ref, other_radii, margins, warm, mode, step, max_samples, scratch, scratch_starts, far, all_starts,
               all_cols, all_values, static_alpha, shift, ends_starts, ends_cols, ends_values, interp_ends, ref_weights,
               q_line, no_group_marked, n_end, ends, intervals, boxes, pieces, bounds, radius, max_speed, max_accel,
               eps0, reach, contact_tolerance, eps_end, static_base, static_line, tail_on, horizon, speed_horizon,
               accel_horizon, accel_horizon_sq_half, double_decel, group_point, group_wv, term_offset, dyn_phi,
               dyn_line, last_interval, tail_phi, tail_line, tol, rows):
    """A step's set-up up to its first tracking QP: the predictions ``interp_all @ others[j]`` into
    ``pred`` ``(m, P, 2)``, :func:`~nodnav.control.mpc_rows.step_state` (with ``static_alpha @ v0``
    and the speed ``|v0|``), the linearisation points into ``lin`` ``(N, 2)`` (``mode`` 0, cold:
    ``interp_ends @ ref``; 1: ``b_ends @ (shift @ warm)``, the previous plan moved on a step; 2:
    ``b_ends @ warm``) and :func:`~nodnav.control.mpc_rows.tracking_rows` (``ref_weights @
    ref_local``; the gradient into ``gradient``, the bounds into ``lower``, the rows into ``rows``).
    The products are loops (:func:`product_into`; the interpolation ``interp_all`` and the basis
    ``b_ends``, two to four entries a row, as :func:`sparse_rows`). From ``robot`` to ``partners_dt``:
    the braking partners (:class:`~nodnav.control.mutual_braking.BrakingPartners`' fields), whose
    :func:`~nodnav.control.mutual_braking.passing_bound` (the same kernel, ``inf`` where ``robot < 0``:
    no partners) comes first in the returned values, then ``step_state``'s five. Arguments from
    ``step`` on are the problem's (:attr:`~nodnav.control.mpc_problem.MPCProblem.fused_constants`):
    the bound's sampling, the step's scratch space (the per-group state, then the outputs
    :attr:`~nodnav.control.mpc_problem.MPCProblem.fused_outputs`: views of one buffer, read back by
    :func:`scratch_arrays`), then what the products and kernels read."""
    (x_now, away, dist_now, need, delta_sq, full, contact, gap, need_box, box_low, box_high, pred, static, ref_local,
     lin, gradient, lower) = scratch_arrays(scratch, scratch_starts, others.shape[0], all_starts.shape[0] - 1,
                                            ref.shape[0], n_end)
    for j in range(others.shape[0]):
        sparse_product_into(all_starts, all_cols, all_values, others[j], pred[j])
    alpha_v0 = np.empty(static_alpha.shape[0])
    for r in range(static_alpha.shape[0]):
        alpha_v0[r] = static_alpha[r, 0] * v0[0] + static_alpha[r, 1] * v0[1]
    need_clear, clear_now, overlap, weight, tail_reach = step_state(
        pred, p0, math.hypot(v0[0], v0[1]), other_radii, margins, ref, ref_local, alpha_v0, static, n_end, ends,
        intervals, boxes, pieces, bounds, radius, max_speed, max_accel, eps0, reach, contact_tolerance, eps_end,
        static_base, static_line, tail_on, horizon, speed_horizon, accel_horizon, accel_horizon_sq_half, double_decel,
        x_now, away, dist_now, need, delta_sq, far, full, contact, gap, need_box, box_low, box_high)
    if mode == 0:
        product_into(interp_ends, ref, lin)
    elif mode == 1:
        moved = np.empty((shift.shape[0], 2))
        product_into(shift, warm, moved)
        sparse_product_into(ends_starts, ends_cols, ends_values, moved, lin)
    else:
        sparse_product_into(ends_starts, ends_cols, ends_values, warm, lin)
    weighted = np.empty((ref_weights.shape[0], 2))
    product_into(ref_weights, ref_local, weighted)
    tracking_rows(q_line, weighted, gradient, lin, mode == 0, need, no_group_marked, x_now, away, dist_now, contact,
                  delta_sq, far, pred[:, pred.shape[1] - 1], p0, v0, static, weight, tail_reach, box_low, box_high,
                  boxes, pieces, eps_end, group_point, group_wv, term_offset, dyn_phi, dyn_line, last_interval,
                  tail_phi, tail_line, tol, rows, lower)
    bound = np.inf
    if robot >= 0:
        bound = _bound_kernel(robot, p0, v0, positions, velocities, decels, radii, keeps, seen, turn, convention,
                              partners_dt, step, max_samples)[0]
    return bound, need_clear, clear_now, overlap, weight, tail_reach


def fused_setup(prob, p0, v0, ref, others, other_radii, margins, warm, mode, partners: BrakingPartners):
    """:func:`step_setup` on the problem ``prob`` (an :class:`~nodnav.control.mpc_problem.MPCProblem`),
    into the problem's :attr:`~nodnav.control.mpc_problem.MPCProblem.fused_outputs` (scratch space
    like its rows and per-group state, written again at the next step): returns the kernel's six
    values. One tuple of the problem's arguments, made once: the call builds no other."""
    return step_setup(*partners, others, p0, v0, ref, other_radii, margins, warm, mode, *prob.fused_constants)
