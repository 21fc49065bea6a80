"""The end of the fast planner's timing in one compiled call (issue 23): the corridor and door
gates, the exact search over the bitsets, the retiming within the acceleration limit, the
motion's samples and, for a plan, its stays in the corridor and the door zones.

Each of these was a compiled kernel of its own with a Python wrapper (``close_gates``,
``earliest_arrival_bits``, ``retimed``, ``points_at``, ``RobotPlan._stays``); called one after
the other for every robot of every order, their dispatch and the NumPy steps between them cost
more than the work. :func:`_search_kernel` runs the same kernels on the same values in one call
(the tests check it bit for bit against those steps). :func:`_timing_kernel` also makes the
table of closed cells from the earlier robots' rows first (the loop of ``_timing`` over the
fixed motions, which ORed each motion's rows into the table with two NumPy calls).
"""

from __future__ import annotations

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.planning.fast_state import _stays_kernel
from nodnav.planning.retiming import _points_kernel, _retimed_kernel
from nodnav.planning.timing import _arrival_kernel
from nodnav.scenario.world import World

#: No stays wanted (an empty geometry).
NO_GEOMETRY = np.zeros(0)


def stay_geometry(world: World, door_clearance: float) -> np.ndarray:
    """The arguments of :func:`~nodnav.planning.fast_state._stays_kernel` after the samples,
    as ``RobotPlan._stays`` passes them, in one float array (``along_x`` as 1.0 or 0.0)."""
    p = world.passage
    (e0x, e0y), (e1x, e1y) = world.entrances[0], world.entrances[1]
    return np.array([1.0 if p.along_x else 0.0, p.axis[0], p.axis[1], p.normal[0], p.normal[1], p.s_start, p.s_end,
                     p.t_centre, 0.5 * p.width, float(e0x), float(e0y), float(e1x), float(e1y), float(door_clearance)],
                    dtype=float)


@_compiled
def _gate_word(n, since, w):
    """Word ``w`` of the mask of cells ``since..n-1`` (:func:`~nodnav.planning.occupancy.mask_words`)."""
    lo, hi = max(since - 64 * w, 0), min(n - 64 * w, 64)
    if lo >= hi:
        return np.uint64(0)
    top = ~np.uint64(0) if hi == 64 else (np.uint64(1) << np.uint64(hi)) - np.uint64(1)
    return top ^ ((np.uint64(1) << np.uint64(lo)) - np.uint64(1))


@_compiled
def _closed_kernel(stack, rows, t0, gates, words):
    """The table of closed cells from step ``t0`` on: the OR of the motions' rows, ``stack``
    holding ``rows[i]`` rows of motion ``i`` after those of the motions before it, each motion's
    rows from ``min(t0, rows[i] - 1)`` on and its last row repeated past its end (it stands still
    from then on). As many rows as the longest motion, the latest gate's ``allowed`` or ``t0``
    need (``max(rows[i], allowed + 1, t0 + 1) - t0``)."""
    top = t0 + 1
    for i in range(rows.shape[0]):
        top = max(top, rows[i])
    for g in range(gates.shape[0]):
        top = max(top, gates[g, 1] + 1)
    n_rows = top - t0
    closed = np.zeros((n_rows, words), dtype=np.uint64)
    first = 0
    for i in range(rows.shape[0]):
        last = rows[i] - 1
        start = min(t0, last)
        for t in range(n_rows):
            src = first + min(start + t, last)
            for w in range(words):
                closed[t, w] |= stack[src, w]
        first += rows[i]
    return closed


@_compiled
def _timing_kernel(stack, rows, n, gates, t0, ok2, wait_early, retime, cell_arc, cells_xy, v0, vmax, alpha, dt,
                   geometry):
    """:func:`_closed_kernel` of the motions' rows, then :func:`_search_kernel` of that table."""
    closed = _closed_kernel(stack, rows, t0, gates, (n + 63) // 64)
    return _search_kernel(closed, n, gates, t0, ok2, wait_early, retime, cell_arc, cells_xy, v0, vmax, alpha, dt,
                          geometry)


@_compiled
def _search_kernel(closed, n, gates, t0, ok2, wait_early, retime, cell_arc, cells_xy, v0, vmax,
                   alpha, dt, geometry):
    """The end of the fast planner's ``_timing`` and the motion in one compiled call: close the
    gates (``close_gates``), invert ``closed`` in place into the free cells (``mask_words``'
    last word), search (``_arrival_kernel``), retime when ``retime`` (``_retimed_kernel``) and
    take the motion's samples (``timed_motion``); ``gates`` ``(k, 2)`` holds ``(cell, allowed)``
    rows. With a non-empty ``geometry`` (:func:`stay_geometry`) also the plan's stays in the
    corridor and the door zones (``RobotPlan._stays``). Returns ``(outcome, step cornered at,
    cells, arc, samples, stays)``; ``arc`` is empty when the search's own timing is kept,
    ``stays`` is all -2 when not computed."""
    n_rows, words = closed.shape
    for g in range(gates.shape[0]):
        cell, allowed = gates[g, 0], gates[g, 1]
        if cell >= 0 and allowed > t0:
            for w in range(words):
                word = _gate_word(n, cell, w)
                for t in range(min(allowed - t0, n_rows)):
                    closed[t, w] |= word
    last = _gate_word(n, 0, words - 1)
    for t in range(n_rows):
        for w in range(words):
            closed[t, w] = ~closed[t, w]
        closed[t, words - 1] &= last
    status, step, cells = _arrival_kernel(closed, n, ok2, wait_early)
    arc = np.empty(0)
    samples = np.empty((0, 2))
    stays = (-2, -2, -2, -2, -2, -2)
    if status != 0:
        return status, step, cells, arc, samples, stays
    kept = True
    if retime:
        up = np.empty(cells.shape[0])
        for i in range(cells.shape[0]):
            up[i] = cell_arc[cells[i]]
        arc, clash = _retimed_kernel(up, cell_arc[cell_arc.shape[0] - 1], v0, vmax, alpha, dt, cell_arc, closed)
        if clash < 0:
            samples = _points_kernel(cells_xy, cell_arc, arc)
            kept = False
        else:
            arc = np.empty(0)
    if kept:
        samples = np.empty((cells.shape[0], 2))
        for i in range(cells.shape[0]):
            samples[i, 0], samples[i, 1] = cells_xy[cells[i], 0], cells_xy[cells[i], 1]
    if geometry.shape[0]:
        g = geometry
        stays = _stays_kernel(samples, g[0] != 0.0, g[1], g[2], g[3], g[4], g[5], g[6], g[7], g[8], g[9], g[10], g[11],
                              g[12], g[13])
    return status, step, cells, arc, samples, stays
