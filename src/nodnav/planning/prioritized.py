"""The fast planner: prioritised planning in the passing order with path-velocity decomposition.

The paper plans the joint path of all robots with PRM* in the joint space (appendix); any
planner that returns collision-free joint paths respecting a passing order serves the framework
(Section IV-A-2: "the specific choice of the planner has minimal impact"). This one needs no
precomputation and is fast enough for the closed loop to ask for every strategy of every robot
at every decision step: a few milliseconds for four robots from a new state, and much less for
the further orders asked from the same state (see "Reuse" below).

How a query is answered
-----------------------
1. Orders ruled out by history are repaired with :func:`~nodnav.planning.base.feasible_order`.
   Robots standing inside the corridor count as entered even when the request does not list
   them (appended in the requested order), since their entry has physically happened.
2. Robots are planned one by one in the (planned) passing order; each one moves along its own
   geometric path and chooses only its timing, treating the robots planned before it as moving
   obstacles (path-velocity decomposition).
3. Geometric path: the shortest collision-free polyline (:class:`VisibilityGraph`) around the
   walls, around where the robots after it in the order stand (so that every later robot can
   always wait there), and around the destinations of the robots before it (where they will
   park for good). A robot that starts closer than required to one of these may move away but
   not closer (:func:`~nodnav.planning.visibility.disc_violations`). When that is impossible the
   robot falls back to avoiding the destinations only, then the walls only; the timing step
   then decides.
4. Timing: the path is cut into cells of at most ``v_max dt / 2``; per time step the robot waits,
   advances one cell, or advances two (full speed; only where the straight chord between the
   two cells keeps clear of walls). The set of cells reachable at each step is a bitset of
   64-bit words, ``reach[t+1] = (reach[t] | reach[t] << 1 | (reach[t] & ok2) << 2) & free[t+1]``,
   which makes the search exact and fast (compiled with numba); ``free[t]`` removes every cell
   closer than the required separation to an earlier robot during ``[t, t+1]`` and every cell
   the corridor and door rules (below) close at that step. The robot arrives at the first step at which its
   destination is reachable and stays free for good. Among the equally fast timings it waits
   early (holds back, then drives through), which makes its intention legible to the others'
   eq. (4), or, with ``waiting: late``, drives up and waits late (:func:`earliest_arrival_bits`).
5. Getting out of the way. Before a robot is planned, every robot after it that stands in its
   way (its path had to ignore them) or in the door zone it will come out of (below) first
   moves to a nearby spot clear of the ways of every robot still to plan, waits there, and
   later goes on from there; the robot being planned waits until the way is free. A robot
   that is itself boxed in first has the robots in its way move (up to :data:`_CASCADE` deep),
   and one pinned where only the planned robot's own place would let it out gets that room:
   the planned robot backs off first. Finally a robot that an earlier robot's motion corners
   anyway backs out of the way when its turn comes.

Separation: :func:`separation_requirements` between every pair, relaxed to a hair below their
present distance for a pair that starts closer (:func:`relaxed_separation`): they may stay or
move apart, and the full separation holds again once the earlier robot's motion keeps it from
where the later one started for good.

Corridor rule (single file): a robot may enter the corridor only after every robot before it in
the order that uses the corridor has entered (same direction: following at a safe distance is
fine) and, for opposite directions, only after that robot has left it. Entry and exit are judged
on the samples with :meth:`World.in_corridor`, exactly as :func:`corridor_entry_order` does.

Door rule: the door zone of an entrance is the disc of radius ``door_clearance`` around it. A
crossing robot does not enter the door zone of the entrance it uses while a robot before it
that does not go its way (one coming out towards it) has not left that zone for good (or
parked in it), so that robots waiting for their turn wait clear of the door and the robot
coming out has room. Same-direction following is untouched by it.

Cost: the sum over robots of their arrival times, in seconds after the request's time.

Reuse
-----
A robot's plan depends only on the state (positions, destinations, radii, speeds), on which
robots go before it and on the set of robots after it, so a planner instance remembers, in
bounded memos, the order-independent part of each state, each robot's plan per beginning of
the order, the joint plan of each (repaired) order, each prepared geometric path, and the cells
each path has closed by each planned motion; the closed loop asks for all ``N_r!`` orders from
one state, orders that share a beginning share those plans, and orders repaired to the same one
share its joint plan (whose arrays are therefore read-only). Results do not depend on what is
remembered. Share one instance between the robots of a trial to benefit from it.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.geometry import TOL, segment_clearance, segment_point_distance
from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult, crossing_directions, feasible_order
from nodnav.planning.visibility import (
    GeometricPath,
    VisibilityGraph,
    arc_length_grid,
    disc_violations,
    polyline_point_distance,
)
from nodnav.scenario.params import FastPlannerParams as PlannerParams
from nodnav.scenario.world import World

logger = logging.getLogger(__name__)


#: Radii (m) and number of directions of the rings of candidate spots a cornered robot may back
#: out to; the largest reach a room from anywhere in a corridor of the paper's length.
_RETREAT_RADII = (0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0)
_RETREAT_ANGLES = 16
#: How many of the nearest candidate spots are tried before giving up.
_RETREAT_TRIES = 8
#: How many robots deep a robot that must get out of the way may first move others out of its way.
_CASCADE = 2
#: How many entries each of a planner's memos keeps (a four-robot state needs about a hundred).
_MEMO_SIZE = 1024
#: How far below their present distance the separation of a pair that starts too close is set
#: (m): the geometric paths keep that distance within :data:`TOL`, the timing then never fails by
#: a rounding error.
SLACK = 1e-6
#: A step beyond every horizon: "for good".
FOREVER = np.iinfo(np.int64).max // 2


# ---------------------------------------------------------------------------------------------
# Pure pieces


def separation_requirements(destinations: np.ndarray, radii: np.ndarray, max_speeds: np.ndarray, dt: float,
                            margin: float) -> np.ndarray:
    """Least centre distance kept between every pair at every sample, shape ``(n, n)`` (m).

    The appendix's validity condition is ``||p_i - p_j|| >= 2 r_robot``; the planner keeps
    ``r_i + r_j + margin``, raised where needed to ``sqrt((r_i + r_j)^2 + ((v_i + v_j) dt / 2)^2)``
    so that the condition also holds between samples: two relative positions at least ``s``
    apart whose difference is at most ``d`` are joined by a segment that stays at least
    ``sqrt(s^2 - d^2 / 4)`` from the origin. A pair whose destinations are closer than that is
    held to their distance (never below ``r_i + r_j``), so that both can park. A pair that is
    closer than this now is relaxed for a while, see :func:`relaxed_separation`. Diagonal: 0.
    """
    d = np.asarray(destinations, dtype=float).reshape(-1, 2)
    r = np.asarray(radii, dtype=float).reshape(-1)
    v = np.asarray(max_speeds, dtype=float).reshape(-1)
    contact = r[:, None] + r[None, :]
    between = np.sqrt(contact**2 + ((v[:, None] + v[None, :]) * dt / 2.0) ** 2)
    wanted = np.maximum(contact + margin, between)
    parked = np.linalg.norm(d[:, None] - d[None], axis=2)
    req = np.minimum(wanted, np.maximum(contact, parked))
    np.fill_diagonal(req, 0.0)
    return req


def relaxed_separation(required: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """The separation held between a pair that starts ``distance`` apart, closer than ``required``:
    a hair below that distance (:data:`SLACK`), so that both may stay where they are or move
    apart. It applies until the pair has grown back to ``required``; pairs already that far
    apart keep ``required``.
    """
    required = np.asarray(required, dtype=float)
    distance = np.asarray(distance, dtype=float)
    return np.where(distance < required, np.maximum(distance - SLACK, 0.0), required)


def corridor_passage(inside: np.ndarray) -> tuple[int, int]:
    """The last stay in the corridor along a sampled trajectory: ``(entry, exit)`` samples.

    ``entry`` is the first sample of the last run of samples inside, ``exit`` the first sample
    after it (``len(inside)`` if the trajectory ends inside); ``(-1, -1)`` if never inside.
    """
    entry, exit_ = _passage_kernel(np.ascontiguousarray(inside, dtype=bool))
    return int(entry), int(exit_)


@_compiled
def _passage_kernel(inside):
    """The scan of :func:`corridor_passage`: back to the last sample inside, then to the start of its run."""
    last = len(inside) - 1
    while last >= 0 and not inside[last]:
        last -= 1
    if last < 0:
        return -1, -1
    entry = last
    while entry > 0 and inside[entry - 1]:
        entry -= 1
    return entry, last + 1


def entry_cell(inside: np.ndarray) -> int:
    """The first cell at which a path enters the corridor from outside, or -1.

    A path that starts inside has already entered; only a re-entry after leaving counts.
    """
    return int(_entry_kernel(np.ascontiguousarray(inside, dtype=bool)))


@_compiled
def _entry_kernel(inside):
    """The scan of :func:`entry_cell`: past the cells inside at the start, then to the next one inside."""
    n, c = len(inside), 0
    while c < n and inside[c]:
        c += 1
    while c < n and not inside[c]:
        c += 1
    return c if c < n else -1


def polyline_segments(path: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Start points, unit directions, lengths and start arc lengths of a polyline's non-empty segments."""
    return _segments_kernel(np.ascontiguousarray(path, dtype=float).reshape(-1, 2))


