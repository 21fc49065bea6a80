"""Polylines: distance to a point, length, and arc-length grids along them (the segment
distances are :mod:`nodnav.geometry`'s). The paths of :mod:`nodnav.planning.visibility` are
polylines; the planners time robots along their grids."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.geometry import segment_point_distance


def polyline_point_distance(polyline: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance from each point to a polyline ``(V, 2)``, shape ``(P,)``."""
    poly = np.asarray(polyline, dtype=float).reshape(-1, 2)
    if len(poly) == 1:
        return np.linalg.norm(np.asarray(points, dtype=float).reshape(-1, 2) - poly[0], axis=1)
    return segment_point_distance(poly[:-1], poly[1:], points).min(axis=0)


#: Up to this many segments NumPy sums the segments' lengths one after the other from zero
#: (its pairwise summation starts with eight partial sums at eight terms), as :func:`_length_kernel` does.
SEQUENTIAL_SUM = 7


def polyline_length(polyline: np.ndarray) -> float:
    """Length of a polyline ``(V, 2)`` (m)."""
    poly = np.asarray(polyline, dtype=float).reshape(-1, 2)
    if len(poly) <= SEQUENTIAL_SUM + 1:  # the common short path: one compiled call
        return float(_length_kernel(np.ascontiguousarray(poly)))
    # np.linalg.norm(np.diff(poly, axis=0), axis=1).sum() without its checks: the same operations.
    d = poly[1:] - poly[:-1]
    d *= d
    return float(np.sqrt(d[:, 0] + d[:, 1]).sum())


@_compiled
def _length_kernel(poly):
    """:func:`polyline_length` of at most :data:`SEQUENTIAL_SUM` segments: each segment's norm as
    NumPy's (``sqrt(x * x + y * y)``), summed from zero in order, as NumPy's sum does for so few."""
    total = 0.0
    for i in range(poly.shape[0] - 1):
        dx = poly[i + 1, 0] - poly[i, 0]
        dy = poly[i + 1, 1] - poly[i, 1]
        total += math.sqrt(dx * dx + dy * dy)
    return total


@dataclass(frozen=True)
class ArcGrid:
    """Points along a polyline, no farther apart than a given spacing, every vertex included."""

    points: np.ndarray
    """Grid points ``(N, 2)`` from the start to the end of the polyline (m)."""
    arc_length: np.ndarray
    """Arc length of each grid point from the start ``(N,)`` (m)."""


def arc_length_grid(polyline: np.ndarray, spacing: float) -> ArcGrid:
    """Split every segment of ``polyline`` into equal pieces of length at most ``spacing``.

    Keeping the vertices as grid points means that moving between neighbouring grid points
    never cuts a corner of the polyline.
    """
    poly = np.ascontiguousarray(polyline, dtype=float).reshape(-1, 2)
    return ArcGrid(*_grid_kernel(poly, float(spacing)))


@_compiled
def _grid_kernel(poly, spacing):
    """The loops of :func:`arc_length_grid`: grid points and their arc lengths. Segments of zero
    length are skipped; piece ``q`` of ``p`` on a segment sits at fraction ``q / p`` of it."""
    n_seg = poly.shape[0] - 1
    lengths = np.empty(max(n_seg, 0))
    pieces = np.zeros(max(n_seg, 0), dtype=np.int64)
    total = 0
    for s in range(n_seg):
        dx, dy = poly[s + 1, 0] - poly[s, 0], poly[s + 1, 1] - poly[s, 1]
        lengths[s] = math.sqrt(dx * dx + dy * dy)
        if lengths[s] > 0:
            pieces[s] = max(math.ceil(lengths[s] / spacing - 1e-9), 1)
            total += pieces[s]
    points = np.empty((total + 1, 2))
    arc = np.empty(total + 1)
    k, s0 = 0, 0.0
    for s in range(n_seg):
        if pieces[s] == 0:
            continue
        dx, dy = poly[s + 1, 0] - poly[s, 0], poly[s + 1, 1] - poly[s, 1]
        for q in range(pieces[s]):
            frac = q / pieces[s]
            points[k, 0] = poly[s, 0] + frac * dx
            points[k, 1] = poly[s, 1] + frac * dy
            arc[k] = s0 + frac * lengths[s]
            k += 1
        s0 += lengths[s]
    points[k] = poly[-1] if total else poly[0]
    arc[k] = s0
    return points, arc
