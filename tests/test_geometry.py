"""The geometry core against hand computations and dense sampling."""

import math

import numpy as np
import pytest

from nodnav.geometry import (
    bounds_distance,
    min_gap,
    min_pair_distance,
    point_box_distance,
    segment_box_distance,
    segment_clearance,
    segment_point_distance,
    segments_hit_boxes,
)
from nodnav.scenario.world import paper_world

UNIT_BOX = np.array([[-1.0, -1.0, 1.0, 1.0]])


def dense(a, b, n=4001):
    """Points densely along each segment, ``(S, n, 2)``."""
    t = np.linspace(0.0, 1.0, n)
    return a[:, None] + t[None, :, None] * (b - a)[:, None]


def test_point_box_distance_hand_values():
    pts = np.array([[0.0, 0.0], [3.0, 0.0], [2.0, 2.0], [0.5, -4.0]])
    # inside; 2 m right of the right side; sqrt(2) from corner (1,1); 3 m below the bottom side.
    assert point_box_distance(pts, UNIT_BOX)[:, 0] == pytest.approx([0.0, 2.0, math.sqrt(2.0), 3.0])


def test_segment_point_distance_hand_values():
    a, b = np.array([[0.0, 0.0], [1.0, 1.0]]), np.array([[2.0, 0.0], [1.0, 1.0]])
    pts = np.array([[1.0, 1.0], [3.0, 0.0], [-1.0, -1.0], [1.0, 4.0]])
    d = segment_point_distance(a, b, pts)
    # Segment (0,0)-(2,0): foot inside, past the end, before the start, foot inside.
    assert d[0] == pytest.approx([1.0, 1.0, math.sqrt(2.0), 4.0])
    # A zero-length segment is the point (1,1).
    assert d[1] == pytest.approx([0.0, math.sqrt(5.0), math.sqrt(8.0), 3.0])


def test_segments_hit_boxes_cases():
    a = np.array([[-2.0, 0.0], [-2.0, 2.0], [0.0, 3.0], [2.0, 0.0], [1.5, -3.0], [0.0, 0.0], [-3.0, 1.0]])
    b = np.array([[2.0, 0.0], [2.0, 2.0], [0.0, 1.0], [0.0, 2.0], [1.5, 3.0], [0.1, 0.1], [-1.5, 1.0]])
    # through; parallel above; vertical touching the top; diagonal touching corner (1,1);
    # vertical beside; inside; horizontal stopping short.
    assert segments_hit_boxes(a, b, UNIT_BOX)[:, 0].tolist() == [True, False, True, True, False, True, False]


def test_segment_box_distance_hand_values():
    a = np.array([[-2.0, 3.0], [3.0, 0.0], [2.0, 0.0], [0.0, 0.0], [4.0, -0.5]])
    b = np.array([[2.0, 3.0], [0.0, 3.0], [0.0, 2.0], [0.5, 0.5], [4.0, 0.5]])
    # 2 above the top; line x + y = 3 is (3 - 2)/sqrt(2) from corner (1,1); touching; inside;
    # vertical segment 3 to the right of the right side.
    d = segment_box_distance(a, b, UNIT_BOX)[:, 0]
    assert d == pytest.approx([2.0, 1.0 / math.sqrt(2.0), 0.0, 0.0, 3.0])


def test_segment_box_distance_matches_dense_sampling():
    rng = np.random.default_rng(1)
    a = rng.uniform(-4, 4, (400, 2))
    b = a + rng.normal(0.0, 1.5, (400, 2))
    a[:50, 0] = b[:50, 0]  # vertical
    a[50:70] = b[50:70]  # points
    boxes = np.array([[-1.0, -1.0, 1.0, 1.0], [1.5, -3.0, 2.5, 0.0]])
    exact = segment_box_distance(a, b, boxes)
    sampled = point_box_distance(dense(a, b).reshape(-1, 2), boxes).reshape(len(a), -1, 2).min(axis=1)
    step = np.linalg.norm(b - a, axis=1)[:, None] / 4000
    # The exact minimum is never above a sampled value and at most half a step below it.
    assert np.all(exact <= sampled + 1e-12)
    assert np.all(exact >= sampled - step / 2 - 1e-12)


def test_segment_clearance_matches_world_clearance():
    world = paper_world()
    rng = np.random.default_rng(2)
    a = rng.uniform([-6.8, -2.3], [6.8, 2.3], (300, 2))
    b = a + rng.normal(0.0, 1.0, (300, 2))
    b = np.clip(b, [-6.9, -2.4], [6.9, 2.4])
    exact = segment_clearance(world, a, b)
    sampled = world.clearance(dense(a, b)).min(axis=1)
    step = np.linalg.norm(b - a, axis=1) / 4000
    free = sampled > 0
    assert np.all(exact[free] <= sampled[free] + 1e-12)
    assert np.all(exact[free] >= sampled[free] - step[free] / 2 - 1e-12)
    # Touching or crossing a wall gives zero.
    assert np.all(exact[~free] <= 1e-12)


def test_bounds_distance():
    d = bounds_distance(np.array([[0.0, 0.0], [6.5, 2.0], [8.0, 0.0]]), (-7.0, -2.5, 7.0, 2.5))
    assert d == pytest.approx([2.5, 0.5, -1.0])


def test_segment_rectangle_distance_hand_values():
    rect = np.array([[0.0, 0.0, 1.0, 1.0]])

    def seg(a, b):
        return segment_box_distance(np.array(a, float), np.array(b, float), rect)[0, 0]

    assert seg([-1, 2], [2, 2]) == pytest.approx(1.0)            # parallel above the top side
    assert seg([-1, 0.5], [2, 0.5]) == 0.0                         # straight through
    assert seg([2, -1], [3, 0]) == pytest.approx(np.sqrt(2.0))     # (2, -1) is the closest point, to corner (1, 0)
    assert seg([0.0, 2.0], [2.0, 0.0]) == pytest.approx(0.0)       # touches the corner (1, 1)
    assert seg([0.5, 3.0], [3.0, 0.5]) == pytest.approx(np.hypot(0.75, 0.75))  # closest point (1.75, 1.75)
    assert seg([0.5, 0.5], [0.5, 0.5]) == 0.0                      # a point inside


def test_segment_clearance_keeps_leading_dimensions():
    world = paper_world()
    a = np.array([[[-5.0, 0.0], [5.0, 1.0]], [[-5.0, 2.0], [0.0, 0.0]]])
    b = a + 0.5
    out = segment_clearance(world, a, b)
    assert out.shape == (2, 2)
    assert out.ravel() == pytest.approx(segment_clearance(world, a.reshape(-1, 2), b.reshape(-1, 2)))
    assert segment_clearance(world, a[0, 0], b[0, 0]).shape == (1,)


def test_pair_distances_by_hand():
    p = np.array([[0.0, 0.0], [3.0, 4.0], [0.0, 1.0]])
    assert min_pair_distance(p) == pytest.approx(1.0)
    assert min_gap(p, np.array([0.2, 0.2, 0.3])) == pytest.approx(0.5)
    assert min_pair_distance(p[:1]) == math.inf
