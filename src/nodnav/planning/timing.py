"""Velocity tuning along a line of cells: the earliest arrival that keeps clear of every known
motion, by an exact search over bitsets (compiled with numba).

The robot starts in cell 0 and, per time step, waits, advances one cell or two (full speed, where
the chord between the cells keeps clear of the walls); ``free[t]`` (from
:mod:`nodnav.planning.occupancy`) says which cells it may occupy at step ``t``. Among the equally
fast timings it waits early (legible) or late. The planner then retimes the result within the
robot's acceleration limit (:mod:`nodnav.planning.retiming`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.geometry import TOL
from nodnav.planning.polylines import arc_length_grid


@dataclass(frozen=True)
class Timing:
    """The timing of one robot along its cells: which cell it occupies at every step."""

    success: bool
    """Whether the robot reaches its last cell and can stay there."""
    reason: str
    """Empty on success; otherwise why not."""
    cells: np.ndarray
    """Cell index at steps ``0..arrival`` (int); just ``[0]`` on failure."""
    trapped_at: int = -1
    """On failure: the step at which no cell was left (the robot is cornered), else -1."""
    arc: np.ndarray | None = None
    """Arc length along the path at steps ``0..arrival`` (m) when the cells were retimed within
    the acceleration limit (:mod:`nodnav.planning.retiming`); None: the cells' own arc lengths."""
    samples: np.ndarray | None = None
    """The positions at steps ``0..arrival`` ``(T, 2)`` when the search computed them with the
    timing (the fast planner's fused call), else None."""
    stays: tuple | None = None
    """The stays of those positions in the corridor and the door zones (``RobotPlan._stays``)
    when computed with them, else None."""

    @property
    def arrival(self) -> int:
        """Step at which the robot reaches its last cell."""
        return (len(self.cells) if self.arc is None else len(self.arc)) - 1


