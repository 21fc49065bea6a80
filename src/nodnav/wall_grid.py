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


@compiled
def _grid_range(lo, hi, origin, cell, n):
    """Buckets ``i0..i1`` covering ``[lo, hi]`` along one axis, clipped to the grid."""
    i0 = int(math.floor((lo - origin) / cell))
    i1 = int(math.floor((hi - origin) / cell))
    return min(max(i0, 0), n - 1), min(max(i1, 0), n - 1)


@compiled
def segment_clearance_indexed(a, b, walls, bounds, pieces, gx, gy, cell, nx, ny, starts, items):
    """:func:`nodnav.geometry.segment_clearance`'s loop through a :class:`WallGrid`: the boxes meeting the
    segment's bounding box grown by ``R`` (one bucket, then doubled) are examined until the
    nearest is within ``R`` (every other box is farther than ``R``) or the whole grid has been."""
    out = np.empty(a.shape[0])
    seen = np.zeros(walls.shape[0], dtype=np.int64)  # the pass that last examined each box
    stamp = 0
    for s in range(a.shape[0]):
        ax, ay, bx, by = a[s, 0], a[s, 1], b[s, 0], b[s, 1]
        x0, y0, x1, y1 = bounds[0], bounds[1], bounds[2], bounds[3]
        d = min(min(min(ax - x0, x1 - ax), min(ay - y0, y1 - ay)), min(min(bx - x0, x1 - bx), min(by - y0, y1 - by)))
        if walls.shape[0]:
            nearest = np.inf
            reach = cell
            while True:
                stamp += 1
                i0, i1 = _grid_range(min(ax, bx) - reach, max(ax, bx) + reach, gx, cell, nx)
                j0, j1 = _grid_range(min(ay, by) - reach, max(ay, by) + reach, gy, cell, ny)
                for j in range(j0, j1 + 1):
                    for i in range(i0, i1 + 1):
                        k = j * nx + i
                        for q in range(starts[k], starts[k + 1]):
                            w = items[q]
                            if seen[w] == stamp:
                                continue
                            seen[w] = stamp
                            nearest = min(nearest, segment_box_d2_one(ax, ay, bx, by, walls[w, 0], walls[w, 1],
                                                                      walls[w, 2], walls[w, 3]))
                whole = i0 == 0 and j0 == 0 and i1 == nx - 1 and j1 == ny - 1
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
