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
   walls, around the *current* positions of the robots after it in the order (so that every
   later robot can always wait where it is), and around the destinations of the robots before
   it (where they will park for good). When that is impossible the robot falls back to
   avoiding the destinations only, then the walls only; the timing step then decides.
4. Timing: the path is cut into cells of at most ``v_max dt / 2``; per time step the robot waits,
   advances one cell, or advances two (full speed; only where the straight chord between the
   two cells keeps clear of walls). The set of cells reachable at each step is a Python integer
   bitmask, ``reach[t+1] = (reach[t] | reach[t] << 1 | (reach[t] & ok2) << 2) & free[t+1]``,
   which makes the search exact and fast; ``free[t]`` removes every cell closer than the
   required separation to an earlier robot during ``[t, t+1]`` and, for corridor users, every
   cell past the corridor entrance until the order allows entry (below). The robot arrives at
   the first step at which its destination is reachable and stays free for good. Among the
   equally fast timings it waits early (holds back, then drives through), which makes its
   intention legible to the others' eq. (4), or, with ``waiting: late``, drives up and waits
   late (:func:`earliest_arrival_rows`).
5. A robot that an earlier robot's motion would corner at its current position, with no way out
   along its own path, backs out of the way instead: it goes first to a nearby spot that no
   earlier robot ever comes near, waits there, then goes to its destination.

Corridor rule (single file): a robot may enter the corridor only after every robot before it in
the order that uses the corridor has entered (same direction: following at a safe distance is
fine) and, for opposite directions, only after that robot has left it. Entry and exit are judged
on the samples with :meth:`World.in_corridor`, exactly as :func:`corridor_entry_order` does.

Cost: the sum over robots of their arrival times, in seconds after the request's time.

Reuse
-----
A robot's plan depends only on the state (positions, destinations, radii, speeds) and on which
robots go before it, so a planner instance remembers, in bounded memos, the order-independent
part of each state, each robot's plan per beginning of the order, and each prepared geometric
path; the closed loop asks for all ``N_r!`` orders from one state, and orders that share a
beginning share those plans. Results do not depend on what is remembered. Share one instance
between the robots of a trial to benefit from it.
"""

from __future__ import annotations

import bisect
import logging
import time
from dataclasses import dataclass, field, replace

import numpy as np

from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult, crossing_directions, feasible_order
from nodnav.planning.geometry import (
    TOL,
    GeometricPath,
    VisibilityGraph,
    arc_length_grid,
    polyline_point_distance,
    segment_clearance,
    segment_point_distance,
)
from nodnav.scenario.schema import PlannerParams
from nodnav.scenario.world import World

logger = logging.getLogger(__name__)

#: Radii (m) and number of directions of the rings of candidate spots a cornered robot may back
#: out to; the largest reach a room from anywhere in a corridor of the paper's length.
_RETREAT_RADII = (0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0)
_RETREAT_ANGLES = 16
#: How many of the nearest candidate spots are tried before giving up.
_RETREAT_TRIES = 8
#: How many entries each of a planner's memos keeps (a four-robot state needs about a hundred).
_MEMO_SIZE = 1024


# ---------------------------------------------------------------------------------------------
# Pure pieces


def separation_requirements(positions: np.ndarray, destinations: np.ndarray, radii: np.ndarray,
                            max_speeds: np.ndarray, dt: float, margin: float) -> np.ndarray:
    """Least centre distance kept between every pair at every sample, shape ``(n, n)`` (m).

    The appendix's validity condition is ``||p_i - p_j|| >= 2 r_robot``; the planner keeps
    ``r_i + r_j + margin``, raised where needed to ``sqrt((r_i + r_j)^2 + ((v_i + v_j) dt / 2)^2)``
    so that the condition also holds between samples: two relative positions at least ``s``
    apart whose difference is at most ``d`` are joined by a segment that stays at least
    ``sqrt(s^2 - d^2 / 4)`` from the origin. A pair that is already closer than that now, or
    whose destinations are, is held to that smaller distance (never below ``r_i + r_j``): the
    planner cannot undo the present and must be able to park both robots. Diagonal: 0.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 2)
    d = np.asarray(destinations, dtype=float).reshape(-1, 2)
    r = np.asarray(radii, dtype=float).reshape(-1)
    v = np.asarray(max_speeds, dtype=float).reshape(-1)
    contact = r[:, None] + r[None, :]
    between = np.sqrt(contact**2 + ((v[:, None] + v[None, :]) * dt / 2.0) ** 2)
    wanted = np.maximum(contact + margin, between)
    now = np.linalg.norm(p[:, None] - p[None], axis=2)
    parked = np.linalg.norm(d[:, None] - d[None], axis=2)
    req = np.minimum(wanted, np.maximum(contact, np.minimum(now, parked)))
    np.fill_diagonal(req, 0.0)
    return req


