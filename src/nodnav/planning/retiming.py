"""Timing a path within a robot's speed *and* acceleration limits (issue 18, item 2).

Both planners first time paths by speed alone: the fast planner's exact search
(:mod:`nodnav.planning.timing`) moves 0, 1 or 2 cells a step, i.e. jumps between rest, half and
full speed, and PRM* interpolates every joint segment at full speed. A robot that accelerates
slowly cannot follow that: it overshoots where the plan stops abruptly and lags where it starts.

The profile here is in discrete time, as the planned trajectories are: the robot moves at a
constant speed ``v_t`` along its path during step ``t`` (linear interpolation between samples,
as :class:`~nodnav.planning.base.JointTrajectory`), with

    0 <= v_t <= v_max,   |v_{t+1} - v_t| <= a dt,   v_{-1} = v0 (its speed now),

and it never runs ahead of an upper bound ``upper[t]`` on its arc length at every step (the
position the speed-only timing reserved for it; for PRM* the segment's end). It ends at rest at
the end of the path. :func:`feasible_profile` picks, step after step, the largest speed from
which braking at the limit keeps the robot behind the bound at every later step; braking at the
limit gives the least position at every later step, so a state that fails that test cannot stay
behind the bound at all, and one that passes can. Where the robot is already too fast to stay
behind (it moves now and the bound says stop at once), it brakes at the limit and the profile
says it ran ahead (``ahead``).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.planning.occupancy import search_from

if TYPE_CHECKING:
    from nodnav.planning.timing import Timing

#: Arc length below which the robot counts as at its bound or goal (m).
EPS = 1e-9


def feasible_profile(upper: np.ndarray, goal: float, v0: float, vmax: float, accel: float,
                     dt: float) -> tuple[np.ndarray, bool]:
    """Arc length at steps ``0, 1, ...`` until the robot rests at ``goal``, and whether it ever
    ran ahead of ``upper``.

    ``upper`` ``(T,)`` is non-decreasing, ``upper[0] >= 0``, its last value ``goal``; steps past
    its end repeat the last value. The robot starts at arc length 0 moving at ``v0`` along the
    path (clipped to ``[0, vmax]``), at most ``vmax`` (m/s), changing speed by at most ``accel dt``
    a step (``accel`` m/s^2). With ``upper`` at ``goal`` throughout, the result is the fastest
    rest-to-rest profile in whole steps (a discrete trapezoid, or a triangle on short paths).
    """
    up = np.ascontiguousarray(np.asarray(upper, dtype=float).reshape(-1))
    if len(up) == 0:
        up = np.array([float(goal)])
    arc, ahead = _profile_kernel(up, float(goal), float(v0), float(vmax), float(accel) * float(dt), float(dt))
    return arc, bool(ahead)


@_compiled
def _largest_speed(s, t, up, goal, alpha, dt, hi):
    """The largest speed ``v <= hi`` for step ``t`` (from arc ``s``) from which braking at
    ``alpha`` a step keeps the robot at or behind ``up`` at every later step; -1 if none >= 0.

    Braking from ``v``, the robot is at ``s + dt sum_{j<=k} max(v - j alpha, 0)`` after step
    ``t + k``; that sum is ``dt ((m + 1) v - alpha m (m + 1) / 2)`` with ``m + 1`` positive terms,
    so each bound inverts in closed form."""
    n = up.shape[0]
    best = hi
    k_max = int(math.ceil(hi / alpha)) + 1
    for k in range(k_max + 1):
        j = t + 1 + k
        bound = up[j] if j < n else goal
        g = bound - s
        if g < -EPS:
            return -1.0
        g = max(g, 0.0)
        # Largest m <= k with F_k(m alpha) = dt alpha m (m + 1) / 2 <= g. Where the root's
        # argument is at least (2k + 1)^2 the floor is at least k (a correctly rounded root and
        # the steps after it are monotonic, and exact at that square), so m is k without it.
        x = 1.0 + 8.0 * g / (dt * alpha)
        edge = 2.0 * k + 1.0
        if x >= edge * edge:
            m = k
        else:
            m = int(math.floor((-1.0 + math.sqrt(x)) / 2.0))
            m = min(max(m, 0), k)
        v = g / (dt * (m + 1)) + alpha * m / 2.0
        if v < best:
            best = v
        if best <= k * alpha:  # braking from best stops within k steps: later bounds are looser
            break
    return best


@_compiled
def _profile_kernel(up, goal, v0, vmax, alpha, dt):
    """The forward pass of :func:`feasible_profile`."""
    cap = up.shape[0] + int(math.ceil(goal / max(alpha * dt, 1e-12) + 2.0 * vmax / alpha)) + 8
    arc = np.empty(cap + 1)
    arc[0] = 0.0
    s, v = 0.0, min(max(v0, 0.0), vmax)
    ahead = False
    t = 0
    while t < cap:
        if goal - s <= EPS and v <= alpha + EPS:
            break
        lo, hi = max(0.0, v - alpha), min(vmax, v + alpha)
        best = _largest_speed(s, t, up, goal, alpha, dt, hi)
        if best < lo:
            ahead = ahead or best < lo - 1e-9  # rounding aside
            best = lo
        v = best
        s = min(s + v * dt, goal)
        t += 1
        arc[t] = s
    return arc[:t + 1].copy(), ahead


def profile_clear(arc: np.ndarray, cell_arc: np.ndarray, free: np.ndarray) -> int:
    """The first step at which arc length ``arc[t]`` lies on a cell that ``free[t]`` (bitsets
    ``(n_rows, W)`` as :func:`~nodnav.planning.timing.earliest_arrival_bits` reads them; rows
    past the last repeat it) does not allow, or -1. Between two cells, both must be allowed:
    the robot is within half a cell of one of them, as the search's own moves are."""
    return int(_clear_kernel(np.ascontiguousarray(arc, dtype=float), np.ascontiguousarray(cell_arc, dtype=float),
                             np.ascontiguousarray(free, dtype=np.uint64)))


