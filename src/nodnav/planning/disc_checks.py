"""Whether polylines keep clear of discs (the standing robots the fast planner's paths go
around): one compiled pass per question, each tested against its plain NumPy form.

Split from :mod:`nodnav.planning.visibility`, whose searches ask these questions.
"""

from __future__ import annotations

import math

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.geometry import TOL, _segment_point_d2_one, segment_point_distance


def disc_violations(polyline: np.ndarray, centres: np.ndarray, radii: np.ndarray, d_start: np.ndarray,
                    d_goal: np.ndarray) -> np.ndarray:
    """Which discs a polyline from a start to a goal violates, shape ``(m,)``.

    A polyline keeps out of disc ``j`` when every segment keeps ``radii[j]`` from its centre,
    except that the first segment need only keep ``min(radii[j], d_start[j])`` (the start's
    distance from the centre: leaving a disc one starts in) and the last one
    ``min(radii[j], d_goal[j])`` (entering the disc that holds the goal).

    One compiled call (:func:`_violations_kernel`); :func:`disc_violations_plain` is the NumPy
    form it is tested against.
    """
    centres = np.ascontiguousarray(np.asarray(centres, dtype=float).reshape(-1, 2))
    m = len(centres)
    return _violations_kernel(np.ascontiguousarray(np.asarray(polyline, dtype=float).reshape(-1, 2)), centres,
                              _per_disc(radii, m), _per_disc(d_start, m), _per_disc(d_goal, m))


def _per_disc(values, m: int) -> np.ndarray:
    """``values`` as a contiguous float array ``(m,)`` (one value broadcast to all)."""
    v = np.asarray(values, dtype=float).reshape(-1)
    if len(v) != m:
        v = np.broadcast_to(v, (m,))
    return np.ascontiguousarray(v)


def disc_violations_plain(polyline: np.ndarray, centres: np.ndarray, radii: np.ndarray, d_start: np.ndarray,
                          d_goal: np.ndarray) -> np.ndarray:
    """:func:`disc_violations` with NumPy: the segments' distances as a table, the limits as another."""
    poly = np.asarray(polyline, dtype=float).reshape(-1, 2)
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    if len(poly) == 1:
        poly = np.vstack([poly, poly])
    d = segment_point_distance(poly[:-1], poly[1:], centres)
    limit = np.repeat(np.asarray(radii, dtype=float).reshape(1, -1), len(d), axis=0)
    limit[0] = np.minimum(limit[0], d_start)
    limit[-1] = np.minimum(limit[-1], d_goal)
    return np.asarray((d < limit - TOL).any(axis=0))


@_compiled
def _violations_kernel(poly, centres, radii, d_start, d_goal):
    """The loops of :func:`disc_violations`: the same distances (:func:`_segment_point_d2_one`,
    then the square root) and limits, disc by disc, stopping at its first violated segment."""
    n_pts = poly.shape[0]
    n_seg = max(n_pts - 1, 1)
    out = np.zeros(centres.shape[0], dtype=np.bool_)
    for j in range(centres.shape[0]):
        cx, cy = centres[j, 0], centres[j, 1]
        for s in range(n_seg):
            a, b = min(s, n_pts - 1), min(s + 1, n_pts - 1)
            limit = radii[j]
            if s == 0:
                limit = min(limit, d_start[j])
            if s == n_seg - 1:
                limit = min(limit, d_goal[j])
            ax, ay = poly[a, 0], poly[a, 1]
            d = math.sqrt(_segment_point_d2_one(ax, ay, poly[b, 0] - ax, poly[b, 1] - ay, cx, cy))
            if d < limit - TOL:
                out[j] = True
                break
    return out


@_compiled
def _crosses_any(poly, centres, radii, start, goal):
    """Whether ``poly`` violates one of the discs (those of radius above :data:`TOL`) in the
    sense of :func:`disc_violations`, with ``d_start`` and ``d_goal`` the distances of the
    discs' centres from ``start`` and ``goal``: the same float operations as that function and
    :meth:`VisibilityGraph.shortest_path`'s first check, as loops without their arrays."""
    n_seg = max(poly.shape[0] - 1, 1)
    for j in range(centres.shape[0]):
        r = radii[j]
        if not r > TOL:
            continue
        cx, cy = centres[j, 0], centres[j, 1]
        d_start = math.hypot(cx - start[0], cy - start[1])
        d_goal = math.hypot(cx - goal[0], cy - goal[1])
        for s in range(n_seg):
            a = poly[min(s, poly.shape[0] - 1)]
            b = poly[min(s + 1, poly.shape[0] - 1)]
            limit = r
            if s == 0:
                limit = min(limit, d_start)
            if s == n_seg - 1:
                limit = min(limit, d_goal)
            d = math.sqrt(_segment_point_d2_one(a[0], a[1], b[0] - a[0], b[1] - a[1], cx, cy))
            if d < limit - TOL:
                return True
    return False