@_compiled
def _segments_kernel(path):
    """The loop of :func:`polyline_segments`; the arc length runs on over empty segments (adding 0)."""
    n = max(path.shape[0] - 1, 0)
    start, unit = np.empty((n, 2)), np.empty((n, 2))
    length, arc0 = np.empty(n), np.empty(n)
    k, s = 0, 0.0
    for i in range(n):
        dx, dy = path[i + 1, 0] - path[i, 0], path[i + 1, 1] - path[i, 1]
        h = math.hypot(dx, dy)
        if h > 0:
            start[k, 0], start[k, 1] = path[i, 0], path[i, 1]
            unit[k, 0], unit[k, 1] = dx / h, dy / h
            length[k], arc0[k] = h, s
            k += 1
        s += h
    return start[:k], unit[:k], length[:k], arc0[:k]


@dataclass(frozen=True)
class Motion:
    """A robot moving along a polyline: where it is at every step; afterwards it stays there."""

    path: np.ndarray
    """The polyline ``(V, 2)`` (m)."""
    samples: np.ndarray
    """Positions at steps ``0..T-1`` ``(T, 2)``, on the polyline (m)."""
    arc: np.ndarray
    """Arc length along the polyline at each step ``(T,)``, non-decreasing (m)."""
    segments: tuple | None = field(default=None, repr=False, compare=False)
    """Start points, unit directions, lengths and start arc lengths of the non-empty segments
    (:func:`polyline_segments`; computed when not given)."""

    def __post_init__(self):
        if self.segments is None:
            object.__setattr__(self, "segments", polyline_segments(self.path))

    @property
    def last_step(self) -> int:
        """The step from which the robot stands still."""
        return len(self.samples) - 1

    @cached_property
    def sweep(self) -> tuple:
        """What :func:`conflict_intervals` needs of this motion whatever the cells: the matrix
        and offsets that give a point's coordinates along and across every segment, the
        segments' start arc lengths and lengths, and the steps whose move cuts a corner of the
        polyline, with the chords they follow."""
        q0, unit, length, s0 = self.segments
        basis, offset, step = _sweep_kernel(np.ascontiguousarray(q0), np.ascontiguousarray(unit), s0,
                                            np.ascontiguousarray(self.arc), self.last_step)
        return basis, offset, s0, length, step, self.samples[step], self.samples[step + 1]


@_compiled
def _sweep_kernel(q0, unit, s0, arc, last_step):
    """The loops of :attr:`Motion.sweep`: the frames of the segments (along ``unit``, across
    ``(-unit_y, unit_x)``) as columns of a ``(2, 2S)`` matrix with their offsets, and the steps
    ``t < last_step`` whose move from ``arc[t]`` to ``arc[t+1]`` passes a corner (strictly)."""
    n_seg = unit.shape[0]
    basis = np.empty((2, 2 * n_seg))
    offset = np.empty(2 * n_seg)
    for j in range(n_seg):
        ux, uy = unit[j, 0], unit[j, 1]
        basis[0, j], basis[1, j] = ux, uy
        basis[0, n_seg + j], basis[1, n_seg + j] = -uy, ux
        offset[j] = q0[j, 0] * ux + q0[j, 1] * uy
        offset[n_seg + j] = q0[j, 0] * -uy + q0[j, 1] * ux
    step = np.empty(max(n_seg - 1, 0), dtype=np.int64)
    k = 0
    for j in range(1, n_seg):
        t = np.searchsorted(arc, s0[j], side="left") - 1
        if 0 <= t < last_step and arc[t + 1] > s0[j]:
            step[k] = t
            k += 1
    return basis, offset, step[:k]


