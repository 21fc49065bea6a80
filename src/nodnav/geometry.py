"""The geometry core: exact distances between points, segments, axis-aligned boxes, convex
polygons and discs.

Everything here works on arrays; nothing knows of scenarios, robots' plans or opinions. A wall is
a closed rectangle ``(x_min, y_min, x_max, y_max)`` or a closed convex polygon (a *piece*: a
polygon wall is the union of its convex pieces), given as its vertices counter-clockwise in a
``(P, K, 2)`` array padded by repeating the last vertex (a zero-length edge changes no distance
and no inside test). Boxes keep their own, faster arithmetic. The world's outer boundary is a box
the robots stay inside. Every routine that the compiled kernels of the planners need exists twice: a
vectorised function for NumPy callers and its compiled scalar twin (``*_one``), written once
(the vectorised function loops over its twin), so that both give the same answer to the last
bit. Distances are exact, never sampled: a segment is clear of a box when the least of its
endpoints' distances to the box and the box's corners' distances to it is large enough.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from nodnav.compiled import compiled

#: Numerical slack of every distance comparison (m).
TOL = 1e-9


class Walls(Protocol):
    """What the clearance routines need of a world: its walls and its outer boundary as arrays."""

    @property
    def obstacle_array(self) -> np.ndarray:
        """Wall rectangles ``(M, 4)`` (m)."""
        ...

    @property
    def piece_array(self) -> np.ndarray:
        """Convex wall pieces ``(P, K, 2)`` counter-clockwise, padded by repeating the last vertex (m)."""
        ...

    @property
    def bounds_array(self) -> np.ndarray:
        """The outer boundary ``(4,)``: ``x_min, y_min, x_max, y_max`` (m)."""
        ...


@compiled
def clearance_of(points: np.ndarray, bounds: np.ndarray, obstacles: np.ndarray) -> np.ndarray:
    """Signed distance ``(N,)`` from each of ``points`` ``(N, 2)`` to the nearest of the
    rectangles ``obstacles`` ``(M, 4)`` or the box ``bounds`` ``(4,)``; negative inside a wall.

    To a rectangle it is the length of the point's excess over the rectangle's extent when
    outside, minus the distance to the nearest side when inside.
    """
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        x, y = points[i, 0], points[i, 1]
        d = min(min(x - bounds[0], bounds[2] - x), min(y - bounds[1], bounds[3] - y))
        for o in range(obstacles.shape[0]):
            dx = max(obstacles[o, 0] - x, x - obstacles[o, 2])
            dy = max(obstacles[o, 1] - y, y - obstacles[o, 3])
            outside = math.hypot(max(dx, 0.0), max(dy, 0.0))
            inside = min(max(dx, dy), 0.0)
            d = min(d, outside + inside)
        out[i] = d
    return out


def point_box_distance(points: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Euclidean distance from each point to each closed box (0 inside), shape ``(P, B)``.

    ``boxes`` are rows ``(x_min, y_min, x_max, y_max)``.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    b = np.asarray(boxes, dtype=float).reshape(-1, 4)
    return np.sqrt(_point_box_d2(p, b[:, :2], b[:, 2:]))


def _point_box_d2(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    px, py = p[:, 0:1], p[:, 1:2]
    gx = np.maximum(np.maximum(lo[:, 0] - px, px - hi[:, 0]), 0.0)
    gy = np.maximum(np.maximum(lo[:, 1] - py, py - hi[:, 1]), 0.0)
    return gx * gx + gy * gy


def segment_point_distance(a: np.ndarray, b: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance from each segment ``a[s] -> b[s]`` to each point, shape ``(S, P)``.

    The closest point of a segment is the projection clamped to the segment; a segment of zero
    length is a point.
    """
    a = np.asarray(a, dtype=float).reshape(-1, 2)
    b = np.asarray(b, dtype=float).reshape(-1, 2)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    return np.sqrt(_segment_point_d2(a, b - a, p))


