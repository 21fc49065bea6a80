"""A bucket index of many wall boxes (a map's thousands), and the clearance routines through it.

:class:`WallGrid` lists, for each square bucket over the world, the wall boxes that meet it.
:func:`clearance_indexed` and :func:`segment_clearance_indexed` give exactly what
:func:`nodnav.geometry.clearance_of` and :func:`nodnav.geometry.segment_clearance` give (the same
arithmetic per box, the nearest box always among those examined, and a minimum does not depend
on order) while examining only the boxes near each query. A world builds the index only when it
has a map (:attr:`nodnav.scenario.world.World.wall_grid`).
"""

from __future__ import annotations

import math

import numpy as np

from nodnav.compiled import compiled
from nodnav.geometry import _segment_piece_d2_one, segment_box_d2_one


class WallGrid:
    """Which wall boxes meet each square bucket of side ``cell`` over ``bounds``: the clearance
    routines below then look only at the boxes near a query and give exactly what the full loop
    gives (the nearest box is among those examined; the same arithmetic, and a minimum does not
    depend on order)."""

    def __init__(self, boxes: np.ndarray, bounds: np.ndarray, cell: float = 0.5):
        self.cell = float(cell)
        self.x0, self.y0 = float(bounds[0]), float(bounds[1])
        self.nx = max(int(math.ceil((bounds[2] - bounds[0]) / cell)), 1)
        self.ny = max(int(math.ceil((bounds[3] - bounds[1]) / cell)), 1)
        boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        i0 = np.clip(np.floor((boxes[:, 0] - self.x0) / cell).astype(np.int64), 0, self.nx - 1)
        i1 = np.clip(np.floor((boxes[:, 2] - self.x0) / cell).astype(np.int64), 0, self.nx - 1)
        j0 = np.clip(np.floor((boxes[:, 1] - self.y0) / cell).astype(np.int64), 0, self.ny - 1)
        j1 = np.clip(np.floor((boxes[:, 3] - self.y0) / cell).astype(np.int64), 0, self.ny - 1)
        buckets, owners = [], []
        for w in range(len(boxes)):
            ii, jj = np.meshgrid(np.arange(i0[w], i1[w] + 1), np.arange(j0[w], j1[w] + 1))
            buckets.append((jj * self.nx + ii).ravel())
            owners.append(np.full(ii.size, w, dtype=np.int64))
        bucket = np.concatenate(buckets) if buckets else np.zeros(0, dtype=np.int64)
        owner = np.concatenate(owners) if owners else np.zeros(0, dtype=np.int64)
        order = np.argsort(bucket, kind="stable")
        self.items = np.ascontiguousarray(owner[order])
        self.starts = np.zeros(self.nx * self.ny + 1, dtype=np.int64)
        np.cumsum(np.bincount(bucket, minlength=self.nx * self.ny), out=self.starts[1:])

    def near(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Indices (sorted) of the boxes in the buckets meeting the rectangle ``lo..hi``: a
        superset of the boxes meeting it, for a caller that wants only the walls near a robot."""
        i0, i1 = np.clip(np.floor((np.array([lo[0], hi[0]]) - self.x0) / self.cell).astype(int), 0, self.nx - 1)
        j0, j1 = np.clip(np.floor((np.array([lo[1], hi[1]]) - self.y0) / self.cell).astype(int), 0, self.ny - 1)
        rows = [self.items[self.starts[j * self.nx + i0]:self.starts[j * self.nx + i1 + 1]] for j in range(j0, j1 + 1)]
        return np.unique(np.concatenate(rows)) if rows else np.zeros(0, dtype=np.int64)

    def arrays(self) -> tuple:
        """The index as the compiled routines take it."""
        return self.x0, self.y0, self.cell, self.nx, self.ny, self.starts, self.items

    def segment_clearance(self, a: np.ndarray, b: np.ndarray, boxes: np.ndarray, bounds: np.ndarray,
                          pieces: np.ndarray) -> np.ndarray:
        """:func:`segment_clearance_indexed` of the segments ``a -> b`` (``(S, 2)`` each) among
        the indexed ``boxes``; :func:`nodnav.geometry.segment_clearance` calls it for a world that
        has an index."""
        return segment_clearance_indexed(a, b, boxes, bounds, pieces, *self.arrays())

    def segment_clear(self, a: np.ndarray, b: np.ndarray, need: np.ndarray, boxes: np.ndarray, bounds: np.ndarray,
                      pieces: np.ndarray) -> np.ndarray:
        """:func:`segment_clear_indexed`: whether each segment keeps ``need`` from the indexed
        ``boxes`` (:func:`nodnav.geometry.segment_is_clear` calls it for a world with an index)."""
        return segment_clear_indexed(a, b, need, boxes, bounds, pieces, *self.arrays())


@compiled
def _grid_range(lo, hi, origin, cell, n):
    """Buckets ``i0..i1`` covering ``[lo, hi]`` along one axis, clipped to the grid."""
    i0 = int(math.floor((lo - origin) / cell))
    i1 = int(math.floor((hi - origin) / cell))
    return min(max(i0, 0), n - 1), min(max(i1, 0), n - 1)


@compiled
def _samples_along(ax, ay, bx, by, cell):
    """How many steps of at most half a bucket sample the segment ``(ax, ay) -> (bx, by)``."""
    return int(math.ceil(math.hypot(bx - ax, by - ay) / (0.5 * cell))) + 1


@compiled
def _bucket_along(ax, ay, bx, by, f, gx, gy, cell, nx, ny):
    """The bucket holding the point at fraction ``f`` of the segment ``(ax, ay) -> (bx, by)``."""
    i = _grid_range(ax + f * (bx - ax), ax + f * (bx - ax), gx, cell, nx)[0]
    j = _grid_range(ay + f * (by - ay), ay + f * (by - ay), gy, cell, ny)[0]
    return j * nx + i


@compiled
def _nearest_in_bucket(k, ax, ay, bx, by, walls, starts, items, seen, stamp, nearest):
    """``nearest`` lowered to the squared distance from the segment of every box of bucket ``k``
    not yet examined under ``stamp`` (``seen`` records them)."""
    for q in range(starts[k], starts[k + 1]):
        w = items[q]
        if seen[w] == stamp:
            continue
        seen[w] = stamp
        nearest = min(nearest, segment_box_d2_one(ax, ay, bx, by, walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3]))
    return nearest


@compiled
def segment_clearance_indexed(a, b, walls, bounds, pieces, gx, gy, cell, nx, ny, starts, items):
    """:func:`nodnav.geometry.segment_clearance`'s loop through a :class:`WallGrid`.

    First the boxes in the buckets along the segment (sampled every half bucket): one that the
    segment touches gives 0, the least value there is, and ends the search. Otherwise the boxes
    in the buckets within ``R`` of the segment (one bucket, then doubled) are examined until the
    nearest is within ``R`` (every box not examined is farther than ``R``: it lies in buckets
    farther than ``R``) or the whole grid has been. The minimum is over a set that holds the
    nearest box, with the same arithmetic per box: the value of the full loop, exactly."""
    out = np.empty(a.shape[0])
    seen = np.zeros(walls.shape[0], dtype=np.int64)  # the pass that last examined each box
    stamp = 0
    for s in range(a.shape[0]):
        ax, ay, bx, by = a[s, 0], a[s, 1], b[s, 0], b[s, 1]
        x0, y0, x1, y1 = bounds[0], bounds[1], bounds[2], bounds[3]
        d = min(min(min(ax - x0, x1 - ax), min(ay - y0, y1 - ay)), min(min(bx - x0, x1 - bx), min(by - y0, y1 - by)))
        if walls.shape[0]:
            nearest = np.inf
            stamp += 1
            n_samples = _samples_along(ax, ay, bx, by, cell)
            for t in range(n_samples + 1):
                k = _bucket_along(ax, ay, bx, by, t / n_samples, gx, gy, cell, nx, ny)
                nearest = _nearest_in_bucket(k, ax, ay, bx, by, walls, starts, items, seen, stamp, nearest)
                if nearest == 0.0:
                    break
            reach = cell
            while nearest > 0.0:
                stamp += 1
                i0, i1 = _grid_range(min(ax, bx) - reach, max(ax, bx) + reach, gx, cell, nx)
                j0, j1 = _grid_range(min(ay, by) - reach, max(ay, by) + reach, gy, cell, ny)
                whole = i0 == 0 and j0 == 0 and i1 == nx - 1 and j1 == ny - 1
                for j in range(j0, j1 + 1):
                    for i in range(i0, i1 + 1):
                        # A bucket farther than R from the segment holds no box within R of it (with
                        # a margin for rounding; the grid's edge buckets hold the boxes beyond it, and
                        # at the last, whole-grid pass every bucket is examined).
                        inner = 0 < i < nx - 1 and 0 < j < ny - 1
                        if inner and not whole and segment_box_d2_one(
                                ax, ay, bx, by, gx + i * cell, gy + j * cell, gx + (i + 1) * cell,
                                gy + (j + 1) * cell) > (reach + 1e-6) * (reach + 1e-6):
                            continue
                        nearest = _nearest_in_bucket(j * nx + i, ax, ay, bx, by, walls, starts, items, seen, stamp,
                                                     nearest)
                if nearest <= reach * reach or whole:
                    break
                reach *= 2.0
            d = min(d, math.sqrt(nearest))
        if pieces.shape[0]:
            nearest = np.inf
            for w in range(pieces.shape[0]):
                nearest = min(nearest, _segment_piece_d2_one(ax, ay, bx, by, pieces[w]))
            d = min(d, math.sqrt(nearest))
        out[s] = d
    return out


@compiled
def clearance_indexed(points, bounds, obstacles, gx, gy, cell, nx, ny, starts, items):
    """:func:`nodnav.geometry.clearance_of` through a :class:`WallGrid` (the same values)."""
    out = np.empty(points.shape[0])
    seen = np.zeros(obstacles.shape[0], dtype=np.int64)  # the pass that last examined each box
    stamp = 0
    for p in range(points.shape[0]):
        x, y = points[p, 0], points[p, 1]
        d = min(min(x - bounds[0], bounds[2] - x), min(y - bounds[1], bounds[3] - y))
        best = np.inf
        reach = cell
        while obstacles.shape[0]:
            stamp += 1
            i0, i1 = _grid_range(x - reach, x + reach, gx, cell, nx)
            j0, j1 = _grid_range(y - reach, y + reach, gy, cell, ny)
            for j in range(j0, j1 + 1):
                for i in range(i0, i1 + 1):
                    k = j * nx + i
                    for q in range(starts[k], starts[k + 1]):
                        o = items[q]
                        if seen[o] == stamp:
                            continue
                        seen[o] = stamp
                        dx = max(obstacles[o, 0] - x, x - obstacles[o, 2])
                        dy = max(obstacles[o, 1] - y, y - obstacles[o, 3])
                        outside = math.hypot(max(dx, 0.0), max(dy, 0.0))
                        inside = min(max(dx, dy), 0.0)
                        best = min(best, outside + inside)
            if best <= reach or (i0 == 0 and j0 == 0 and i1 == nx - 1 and j1 == ny - 1):
                break
            reach *= 2.0
        out[p] = min(d, best)
    return out


@compiled
def _box_too_close(ax, ay, bx, by, walls, w, want):
    """Whether box ``w`` is closer than ``want`` to the segment (its clearance verdict fails)."""
    return math.sqrt(segment_box_d2_one(ax, ay, bx, by, walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3])) < want


@compiled
def segment_clear_indexed(a, b, need, walls, bounds, pieces, gx, gy, cell, nx, ny, starts, items):
    """Whether :func:`nodnav.geometry.segment_clearance` of each segment ``a -> b`` is at least
    ``need[s]``, through a :class:`WallGrid`: the verdict of the full loop, exactly
    (:func:`segment_clear_one_indexed` for each segment)."""
    out = np.empty(a.shape[0], dtype=np.bool_)
    seen = np.zeros(walls.shape[0], dtype=np.int64)
    for s in range(a.shape[0]):
        out[s] = segment_clear_one_indexed(a[s, 0], a[s, 1], b[s, 0], b[s, 1], need[s], walls, bounds, pieces,
                                           gx, gy, cell, nx, ny, starts, items, seen, s + 1)
    return out


@compiled
def segment_clear_one_indexed(ax, ay, bx, by, want, walls, bounds, pieces, gx, gy, cell, nx, ny, starts, items,
                              seen, mark):
    """Whether :func:`nodnav.geometry.segment_clearance` of the one segment ``(ax, ay) -> (bx, by)``
    is at least ``want``, through a :class:`WallGrid`: the verdict of the full loop, exactly (the
    compiled twin for other kernels, e.g. the PRM planner's joint checks).

    The verdict fails exactly when some box is closer than ``want``, and every such box lies in a
    bucket within ``want`` of the segment. So: first the boxes of the buckets along the segment
    (sampled every half bucket; a segment through a wall ends there), then, row by row, the
    buckets within ``want`` (plus a margin for rounding) of the part of the segment in that
    row's band. A long clear segment costs the buckets along it, not its bounding box's. A
    segment leaving the world (negative clearance of the bounds, only with a negative ``want``)
    examines every box. ``seen`` ``(M,)`` records the boxes examined (``seen[w] == mark``: not
    again); ``mark`` must differ from every value ``seen`` holds from an earlier segment."""
    x0, y0, x1, y1 = bounds[0], bounds[1], bounds[2], bounds[3]
    d = min(min(min(ax - x0, x1 - ax), min(ay - y0, y1 - ay)), min(min(bx - x0, x1 - bx), min(by - y0, y1 - by)))
    if not d >= want:
        return False
    if walls.shape[0] and d < 0.0:
        for w in range(walls.shape[0]):
            if _box_too_close(ax, ay, bx, by, walls, w, want):
                return False
    elif walls.shape[0]:
        n_samples = _samples_along(ax, ay, bx, by, cell)
        for t in range(n_samples + 1):
            k = _bucket_along(ax, ay, bx, by, t / n_samples, gx, gy, cell, nx, ny)
            for q in range(starts[k], starts[k + 1]):
                w = items[q]
                if seen[w] != mark:
                    seen[w] = mark
                    if _box_too_close(ax, ay, bx, by, walls, w, want):
                        return False
        reach = max(want, 0.0) + 1e-6
        j0, j1 = _grid_range(min(ay, by) - reach, max(ay, by) + reach, gy, cell, ny)
        for j in range(j0, j1 + 1):
            # The part of the segment within ``reach`` of this row's band (the edge rows hold
            # the boxes beyond the grid: their band is unbounded).
            lo = gy + j * cell - reach if j > 0 else -np.inf
            hi = gy + (j + 1) * cell + reach if j < ny - 1 else np.inf
            if by != ay:
                t0, t1 = (lo - ay) / (by - ay), (hi - ay) / (by - ay)
                t0, t1 = max(min(t0, t1), 0.0), min(max(t0, t1), 1.0)
                if t0 > t1:
                    continue
            elif lo <= ay <= hi:
                t0, t1 = 0.0, 1.0
            else:
                continue
            xa, xb = ax + t0 * (bx - ax), ax + t1 * (bx - ax)
            i0, i1 = _grid_range(min(xa, xb) - reach - 1e-6, max(xa, xb) + reach + 1e-6, gx, cell, nx)
            for q in range(starts[j * nx + i0], starts[j * nx + i1 + 1]):
                w = items[q]
                if seen[w] != mark:
                    seen[w] = mark
                    if _box_too_close(ax, ay, bx, by, walls, w, want):
                        return False
    if pieces.shape[0]:
        nearest = np.inf
        for w in range(pieces.shape[0]):
            nearest = min(nearest, _segment_piece_d2_one(ax, ay, bx, by, pieces[w]))
        return math.sqrt(nearest) >= want
    return True
