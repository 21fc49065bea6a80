"""The compiled steps of a visibility graph's queries among the walls alone
(:meth:`nodnav.planning.visibility.VisibilityGraph.shortest_paths`): the segments to check, the
best way through the graph, and the paths' points and lengths, for many queries in a few calls
instead of a few NumPy calls per query."""

from __future__ import annotations

import math

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.planning.polylines import SEQUENTIAL_SUM

#: What a query's answer is (:func:`walls_paths`): no path, the straight segment, or a way through the graph.
NONE, DIRECT, VIA = 0, 1, 2


@_compiled
def segments_to_check(starts, goals, vertices, c_start, c_goal, clearance, tol):
    """The segments whose clearance decides ``m`` queries, and the clearance each needs, as
    ``(a, b, need, one_start)``: each start to its goal (needing the lesser of their thresholds
    ``min(clearance, c) - tol``, ``c`` the end's own clearance), each start to every vertex, each
    goal to every vertex. When every start is the same point with the same threshold
    (``one_start``: the ways from one spot to the waiting spots around it), the start's segments
    are listed once, for the first start: a segment's answer depends on it alone."""
    m, nv = starts.shape[0], vertices.shape[0]
    thr_start = np.empty(m)
    thr_goal = np.empty(m)
    for i in range(m):
        thr_start[i] = min(clearance, c_start[i]) - tol
        thr_goal[i] = min(clearance, c_goal[i]) - tol
    one_start = m > 1
    for i in range(1, m):
        if not (starts[i, 0] == starts[0, 0] and starts[i, 1] == starts[0, 1] and thr_start[i] == thr_start[0]):
            one_start = False
            break
    ns = 1 if one_start else m
    size = m + ns * nv + m * nv
    a = np.empty((size, 2))
    b = np.empty((size, 2))
    need = np.empty(size)
    for i in range(m):
        a[i, 0], a[i, 1] = starts[i, 0], starts[i, 1]
        b[i, 0], b[i, 1] = goals[i, 0], goals[i, 1]
        need[i] = min(thr_start[i], thr_goal[i])
    k = _to_vertices(starts, thr_start, ns, vertices, a, b, need, m)
    _to_vertices(goals, thr_goal, m, vertices, a, b, need, k)
    return a, b, need, one_start


@_compiled
def _to_vertices(points, thresholds, count, vertices, a, b, need, k):
    """Write the segments from each of the first ``count`` ``points`` to every vertex into
    ``a``, ``b`` and ``need`` from row ``k`` on, each needing its point's threshold; returns the
    next free row."""
    for i in range(count):
        for j in range(vertices.shape[0]):
            a[k, 0], a[k, 1] = points[i, 0], points[i, 1]
            b[k, 0], b[k, 1] = vertices[j, 0], vertices[j, 1]
            need[k] = thresholds[i]
            k += 1
    return k


@_compiled
def walls_answers(starts, goals, vertices, seen, one_start, dist, pred, c_start, c_goal, least):
    """Every query's answer from the segments' clearances ``seen`` (in
    :func:`segments_to_check`'s order): its kind, ``NONE`` unless the start's clearance is at
    least 0 and the goal's at least ``least``, then ``DIRECT`` if the straight segment is clear,
    else ``VIA`` if the graph joins a vertex seen from the start to one seen from the goal
    (:func:`best_via`, each leg ``hypot`` of the differences as NumPy's), else ``NONE``; and the
    paths as :func:`walls_paths` gives them, ``(kind, points, offsets, lengths)``."""
    m, nv = starts.shape[0], vertices.shape[0]
    ns = 1 if one_start else m
    d_start = np.full((m, nv), np.inf)
    d_goal = np.full((m, nv), np.inf)
    from_start = np.zeros((m, nv), dtype=np.bool_)
    to_goal = np.zeros((m, nv), dtype=np.bool_)
    for i in range(m):
        row_s = m + (0 if one_start else i * nv)
        row_g = m + ns * nv + i * nv
        for j in range(nv):
            if seen[row_s + j]:
                from_start[i, j] = True
                d_start[i, j] = math.hypot(vertices[j, 0] - starts[i, 0], vertices[j, 1] - starts[i, 1])
            if seen[row_g + j]:
                to_goal[i, j] = True
                d_goal[i, j] = math.hypot(vertices[j, 0] - goals[i, 0], vertices[j, 1] - goals[i, 1])
    best, cost = _best_via_kernel(d_start, dist, d_goal, from_start, to_goal)
    kind = np.zeros(m, dtype=np.int64)
    for i in range(m):
        if c_start[i] >= 0.0 and c_goal[i] >= least:
            if seen[i]:
                kind[i] = DIRECT
            elif nv > 0 and math.isfinite(cost[i]):
                kind[i] = VIA
    points, offsets, lengths = walls_paths(starts, goals, vertices, pred, kind, best)
    return kind, points, offsets, lengths


