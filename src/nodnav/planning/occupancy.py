"""Where a robot may be when: cells along a path, motions along polylines, and the steps at which
cells are too close to another robot's motion, as bitsets (the fast planner's occupancy tables).

A robot's path is cut into cells; :func:`conflict_intervals` finds, in closed form, the steps at
which each cell is closer than the required separation to another robot moving along its own
polyline (:class:`Motion`); :func:`blocked_bits` turns those into one bitset per step, which
:mod:`nodnav.planning.timing` searches. :func:`separation_requirements` is the distance kept
between every pair, relaxed for pairs that start too close (:func:`relaxed_separation`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.geometry import TOL
from nodnav.planning.memo import remembered_property

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


def relaxed_separation(required: np.ndarray | float, distance: np.ndarray | float) -> np.ndarray:
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


@dataclass
class Motion:
    """A robot moving along a polyline: where it is at every step; afterwards it stays there."""

    path: np.ndarray
    """The polyline ``(V, 2)`` (m)."""
    samples: np.ndarray
    """Positions at steps ``0..T-1`` ``(T, 2)``, on the polyline (m)."""
    arc: np.ndarray
    """Arc length along the polyline at each step ``(T,)``, non-decreasing (m)."""
    segments: tuple = field(default=(), repr=False, compare=False)
    """Start points, unit directions, lengths and start arc lengths of the non-empty segments
    (:func:`polyline_segments`; computed in ``__post_init__`` when not given)."""

    def __post_init__(self):
        if not self.segments:
            object.__setattr__(self, "segments", polyline_segments(self.path))

    @property
    def last_step(self) -> int:
        """The step from which the robot stands still."""
        return len(self.samples) - 1

    @remembered_property
    def length(self) -> float:
        """The polyline's length, the sum of its segments' lengths (remembered: the plan of a
        robot is shared by the joint plans of many orders)."""
        return float(np.add.reduce(self.segments[2]))  # what .sum() calls, without its wrapper

    @remembered_property
    def sweep(self) -> tuple:
        """What :func:`conflict_intervals` needs of this motion whatever the cells: the matrix
        and offsets that give a point's coordinates along and across every segment, the
        segments' start arc lengths and lengths, and the steps whose move cuts a corner of the
        polyline, with the chords they follow."""
        q0, unit, length, s0 = self.segments
        basis, offset, step, chord_a, chord_b = _sweep_kernel(np.ascontiguousarray(q0), np.ascontiguousarray(unit), s0,
                                                              np.ascontiguousarray(self.arc), self.last_step,
                                                              np.ascontiguousarray(self.samples, dtype=float))
        return basis, offset, s0, length, step, chord_a, chord_b


@_compiled
def _sweep_kernel(q0, unit, s0, arc, last_step, samples):
    """The loops of :attr:`Motion.sweep`: the frames of the segments (along ``unit``, across
    ``(-unit_y, unit_x)``) as columns of a ``(2, 2S)`` matrix with their offsets, the steps
    ``t < last_step`` whose move from ``arc[t]`` to ``arc[t+1]`` passes a corner (strictly), and
    the ``samples`` at those steps and the steps after them (the chords' ends)."""
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
    chord_a, chord_b = np.empty((k, 2)), np.empty((k, 2))
    for i in range(k):
        for d in range(2):
            chord_a[i, d] = samples[step[i], d]
            chord_b[i, d] = samples[step[i] + 1, d]
    return basis, offset, step[:k], chord_a, chord_b


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


#: How much farther apart than the separation the boxes of :func:`boxes_apart` must be (m): far
#: above the rounding of the intervals' arithmetic on coordinates of a few metres.
BOX_MARGIN = 1e-6


def boxes_apart_plain(cells: np.ndarray, path: np.ndarray, samples: np.ndarray, required: float) -> bool:
    """:func:`boxes_apart` with NumPy (the reference it is tested against)."""
    if not len(cells) or not len(path):
        return False
    lo_c, hi_c = cells.min(axis=0), cells.max(axis=0)
    pts = np.concatenate((path, samples))
    lo_m, hi_m = pts.min(axis=0), pts.max(axis=0)
    gap = np.maximum(np.maximum(lo_c - hi_m, lo_m - hi_c), 0.0)
    return bool(gap[0] * gap[0] + gap[1] * gap[1] > (required + BOX_MARGIN) ** 2)


@_compiled
def _widen(box, pts):
    """Widen ``box`` (x min, x max, y min, y max) to hold the points ``pts`` ``(m, 2)``."""
    for i in range(pts.shape[0]):
        x, y = pts[i, 0], pts[i, 1]
        box[0] = min(box[0], x)
        box[1] = max(box[1], x)
        box[2] = min(box[2], y)
        box[3] = max(box[3], y)


@_compiled
def boxes_apart(cells, path, samples, required):
    """Whether the bounding box of ``cells`` and that of a motion's ``path`` and ``samples`` are
    more than ``required + BOX_MARGIN`` apart. Everything :func:`blocked_rows` measures the
    cells against lies in the motion's box (its stretches of the polyline, the chords between
    its samples, where it parks), so then no cell is closer than ``required`` to it at any step
    and its rows are all clear."""
    if cells.shape[0] == 0 or path.shape[0] == 0:
        return False
    c = np.array([np.inf, -np.inf, np.inf, -np.inf])
    m = np.array([np.inf, -np.inf, np.inf, -np.inf])
    _widen(c, cells)
    _widen(m, path)
    _widen(m, samples)
    gx = max(max(c[0] - m[1], m[0] - c[1]), 0.0)
    gy = max(max(c[2] - m[3], m[2] - c[3]), 0.0)
    limit = required + BOX_MARGIN
    return gx * gx + gy * gy > limit * limit


def blocked_rows(cells: np.ndarray, motion: Motion, required: float) -> np.ndarray:
    """:func:`blocked_bits` of :func:`_conflicts_with`'s intervals, one row per step of
    ``motion`` (``cells`` contiguous ``(N, 2)``), in one compiled call: the same bits."""
    basis, offset, s0, length, step, chord_a, chord_b = motion.sweep
    # The matrix product stays NumPy's (its rounding, see _conflicts_with); the offsets are
    # subtracted in the compiled call, element by element as NumPy would.
    product = cells @ basis if motion.last_step > 0 and len(length) else _NO_FRAME
    return _blocked_kernel(cells, product, offset, motion.samples[-1], motion.arc, s0, length, step, chord_a, chord_b,
                           motion.last_step, required, (required - TOL) ** 2)


#: The frame of a motion that does not move (the compiled loops do not read it).
_NO_FRAME = np.zeros((0, 0))


@_compiled
def _blocked_kernel(cells, product, offset, end, arc, s0, length, step, chord_a, chord_b, last_step, required,
                    parked2):
    """``frame = product - offset`` (in place, when the motion moves), :func:`_intervals_kernel`,
    then :func:`_close_kernel` into a new table of ``last_step + 1`` rows."""
    frame = product
    if last_step > 0 and length.shape[0] > 0:
        for c in range(frame.shape[0]):
            for j in range(frame.shape[1]):
                frame[c, j] = frame[c, j] - offset[j]
    cols, firsts, lasts = _intervals_kernel(cells, frame, end, arc, s0, length, step, chord_a, chord_b, last_step,
                                            required, parked2)
    bits = np.zeros((last_step + 1, (cells.shape[0] + 63) // 64), dtype=np.uint64)
    _close_kernel(bits, cols, firsts, lasts)
    return bits


@_compiled
def search_from(a, x, h, right):
    """``np.searchsorted(a, x, side="right" if right else "left")`` for a sorted ``a`` (no NaN),
    galloping from the index ``h`` (an earlier answer): doubling steps away from it bracket the
    answer, a binary search finds it in the bracket. The cells along a path ask for nearby arc
    lengths one after another, so the answer is mostly a step or two away."""
    n = a.shape[0]
    h = min(max(h, 0), n)
    if h < n and (a[h] <= x if right else a[h] < x):  # the answer is past h
        lo, width = h + 1, 1
        while lo + width - 1 < n and (a[lo + width - 1] <= x if right else a[lo + width - 1] < x):
            lo += width
            width *= 2
        hi = min(lo + width - 1, n)
    else:  # the answer is h or before it
        hi, width = h, 1
        while hi - width >= 0 and not (a[hi - width] <= x if right else a[hi - width] < x):
            hi -= width
            width *= 2
        lo = max(hi - width + 1, 0)
    while lo < hi:  # the first index in [lo, hi] whose value is past x (hi itself if none)
        mid = (lo + hi) // 2
        if a[mid] <= x if right else a[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


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
        # Per segment, where the searches of the cell before ended (see search_from).
        near_lo = np.zeros(n_seg, dtype=np.int64)
        near_hi = np.zeros(n_seg, dtype=np.int64)
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
                near_lo[j] = search_from(arc, lo + s0[j], near_lo[j], False)
                near_hi[j] = search_from(arc, hi + s0[j], near_hi[j], True)
                first = max(near_lo[j] - 1, 0)
                last = min(near_hi[j] - 1, last_step - 1)
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
    close_gates(bits, n_cells, 0, gates)
    return bits


@_compiled
def _close_kernel(bits, cols, first, last):
    """Set bit ``cols[i]`` in rows ``first[i]..last[i]`` of ``bits`` (clipped to its rows)."""
    n_rows = bits.shape[0]
    for i in range(cols.shape[0]):
        word, bit = cols[i] // 64, np.uint64(1) << np.uint64(cols[i] % 64)
        for t in range(max(first[i], 0), min(last[i], n_rows - 1) + 1):
            bits[t, word] |= bit


def close_gates(bits: np.ndarray, n_cells: int, t0: int, gates) -> None:
    """Close, in rows ``0..allowed-t0-1`` of ``bits`` (step ``t0`` onwards), the cells at and past
    ``cell`` of every gate ``(cell, allowed)``."""
    for cell, allowed in gates:
        if cell >= 0 and allowed > t0:
            bits[:allowed - t0] |= mask_words(n_cells, int(cell))


@functools.lru_cache(maxsize=4096)
def mask_words(n_cells: int, since: int) -> np.ndarray:
    """The cells ``since..n_cells-1`` as a row of 64-bit words (read-only: remembered, the
    planner asks for the same few masks at every step)."""
    words = (n_cells + 63) // 64
    mask = ((1 << n_cells) - 1) ^ ((1 << since) - 1)
    row = np.frombuffer(mask.to_bytes(8 * words, "little"), dtype="<u8").astype(np.uint64)
    row.setflags(write=False)
    return row


def relaxed_bits(cells: np.ndarray, motion: Motion, required: float, gap: float) -> np.ndarray:
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




def join_motions(head: Motion, tail: Motion) -> Motion:
    """``head`` up to its last step, then ``tail``, which starts where ``head`` ends."""
    return Motion(np.vstack([head.path, tail.path[1:]]), np.vstack([head.samples[:-1], tail.samples]),
                  np.concatenate([head.arc[:-1], tail.arc + head.length]))