def corridor_passage(inside: np.ndarray) -> tuple[int, int]:
    """The last stay in the corridor along a sampled trajectory: ``(entry, exit)`` samples.

    ``entry`` is the first sample of the last run of samples inside, ``exit`` the first sample
    after it (``len(inside)`` if the trajectory ends inside); ``(-1, -1)`` if never inside.
    """
    inside = np.asarray(inside, dtype=bool)
    if not inside.any():
        return -1, -1
    last = len(inside) - 1 - int(np.argmax(inside[::-1]))
    before = np.nonzero(~inside[:last])[0]
    return (int(before[-1]) + 1 if len(before) else 0), last + 1


def entry_cell(inside: np.ndarray) -> int:
    """The first cell at which a path enters the corridor from outside, or -1.

    A path that starts inside has already entered; only a re-entry after leaving counts.
    """
    inside = np.asarray(inside, dtype=bool)
    start = 0
    if inside[0]:
        out = np.nonzero(~inside)[0]
        if not len(out):
            return -1
        start = int(out[0])
    rest = np.nonzero(inside[start:])[0]
    return start + int(rest[0]) if len(rest) else -1


def polyline_segments(path: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Start points, unit directions, lengths and start arc lengths of a polyline's non-empty segments."""
    path = np.asarray(path, dtype=float).reshape(-1, 2)
    vec = np.diff(path, axis=0)
    length = np.hypot(vec[:, 0], vec[:, 1])
    keep = length > 0
    arc0 = np.concatenate([[0.0], np.cumsum(length)])[:-1]
    return path[:-1][keep], vec[keep] / length[keep, None], length[keep], arc0[keep]


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


def conflict_intervals(cells: np.ndarray, motions, required) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Steps at which cells are too close to other robots: intervals ``(cell, first, last)``.

    Cell ``c`` conflicts with the robot of ``motions[i]`` at step ``t`` when it is closer than
    ``required[i]`` to where that robot is during ``[t, t+1]``: the stretch of its polyline
    between ``arc[t]`` and ``arc[t+1]`` and, where that stretch turns a corner, also the
    straight chord it follows in between. For each cell and each segment of a polyline the arc
    lengths within ``required`` form one interval, found in closed form (half-chord
    ``sqrt(required^2 - d_perp^2)`` about the foot of the perpendicular); the steps whose
    stretch meets it follow by binary search. ``last`` may exceed any horizon (parked for good).
    Returns three integer arrays of equal length.
    """
    cells = np.asarray(cells, dtype=float)
    required = np.asarray(required, dtype=float).reshape(-1)
    if not len(motions):
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, empty
    forever = np.iinfo(np.int64).max // 2
    last_step = np.array([m.last_step for m in motions])
    ends = np.array([m.samples[-1] for m in motions])
    cx, cy = cells[:, 0:1], cells[:, 1:2]
    dx, dy = cx - ends[:, 0], cy - ends[:, 1]
    c, i = np.nonzero(dx * dx + dy * dy < (required - TOL) ** 2)
    cols, firsts, lasts = [c], [last_step[i]], [np.full(len(c), forever)]
    moving = [k for k, m in enumerate(motions) if last_step[k] > 0 and len(m.segments[2])]
    if not moving:
        return c, last_step[i], lasts[0]
    # The moving robots' step-indexed arc lengths are laid end to end, each shifted past the
    # previous one, so that one binary search serves them all.
    shift = np.concatenate([[0.0], np.cumsum([m.arc[-1] + 1.0 for m in motions])])[:-1]
    base = np.concatenate([[0], np.cumsum([len(m.arc) for m in motions])])[:-1]
    line = np.concatenate([m.arc + o for m, o in zip(motions, shift)])
    q0, unit, length, s0 = (np.concatenate([motions[k].segments[f] for k in moving]) for f in range(4))
    owner = np.repeat(moving, [len(motions[k].segments[2]) for k in moving])
    # Coordinates of every cell along and across every segment, in one product.
    basis = np.concatenate([unit, unit[:, ::-1] * (-1.0, 1.0)])
    frame = cells @ basis.T - (np.concatenate([q0, q0]) * basis).sum(axis=1)
    along, perp = frame[:, :len(unit)], frame[:, len(unit):]
    reach = required[owner]
    half2 = reach * reach - perp * perp
    half = np.sqrt(np.maximum(half2, 0.0))
    lo = np.maximum(along - half, 0.0)
    hi = np.minimum(along + half, length)
    c, j = np.nonzero((half2 > TOL * reach) & (lo <= hi))
    k = owner[j]
    offset = s0[j] + shift[k]
    first = np.maximum(np.searchsorted(line, lo[c, j] + offset, side="left") - base[k] - 1, 0)
    last = np.minimum(np.searchsorted(line, hi[c, j] + offset, side="right") - 1 - base[k], last_step[k] - 1)
    ok = first <= last
    cols.append(c[ok])
    firsts.append(first[ok])
    lasts.append(last[ok])
    # Steps whose move cuts a corner of a polyline: check the chord itself as well.
    inner = np.flatnonzero(owner[1:] == owner[:-1]) + 1
    k = owner[inner]
    corner = s0[inner] + shift[k]
    step = np.searchsorted(line, corner, side="left") - 1 - base[k]
    valid = (step >= 0) & (step < last_step[k])
    step, k, corner = step[valid], k[valid], corner[valid]
    cut = line[base[k] + step + 1] > corner
    step, k = step[cut], k[cut]
    if len(step):
        samples = np.concatenate([m.samples for m in motions])
        at = base[k] + step
        t, c = np.nonzero(segment_point_distance(samples[at], samples[at + 1], cells) < required[k][:, None] - TOL)
        cols.append(c)
        firsts.append(step[t])
        lasts.append(step[t])
    return np.concatenate(cols), np.concatenate(firsts), np.concatenate(lasts)


def blocked_bits(n_cells: int, n_rows: int, intervals, entry: int = -1, allowed: int = 0) -> np.ndarray:
    """The cells that may not be occupied at each step, as bitsets: ``(n_rows, W)`` little-endian
    64-bit words, bit ``c`` of row ``t`` set when cell ``c`` is closed at step ``t``.

    ``intervals`` is an iterable of ``(cell, first, last)`` arrays (see
    :func:`conflict_intervals`); cells at and past ``entry`` are also closed before step
    ``allowed`` (the corridor rule). Overlapping intervals of a cell are merged first, so that
    each cell's bit is added once where an interval starts and subtracted once after it ends;
    a running sum down the steps then sets exactly the closed bits, without carries.
    """
    words = (n_cells + 63) // 64
    diff = np.zeros((n_rows + 1, words), dtype="<u8")
    parts = list(intervals)
    if parts:
        cols, first, last = (np.concatenate(x).astype(np.int64) for x in zip(*parts))
        now = first < n_rows
        cols, first, last = cols[now], first[now], np.minimum(last[now], n_rows - 1)
        if len(cols):
            span = n_rows + 2
            a, b = cols * span + first, cols * span + last
            order = np.argsort(a, kind="stable")
            a, b = a[order], np.maximum.accumulate(b[order])
            opens = np.r_[True, a[1:] > b[:-1] + 1]
            start, stop = a[opens], b[np.r_[opens[1:], True]]
            cell = start // span
            bit = np.left_shift(np.uint64(1), (cell % 64).astype(np.uint64))
            np.add.at(diff, (start % span, cell // 64), bit)
            np.subtract.at(diff, (stop % span + 1, cell // 64), bit)
    bits = np.cumsum(diff[:-1], axis=0, dtype="<u8")
    if entry >= 0 and allowed > 0:
        gate = ((1 << n_cells) - 1) ^ ((1 << entry) - 1)
        bits[:allowed] |= np.frombuffer(gate.to_bytes(8 * words, "little"), dtype="<u8")
    return bits


def free_rows(bits: np.ndarray, n_cells: int) -> tuple[list[int], list[int]]:
    """The free cells of each step as Python integers (bit ``c``: cell ``c`` is free), and the
    steps at which they change (runs of equal steps share one integer)."""
    full = (1 << n_cells) - 1
    bits = np.ascontiguousarray(bits, dtype="<u8")
    buf = bits.tobytes()
    size = 8 * bits.shape[1]
    starts = np.flatnonzero(np.concatenate([[True], (bits[1:] != bits[:-1]).any(axis=1)])).tolist()
    rows: list[int] = []
    for a, b in zip(starts, starts[1:] + [len(bits)]):
        rows.extend([full ^ int.from_bytes(buf[a * size:(a + 1) * size], "little")] * (b - a))
    return rows, starts


def free_cells(n_cells: int, n_rows: int, intervals, entry: int = -1, allowed: int = 0) -> np.ndarray:
    """The cells free at each step as a boolean array ``(n_rows, n_cells)`` (see :func:`blocked_bits`)."""
    bits = blocked_bits(n_cells, n_rows, intervals, entry, allowed)
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
    """:func:`earliest_arrival_rows` for a boolean array ``free[t, c]`` ``(n_rows, n_cells)``."""
    free = np.asarray(free, dtype=bool)
    n_rows, n_cells = free.shape
    closed = np.zeros((n_rows, 8 * ((n_cells + 63) // 64)), dtype=np.uint8)
    packed = np.packbits(~free, axis=1, bitorder="little")
    closed[:, :packed.shape[1]] = packed
    return earliest_arrival_rows(*free_rows(closed.view("<u8"), n_cells), n_cells, ok2, wait_early)


def earliest_arrival_rows(rows: list[int], starts: list[int], n_cells: int, ok2: np.ndarray,
                          wait_early: bool = True) -> Timing:
    """Earliest arrival along a line of cells, moving 0, 1 or 2 cells per step (exact search).

    ``rows[t]`` has bit ``c`` set when cell ``c`` may be occupied at step ``t``; steps past the
    last row repeat it (everything stands still by then); ``starts`` lists the steps at which
    ``rows`` changes, in increasing order. ``ok2[c]`` allows the two-cell move
    ``c -> c+2``. The robot starts in cell 0 at step 0 whatever ``rows[0]`` says (it is there),
    and arrives at the first step at which the last cell is reachable and stays free from then
    on. The reachable sets are bitmasks, one Python integer per step,
    ``reach[t+1] = (reach[t] | reach[t] << 1 | (reach[t] & ok2) << 2) & rows[t+1]``.
    Every cell sequence consistent with that arrival is equally fast; backtracking picks, at
    every step, the nearest such cell with ``wait_early`` (the robot holds back first and then
    drives through at full speed) and the farthest one otherwise (it drives up and waits late).
    Waiting early is the default because it makes a yielding robot's intention visible at once:
    in eq. (4) its plans for "I go first" and "I yield" then differ from the first window on,
    instead of only once it reaches the corridor. When driving at full speed meets no obstacle, that is
    the answer and the search is skipped; while the steps stay the same and the reachable set
    stops growing, the search jumps to the next change.
    """
    n_rows, n = len(rows), n_cells
    goal = 1 << (n - 1)
    step2 = int.from_bytes(np.packbits(np.asarray(ok2, dtype=bool)[:n], bitorder="little").tobytes(), "little")
    last_row = rows[-1]
    if not last_row & goal:
        return Timing(False, "its destination stays blocked by a robot parked next to it", np.zeros(1, dtype=int))
    earliest = 0
    for t in range(n_rows - 1, 0, -1):
        if not rows[t] & goal:
            earliest = t + 1
            break
    if (~step2) & ((1 << max(n - 2, 0)) - 1):
        dash = [0]
        c = 0
        while c < n - 1:
            c += 2 if c + 2 < n and (step2 >> c) & 1 else 1
            dash.append(c)
    else:
        dash = list(range(0, n - 1, 2)) + [n - 1]
    if len(dash) > earliest and all((rows[t] if t < n_rows else last_row) >> c & 1 for t, c in enumerate(dash) if t):
        return Timing(True, "", np.array(dash))
    reach = [1]
    r = 1
    t = 0
    while not (r & goal and t >= earliest):
        t += 1
        row = rows[t] if t < n_rows else last_row
        nxt = (r | (r << 1) | ((r & step2) << 2)) & row
        if nxt == 0:
            return Timing(False, f"cornered at step {t}: every cell it can reach is too close to an earlier robot",
                          np.zeros(1, dtype=int), trapped_at=t)
        if nxt == r:
            if t >= n_rows:
                return Timing(False, "cannot reach its destination: its path stays blocked after every earlier "
                                     "robot has parked", np.zeros(1, dtype=int))
            # Nothing changes while the steps stay the same: jump to the last step of the run
            # (or to when the destination is free for good), sharing one object.
            run = bisect.bisect_right(starts, t)
            end = starts[run] - 1 if run < len(starts) else n_rows - 1
            if r & goal:
                end = min(end, max(t, earliest))
            if end > t:
                reach.extend([r] * (end - t))
                t = end
        else:
            r = nxt
        reach.append(r)
    cells = np.empty(t + 1, dtype=int)
    c = n - 1
    for s in range(t, 0, -1):
        cells[s] = c
        prev = reach[s - 1]
        if wait_early:
            if c >= 2 and (prev >> (c - 2)) & (step2 >> (c - 2)) & 1:
                c -= 2
            elif c >= 1 and (prev >> (c - 1)) & 1:
                c -= 1
        elif not (prev is reach[s] or (prev >> c) & 1):
            c = c - 1 if (prev >> (c - 1)) & 1 else c - 2
    cells[0] = c
    return Timing(True, "", cells)


def _dash_clashes(path: np.ndarray, step: float, others: np.ndarray, required: np.ndarray) -> bool:
    """Whether driving along ``path`` at ``step`` per step and then standing at its end comes
    closer than ``required`` to robots at ``others[t]`` ``(T, m, 2)`` at some step."""
    grid = arc_length_grid(path, step).points
    at = grid[np.minimum(np.arange(len(others)), len(grid) - 1)]
    gap = np.linalg.norm(others - at[:, None], axis=2)
    return bool((gap < required - TOL).any())


def retreat_spots(centre: np.ndarray) -> np.ndarray:
    """Candidate spots to back out to: rings of points around ``centre``, shape ``(M, 2)``."""
    ang = 2.0 * np.pi * np.arange(_RETREAT_ANGLES) / _RETREAT_ANGLES
    ring = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    return (np.asarray(centre, dtype=float)[None, None] + np.asarray(_RETREAT_RADII)[:, None, None] * ring[None]).reshape(-1, 2)


# ---------------------------------------------------------------------------------------------
# The planner


@dataclass(frozen=True)
class _Route:
    """One robot's geometric path and the standing robots (discs) it keeps clear of."""

    path: GeometricPath
    centres: np.ndarray
    radii: np.ndarray


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
    segments: tuple
    """The path's segments, :func:`polyline_segments`."""


@dataclass(frozen=True)
class _RobotPlan:
    """One robot's planned motion."""

    motion: Motion
    """Its polyline and where it is along it at steps ``0..arrival``."""
    passage: tuple[int, int]
    """``(entry, exit)`` samples of its last stay in the corridor, see :func:`corridor_passage`."""
    retreat: bool = False
    """Whether it backs out of an earlier robot's way first."""

    @property
    def arrival(self) -> int:
        return self.motion.last_step


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
    end_clearance: np.ndarray
    """Least of the clearances of each robot's position and destination (m)."""
    problem: str
    """Why no order can be planned (a destination outside free space, overlapping ones), or empty."""


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


class PrioritizedPlanner:
    """Prioritised space-time planner (see the module docstring); deterministic, no precomputation."""

    name = "fast"

    def __init__(self, world: World, params: PlannerParams | None = None):
        self.world = world
        self.params = params if params is not None else PlannerParams()
        self._graphs: dict[tuple[World, float], VisibilityGraph] = {}
        self._tracks: dict[tuple, _Track] = {}
        self._states: dict[tuple, _State] = {}
        self._attempts: dict[tuple, _Attempt] = {}

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
        result = self._plan(request)
        return replace(result, compute_time=time.perf_counter() - began)

    # -----------------------------------------------------------------------------------------

    def _plan(self, request: PlanRequest) -> PlanResult:
        world = request.world
        dt = float(self.params.dt)
        # Copies: the memos keep them, and the caller may reuse its arrays.
        pos = np.array(request.positions, dtype=float).reshape(-1, 2)
        dest = np.array(request.destinations, dtype=float).reshape(-1, 2)
        radii = np.array(request.radii, dtype=float).reshape(-1)
        vmax = np.array(request.max_speeds, dtype=float).reshape(-1)
        n = len(pos)
        order = tuple(int(k) for k in request.order)
        if (sorted(order) != list(range(n)) or dest.shape != pos.shape or radii.shape != (n,) or vmax.shape != (n,)
                or not (np.isfinite(pos).all() and np.isfinite(dest).all() and (radii > 0).all() and (vmax > 0).all())):
            raise ValueError(f"malformed request: order {order} for {n} robots, positions {pos.shape}, destinations "
                             f"{dest.shape}, radii {radii.tolist()}, max_speeds {vmax.tolist()}")
        state = self._state(world, pos, dest, radii, vmax, dt)
        entered = tuple(int(k) for k in request.entered)
        entered += tuple(k for k in order if state.inside[k] and k not in entered)
        planned = feasible_order(order, entered)

        def failure(reason: str) -> PlanResult:
            logger.debug("fast planner: order %s failed: %s", planned, reason)
            return replace(PlanResult.failure(request, reason), order_planned=planned)

        if state.problem:
            return failure(state.problem)
        plans: dict[int, _RobotPlan] = {}
        for rank, k in enumerate(planned):
            # A robot's plan depends only on the state and on who goes before it (the rest go
            # after), so orders that share a beginning share those plans.
            key = (state.key, planned[:rank + 1])
            attempt = self._attempts.get(key)
            if attempt is None:
                attempt = self._plan_robot(world, state, k, planned[:rank], planned[rank + 1:], plans, dt)
                _remember(self._attempts, key, attempt)
            if not attempt.success:
                return failure(f"robot {k}: {attempt.reason}")
            plans[k] = attempt.plan
        return self._result(request, order, planned, entered, plans, dt)

    def _state(self, world: World, pos: np.ndarray, dest: np.ndarray, radii: np.ndarray, vmax: np.ndarray,
               dt: float) -> _State:
        """What every order planned from this state shares (memoised)."""
        key = (world, pos.tobytes(), dest.tobytes(), radii.tobytes(), vmax.tobytes())
        state = self._states.get(key)
        if state is None:
            clear = world.clearance(np.vstack([pos, dest]))
            n = len(pos)
            state = _State(key, pos, dest, radii, vmax, separation_requirements(pos, dest, radii, vmax, dt, self.params.margin),
                           crossing_directions(world, pos, dest), world.in_corridor(pos),
                           np.minimum(clear[:n], clear[n:]), _state_problem(dest, clear[n:], radii))
            _remember(self._states, key, state)
            # Every robot's path among the walls alone is the first thing any order asks for.
            for radius in np.unique(radii):
                group = radii == radius
                self.graph(world, radius).shortest_paths(pos[group], dest[group])
        return state

    def _plan_robot(self, world: World, state: _State, k: int, earlier: tuple[int, ...], later: tuple[int, ...],
                    plans: dict[int, _RobotPlan], dt: float) -> _Attempt:
        """Robot ``k``'s path and timing, after the robots ``earlier`` and before ``later``."""
        pos, dest, radii, vmax, req = state.positions, state.destinations, state.radii, state.max_speeds, state.required
        centres = np.vstack([pos[list(later)], dest[list(earlier)]]).reshape(-1, 2)
        rads = np.concatenate([req[k, list(later)], req[k, list(earlier)]])
        track = self._track(world, radii[k], vmax[k] * dt, pos[k], dest[k], centres, rads, len(later),
                            state.end_clearance[k])
        if not track.route.path.success:
            return _Attempt(False, track.route.path.reason)
        attempt = self._time(world, k, track, plans, earlier, req, state.directions)
        if not attempt.success and attempt.trapped:
            retreat = self._retreat(world, k, state, plans, earlier, later, centres, rads, dt)
            if retreat.success:
                return retreat
        return attempt

    def _track(self, world: World, radius: float, step: float, start: np.ndarray, goal: np.ndarray,
               centres: np.ndarray, rads: np.ndarray, n_later: int, end_clearance: float) -> _Track:
        """The robot's prepared path (memoised: the closed loop asks the same from every order)."""
        key = (world, radius, step, start.tobytes(), goal.tobytes(), centres.tobytes(), rads.tobytes(), n_later)
        track = self._tracks.get(key)
        if track is None:
            route = self._route(world, radius, start, goal, centres, rads, n_later)
            track = self._prepare(world, radius, step, route, end_clearance)
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
        for c, r in attempts:
            path = graph.shortest_path(start, goal, c, r)
            if path.success:
                break
        return _Route(path, c, r)

    def _prepare(self, world: World, radius: float, step: float, route: _Route, end_clearance: float) -> _Track:
        """Cut the path into cells of at most half a step and find the allowed full-speed moves.

        A move ``c -> c+2`` leaves the polyline only where it cuts a corner; there the straight
        chord must keep the robot's radius from the walls (or not go deeper than its ends
        already are) and must not come closer to a standing robot than the polyline does. The
        polyline keeps ``g = min(radius + wall margin, end_clearance)`` from the walls (the least
        clearance of its two ends),
        and no point of a chord is farther from the polyline than the corner is from the chord
        (``h``), so ``g - h >= radius`` settles most corners without computing distances.
        """
        grid = arc_length_grid(route.path.points, step / 2.0)
        cells = grid.points
        n = len(cells)
        ok = np.zeros(n, dtype=bool)
        if n >= 3:
            ok[:n - 2] = True
            u, w = cells[1:-1] - cells[:-2], cells[2:] - cells[1:-1]
            cross = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
            corners = np.nonzero(np.abs(cross) > 1e-12)[0]
            if len(corners):
                a, b = cells[corners], cells[corners + 2]
                height = np.abs(cross[corners]) / np.linalg.norm(b - a, axis=1)
                polyline_clearance = min(radius + self.wall_margin, end_clearance)
                good = polyline_clearance - height >= radius
                unsure = np.nonzero(~good)[0]
                if len(unsure):
                    au, bu = a[unsure], b[unsure]
                    limit = np.minimum(radius, np.minimum(world.clearance(au), world.clearance(bu)))
                    good[unsure] = segment_clearance(world, au, bu) >= limit - TOL
                if len(route.centres):
                    keep = np.minimum(route.radii, polyline_point_distance(route.path.points, route.centres))
                    good &= (segment_point_distance(a, b, route.centres) >= keep - TOL).all(axis=1)
                ok[corners] = good
        inside = world.in_corridor(cells)
        return _Track(route, cells, grid.arc_length, ok, inside, entry_cell(inside), polyline_segments(route.path.points))

    def _time(self, world: World, k: int, track: _Track, plans: dict[int, _RobotPlan], earlier: tuple[int, ...],
              req: np.ndarray, dirs: np.ndarray) -> _Attempt:
        """Velocity tuning of robot ``k`` along ``track`` among the robots planned before it."""
        allowed = 0
        if track.entry >= 0:
            for i in earlier:
                e_i, x_i = plans[i].passage
                if e_i < 0:
                    continue
                if dirs[i] == dirs[k] != 0:
                    allowed = max(allowed, e_i + 1)
                elif x_i > plans[i].arrival:
                    return _Attempt(False, f"robot {i} before it in the order parks inside the corridor")
                else:
                    allowed = max(allowed, x_i + 1)
        cells = track.cells
        n_rows = max([plans[i].arrival + 1 for i in earlier] + [allowed + 1])
        conflicts = conflict_intervals(cells, [plans[i].motion for i in earlier], req[list(earlier), k])
        bits = blocked_bits(len(cells), n_rows, [conflicts], track.entry, allowed)
        timing = earliest_arrival_rows(*free_rows(bits, len(cells)), len(cells), track.ok2,
                                       self.params.waiting == "early")
        if not timing.success:
            return _Attempt(False, timing.reason, trapped=timing.trapped_at >= 0)
        steps = timing.cells
        motion = Motion(track.route.path.points, cells[steps], track.arc[steps], track.segments)
        return _Attempt(True, "", _RobotPlan(motion, corridor_passage(track.inside[steps])))

    def _retreat(self, world: World, k: int, state: _State, plans: dict[int, _RobotPlan], earlier: tuple[int, ...],
                 later: tuple[int, ...], centres: np.ndarray, rads: np.ndarray, dt: float) -> _Attempt:
        """Back robot ``k`` out of the way: via the cheapest nearby spot where it can wait for good."""
        pos, dest, radii, vmax, req = state.positions, state.destinations, state.radii, state.max_speeds, state.required
        graph = self.graph(world, radii[k])
        spots = retreat_spots(pos[k])
        ok = (world.clearance(spots) >= graph.clearance - TOL) & ~world.in_corridor(spots)
        for j in later:
            ok &= np.linalg.norm(spots - pos[j], axis=1) >= req[k, j] - TOL
        for i in earlier:
            s = plans[i].motion.samples
            a, b = (s[:-1], s[1:]) if len(s) > 1 else (s, s)
            ok &= segment_point_distance(a, b, spots).min(axis=0) >= req[i, k] - TOL
        spots = spots[ok]
        # Spots that the robot can reach at full speed without meeting anyone first, nearest
        # along free space first: a cornered robot must get out of the way in time.
        ways = graph.shortest_paths(np.repeat(pos[k][None], len(spots), 0), spots)
        horizon = max([plans[i].arrival for i in earlier] + [0])
        others = np.stack([plans[i].motion.samples[np.minimum(np.arange(horizon + 1), plans[i].arrival)]
                           for i in earlier], axis=1) if earlier else np.zeros((horizon + 1, 0, 2))
        need = req[list(earlier), k]
        clash = np.array([_dash_clashes(w.points, vmax[k] * dt, others, need) if w.success else True for w in ways])
        length = np.array([w.length for w in ways])
        reason = "cornered by an earlier robot, and no spot nearby to back out to"
        for q in spots[np.lexsort((length, clash))[:_RETREAT_TRIES]]:
            out = graph.shortest_path(pos[k], q, centres, rads)
            back = graph.shortest_path(q, dest[k], centres, rads)
            if not (out.success and back.success):
                continue
            points = np.vstack([out.points, back.points[1:]])
            route = _Route(GeometricPath(True, "", points, out.length + back.length), centres, rads)
            track = self._prepare(world, radii[k], vmax[k] * dt, route, state.end_clearance[k])
            attempt = self._time(world, k, track, plans, earlier, req, state.directions)
            if attempt.success:
                logger.debug("fast planner: robot %d backs out to (%.2f, %.2f)", k, q[0], q[1])
                return _Attempt(True, "", replace(attempt.plan, retreat=True))
            reason = f"cornered by an earlier robot; backing out failed too: {attempt.reason}"
        return _Attempt(False, reason)

    def _result(self, request: PlanRequest, order, planned, entered, plans: dict[int, _RobotPlan], dt: float) -> PlanResult:
        n = len(plans)
        steps = max(p.arrival for p in plans.values()) + 1
        positions = np.empty((steps, n, 2))
        for k, p in plans.items():
            positions[:p.arrival + 1, k] = p.motion.samples
            positions[p.arrival + 1:, k] = p.motion.samples[-1]
        times = request.t0 + dt * np.arange(steps)
        trajectory = JointTrajectory.from_positions(times, positions)
        arrival = np.array([plans[k].arrival * dt for k in range(n)])
        lengths = np.array([float(plans[k].motion.segments[2].sum()) for k in range(n)])
        retreats = tuple(k for k in planned if plans[k].retreat)
        notes = []
        if planned != order:
            notes.append(f"order {order} repaired to {planned}: robots {entered} have already entered the corridor")
        if retreats:
            notes.append(f"robots {retreats} back out of the way of robots before them")
        info = {
            "arrival_times": arrival,
            "path_lengths": lengths,
            "paths": tuple(plans[k].motion.path for k in range(n)),
            "retreats": retreats,
            "entered": entered,
        }
        return PlanResult(True, "; ".join(notes), float(arrival.sum()), trajectory, order, planned, 0.0, info)