def _segment_point_d2(a: np.ndarray, d: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Squared distance from each segment ``a[s] -> a[s] + d[s]`` to each point, ``(S, P)``."""
    return _segment_point_d2_kernel(np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(d, dtype=float),
                                    np.ascontiguousarray(p, dtype=float))


@compiled
def _segment_point_d2_kernel(a, d, p):
    """The loops of :func:`_segment_point_d2`."""
    out = np.empty((a.shape[0], p.shape[0]))
    for s in range(a.shape[0]):
        for q in range(p.shape[0]):
            out[s, q] = _segment_point_d2_one(a[s, 0], a[s, 1], d[s, 0], d[s, 1], p[q, 0], p[q, 1])
    return out


@compiled
def _segment_point_d2_one(ax, ay, dx, dy, px, py):
    """Squared distance from the segment ``(ax, ay) -> (ax + dx, ay + dy)`` to ``(px, py)``: the
    projection's fraction along the segment, clamped to it, gives the closest point."""
    rx, ry = px - ax, py - ay
    t = min(max((rx * dx + ry * dy) / max(dx * dx + dy * dy, 1e-300), 0.0), 1.0)
    ex, ey = rx - t * dx, ry - t * dy
    return ex * ex + ey * ey


def segments_hit_boxes(a: np.ndarray, b: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Whether each closed segment meets each closed box, shape ``(S, B)`` (slab clipping)."""
    a = np.asarray(a, dtype=float).reshape(-1, 2)
    b = np.asarray(b, dtype=float).reshape(-1, 2)
    bx = np.asarray(boxes, dtype=float).reshape(-1, 4)
    return _hit(a, b - a, bx[:, :2], bx[:, 2:])


def _hit(a: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    # A zero step becomes a tiny one: the slab then spans (-huge, huge) when the segment lies
    # inside it and sits entirely beyond [0, 1] when it does not, which is the right answer.
    d = d.copy()
    d[d == 0.0] = 1e-300
    inv = 1.0 / d
    ax, ay, ix, iy = a[:, 0:1], a[:, 1:2], inv[:, 0:1], inv[:, 1:2]
    x1, x2 = (lo[:, 0] - ax) * ix, (hi[:, 0] - ax) * ix
    y1, y2 = (lo[:, 1] - ay) * iy, (hi[:, 1] - ay) * iy
    t_in = np.maximum(np.minimum(x1, x2), np.minimum(y1, y2))
    t_out = np.minimum(np.maximum(x1, x2), np.maximum(y1, y2))
    return (t_in <= t_out) & (t_in <= 1.0) & (t_out >= 0.0)


def segment_box_distance(a: np.ndarray, b: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Exact distance from each segment to each closed box (0 when they meet), shape ``(S, B)``.

    Between two disjoint convex polygons the distance is attained at a vertex of one of them,
    so it is the least of the segment's endpoints to the box and the box's corners to the segment.
    """
    a = np.asarray(a, dtype=float).reshape(-1, 2)
    b = np.asarray(b, dtype=float).reshape(-1, 2)
    bx = np.asarray(boxes, dtype=float).reshape(-1, 4)
    return np.sqrt(_segment_box_d2(a, b, bx))


def _segment_box_d2(a: np.ndarray, b: np.ndarray, bx: np.ndarray) -> np.ndarray:
    lo, hi = bx[:, :2], bx[:, 2:]
    d = b - a
    ends = _point_box_d2(np.vstack([a, b]), lo, hi)
    corners = bx[:, [[0, 1], [2, 1], [2, 3], [0, 3]]].reshape(-1, 2)
    to_corners = _segment_point_d2(a, d, corners).reshape(len(a), len(bx), 4).min(axis=2)
    d2 = np.minimum(np.minimum(ends[:len(a)], ends[len(a):]), to_corners)
    d2[_hit(a, d, lo, hi)] = 0.0
    return d2


def bounds_distance(points: np.ndarray, bounds: tuple[float, float, float, float]) -> np.ndarray:
    """Distance from each point to the world's outer boundary (negative outside), shape ``(P,)``."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    x0, y0, x1, y1 = bounds
    return np.minimum(np.minimum(p[:, 0] - x0, x1 - p[:, 0]), np.minimum(p[:, 1] - y0, y1 - p[:, 1]))


def segment_clearance(walls: Walls, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Least clearance along each segment ``a[s] -> b[s]``: distance to the nearest wall or to the
    boundary, exactly (0 when the segment touches a wall; negative outside the boundary), shape
    ``a.shape[:-1]`` (``(1,)`` for a single segment).

    The distance to the (convex) boundary is a concave function along a segment, so its least
    value is at an endpoint; each wall contributes :func:`segment_box_distance`. The loops are
    :func:`segment_clearance_one`, which compiled code calls directly.
    """
    shape = np.shape(a)[:-1] if np.ndim(a) > 1 else (1,)
    a = np.ascontiguousarray(a, dtype=float).reshape(-1, 2)
    b = np.ascontiguousarray(b, dtype=float).reshape(-1, 2)
    grid = getattr(walls, "wall_grid", None)
    if grid is not None:  # many walls (a map's): look only at the boxes near each segment
        return grid.segment_clearance(a, b, walls.obstacle_array, walls.bounds_array, walls.piece_array).reshape(shape)
    return _segment_clearance_kernel(a, b, walls.obstacle_array, walls.bounds_array,
                                     walls.piece_array).reshape(shape)


def segment_is_clear(walls: Walls, a: np.ndarray, b: np.ndarray, need: np.ndarray | float) -> np.ndarray:
    """Whether ``segment_clearance(walls, a, b) >= need`` for each segment (``need`` per segment or
    one for all), exactly; a world with a wall index answers from the boxes within ``need`` of
    each segment (:meth:`nodnav.wall_grid.WallGrid.segment_clear`), the others compare the
    clearance itself."""
    grid = getattr(walls, "wall_grid", None)
    if grid is None:
        return np.asarray(segment_clearance(walls, a, b) >= need)
    shape = np.shape(a)[:-1] if np.ndim(a) > 1 else (1,)
    a = np.ascontiguousarray(a, dtype=float).reshape(-1, 2)
    b = np.ascontiguousarray(b, dtype=float).reshape(-1, 2)
    need = np.ascontiguousarray(np.broadcast_to(np.asarray(need, dtype=float), shape).reshape(-1))
    return grid.segment_clear(a, b, need, walls.obstacle_array, walls.bounds_array, walls.piece_array).reshape(shape)


@compiled
def _segment_clearance_kernel(a, b, walls, bounds, pieces):
    """The loop of :func:`segment_clearance` over segments."""
    out = np.empty(a.shape[0])
    for s in range(a.shape[0]):
        out[s] = segment_clearance_one(a[s, 0], a[s, 1], b[s, 0], b[s, 1], walls, bounds, pieces)
    return out


@compiled
def segment_clearance_one(ax, ay, bx, by, walls, bounds, pieces):
    """:func:`segment_clearance` of the one segment ``(ax, ay) -> (bx, by)`` among the rectangles
    ``walls`` ``(M, 4)`` and the convex pieces ``pieces`` ``(P, K, 2)`` inside the box ``bounds``
    ``(4,)``: the compiled twin, for other kernels."""
    x0, y0, x1, y1 = bounds[0], bounds[1], bounds[2], bounds[3]
    d = min(min(min(ax - x0, x1 - ax), min(ay - y0, y1 - ay)), min(min(bx - x0, x1 - bx), min(by - y0, y1 - by)))
    if walls.shape[0]:
        nearest = np.inf
        for w in range(walls.shape[0]):
            nearest = min(nearest, segment_box_d2_one(ax, ay, bx, by, walls[w, 0], walls[w, 1], walls[w, 2],
                                                      walls[w, 3]))
        d = min(d, math.sqrt(nearest))
    if pieces.shape[0]:
        nearest = np.inf
        for w in range(pieces.shape[0]):
            nearest = min(nearest, _segment_piece_d2_one(ax, ay, bx, by, pieces[w]))
        d = min(d, math.sqrt(nearest))
    return d


@compiled
def segment_box_d2_one(ax, ay, bx, by, lx, ly, hx, hy):
    """Squared distance between the segment ``(ax, ay) -> (bx, by)`` and the rectangle
    ``(lx, ly, hx, hy)``: 0 when they touch, else the least of the ends' distances to the box and
    the corners' distances to the segment."""
    dx, dy = bx - ax, by - ay
    if _hit_one(ax, ay, dx, dy, lx, ly, hx, hy):
        return 0.0
    d2 = min(_point_box_d2_one(ax, ay, lx, ly, hx, hy), _point_box_d2_one(bx, by, lx, ly, hx, hy))
    return min(d2, min(min(_segment_point_d2_one(ax, ay, dx, dy, lx, ly),
                           _segment_point_d2_one(ax, ay, dx, dy, hx, ly)),
                       min(_segment_point_d2_one(ax, ay, dx, dy, hx, hy),
                           _segment_point_d2_one(ax, ay, dx, dy, lx, hy))))


@compiled
def _point_piece_d2_one(px, py, piece):
    """Squared distance from a point to the boundary of a convex piece ``(K, 2)``, and whether
    the point is inside the closed piece."""
    k = piece.shape[0]
    d2 = np.inf
    inside = True
    for v in range(k):
        ax, ay = piece[v, 0], piece[v, 1]
        w = v + 1 if v + 1 < k else 0
        dx, dy = piece[w, 0] - ax, piece[w, 1] - ay
        d2 = min(d2, _segment_point_d2_one(ax, ay, dx, dy, px, py))
        if dx * (py - ay) - dy * (px - ax) < 0.0:
            inside = False
    return d2, inside


@compiled
def piece_signed_distance_one(px, py, piece):
    """Signed distance from a point to a closed convex piece ``(K, 2)``: negative inside."""
    d2, inside = _point_piece_d2_one(px, py, piece)
    return -math.sqrt(d2) if inside else math.sqrt(d2)


@compiled
def piece_closest_point_one(px, py, piece):
    """The point of a closed convex piece ``(K, 2)`` nearest to ``(px, py)``: the point itself
    when inside, else the nearest point of its boundary."""
    k = piece.shape[0]
    best, qx, qy = np.inf, px, py
    inside = True
    for v in range(k):
        ax, ay = piece[v, 0], piece[v, 1]
        w = v + 1 if v + 1 < k else 0
        dx, dy = piece[w, 0] - ax, piece[w, 1] - ay
        rx, ry = px - ax, py - ay
        if dx * ry - dy * rx < 0.0:
            inside = False
        t = min(max((rx * dx + ry * dy) / max(dx * dx + dy * dy, 1e-300), 0.0), 1.0)
        cx, cy = ax + t * dx, ay + t * dy
        e2 = (px - cx) ** 2 + (py - cy) ** 2
        if e2 < best:
            best, qx, qy = e2, cx, cy
    if inside:
        return px, py
    return qx, qy


@compiled
def _segment_hits_piece_one(ax, ay, dx, dy, piece):
    """Whether the segment ``(ax, ay) -> (ax + dx, ay + dy)`` meets the closed convex piece
    (Cyrus-Beck clipping against its edges' half-planes)."""
    k = piece.shape[0]
    t_in, t_out = 0.0, 1.0
    for v in range(k):
        w = v + 1 if v + 1 < k else 0
        ex, ey = piece[w, 0] - piece[v, 0], piece[w, 1] - piece[v, 1]
        nx, ny = ey, -ex  # outward normal of a counter-clockwise edge
        num = nx * (piece[v, 0] - ax) + ny * (piece[v, 1] - ay)
        den = nx * dx + ny * dy
        if den == 0.0:
            if num < 0.0:
                return False
        elif den > 0.0:
            t_out = min(t_out, num / den)
        else:
            t_in = max(t_in, num / den)
        if t_in > t_out:
            return False
    return True


@compiled
def _segment_piece_d2_one(ax, ay, bx, by, piece):
    """Squared distance between a segment and a closed convex piece (0 when they meet): between
    disjoint convex sets it is attained at a vertex of one of them."""
    dx, dy = bx - ax, by - ay
    if _segment_hits_piece_one(ax, ay, dx, dy, piece):
        return 0.0
    d2 = min(_point_piece_d2_one(ax, ay, piece)[0], _point_piece_d2_one(bx, by, piece)[0])
    for v in range(piece.shape[0]):
        d2 = min(d2, _segment_point_d2_one(ax, ay, dx, dy, piece[v, 0], piece[v, 1]))
    return d2


@compiled
def piece_clearance(points: np.ndarray, pieces: np.ndarray) -> np.ndarray:
    """Signed distance ``(N,)`` from each of ``points`` ``(N, 2)`` to the nearest convex piece
    ``(P, K, 2)`` (inf without pieces); negative inside one."""
    out = np.full(points.shape[0], np.inf)
    for i in range(points.shape[0]):
        for w in range(pieces.shape[0]):
            out[i] = min(out[i], piece_signed_distance_one(points[i, 0], points[i, 1], pieces[w]))
    return out


@compiled
def _point_box_d2_one(px, py, lx, ly, hx, hy):
    """Squared distance from a point to the closed box ``[lx, hx] x [ly, hy]`` (0 inside)."""
    gx = max(max(lx - px, px - hx), 0.0)
    gy = max(max(ly - py, py - hy), 0.0)
    return gx * gx + gy * gy


@compiled
def _hit_one(ax, ay, dx, dy, lx, ly, hx, hy):
    """Whether the segment ``(ax, ay) -> (ax + dx, ay + dy)`` meets the closed box (as :func:`_hit`)."""
    ix = 1.0 / (dx if dx != 0.0 else 1e-300)
    iy = 1.0 / (dy if dy != 0.0 else 1e-300)
    x1, x2 = (lx - ax) * ix, (hx - ax) * ix
    y1, y2 = (ly - ay) * iy, (hy - ay) * iy
    t_in = max(min(x1, x2), min(y1, y2))
    t_out = min(max(x1, x2), max(y1, y2))
    return t_in <= t_out and t_in <= 1.0 and t_out >= 0.0


def min_pair_distance(positions: np.ndarray) -> float:
    """Smallest centre-to-centre distance over all pairs and all leading indices (m); inf for one robot."""
    p = np.asarray(positions, dtype=float)
    n = p.shape[-2]
    if n < 2:
        return float("inf")
    a, b = np.triu_indices(n, k=1)
    return float(np.linalg.norm(p[..., a, :] - p[..., b, :], axis=-1).min())


def min_gap(positions: np.ndarray, radii: np.ndarray) -> float:
    """Smallest surface-to-surface gap ``|p_a - p_b| - r_a - r_b`` over pairs and leading indices (m)."""
    p = np.asarray(positions, dtype=float)
    r = np.asarray(radii, dtype=float)
    n = p.shape[-2]
    if n < 2:
        return float("inf")
    a, b = np.triu_indices(n, k=1)
    return float((np.linalg.norm(p[..., a, :] - p[..., b, :], axis=-1) - (r[a] + r[b])).min())

