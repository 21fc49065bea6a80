"""Polygon walls at load time: validation and decomposition into convex pieces.

A polygon wall (convex or not) is kept at run time as the union of convex pieces, because the
controller needs convex walls (the nearest point ``q`` of a convex set to a point ``p`` outside it
gives the half-plane ``(p - q) . (x - q) >= 0`` that contains ``p`` and excludes the whole set)
and the compiled distance kernels are simplest on them (:mod:`nodnav.geometry`). The pieces come
from a constrained Delaunay triangulation (shapely/GEOS) merged greedily while the union stays
convex (Hertel and Mehlhorn: at most four times the fewest pieces). shapely is used here only,
once per world.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

#: Most vertices of one polygon wall.
MAX_POLYGON_POINTS = 256


def polygon_problem(points: Sequence[Sequence[float]]) -> str:
    """Why ``points`` is not a usable polygon wall ("" when it is): fewer than 3 points, a
    repeated closing point is fine, crossing edges, or zero area."""
    import shapely

    pts = [tuple(map(float, p)) for p in points]
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts = pts[:-1]
    if len(pts) < 3:
        return f"a polygon needs at least 3 points, got {len(pts)}"
    if len(pts) > MAX_POLYGON_POINTS:
        return f"at most {MAX_POLYGON_POINTS} points per polygon, got {len(pts)}"
    if not all(math.isfinite(c) for p in pts for c in p):
        return "every coordinate must be a finite number"
    q = np.asarray(pts) - pts[0]
    scale = max(float(np.ptp(q)), 1.0)
    if np.abs(q[1:, 0] * q[1, 1] - q[1:, 1] * q[1, 0]).max() <= 1e-12 * scale * scale and len(pts) >= 3:
        cross = q[:, 0, None] * q[None, :, 1] - q[:, 1, None] * q[None, :, 0]
        if np.abs(cross).max() <= 1e-12 * scale * scale:
            return "the polygon has zero area (its points are on one line)"
    poly = shapely.Polygon(pts)
    if not poly.is_valid:
        return (f"the polygon crosses itself ({shapely.is_valid_reason(poly)}); "
                f"list its points in order round its boundary")
    if poly.area <= 1e-12 * scale * scale:
        return "the polygon has zero area"
    return ""


def _ccw(points: np.ndarray) -> np.ndarray:
    """The vertices counter-clockwise, without a repeated closing point or collinear vertices."""
    p = np.asarray(points, dtype=float)
    if len(p) > 1 and np.array_equal(p[0], p[-1]):
        p = p[:-1]
    area2 = np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
    if area2 < 0:
        p = p[::-1]
    prev, nxt = np.roll(p, 1, axis=0), np.roll(p, -1, axis=0)
    turn = (p[:, 0] - prev[:, 0]) * (nxt[:, 1] - p[:, 1]) - (p[:, 1] - prev[:, 1]) * (nxt[:, 0] - p[:, 0])
    scale = max(float(np.ptp(p)), 1.0)
    keep = np.abs(turn) > 1e-12 * scale * scale
    return p[keep] if keep.sum() >= 3 else p


def is_convex(points: np.ndarray) -> bool:
    """Whether the counter-clockwise ``points`` turn left (or go straight) at every vertex."""
    p = np.asarray(points, dtype=float)
    prev, nxt = np.roll(p, 1, axis=0), np.roll(p, -1, axis=0)
    turn = (p[:, 0] - prev[:, 0]) * (nxt[:, 1] - p[:, 1]) - (p[:, 1] - prev[:, 1]) * (nxt[:, 0] - p[:, 0])
    scale = max(float(np.ptp(p)), 1.0)
    return bool(np.all(turn >= -1e-12 * scale * scale))


def convex_pieces(points: Sequence[Sequence[float]]) -> list[np.ndarray]:
    """Convex pieces ``(K_i, 2)`` counter-clockwise whose union is the polygon ``points``.

    A convex polygon is its own piece. Otherwise: the constrained Delaunay triangles of the
    polygon, merged two at a time across a shared edge while the merged piece is convex.
    """
    p = _ccw(np.asarray(points, dtype=float))
    if is_convex(p):
        return [p]
    import shapely

    tris = shapely.get_parts(shapely.constrained_delaunay_triangles(shapely.Polygon(p)))
    pieces = [_ccw(np.asarray(t.exterior.coords)) for t in tris if t.area > 0.0]
    merged = True
    while merged:
        merged = False
        for a in range(len(pieces)):
            for b in range(a + 1, len(pieces)):
                union = _merge(pieces[a], pieces[b])
                if union is not None:
                    pieces[a] = union
                    del pieces[b]
                    merged = True
                    break
            if merged:
                break
    return pieces


def _merge(a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """The union of two counter-clockwise pieces sharing an edge, if it is convex; else None."""
    ka, kb = len(a), len(b)
    for i in range(ka):
        u, v = a[i], a[(i + 1) % ka]
        for j in range(kb):  # the shared edge runs the other way round in b
            if np.array_equal(b[j], v) and np.array_equal(b[(j + 1) % kb], u):
                ring = [a[(i + 1 + k) % ka] for k in range(ka)]  # v ... u
                ring += [b[(j + 2 + k) % kb] for k in range(kb - 2)]  # b's vertices after u, before v
                union = _ccw(np.array(ring))
                return union if is_convex(union) else None
    return None


def padded_pieces(pieces: list[np.ndarray]) -> np.ndarray:
    """The pieces as one ``(P, K, 2)`` array, each padded to ``K`` vertices by repeating its last."""
    k = max(len(q) for q in pieces)
    out = np.empty((len(pieces), k, 2))
    for i, q in enumerate(pieces):
        out[i, :len(q)] = q
        out[i, len(q):] = q[-1]
    return out


def box_polygon(box: Sequence[float]) -> tuple[tuple[float, float], ...]:
    """A box ``(x_min, y_min, x_max, y_max)`` as a counter-clockwise polygon."""
    x0, y0, x1, y1 = map(float, box)
    return (x0, y0), (x1, y0), (x1, y1), (x0, y1)
