"""The wall index of maps' worlds: its clearances are exactly the full loop's (bit for bit)."""

import numpy as np
import pytest

from nodnav.geometry import (
    WallGrid,
    _segment_clearance_indexed,
    _segment_clearance_kernel,
    clearance_indexed,
    clearance_of,
)


@pytest.mark.parametrize("seed", range(4))
def test_indexed_clearances_equal_the_full_loop(seed):
    rng = np.random.default_rng(seed)
    bounds = np.array([-3.0, -2.0, 9.0, 7.0])
    lo = rng.uniform(bounds[:2], bounds[2:], (300, 2))
    boxes = np.hstack([lo, lo + rng.uniform(0.05, 1.5, (300, 2))])  # some reach past the bounds
    grid = WallGrid(boxes, bounds, cell=0.5)
    pts = rng.uniform(bounds[:2] - 1.0, bounds[2:] + 1.0, (2000, 2))
    assert np.array_equal(clearance_indexed(pts, bounds, boxes, *grid.arrays()), clearance_of(pts, bounds, boxes))
    a, b = pts[:1000], pts[1000:]
    b[::3] = a[::3] + rng.normal(0.0, 0.2, (len(a[::3]), 2))  # short segments as well as long ones
    pieces = np.zeros((0, 3, 2))
    full = _segment_clearance_kernel(a, b, boxes, bounds, pieces)
    assert np.array_equal(_segment_clearance_indexed(a, b, boxes, bounds, pieces, *grid.arrays()), full)