@_compiled
def walls_paths(starts, goals, vertices, pred, kind, best):
    """The points of every query's path, stacked ``(K, 2)``, with where each begins ``(m + 1,)``
    and its length ``(m,)``: ``[start, goal]`` for a ``DIRECT`` query, the start, the graph's
    chain of vertices from ``best // V`` to ``best % V`` (followed back along the predecessors
    ``pred``) and the goal for a ``VIA`` one, nothing for ``NONE``. A length is that of
    :func:`~nodnav.planning.polylines.polyline_length` (each segment ``sqrt(x * x + y * y)``,
    summed from zero in order) for paths of at most ``SEQUENTIAL_SUM`` segments, ``-1`` for
    longer ones (NumPy sums those pairwise) and for ``NONE``."""
    m, nv = starts.shape[0], vertices.shape[0]
    offsets = np.zeros(m + 1, dtype=np.int64)
    for i in range(m):
        count = 0
        if kind[i] == DIRECT:
            count = 2
        elif kind[i] == VIA:
            first, last = best[i] // nv, best[i] % nv
            count = 3
            at = last
            while at != first:
                at = pred[first, at]
                count += 1
        offsets[i + 1] = offsets[i] + count
    points = np.empty((offsets[m], 2))
    lengths = np.full(m, -1.0)
    for i in range(m):
        o, e = offsets[i], offsets[i + 1]
        if e == o:
            continue
        points[o, 0], points[o, 1] = starts[i, 0], starts[i, 1]
        points[e - 1, 0], points[e - 1, 1] = goals[i, 0], goals[i, 1]
        if kind[i] == VIA:
            first, last = best[i] // nv, best[i] % nv
            at = last
            q = e - 2
            points[q, 0], points[q, 1] = vertices[at, 0], vertices[at, 1]
            while at != first:
                at = pred[first, at]
                q -= 1
                points[q, 0], points[q, 1] = vertices[at, 0], vertices[at, 1]
        if e - o <= SEQUENTIAL_SUM + 1:
            total = 0.0
            for s in range(o, e - 1):
                dx = points[s + 1, 0] - points[s, 0]
                dy = points[s + 1, 1] - points[s, 1]
                total += math.sqrt(dx * dx + dy * dy)
            lengths[i] = total
    return points, offsets, lengths


def best_via(d_start: np.ndarray, dist: np.ndarray, d_goal: np.ndarray, from_start: np.ndarray,
             to_goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each query ``q``, the first pair ``(first, last)`` (as ``first * V + last``) in row-major
    order minimising ``d_start[q, first] + dist[first, last] + d_goal[q, last]``, and that least
    sum. Only the vertices seen from the start and from the goal are summed (the rest are
    ``inf``): the same pair and value as the whole ``(V, V)`` table, at a fraction of its cost
    on a map's graph of a thousand vertices. One compiled loop (:func:`_best_via_kernel`);
    :func:`best_via_plain` is the NumPy version it is tested against."""
    return _best_via_kernel(d_start, dist, d_goal, from_start, to_goal)


def best_via_plain(d_start: np.ndarray, dist: np.ndarray, d_goal: np.ndarray, from_start: np.ndarray,
                   to_goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`best_via` with NumPy: the sums of the seen pairs as a table, its first least entry."""
    m, nv = d_start.shape
    best = np.zeros(m, dtype=np.int64)
    cost = np.full(m, np.inf)
    for q in range(m):
        fs, tg = np.flatnonzero(from_start[q]), np.flatnonzero(to_goal[q])
        if not (len(fs) and len(tg)):
            continue
        total = d_start[q, fs][:, None] + dist[np.ix_(fs, tg)] + d_goal[q, tg][None, :]
        k = int(total.argmin())
        best[q], cost[q] = fs[k // len(tg)] * nv + tg[k % len(tg)], total.flat[k]
    return best, cost


@_compiled
def _best_via_kernel(d_start, dist, d_goal, from_start, to_goal):
    """:func:`best_via_plain` as loops: the same sums (start leg plus the graph's distance, then
    the goal leg), the first least in the same row-major order (a strictly smaller sum replaces
    it, as ``argmin`` keeps the first of equal ones)."""
    m, nv = d_start.shape
    best = np.zeros(m, dtype=np.int64)
    cost = np.full(m, np.inf)
    for q in range(m):
        found = False
        for a in range(nv):
            if not from_start[q, a]:
                continue
            for b in range(nv):
                if not to_goal[q, b]:
                    continue
                total = d_start[q, a] + dist[a, b] + d_goal[q, b]
                if not found or total < cost[q]:
                    best[q] = a * nv + b
                    cost[q] = total
                    found = True
    return best, cost