@_compiled
def _last_at_or_below(xp, x, i):
    """``np.searchsorted(xp, x, side="right") - 1`` for sorted ``xp``: the last index whose value
    is at most ``x`` (-1 if none), searched from ``i``, the answer for an earlier ``x`` (-1 to
    start; :func:`~nodnav.planning.occupancy.search_from`). A profile's arc lengths never
    decrease, so the answer is mostly a cell or two on."""
    return search_from(xp, x, i + 1, True) - 1


@_compiled
def _clear_kernel(arc, cell_arc, free):
    n_rows, n = free.shape[0], cell_arc.shape[0]
    last = arc.shape[0] - 1
    at = -1  # the last cell at or below the arc length of the step before (see _last_at_or_below)
    # After its last step the robot stands at its last arc length: check until the rows end too.
    for t in range(1, max(last, n_rows - 1) + 1):
        s = arc[min(t, last)]
        row = free[min(t, n_rows - 1)]
        at = _last_at_or_below(cell_arc, s + EPS, at)
        c = min(max(at, 0), n - 1)
        if (row[c // 64] >> np.uint64(c % 64)) & np.uint64(1) == 0:
            return t
        if c + 1 < n and s > cell_arc[c] + EPS:
            if (row[(c + 1) // 64] >> np.uint64((c + 1) % 64)) & np.uint64(1) == 0:
                return t
    return -1


def points_at(cells: np.ndarray, cell_arc: np.ndarray, arc: np.ndarray) -> np.ndarray:
    """Points at arc lengths ``arc`` along a path given by its cells (every vertex is a cell, so
    interpolating between cells stays on the path)."""
    a = np.asarray(arc, dtype=float)
    out = np.empty(a.shape + (2,))
    out[..., 0] = np.interp(a, cell_arc, cells[:, 0])
    out[..., 1] = np.interp(a, cell_arc, cells[:, 1])
    return out


def retimed(timing: "Timing", cell_arc: np.ndarray, free: np.ndarray, v0: float, vmax: float, accel: float,
            dt: float) -> "Timing":
    """The search's ``timing`` (cells moving 0, 1 or 2 a step) retimed within the acceleration
    limit, never ahead of the cells it reserved (:func:`feasible_profile`), from speed ``v0``.

    The retimed motion is checked against the same bitsets ``free`` the search used
    (:func:`profile_clear`): being behind a reservation is not always clear (a robot that
    crossed another's way just before it may be caught there), and a robot moving too fast to
    stop where the search waits runs ahead. Where the check fails, the search's own timing is
    kept (the plan stays clear of every earlier robot; the controller copes with the jump).
    """
    upper = cell_arc[timing.cells]
    if not len(upper):
        upper = np.array([float(cell_arc[-1])])
    arc, clash = _retimed_kernel(np.ascontiguousarray(upper, dtype=float), float(cell_arc[-1]), float(v0), float(vmax),
                                 float(accel) * float(dt), float(dt), np.ascontiguousarray(cell_arc, dtype=float),
                                 np.ascontiguousarray(free, dtype=np.uint64))
    if clash >= 0:
        return timing
    return replace(timing, arc=arc)


@_compiled
def _retimed_kernel(up, goal, v0, vmax, alpha, dt, cell_arc, free):
    """:func:`feasible_profile` then :func:`profile_clear` in one compiled call (the planner
    retimes every robot it plans): the profile, and the first step it is not clear at or -1."""
    arc, _ = _profile_kernel(up, goal, v0, vmax, alpha, dt)
    return arc, _clear_kernel(arc, cell_arc, free)


def interp_twin(x: np.ndarray, xp: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """``np.interp(x, xp, fp)`` for non-decreasing ``xp`` and finite values, compiled: the same
    operations as NumPy's (``tests/planning/test_timing_fused.py`` checks it bit for bit)."""
    out = np.empty(len(x))
    _interp_kernel(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(xp, dtype=float),
                   np.ascontiguousarray(fp, dtype=float), out)
    return out


@_compiled
def _interp_kernel(x, xp, fp, out):
    """NumPy's ``arr_interp`` (numpy/_core/src/multiarray/compiled_base.c): the left or right
    value beyond the ends, ``fp[j]`` at a knot or on the last one, else ``slope * (x - xp[j]) +
    fp[j]`` with ``slope = (fp[j+1] - fp[j]) / (xp[j+1] - xp[j])`` and ``j`` the last knot at or
    below ``x`` (NumPy's guessed binary search finds the same ``j`` on sorted knots)."""
    n = xp.shape[0]
    for i in range(x.shape[0]):
        v = x[i]
        if n == 1:
            out[i] = fp[0]
            continue
        if v > xp[n - 1]:
            out[i] = fp[n - 1]
            continue
        if v < xp[0]:
            out[i] = fp[0]
            continue
        j = np.searchsorted(xp, v, side="right") - 1
        if j == n - 1 or xp[j] == v:
            out[i] = fp[j]
            continue
        slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
        r = slope * (v - xp[j]) + fp[j]
        if math.isnan(r):  # NumPy's fallback: from the other end, then the common value
            r = slope * (v - xp[j + 1]) + fp[j + 1]
            if math.isnan(r) and fp[j] == fp[j + 1]:
                r = fp[j]
        out[i] = r


@_compiled
def _points_kernel(cells, cell_arc, arc):
    """:func:`points_at` in one call: both coordinates as :func:`_interp_kernel` computes them
    (:func:`_points_plain` is that twice), with the knot of each query found once for both and
    by walking on from the query before (:func:`_last_at_or_below`: the same knot)."""
    m, n = arc.shape[0], cell_arc.shape[0]
    out = np.empty((m, 2))
    j = -1
    for i in range(m):
        v = arc[i]
        if n == 1:
            out[i, 0], out[i, 1] = cells[0, 0], cells[0, 1]
            continue
        if v > cell_arc[n - 1]:
            out[i, 0], out[i, 1] = cells[n - 1, 0], cells[n - 1, 1]
            continue
        if v < cell_arc[0]:
            out[i, 0], out[i, 1] = cells[0, 0], cells[0, 1]
            continue
        j = _last_at_or_below(cell_arc, v, j)
        if j == n - 1 or cell_arc[j] == v:
            out[i, 0], out[i, 1] = cells[j, 0], cells[j, 1]
            continue
        for d in range(2):
            slope = (cells[j + 1, d] - cells[j, d]) / (cell_arc[j + 1] - cell_arc[j])
            r = slope * (v - cell_arc[j]) + cells[j, d]
            if math.isnan(r):  # NumPy's fallback: from the other end, then the common value
                r = slope * (v - cell_arc[j + 1]) + cells[j + 1, d]
                if math.isnan(r) and cells[j, d] == cells[j + 1, d]:
                    r = cells[j, d]
            out[i, d] = r
    return out


def _points_plain(cells: np.ndarray, cell_arc: np.ndarray, arc: np.ndarray) -> np.ndarray:
    """:func:`_points_kernel` as it was, each coordinate by :func:`interp_twin` (the reference the
    tests compare it with, and with :func:`points_at`)."""
    return np.stack([interp_twin(arc, cell_arc, cells[:, 0]), interp_twin(arc, cell_arc, cells[:, 1])], axis=1)