def conflict_intervals(cells: np.ndarray, motions, required, windows=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Steps at which cells are too close to other robots: intervals ``(cell, first, last)``.

    Cell ``c`` conflicts with the robot of ``motions[i]`` at step ``t`` when it is closer than
    ``required[i]`` to where that robot is during ``[t, t+1]``: the stretch of its polyline
    between ``arc[t]`` and ``arc[t+1]`` and, where that stretch turns a corner, also the
    straight chord it follows in between. For each cell and each segment of a polyline the arc
    lengths within ``required`` form one interval, found in closed form (half-chord
    ``sqrt(required^2 - d_perp^2)`` about the foot of the perpendicular); the steps whose
    stretch meets it follow by binary search. ``last`` may exceed any horizon (parked for good).
    ``windows``, a pair of integer arrays ``(since, until)`` over the motions, keeps only the
    steps ``since[i] <= t <= until[i]`` of each motion. Returns three integer arrays of equal length.
    """
    cells = np.ascontiguousarray(cells, dtype=float).reshape(-1, 2)
    required = np.asarray(required, dtype=float).reshape(-1)
    parts = [_conflicts_with(cells, m, float(r)) for m, r in zip(motions, required)]
    if not parts:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, empty
    cols, firsts, lasts = (np.concatenate(x) for x in zip(*parts))
    if windows is not None:
        owners = np.repeat(np.arange(len(parts)), [len(p[0]) for p in parts])
        since, until = (np.asarray(w, dtype=np.int64).reshape(-1) for w in windows)
        firsts = np.maximum(firsts, since[owners])
        lasts = np.minimum(lasts, until[owners])
        keep = firsts <= lasts
        cols, firsts, lasts = cols[keep], firsts[keep], lasts[keep]
    return cols, firsts, lasts


def _conflicts_with(cells: np.ndarray, motion: Motion, required: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`conflict_intervals` for one motion (``cells`` contiguous ``(N, 2)``)."""
    basis, offset, s0, length, step, chord_a, chord_b = motion.sweep
    # The projections onto the segments' frames are taken with NumPy's matrix product, whose
    # rounding (fused multiply-adds in BLAS) the compiled loops could not reproduce exactly.
    frame = cells @ basis - offset if motion.last_step > 0 and len(length) else np.zeros((len(cells), 0))
    return _intervals_kernel(cells, frame, motion.samples[-1], motion.arc, s0, length, step, chord_a, chord_b,
                             motion.last_step, required, (required - TOL) ** 2)


@_compiled
def _intervals_kernel(cells, frame, end, arc, s0, length, step, chord_a, chord_b, last_step, required, parked2):
    """The loops of :func:`_conflicts_with`: ``frame`` holds each cell's coordinates along
    (first half of the columns) and across (second half) every segment, ``parked2`` is the
    squared distance within which the parked robot blocks a cell for good."""
    n_cells, n_seg, n_chord = cells.shape[0], length.shape[0], step.shape[0]
    moving = last_step > 0 and n_seg > 0
    cap = n_cells * (1 + n_seg + n_chord) if moving else n_cells
    cols = np.empty(cap, dtype=np.int64)
    firsts = np.empty(cap, dtype=np.int64)
    lasts = np.empty(cap, dtype=np.int64)
    k = 0
    for c in range(n_cells):
        dx, dy = cells[c, 0] - end[0], cells[c, 1] - end[1]
        if dx * dx + dy * dy < parked2:
            cols[k], firsts[k], lasts[k] = c, last_step, FOREVER
            k += 1
    if moving:
        r2, floor = required * required, TOL * required
        for c in range(n_cells):
            for j in range(n_seg):
                along, perp = frame[c, j], frame[c, n_seg + j]
                half2 = r2 - perp * perp
                if not half2 > floor:
                    continue
                half = math.sqrt(max(half2, 0.0))
                lo, hi = max(along - half, 0.0), min(along + half, length[j])
                if not lo <= hi:
                    continue
                first = max(np.searchsorted(arc, lo + s0[j], side="left") - 1, 0)
                last = min(np.searchsorted(arc, hi + s0[j], side="right") - 1, last_step - 1)
                if first <= last:
                    cols[k], firsts[k], lasts[k] = c, first, last
                    k += 1
        # Steps whose move cuts a corner of the polyline: the chord itself as well.
        for t in range(n_chord):
            ax, ay = chord_a[t, 0], chord_a[t, 1]
            dx, dy = chord_b[t, 0] - ax, chord_b[t, 1] - ay
            norm2 = max(dx * dx + dy * dy, 1e-300)
            for c in range(n_cells):
                rx, ry = cells[c, 0] - ax, cells[c, 1] - ay
                u = min(max((rx * dx + ry * dy) / norm2, 0.0), 1.0)
                ex, ey = rx - u * dx, ry - u * dy
                if math.sqrt(ex * ex + ey * ey) < required - TOL:
                    cols[k], firsts[k], lasts[k] = c, step[t], step[t]
                    k += 1
    return cols[:k], firsts[:k], lasts[:k]


def blocked_bits(n_cells: int, n_rows: int, intervals, gates=()) -> np.ndarray:
    """The cells that may not be occupied at each step, as bitsets: ``(n_rows, W)`` little-endian
    64-bit words, bit ``c`` of row ``t`` set when cell ``c`` is closed at step ``t``.

    ``intervals`` is an iterable of ``(cell, first, last)`` arrays (see
    :func:`conflict_intervals`; steps outside ``0..n_rows-1`` are ignored). Each gate ``(cell,
    allowed)`` also closes the cells at and past ``cell`` before step ``allowed`` (the corridor
    and door rules).
    """
    bits = np.zeros((n_rows, (n_cells + 63) // 64), dtype=np.uint64)
    for cols, first, last in intervals:
        _close_kernel(bits, np.asarray(cols, dtype=np.int64), np.asarray(first, dtype=np.int64),
                      np.asarray(last, dtype=np.int64))
    _close_gates(bits, n_cells, 0, gates)
    return bits


@_compiled
def _close_kernel(bits, cols, first, last):
    """Set bit ``cols[i]`` in rows ``first[i]..last[i]`` of ``bits`` (clipped to its rows)."""
    n_rows = bits.shape[0]
    for i in range(cols.shape[0]):
        word, bit = cols[i] // 64, np.uint64(1) << np.uint64(cols[i] % 64)
        for t in range(max(first[i], 0), min(last[i], n_rows - 1) + 1):
            bits[t, word] |= bit


def _close_gates(bits: np.ndarray, n_cells: int, t0: int, gates) -> None:
    """Close, in rows ``0..allowed-t0-1`` of ``bits`` (step ``t0`` onwards), the cells at and past
    ``cell`` of every gate ``(cell, allowed)``."""
    for cell, allowed in gates:
        if cell >= 0 and allowed > t0:
            bits[:allowed - t0] |= _mask_words(n_cells, int(cell))


def _mask_words(n_cells: int, since: int) -> np.ndarray:
    """The cells ``since..n_cells-1`` as a row of 64-bit words."""
    words = (n_cells + 63) // 64
    mask = ((1 << n_cells) - 1) ^ ((1 << since) - 1)
    return np.frombuffer(mask.to_bytes(8 * words, "little"), dtype="<u8").astype(np.uint64)


def _relaxed_bits(cells: np.ndarray, motion: Motion, required: float, gap: float) -> np.ndarray:
    """:func:`blocked_bits` against ``motion`` (one row per step of it) for a robot whose first
    cell is only ``gap < required`` away from it: the relaxed separation holds until the step
    after which the motion keeps ``required`` from that cell for good, the full one from then on."""
    _, _, last = conflict_intervals(cells[:1], [motion], [required])
    since = int(last.max()) + 1 if len(last) else 0
    parts = [conflict_intervals(cells, [motion], [required], ([since], [FOREVER])),
             conflict_intervals(cells, [motion], [relaxed_separation(required, gap)], ([0], [since - 1]))]
    return blocked_bits(len(cells), motion.last_step + 1, parts)


def free_cells(n_cells: int, n_rows: int, intervals, gates=()) -> np.ndarray:
    """The cells free at each step as a boolean array ``(n_rows, n_cells)`` (see :func:`blocked_bits`)."""
    bits = blocked_bits(n_cells, n_rows, intervals, gates)
    closed = np.unpackbits(bits.view(np.uint8), axis=1, bitorder="little")[:, :n_cells]
    return closed == 0


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

    @property
    def arrival(self) -> int:
        """Step at which the robot reaches its last cell."""
        return len(self.cells) - 1


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
    if status == _ARRIVED:
        return Timing(True, "", cells)
    if status == _PARKED_ON_GOAL:
        return Timing(False, "its destination stays blocked by a robot parked next to it", np.zeros(1, dtype=int))
    if status == _CORNERED:
        return Timing(False, f"cornered at step {step}: every cell it can reach is too close to an earlier robot",
                      np.zeros(1, dtype=int), trapped_at=step)
    return Timing(False, "cannot reach its destination: its path stays blocked after every earlier robot has parked",
                  np.zeros(1, dtype=int))


#: Outcomes of :func:`_arrival_kernel`.
_ARRIVED, _PARKED_ON_GOAL, _CORNERED, _BLOCKED = 0, 1, 2, 3


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


def _dash_clashes(path: np.ndarray, step: float, others: np.ndarray, required: np.ndarray) -> bool:
    """Whether driving along ``path`` at ``step`` per step and then standing at its end comes
    closer than ``required`` to robots at ``others[t]`` ``(T, m, 2)`` at some step after the first."""
    grid = arc_length_grid(path, step).points
    limit = np.asarray(required, dtype=float).reshape(-1) - TOL
    return bool(_dash_kernel(grid, np.ascontiguousarray(others, dtype=float), limit))


@_compiled
def _dash_kernel(grid, others, limit):
    """The loops of :func:`_dash_clashes`: the robot is at ``grid[t]`` (at its end once past it)."""
    for t in range(1, others.shape[0]):
        at = grid[min(t, grid.shape[0] - 1)]
        for i in range(others.shape[1]):
            dx, dy = others[t, i, 0] - at[0], others[t, i, 1] - at[1]
            if math.sqrt(dx * dx + dy * dy) < limit[i]:
                return True
    return False


def retreat_spots(centre: np.ndarray) -> np.ndarray:
    """Candidate spots to back out to: rings of points around ``centre``, shape ``(M, 2)``."""
    ang = 2.0 * np.pi * np.arange(_RETREAT_ANGLES) / _RETREAT_ANGLES
    ring = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    return (np.asarray(centre, dtype=float)[None, None] + np.asarray(_RETREAT_RADII)[:, None, None] * ring[None]).reshape(-1, 2)


def join_motions(head: Motion, tail: Motion) -> Motion:
    """``head`` up to its last step, then ``tail``, which starts where ``head`` ends."""
    length = float(head.segments[2].sum())
    return Motion(np.vstack([head.path, tail.path[1:]]), np.vstack([head.samples[:-1], tail.samples]),
                  np.concatenate([head.arc[:-1], tail.arc + length]))


# ---------------------------------------------------------------------------------------------
# The planner


@dataclass(frozen=True)
class _Route:
    """One robot's geometric path and the standing robots (discs) it keeps clear of."""

    path: GeometricPath
    centres: np.ndarray
    radii: np.ndarray
    detour: bool = False
    """Whether the path had to ignore the robots standing in the way (it may cross them)."""


@dataclass(frozen=True)
class _Track:
    """A robot's geometric path cut into cells, ready for timing."""

    route: _Route
    cells: np.ndarray
    """Cells ``(N, 2)`` along the path, at most ``v_max dt / 2`` apart (m)."""
    arc: np.ndarray
    """Arc length of each cell ``(N,)`` (m)."""
    ok2: np.ndarray
    """Whether the full-speed move ``c -> c+2`` is allowed ``(N,)``."""
    inside: np.ndarray
    """Which cells are in the corridor ``(N,)``."""
    entry: int
    """First cell entering the corridor from outside, or -1 (:func:`entry_cell`)."""
    doors: tuple[int, int]
    """First cell entering the door zone of the left and of the right entrance from outside, or -1."""
    segments: tuple
    """The path's segments, :func:`polyline_segments`."""


@dataclass(frozen=True)
class _Cut:
    """A path cut into cells, before any standing robot is considered (see :class:`_Track`)."""

    cells: np.ndarray
    arc: np.ndarray
    ok2: np.ndarray
    corners: np.ndarray
    """Cells ``c`` whose full-speed move ``c -> c+2`` cuts a corner of the path."""
    inside: np.ndarray
    entry: int
    doors: tuple[int, int]
    segments: tuple


@dataclass(frozen=True)
class _RobotPlan:
    """One robot's planned motion."""

    motion: Motion
    """Its polyline and where it is along it at steps ``0..arrival``."""
    world: World = field(repr=False)
    door_clearance: float = 1.0
    """Radius of the door zones (m)."""
    retreat: bool = False
    """Whether it backs out of the way first."""

    @property
    def arrival(self) -> int:
        return self.motion.last_step

    @cached_property
    def passage(self) -> tuple[int, int]:
        """``(entry, exit)`` samples of its last stay in the corridor, see :func:`corridor_passage`."""
        return corridor_passage(self.world.in_corridor(self.motion.samples))

    @cached_property
    def doors(self) -> tuple[tuple[int, int], tuple[int, int]]:
        """``(entry, exit)`` samples of its last stay in the door zone of the left and of the right entrance."""
        s = self.motion.samples
        return tuple(corridor_passage(np.hypot(s[:, 0] - e[0], s[:, 1] - e[1]) < self.door_clearance)
                     for e in self.world.entrances)


@dataclass(frozen=True)
class _State:
    """Everything about a request that does not depend on the order."""

    key: tuple
    positions: np.ndarray
    destinations: np.ndarray
    radii: np.ndarray
    max_speeds: np.ndarray
    required: np.ndarray
    """Pairwise separation, :func:`separation_requirements`."""
    directions: np.ndarray
    """Crossing directions, :func:`crossing_directions`."""
    inside: np.ndarray
    """Which robots stand in the corridor."""
    door: np.ndarray
    """Index of the entrance each robot crosses through first (0 left, 1 right), -1 if it does not cross."""
    in_door: np.ndarray
    """Which crossing robots stand in the door zone of that entrance."""
    natural: tuple
    """Each robot's shortest path among the walls alone, from its position to its destination."""
    problem: str
    """Why no order can be planned (a destination outside free space, overlapping ones), or empty."""


def _reject(order: tuple, pos: np.ndarray, dest: np.ndarray, radii: np.ndarray, vmax: np.ndarray):
    """Raise the error for a malformed request."""
    raise ValueError(f"malformed request: order {order} for {len(pos)} robots, positions {pos.shape}, destinations "
                     f"{dest.shape}, radii {radii.tolist()}, max_speeds {vmax.tolist()}")


def _state_problem(dest: np.ndarray, clear: np.ndarray, radii: np.ndarray) -> str:
    for k in np.flatnonzero(clear < radii - TOL):
        return (f"robot {k}: destination ({dest[k, 0]:.3f}, {dest[k, 1]:.3f}) is not in free space "
                f"(clearance {clear[k]:.3f} m < radius {radii[k]:.3f} m)")
    gaps = np.linalg.norm(dest[:, None] - dest[None], axis=2)
    for a, b in zip(*np.triu_indices(len(dest), 1)):
        if gaps[a, b] < radii[a] + radii[b] - TOL:
            return (f"robots {a} and {b}: destinations overlap ({gaps[a, b]:.3f} m apart, "
                    f"need {radii[a] + radii[b]:.3f} m)")
    return ""


def _remember(memo: dict, key, value) -> None:
    """Store in a bounded memo, forgetting the oldest entry when full."""
    if len(memo) >= _MEMO_SIZE:
        del memo[next(iter(memo))]
    memo[key] = value


@dataclass(frozen=True)
class _Attempt:
    success: bool
    reason: str
    plan: _RobotPlan | None = None
    trapped: bool = False
    evasions: tuple = ()
    """``(robot, motion)`` of the robots after it that get out of its way first."""


@dataclass(frozen=True)
class _Joint:
    """Every robot planned in one order: what all results for that order share."""

    success: bool
    reason: str
    cost: float = math.inf
    """Sum of the arrival times (s)."""
    trajectory: JointTrajectory | None = None
    arrival: np.ndarray | None = None
    """Each robot's arrival time after the request's time (s)."""
    lengths: np.ndarray | None = None
    """Each robot's path length (m)."""
    paths: tuple = ()
    """Each robot's polyline."""
    retreats: tuple = ()
    """The robots that back out of the way of robots before them."""
    deferred: tuple = ()
    """The robots that wait aside before they park, so as not to block the robots after them."""


@dataclass(frozen=True)
class _Layout:
    """Where everybody is while one robot is planned: the robots before it (their plans), and
    the robots after it, standing where they are or where they get out of the way to."""

    plans: dict
    """Planned robot -> :class:`_RobotPlan`."""
    heads: dict
    """Robot still to plan -> the motion by which it gets out of the way first (it then stands
    at its end)."""
    later: tuple[int, ...]
    """The robots still to plan, in index order (other than the one being planned)."""

    def fixed(self, but: int) -> list[tuple[int, Motion]]:
        """Every known motion, except robot ``but``'s own: the plans, then the heads."""
        return ([(i, p.motion) for i, p in self.plans.items()]
                + [(j, m) for j, m in sorted(self.heads.items()) if j != but])


class PrioritizedPlanner:
    """Prioritised space-time planner (see the module docstring); deterministic, no precomputation."""

    name = "fast"

    def __init__(self, world: World, params: PlannerParams | None = None):
        self.world = world
        self.params = params if params is not None else PlannerParams()
        self._graphs: dict[tuple[World, float], VisibilityGraph] = {}
        self._tracks: dict[tuple, _Track] = {}
        self._cuts: dict[tuple, _Cut] = {}
        self._rows: dict[tuple, tuple] = {}
        self._states: dict[tuple, _State] = {}
        self._attempts: dict[tuple, _Attempt] = {}
        self._joints: dict[tuple, _Joint] = {}

    @property
    def wall_margin(self) -> float:
        """Extra clearance kept from walls where there is room: half the pair margin (m)."""
        return 0.5 * self.params.margin

    def graph(self, world: World, radius: float) -> VisibilityGraph:
        """The visibility graph for robots of ``radius`` in ``world`` (built once, then kept)."""
        key = (world, float(radius))
        g = self._graphs.get(key)
        if g is None:
            g = VisibilityGraph(world, radius, self.wall_margin)
            _remember(self._graphs, key, g)
        return g

    def plan(self, request: PlanRequest) -> PlanResult:
        """Plan every robot of the request through the corridor in its (feasible) passing order."""
        began = time.perf_counter()
        world = request.world
        pos = np.asarray(request.positions, dtype=float).reshape(-1, 2)
        dest = np.asarray(request.destinations, dtype=float).reshape(-1, 2)
        radii = np.asarray(request.radii, dtype=float).reshape(-1)
        vmax = np.asarray(request.max_speeds, dtype=float).reshape(-1)
        order = tuple(int(k) for k in request.order)
        if sorted(order) != list(range(len(pos))):
            _reject(order, pos, dest, radii, vmax)
        state = self._state(world, pos, dest, radii, vmax, order)
        entered = tuple(int(k) for k in request.entered)
        entered += tuple(k for k in order if state.inside[k] and k not in entered)
        planned = feasible_order(order, entered)

        def failure(reason: str) -> PlanResult:
            logger.debug("fast planner: order %s failed: %s", planned, reason)
            return replace(PlanResult.failure(request, reason, time.perf_counter() - began), order_planned=planned)

        if state.problem:
            return failure(state.problem)
        # Orders repaired to the same one share its joint plan; only the notes differ.
        key = (state.key, planned, float(request.t0))
        joint = self._joints.get(key)
        if joint is None:
            joint = self._joint(world, state, planned, float(request.t0))
            _remember(self._joints, key, joint)
        if not joint.success:
            return failure(joint.reason)
        notes = []
        if planned != order:
            notes.append(f"order {order} repaired to {planned}: robots {entered} have already entered the corridor")
        if joint.retreats:
            notes.append(f"robots {joint.retreats} back out of the way of robots before them")
        if joint.deferred:
            notes.append(f"robots {joint.deferred} wait aside before they park, clear of the robots after them")
        info = {"arrival_times": joint.arrival, "path_lengths": joint.lengths, "paths": joint.paths,
                "retreats": joint.retreats, "deferred": joint.deferred, "entered": entered}
        return PlanResult(True, "; ".join(notes), joint.cost, joint.trajectory, order, planned,
                          time.perf_counter() - began, info)

    # -----------------------------------------------------------------------------------------

    def _joint(self, world: World, state: _State, planned: tuple, t0: float,
               deferred: frozenset = frozenset()) -> _Joint:
        """Every robot planned in the order ``planned``, one after the other.

        A robot whose way is blocked for good by where a robot before it parks has that robot
        wait aside instead (``deferred``): it is planned to a holding spot clear of the ways of
        the robots after it, and goes on to its destination once they have passed
        (:meth:`_park`).
        """
        work = state
        if deferred:
            work = self._deferring(world, state, planned, deferred)
            if work is None:
                return _Joint(False, f"robots {tuple(sorted(deferred))} would block the way where they park, "
                                     "and have no spot nearby to wait aside")
        plans: dict[int, _RobotPlan] = {}
        heads: dict[int, Motion] = {}
        for rank, k in enumerate(planned):
            # A robot's plan depends only on the state, on who goes before it and on the set of
            # robots after it, so orders that share a beginning share those plans.
            key = (work.key, planned[:rank + 1])
            attempt = self._attempts.get(key)
            if attempt is None:
                layout = _Layout(dict(plans), dict(heads), tuple(sorted(planned[rank + 1:])))
                attempt = self._plan_robot(world, work, k, layout)
                _remember(self._attempts, key, attempt)
            if not attempt.success:
                start = heads[k].samples[-1] if k in heads else state.positions[k]
                blockers = self._blockers(world, state, planned[:rank], k, start) - deferred
                if blockers:
                    retry = self._joint(world, state, planned, t0, deferred | blockers)
                    if retry.success:
                        return retry
                return _Joint(False, f"robot {k}: {attempt.reason}")
            plans[k] = attempt.plan
            heads.pop(k, None)
            heads.update(attempt.evasions)
        for k in planned:
            if k in deferred:
                parked = self._park(world, state, k, plans)
                if parked is None:
                    return _Joint(False, f"robot {k} waits aside for the robots after it, and cannot park afterwards")
                plans[k] = parked
        dt = float(self.params.dt)
        n = len(plans)
        steps = max(p.arrival for p in plans.values()) + 1
        positions = np.empty((steps, n, 2))
        for k, p in plans.items():
            positions[:p.arrival + 1, k] = p.motion.samples
            positions[p.arrival + 1:, k] = p.motion.samples[-1]
        trajectory = JointTrajectory.from_positions(t0 + dt * np.arange(steps), positions)
        arrival = np.array([plans[k].arrival * dt for k in range(n)])
        lengths = np.array([float(plans[k].motion.segments[2].sum()) for k in range(n)])
        # Shared by every result of this order: nobody may change them in place.
        for a in (trajectory.times, trajectory.positions, trajectory.velocities, arrival, lengths):
            a.setflags(write=False)
        return _Joint(True, "", float(arrival.sum()), trajectory, arrival, lengths,
                      tuple(plans[k].motion.path for k in range(n)), tuple(k for k in planned if plans[k].retreat),
                      tuple(k for k in planned if k in deferred))

    def _blockers(self, world: World, state: _State, earlier: tuple, k: int, start: np.ndarray) -> frozenset:
        """The robots of ``earlier`` whose destination lies on robot ``k``'s way among the walls
        from ``start`` (where it stands, or where it got out of the way to), closer to it than
        their required distance: parked there, they block it for good."""
        if not earlier:
            return frozenset()
        way = self.graph(world, state.radii[k]).shortest_paths(start[None], state.destinations[k][None])[0]
        dest = state.destinations[list(earlier)]
        near = polyline_point_distance(way.points, dest) < state.required[k, list(earlier)] - TOL
        return frozenset(int(i) for i in np.asarray(earlier)[near])

    def _deferring(self, world: World, state: _State, planned: tuple, deferred: frozenset) -> _State | None:
        """The state with each robot of ``deferred`` going to a holding spot instead of its
        destination: the spot nearest its destination that keeps the required distance from the
        ways (among the walls) of the robots after it in ``planned``, from where every other robot
        stands and parks, and from the other holding spots, out of the corridor and of both door
        zones, in the room of its destination (so that it has passed the corridor where the order
        says), and from which its destination stays in reach once the others have parked; ``None``
        if a robot has no such spot (one that parks in the corridor has none).
        """
        goals = state.destinations.copy()
        for i in sorted(deferred, key=planned.index):
            later = list(planned[planned.index(i) + 1:])
            others = [m for m in range(len(goals)) if m != i]
            graph = self.graph(world, state.radii[i])
            spots = retreat_spots(state.destinations[i])
            ok = (world.clearance(spots) >= graph.clearance - TOL) & (world.side_of(spots) == world.side_of(goals[i]))
            ok &= ~world.in_corridor(spots)
            ok &= ~self._in_door(world, spots, 0) & ~self._in_door(world, spots, 1)
            req = state.required[i]
            for m in others:
                ok &= np.hypot(*(spots - goals[m]).T) >= req[m] - TOL
                ok &= np.hypot(*(spots - state.positions[m]).T) >= req[m] - TOL
            for m in later:
                ok &= polyline_point_distance(state.natural[m], spots) >= req[m] - TOL
            spots = spots[ok][np.argsort(np.hypot(*(spots[ok] - state.destinations[i]).T), kind="stable")]
            ways = graph.shortest_paths(np.repeat(state.positions[i][None], len(spots), 0), spots)
            # From the spot, its destination must stay in reach once everybody else has parked.
            parked, rads = goals[others], req[others]
            for spot in (spots[q] for q, way in enumerate(ways) if way.success):
                if graph.shortest_path(spot, state.destinations[i], parked, rads).success:
                    goals[i] = spot
                    break
            else:
                return None
        return self._state(world, state.positions, goals, state.radii, state.max_speeds, planned)

    def _park(self, world: World, state: _State, k: int, plans: dict) -> _RobotPlan | None:
        """Robot ``k``'s plan to its holding spot, then on to its destination once every other
        robot's planned motion leaves the way free (None if it never does)."""
        head = plans[k].motion
        others = [j for j in plans if j != k]
        centres = np.array([plans[j].motion.samples[-1] for j in others]).reshape(-1, 2)
        track = self._track(world, state.radii[k], state.max_speeds[k] * self.params.dt, head.samples[-1],
                            state.destinations[k], centres, state.required[k, others], 0)
        if not track.route.path.success:
            return None
        timing = self._timing(state, k, track, [(j, plans[j].motion) for j in others], (), head.last_step)
        if not timing.success:
            return None
        steps = timing.cells
        tail = Motion(track.route.path.points, track.cells[steps], track.arc[steps], track.segments)
        return replace(plans[k], motion=join_motions(head, tail))

    def _state(self, world: World, pos: np.ndarray, dest: np.ndarray, radii: np.ndarray, vmax: np.ndarray,
               order: tuple) -> _State:
        """What every order planned from this state shares (memoised; checked when first seen,
        ``order`` is only quoted in the error)."""
        key = (world, pos.tobytes(), dest.tobytes(), radii.tobytes(), vmax.tobytes())
        state = self._states.get(key)
        if state is None:
            n = len(pos)
            if (dest.shape != pos.shape or radii.shape != (n,) or vmax.shape != (n,) or not (
                    np.isfinite(pos).all() and np.isfinite(dest).all() and (radii > 0).all() and (vmax > 0).all())):
                _reject(order, pos, dest, radii, vmax)
            # Copies: the memos keep them, and the caller may reuse its arrays.
            pos, dest, radii, vmax = pos.copy(), dest.copy(), radii.copy(), vmax.copy()
            clear = world.clearance(dest)
            dirs = crossing_directions(world, pos, dest)
            door = np.where(dirs > 0, 0, np.where(dirs < 0, 1, -1))
            entrances = np.asarray(world.entrances, dtype=float)
            gap = np.linalg.norm(pos - entrances[np.maximum(door, 0)], axis=1)
            natural = [None] * n
            for radius in np.unique(radii):
                group = np.flatnonzero(radii == radius)
                for k, path in zip(group, self.graph(world, radius).shortest_paths(pos[group], dest[group])):
                    natural[k] = path.points
            state = _State(key, pos, dest, radii, vmax,
                           separation_requirements(dest, radii, vmax, self.params.dt, self.params.margin),
                           dirs, world.in_corridor(pos), door, (door >= 0) & (gap < self.params.door_clearance),
                           tuple(natural), _state_problem(dest, clear, radii))
            _remember(self._states, key, state)
        return state

    def _start(self, state: _State, k: int, layout: _Layout) -> np.ndarray:
        """Where robot ``k`` stands once it has got out of the way (its position if it need not)."""
        head = layout.heads.get(k)
        return head.samples[-1] if head is not None else state.positions[k]

    def _plan_robot(self, world: World, state: _State, k: int, layout: _Layout) -> _Attempt:
        """Robot ``k``'s path and timing among the robots before it. Robots after it that stand
        in its way, or in the door zone it will come out of, get out of the way first; one pinned
        where only ``k``'s own place would let it out gets that room: ``k`` backs off first."""
        dirs = state.directions
        heads = dict(layout.heads)  # grows as robots get out of the way
        evasions: dict[int, Motion] = {}

        def now() -> _Layout:
            return replace(layout, heads=dict(heads))

        def evade(j: int) -> None:
            moves = self._evade(world, state, j, k, now())
            if not moves and k not in heads:
                back = self._back_off(world, state, k, j, now())
                if back:
                    moves = self._evade(world, state, j, k, replace(layout, heads={**heads, **back}))
                    moves = {**back, **moves} if moves else {}
            if k in moves:
                heads[k] = moves.pop(k)
            heads.update(moves)
            evasions.update(moves)

        if dirs[k] != 0:
            for j in layout.later:
                if j not in heads and state.in_door[j] and dirs[j] == -dirs[k]:
                    evade(j)
        track = self._track_for(world, state, k, now())
        if track.route.detour:
            stand = np.array([self._start(state, j, now()) for j in layout.later]).reshape(-1, 2)
            start, goal = track.cells[0], track.cells[-1]
            crossed = disc_violations(track.route.path.points, stand, state.required[k, list(layout.later)],
                                      np.linalg.norm(stand - start, axis=1), np.linalg.norm(stand - goal, axis=1))
            for j in np.asarray(layout.later)[crossed]:
                if int(j) not in heads:
                    evade(int(j))
        here = now()
        if len(heads) > len(layout.heads):
            track = self._track_for(world, state, k, here)
        if not track.route.path.success:
            return _Attempt(False, track.route.path.reason)
        attempt = self._time(world, state, k, track, here)
        if not attempt.success and attempt.trapped and k not in heads:
            retreat = self._retreat(world, state, k, here)
            if retreat.success:
                attempt = retreat
        return replace(attempt, evasions=tuple(sorted(evasions.items())))

    def _track_for(self, world: World, state: _State, k: int, layout: _Layout) -> _Track:
        """Robot ``k``'s prepared path from where it starts (after getting out of the way, if it
        must), around the robots after it standing and the destinations of those before it."""
        dest, req = state.destinations, state.required
        later, earlier = list(layout.later), sorted(layout.plans)
        start = self._start(state, k, layout)
        centres = np.vstack([np.array([self._start(state, j, layout) for j in later]).reshape(-1, 2), dest[earlier]])
        rads = np.concatenate([req[k, later], req[k, earlier]])
        return self._track(world, state.radii[k], state.max_speeds[k] * self.params.dt, start, dest[k], centres,
                           rads, len(later))

    def _track(self, world: World, radius: float, step: float, start: np.ndarray, goal: np.ndarray,
               centres: np.ndarray, rads: np.ndarray, n_later: int) -> _Track:
        """The robot's prepared path (memoised: the closed loop asks the same from every order)."""
        key = (world, radius, step, start.tobytes(), goal.tobytes(), centres.tobytes(), rads.tobytes(), n_later)
        track = self._tracks.get(key)
        if track is None:
            route = self._route(world, radius, start, goal, centres, rads, n_later)
            track = self._prepare(world, radius, step, route)
            _remember(self._tracks, key, track)
        return track

    def _route(self, world: World, radius: float, start: np.ndarray, goal: np.ndarray,
               centres: np.ndarray, rads: np.ndarray, n_later: int) -> _Route:
        """The geometric path, keeping clear of later robots' positions and earlier robots'
        destinations if possible, else of the destinations only, else of the walls only."""
        graph = self.graph(world, radius)
        attempts = [(centres, rads)]
        if n_later:
            attempts.append((centres[n_later:], rads[n_later:]))
        if len(attempts[-1][0]):
            attempts.append((np.zeros((0, 2)), np.zeros(0)))
        for level, (c, r) in enumerate(attempts):
            path = graph.shortest_path(start, goal, c, r)
            if path.success:
                break
        return _Route(path, c, r, detour=bool(n_later) and level > 0)

    def _prepare(self, world: World, radius: float, step: float, route: _Route) -> _Track:
        """The path cut into cells (:meth:`_cut`), with the full-speed moves that would cut a
        corner closer to a standing robot than the polyline comes removed."""
        cut = self._cut(world, radius, step, route.path.points)
        ok2 = cut.ok2
        if len(cut.corners) and len(route.centres):
            a, b = cut.cells[cut.corners], cut.cells[cut.corners + 2]
            keep = np.minimum(route.radii, polyline_point_distance(route.path.points, route.centres))
            bad = (segment_point_distance(a, b, route.centres) < keep - TOL).any(axis=1)
            if bad.any():
                ok2 = ok2.copy()
                ok2[cut.corners[bad]] = False
        return _Track(route, cut.cells, cut.arc, ok2, cut.inside, cut.entry, cut.doors, cut.segments)

    def _cut(self, world: World, radius: float, step: float, path: np.ndarray) -> _Cut:
        """Cut a path into cells of at most half a step and find the full-speed moves the walls
        allow (memoised by path: many disc sets give the same path).

        A move ``c -> c+2`` leaves the polyline only where it cuts a corner; there the straight
        chord must keep the robot's radius from the walls (or not go deeper than its ends
        already are). The polyline keeps ``g = min(radius + wall margin, end clearance)`` from
        the walls (the least clearance of its two ends), and no point of a chord is farther
        from the polyline than the corner is from the chord (``h``), so ``g - h >= radius``
        settles most corners without computing distances.
        """
        key = (world, radius, step, path.tobytes())
        cut = self._cuts.get(key)
        if cut is not None:
            return cut
        grid = arc_length_grid(path, step / 2.0)
        cells = grid.points
        n = len(cells)
        ok = np.zeros(n, dtype=bool)
        corners = np.zeros(0, dtype=int)
        if n >= 3:
            ok[:n - 2] = True
            u, w = cells[1:-1] - cells[:-2], cells[2:] - cells[1:-1]
            cross = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
            corners = np.nonzero(np.abs(cross) > 1e-12)[0]
            if len(corners):
                a, b = cells[corners], cells[corners + 2]
                height = np.abs(cross[corners]) / np.linalg.norm(b - a, axis=1)
                end_clearance = float(world.clearance(path[[0, -1]]).min())
                good = min(radius + self.wall_margin, end_clearance) - height >= radius
                unsure = np.nonzero(~good)[0]
                if len(unsure):
                    au, bu = a[unsure], b[unsure]
                    limit = np.minimum(radius, np.minimum(world.clearance(au), world.clearance(bu)))
                    good[unsure] = segment_clearance(world, au, bu) >= limit - TOL
                ok[corners] = good
        inside = world.in_corridor(cells)
        doors = tuple(entry_cell(self._in_door(world, cells, e)) for e in (0, 1))
        cut = _Cut(cells, grid.arc_length, ok, corners, inside, entry_cell(inside), doors, polyline_segments(path))
        _remember(self._cuts, key, cut)
        return cut

    def _in_door(self, world: World, points: np.ndarray, entrance: int) -> np.ndarray:
        """Which points are in the door zone of entrance ``entrance`` (0 left, 1 right)."""
        e = world.entrances[entrance]
        return np.hypot(points[:, 0] - e[0], points[:, 1] - e[1]) < self.params.door_clearance

    def _gates(self, state: _State, k: int, track: _Track, plans: dict) -> tuple[list, str]:
        """The corridor and door rules for robot ``k`` after the robots ``plans``: ``(cell,
        allowed)`` pairs (cells at and past ``cell`` are closed before step ``allowed``), or why
        the order cannot be kept."""
        dirs, gates = state.directions, []
        door = state.door[k]
        for i, p in plans.items():
            e_i, x_i = p.passage
            if dirs[i] == dirs[k] != 0:
                if track.entry >= 0 and e_i >= 0:
                    gates.append((track.entry, e_i + 1))
                continue
            if track.entry >= 0 and e_i >= 0:
                if x_i > p.arrival:
                    return [], f"robot {i} before it in the order parks inside the corridor"
                gates.append((track.entry, x_i + 1))
            if door >= 0 and track.doors[door] >= 0:
                z_i, out_i = p.doors[door]
                if z_i >= 0:
                    gates.append((track.doors[door], min(out_i, p.arrival) + 1))
        return gates, ""

    def _timing(self, state: _State, k: int, track: _Track, fixed: list, gates=(), t0: int = 0) -> Timing:
        """Velocity tuning of robot ``k`` along ``track`` from step ``t0`` among the ``fixed``
        ``(robot, motion)`` pairs, under the ``gates`` (absolute steps); the timing's step 0 is
        step ``t0``. A pair that starts closer than required keeps the relaxed separation until
        the other robot's motion is required distance away from this one's start for good
        (:func:`relaxed_separation`)."""
        cells, n = track.cells, len(track.cells)
        n_rows = max([m.last_step + 1 for _, m in fixed] + [a + 1 for _, a in gates] + [t0 + 1]) - t0
        closed = np.zeros((n_rows, (n + 63) // 64), dtype=np.uint64)
        for j, m in fixed:
            r = float(state.required[j, k])
            here = m.samples[min(t0, m.last_step)]
            gap = math.hypot(here[0] - cells[0, 0], here[1] - cells[0, 1])
            bits = self._blocked(cells, m, r) if gap >= r else _relaxed_bits(cells, m, r, gap)
            # Rows past the motion's last step repeat it: it stands still from then on.
            part = bits[min(t0, len(bits) - 1):]
            closed[:len(part)] |= part
            closed[len(part):] |= part[-1]
        _close_gates(closed, n, t0, gates)
        free = ~closed
        free[:, -1] &= _mask_words(n, 0)[-1]
        return earliest_arrival_bits(free, n, track.ok2, self.params.waiting == "early")

    def _blocked(self, cells: np.ndarray, motion: Motion, required: float) -> np.ndarray:
        """The cells too close to ``motion`` at each of its steps (:func:`blocked_bits`; memoised:
        the same path meets the same motion in many orders, and equal motions in others)."""
        key = (id(cells), motion.samples.tobytes(), motion.path.tobytes(), required)
        hit = self._rows.get(key)
        if hit is None:
            bits = blocked_bits(len(cells), motion.last_step + 1, [conflict_intervals(cells, [motion], [required])])
            # The cells are kept with the bits so that their id stays theirs while remembered.
            hit = (cells, bits)
            _remember(self._rows, key, hit)
        return hit[1]

    def _time(self, world: World, state: _State, k: int, track: _Track, layout: _Layout,
              head: Motion | None = None) -> _Attempt:
        """Robot ``k``'s timing along ``track`` among everything known, after ``head`` (the
        motion by which it first got out of the way) if there is one."""
        head = layout.heads.get(k) if head is None else head
        gates, problem = self._gates(state, k, track, layout.plans)
        if problem:
            return _Attempt(False, problem)
        t0 = head.last_step if head is not None else 0
        timing = self._timing(state, k, track, layout.fixed(k), gates, t0)
        if not timing.success:
            return _Attempt(False, timing.reason, trapped=timing.trapped_at >= 0)
        steps = timing.cells
        motion = Motion(track.route.path.points, track.cells[steps], track.arc[steps], track.segments)
        if head is not None:
            motion = join_motions(head, motion)
        return _Attempt(True, "", _RobotPlan(motion, world, self.params.door_clearance, head is not None))

    def _evade(self, world: World, state: _State, j: int, k: int, layout: _Layout, clear: tuple = (),
               depth: int = 0) -> dict:
        """How robot ``j`` (planned after ``k``) first gets out of ``k``'s way: to a nearby spot
        clear of the ways on of every robot still to plan and of the polylines ``clear``, and out
        of its door zone if ``k`` or an earlier robot comes out through it (:meth:`_make_way`).
        Returns robot -> motion for every robot that moves (empty if ``j`` cannot)."""
        others = [m for m in layout.later if m != j] + [k]
        dirs = state.directions
        door = dirs[j] != 0 and any(dirs[i] == -dirs[j] for i in [*layout.plans, k])

        def keep(lay: _Layout) -> list:
            # The ways on of the others: from where they stand, or from the spot they got out of
            # the way to (a spot must not block the way on of a robot that moved before).
            ways = []
            for m in others:
                if m in lay.heads:
                    spot = lay.heads[m].samples[-1]
                    way = self.graph(world, state.radii[m]).shortest_paths(spot[None], state.destinations[m][None])[0]
                    ways.append((way.points, state.required[j, m]))
                else:
                    ways.append((state.natural[m], state.required[j, m]))
            return ways + list(clear)

        return self._make_way(world, state, j, k, layout, others, keep, door, (k,), depth)

    def _back_off(self, world: World, state: _State, k: int, j: int, layout: _Layout) -> dict:
        """How robot ``k`` first makes room for robot ``j`` (planned after it, standing in its
        way) to get out of the way: to a spot clear of ``j``'s way, among the walls alone, to
        the nearest spot ``j`` could go to were ``k`` not there (:meth:`_make_way`). Returns
        robot -> motion for every robot that moves, ``k`` included (empty if it cannot)."""
        dirs = state.directions
        others = [m for m in layout.later if m != j]
        door = dirs[j] != 0 and any(dirs[i] == -dirs[j] for i in [*layout.plans, k])
        clear = [(state.natural[m], state.required[j, m]) for m in others if m not in layout.heads]
        way = next((w for w in self._spots(world, state, j, layout, others, clear, door)[1] if w.success), None)
        if way is None:
            return {}
        door = dirs[k] != 0 and any(dirs[i] == -dirs[k] for i in layout.plans)
        return self._make_way(world, state, k, k, layout, list(layout.later),
                              lambda lay: [(way.points, state.required[j, k])], door, (j,), 0)

    def _make_way(self, world: World, state: _State, x: int, k: int, layout: _Layout, others: list, keep,
                  door: bool, pinned: tuple, depth: int) -> dict:
        """Robot ``x`` gets out of the way (of ``k``, which is being planned) to one of
        :meth:`_spots` among the robots ``others``, keeping clear of ``keep(layout)``. When it
        cannot, the robots standing on its way to the nearest spot it could reach without
        passing one of the ``pinned`` robots get out of the way first, keeping that way clear
        too (up to :data:`_CASCADE` deep), and ``x`` tries again. Returns robot -> motion for
        every robot that moves (empty if ``x`` cannot)."""
        head = next(self._escapes(world, state, x, layout, others, keep(layout), door), None)
        if head is not None:
            return {x: head}
        movable = [m for m in others if m not in pinned and m != k and m not in layout.heads]
        if depth >= _CASCADE or not movable:
            return {}
        stand = np.array([self._start(state, m, layout) for m in [*pinned, *movable]])
        need = state.required[x, [*pinned, *movable]]
        gap = np.linalg.norm(stand - state.positions[x], axis=1)
        for way in self._spots(world, state, x, layout, others, keep(layout), door)[1]:
            if way.success:
                crossed = disc_violations(way.points, stand, need, gap, np.linalg.norm(stand - way.points[-1], axis=1))
                if not crossed[:len(pinned)].any():
                    break
        else:
            return {}
        moves: dict[int, Motion] = {}
        for m, c in zip(movable, crossed[len(pinned):]):
            if c:
                moves.update(self._evade(world, state, m, k, replace(layout, heads={**layout.heads, **moves}),
                                         ((way.points, state.required[x, m]),), depth + 1))
        if not moves:
            return {}
        after = replace(layout, heads={**layout.heads, **moves})
        head = next(self._escapes(world, state, x, after, others, keep(after), door), None)
        return {**moves, x: head} if head is not None else {}

    def _retreat(self, world: World, state: _State, k: int, layout: _Layout) -> _Attempt:
        """Robot ``k``, cornered by a robot before it, backs out of the way first: to the cheapest
        nearby spot where it can wait for good, then on to its destination."""
        dirs = state.directions
        door = dirs[k] != 0 and any(dirs[i] == -dirs[k] for i in layout.plans)
        reason = "cornered by an earlier robot, and no spot nearby to back out to"
        for head in self._escapes(world, state, k, layout, list(layout.later), [], door):
            track = self._track_for(world, state, k, replace(layout, heads={**layout.heads, k: head}))
            if not track.route.path.success:
                continue
            attempt = self._time(world, state, k, track, layout, head)
            if attempt.success:
                logger.debug("fast planner: robot %d backs out to (%.2f, %.2f)", k, *head.samples[-1])
                return attempt
            reason = f"cornered by an earlier robot; backing out failed too: {attempt.reason}"
        return _Attempt(False, reason)

    def _spots(self, world: World, state: _State, j: int, layout: _Layout, others: list, clear: list,
               door: bool) -> tuple[np.ndarray, list]:
        """Spots robot ``j`` could get out of the way to, and its ways there among the walls
        alone, nearest first: spots that keep the required distance from where the robots
        ``others`` stand, the given distance from the polylines ``clear`` (``(polyline,
        distance)`` pairs), the required distance from every known motion, and, with ``door``,
        out of its door zone."""
        pos, req, radius = state.positions[j], state.required, state.radii[j]
        graph = self.graph(world, radius)
        spots = retreat_spots(pos)
        ok = (world.clearance(spots) >= graph.clearance - TOL) & ~world.in_corridor(spots)
        if door:
            ok &= ~self._in_door(world, spots, state.door[j])
        stand = np.array([self._start(state, m, layout) for m in others]).reshape(-1, 2)
        if len(others):
            ok &= (np.linalg.norm(spots[:, None] - stand[None], axis=2) >= req[j, others] - TOL).all(axis=1)
        for route, distance in clear:
            ok &= polyline_point_distance(route, spots) >= distance - TOL
        for i, motion in layout.fixed(j):
            ok &= polyline_point_distance(motion.samples, spots) >= req[i, j] - TOL
        spots = spots[ok]
        if not len(spots):
            return spots, []
        ways = graph.shortest_paths(np.repeat(pos[None], len(spots), 0), spots)
        near = np.argsort([w.length for w in ways], kind="stable")[:3 * _RETREAT_TRIES]
        return spots[near], [ways[q] for q in near]

    def _escapes(self, world: World, state: _State, j: int, layout: _Layout, others: list, clear: list, door: bool):
        """Motions by which robot ``j`` gets out of the way to one of :meth:`_spots`, best first:
        nearest first among those it can dash to without meeting anyone, then the others."""
        spots, ways = self._spots(world, state, j, layout, others, clear, door)
        if not len(spots):
            return
        pos, req, radius = state.positions[j], state.required, state.radii[j]
        graph = self.graph(world, radius)
        fixed = layout.fixed(j)
        step = state.max_speeds[j] * self.params.dt
        horizon = max([m.last_step for _, m in fixed] + [0])
        others_at = (np.stack([m.samples[np.minimum(np.arange(horizon + 1), m.last_step)] for _, m in fixed], axis=1)
                     if fixed else np.zeros((horizon + 1, 0, 2)))
        need = req[[i for i, _ in fixed], j]
        clash = np.array([_dash_clashes(w.points, step, others_at, need) if w.success else True for w in ways])
        stand = np.array([self._start(state, m, layout) for m in others]).reshape(-1, 2)
        starts_inside = bool(world.in_corridor(pos))
        for q in np.argsort(clash, kind="stable")[:_RETREAT_TRIES]:
            way = graph.shortest_path(pos, spots[q], stand, req[j, others])
            if not way.success:
                continue
            track = self._prepare(world, radius, step, _Route(way, stand, req[j, others]))
            if not starts_inside and track.inside.any():
                continue  # it would enter the corridor out of turn
            timing = self._timing(state, j, track, fixed)
            if timing.success:
                steps = timing.cells
                yield Motion(way.points, track.cells[steps], track.arc[steps], track.segments)