@_compiled
def corner_cuts_close(path, a, b, centres, radii):
    """Which chords ``a[c] -> b[c]`` come closer than ``min(radii[j], distance of centre j
    from path) - TOL`` to a centre ``j``: the corner check of the fast planner's tracks
    (:meth:`~nodnav.planning.geometric_paths.GeometricPaths._prepare`) as loops, with the
    float operations of :func:`~nodnav.planning.polylines.polyline_point_distance` and
    :func:`segment_point_distance`."""
    m = centres.shape[0]
    keep = np.empty(m)
    for j in range(m):
        cx, cy = centres[j, 0], centres[j, 1]
        if path.shape[0] == 1:
            dx, dy = cx - path[0, 0], cy - path[0, 1]
            near = math.sqrt(dx * dx + dy * dy)
        else:
            near = math.inf
            for s in range(path.shape[0] - 1):
                d = math.sqrt(_segment_point_d2_one(path[s, 0], path[s, 1], path[s + 1, 0] - path[s, 0],
                                                    path[s + 1, 1] - path[s, 1], cx, cy))
                if d < near:
                    near = d
        keep[j] = min(radii[j], near)
    bad = np.zeros(a.shape[0], dtype=np.bool_)
    for c in range(a.shape[0]):
        for j in range(m):
            d = math.sqrt(_segment_point_d2_one(a[c, 0], a[c, 1], b[c, 0] - a[c, 0], b[c, 1] - a[c, 1],
                                                centres[j, 0], centres[j, 1]))
            if d < keep[j] - TOL:
                bad[c] = True
                break
    return bad


@_compiled
def corner_cuts_of(cells, corners, path, centres, radii):
    """:func:`corner_cuts_close` of the chords ``cells[corners] -> cells[corners + 2]`` (the
    full-speed moves that cut a corner), gathered in the same call: ``(bad, how many)``."""
    m = corners.shape[0]
    a, b = np.empty((m, 2)), np.empty((m, 2))
    for c in range(m):
        for d in range(2):
            a[c, d] = cells[corners[c], d]
            b[c, d] = cells[corners[c] + 2, d]
    bad = corner_cuts_close(path, a, b, centres, radii)
    count = 0
    for c in range(m):
        count += bad[c]
    return bad, count


@_compiled
def corner_heights(cells):
    """The cells ``i`` whose move ``i -> i+2`` along the polyline ``cells`` turns (``|u x w| >
    1e-12`` for ``u = cells[i+1] - cells[i]``, ``w = cells[i+2] - cells[i+1]``), and how far
    ``cells[i+1]`` is from that chord (``|u x w| / |cells[i+2] - cells[i]|``, the norm as
    ``sqrt(x * x + y * y)``): the NumPy steps of ``GeometricPaths._cut`` in one loop, the same
    operations (:func:`corner_heights_plain` is them)."""
    n = cells.shape[0]
    corners = np.empty(max(n - 2, 0), dtype=np.int64)
    height = np.empty(max(n - 2, 0))
    k = 0
    for i in range(n - 2):
        ux, uy = cells[i + 1, 0] - cells[i, 0], cells[i + 1, 1] - cells[i, 1]
        wx, wy = cells[i + 2, 0] - cells[i + 1, 0], cells[i + 2, 1] - cells[i + 1, 1]
        cross = ux * wy - uy * wx
        if abs(cross) > 1e-12:
            cx, cy = cells[i + 2, 0] - cells[i, 0], cells[i + 2, 1] - cells[i, 1]
            height[k] = abs(cross) / math.sqrt(cx * cx + cy * cy)
            corners[k] = i
            k += 1
    return corners[:k], height[:k]


def corner_heights_plain(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`corner_heights` with NumPy, as ``_cut`` computed it (the reference it is tested against)."""
    u, w = cells[1:-1] - cells[:-2], cells[2:] - cells[1:-1]
    cross = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
    corners = np.nonzero(np.abs(cross) > 1e-12)[0]
    chord = cells[corners + 2] - cells[corners]
    chord *= chord
    return corners, np.abs(cross[corners]) / np.sqrt(chord[:, 0] + chord[:, 1])