def earliest_arrival(free: np.ndarray, ok2: np.ndarray, wait_early: bool = True) -> Timing:
    """:func:`earliest_arrival_bits` for a boolean array ``free[t, c]`` ``(n_rows, n_cells)``."""
    free = np.asarray(free, dtype=bool)
    n_rows, n_cells = free.shape
    words = np.zeros((n_rows, 8 * ((n_cells + 63) // 64)), dtype=np.uint8)
    packed = np.packbits(free, axis=1, bitorder="little")
    words[:, :packed.shape[1]] = packed
    return earliest_arrival_bits(words.view("<u8").astype(np.uint64), n_cells, ok2, wait_early)


def earliest_arrival_bits(free: np.ndarray, n_cells: int, ok2: np.ndarray, wait_early: bool = True) -> Timing:
    """Earliest arrival along a line of cells, moving 0, 1 or 2 cells per step (exact search).

    ``free[t]`` ``(n_rows, W)`` is the bitset (64-bit words, little-endian) of the cells that
    may be occupied at step ``t``, no bit at or past ``n_cells``; steps past the last row
    repeat it (everything stands still by then). ``ok2[c]`` allows the two-cell move
    ``c -> c+2``. The robot starts in cell 0 at step 0 whatever ``free[0]`` says (it is there),
    and arrives at the first step at which the last cell is reachable and stays free from then
    on. The reachable sets are bitsets, ``reach[t+1] = (reach[t] | reach[t] << 1 | (reach[t] &
    ok2) << 2) & free[t+1]``. Every cell sequence consistent with that arrival is equally fast;
    backtracking picks, at every step, the nearest such cell with ``wait_early`` (the robot
    holds back first and then drives through at full speed) and the farthest one otherwise (it
    drives up and waits late). Waiting early is the default because it makes a yielding robot's
    intention visible at once: in eq. (4) its plans for "I go first" and "I yield" then differ
    from the first window on, instead of only once it reaches the corridor. When driving at full
    speed meets no obstacle, that is the answer and the search is skipped.
    """
    ok2 = np.ascontiguousarray(np.asarray(ok2, dtype=bool)[:n_cells])
    status, step, cells = _arrival_kernel(np.ascontiguousarray(free, dtype=np.uint64), n_cells, ok2, bool(wait_early))
    return timing_of(status, step, cells)


def timing_of(status: int, step: int, cells: np.ndarray, arc: np.ndarray | None = None,
              samples: np.ndarray | None = None, stays: tuple | None = None) -> Timing:
    """The :class:`Timing` of an outcome of :func:`_arrival_kernel`."""
    if status == _ARRIVED:
        return Timing(True, "", cells, -1, arc, samples, stays)
    if status == _PARKED_ON_GOAL:
        return Timing(False, "its destination stays blocked by a robot parked next to it", np.zeros(1, dtype=int))
    if status == _CORNERED:
        return Timing(False, f"cornered at step {step}: every cell it can reach is too close to an earlier robot",
                      np.zeros(1, dtype=int), trapped_at=step)
    return Timing(False, "cannot reach its destination: its path stays blocked after every earlier robot has parked",
                  np.zeros(1, dtype=int))


#: Outcomes of :func:`_arrival_kernel`.
_ARRIVED, _PARKED_ON_GOAL, _CORNERED, _BLOCKED = 0, 1, 2, 3
#: The outcome of a search that arrived (:func:`timing_of` makes a successful :class:`Timing` of it).
ARRIVED = _ARRIVED


@_compiled
def _has(row, c):
    """Whether bit ``c`` is set in the bitset ``row``."""
    return (row[c // 64] >> np.uint64(c % 64)) & np.uint64(1) != 0


@_compiled
def _arrival_kernel(free, n, ok2, wait_early):
    """The search of :func:`earliest_arrival_bits`: ``(outcome, step cornered at, cells)``."""
    n_rows, words = free.shape
    none = np.zeros(0, dtype=np.int64)
    goal = n - 1
    if not _has(free[n_rows - 1], goal):
        return _PARKED_ON_GOAL, -1, none
    earliest = 0
    for t in range(n_rows - 1, 0, -1):
        if not _has(free[t], goal):
            earliest = t + 1
            break
    # Full speed all the way: two cells a step wherever allowed.
    dash = np.empty(n, dtype=np.int64)
    dash[0] = 0
    m, c = 1, 0
    while c < n - 1:
        c += 2 if c + 2 < n and ok2[c] else 1
        dash[m] = c
        m += 1
    if m > earliest:
        clear = True
        for t in range(1, m):
            if not _has(free[min(t, n_rows - 1)], dash[t]):
                clear = False
                break
        if clear:
            return _ARRIVED, -1, dash[:m].copy()
    step2 = np.zeros(words, dtype=np.uint64)
    for c in range(n):
        if ok2[c]:
            step2[c // 64] |= np.uint64(1) << np.uint64(c % 64)
    # After the last row nothing changes, so the reachable set must grow at every step: at
    # most n more steps.
    reach = np.zeros((n_rows + n + 1, words), dtype=np.uint64)
    reach[0, 0] = 1
    t = 0
    one, top, top2 = np.uint64(1), np.uint64(63), np.uint64(62)
    while not (_has(reach[t], goal) and t >= earliest):
        row = free[min(t + 1, n_rows - 1)]
        carry1 = carry2 = np.uint64(0)
        same = empty = True
        for w in range(words):
            a = reach[t, w]
            b = a & step2[w]
            nxt = (a | (a << one) | carry1 | (b << np.uint64(2)) | carry2) & row[w]
            carry1, carry2 = a >> top, b >> top2
            reach[t + 1, w] = nxt
            same &= nxt == a
            empty &= nxt == 0
        t += 1
        if empty:
            return _CORNERED, t, none
        if same and t >= n_rows:
            return _BLOCKED, -1, none
    cells = np.empty(t + 1, dtype=np.int64)
    c = n - 1
    for s in range(t, 0, -1):
        cells[s] = c
        prev = reach[s - 1]
        if wait_early:
            if c >= 2 and ok2[c - 2] and _has(prev, c - 2):
                c -= 2
            elif c >= 1 and _has(prev, c - 1):
                c -= 1
        elif not _has(prev, c):
            c = c - 1 if _has(prev, c - 1) else c - 2
    cells[0] = c
    return _ARRIVED, -1, cells


def dash_clashes(path: np.ndarray, step: float, others: np.ndarray, required: np.ndarray) -> bool:
    """Whether driving along ``path`` at ``step`` per step and then standing at its end comes
    closer than ``required`` to robots at ``others[t]`` ``(T, m, 2)`` at some step after the first."""
    grid = arc_length_grid(path, step).points
    limit = np.asarray(required, dtype=float).reshape(-1) - TOL
    return bool(_dash_kernel(grid, np.ascontiguousarray(others, dtype=float), limit))


@_compiled
def _dash_kernel(grid, others, limit):
    """The loops of :func:`dash_clashes`: the robot is at ``grid[t]`` (at its end once past it)."""
    for t in range(1, others.shape[0]):
        at = grid[min(t, grid.shape[0] - 1)]
        for i in range(others.shape[1]):
            dx, dy = others[t, i, 0] - at[0], others[t, i, 1] - at[1]
            if math.sqrt(dx * dx + dy * dy) < limit[i]:
                return True
    return False
