"""Polygon walls: convex pieces, distances and the visibility graph's corners, checked against
shapely (GEOS), an independent implementation of the same geometry."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
import shapely.ops

from nodnav.geometry import piece_clearance, piece_closest_point_one
from nodnav.planning.visibility import chamfered_polygon_vertices
from nodnav.scenario.polygons import convex_pieces, is_convex, padded_pieces, polygon_problem
from nodnav.scenario.world import Passage, World

#: A non-convex wall: an L with a notch, listed clockwise (the loader takes either orientation).
SHAPE = [(0.0, 0.0), (0.0, 3.0), (1.0, 3.0), (1.0, 1.0), (2.0, 1.5), (3.0, 1.0), (3.0, 0.0)]


def world_with(polygons) -> World:
    return World(bounds=(-5.0, -5.0, 5.0, 5.0), obstacles=(), passages=(Passage((-4.0, 4.0), (4.0, 4.0), 0.7),),
                 polygons=tuple(tuple(p) for p in polygons))


def test_convex_pieces_cover_the_polygon_exactly():
    poly = shapely.Polygon(SHAPE)
    pieces = convex_pieces(SHAPE)
    assert len(pieces) < len(SHAPE) - 2  # merged beyond plain triangles
    union = shapely.union_all([shapely.Polygon(p) for p in pieces])
    assert union.symmetric_difference(poly).area < 1e-12
    assert sum(shapely.Polygon(p).area for p in pieces) == pytest.approx(poly.area)  # no overlaps
    for p in pieces:
        assert is_convex(p) and shapely.Polygon(p).exterior.is_ccw


def test_a_convex_polygon_is_its_own_piece():
    square = [(0, 0), (2, 0), (2, 2), (0, 2)]
    assert len(convex_pieces(square)) == 1


def test_clearance_matches_shapely_outside_and_its_sign_inside():
    rng = np.random.default_rng(3)
    world = world_with([SHAPE])
    pts = rng.uniform(-1.0, 4.0, size=(400, 2))
    d = piece_clearance(pts, world.piece_array)
    poly = shapely.Polygon(SHAPE)
    ref = np.array([poly.distance(shapely.Point(p)) for p in pts])
    inside = np.array([poly.covers(shapely.Point(p)) for p in pts])
    np.testing.assert_allclose(d[~inside], ref[~inside], atol=1e-12)
    assert (d[inside] <= 1e-12).all()


def test_segment_clearance_matches_shapely():
    rng = np.random.default_rng(4)
    world = world_with([SHAPE])
    a, b = rng.uniform(-1.5, 4.5, size=(300, 2)), rng.uniform(-1.5, 4.5, size=(300, 2))
    got = world.segment_clearance(a, b)
    poly = shapely.Polygon(SHAPE)
    walls = np.array([poly.distance(shapely.LineString([p, q])) for p, q in zip(a, b)])
    box = np.minimum.reduce([np.minimum(a[:, 0], b[:, 0]) + 5, 5 - np.maximum(a[:, 0], b[:, 0]),
                             np.minimum(a[:, 1], b[:, 1]) + 5, 5 - np.maximum(a[:, 1], b[:, 1])])
    np.testing.assert_allclose(got, np.minimum(walls, box), atol=1e-12)


def test_closest_point_is_shapely_nearest_point():
    rng = np.random.default_rng(5)
    piece = padded_pieces([np.array([[0.0, 0.0], [2.0, 0.0], [3.0, 1.0], [0.5, 2.0]])])[0]
    poly = shapely.Polygon(piece)
    for p in rng.uniform(-2.0, 5.0, size=(200, 2)):
        q = np.array(piece_closest_point_one(p[0], p[1], piece))
        if poly.covers(shapely.Point(p)):
            assert np.array_equal(q, p)
        else:
            ref = np.array(shapely.ops.nearest_points(poly, shapely.Point(p))[0].coords[0])
            np.testing.assert_allclose(q, ref, atol=1e-12)
            # the half-plane through q facing p keeps the whole (convex) piece on the other side
            assert ((piece - q) @ (p - q) <= 1e-12).all()


def test_grown_polygon_edges_keep_the_inflation():
    r = 0.3
    v = chamfered_polygon_vertices(np.array(SHAPE), r)
    poly = shapely.Polygon(SHAPE)
    convex_corners = 6  # the notch's bottom is reflex
    assert len(v) >= convex_corners
    ring = shapely.LinearRing(v)
    assert ring.distance(poly) == pytest.approx(r, abs=1e-12)  # tangent to the grown polygon, never closer


@pytest.mark.parametrize("points, words", [
    ([(0, 0), (1, 1)], "at least 3 points"),
    ([(0, 0), (1, 1), (2, 2)], "zero area"),
    ([(0, 0), (2, 2), (2, 0), (0, 2)], "crosses itself"),
])
def test_bad_polygons_are_named(points, words):
    assert words in polygon_problem(points)


def test_orca_gets_polygon_walls_counter_clockwise():
    from nodnav.sim.baselines import wall_polygons

    world = world_with([SHAPE])  # SHAPE is listed clockwise
    polys = wall_polygons(world)
    assert len(polys) == 2  # the polygon, then the boundary
    assert shapely.LinearRing(polys[0]).is_ccw and not shapely.LinearRing(polys[1]).is_ccw
    assert shapely.Polygon(polys[0]).equals(shapely.Polygon(SHAPE))


def test_controller_walls_as_pieces_agree_with_boxes():
    # The MPC's per-wall state (nearest point, direction away, distance) and its exact plan check
    # give the same for a box and for the same box as a convex piece.
    from nodnav.control.mpc_rows import group_state, plan_extremes

    rng = np.random.default_rng(6)
    boxes = np.array([[-3.0, -2.5, 3.0, -0.35], [-3.0, 0.35, 3.0, 2.5]])
    pieces = padded_pieces([np.array(box_polygon_ccw(b)) for b in boxes])
    none_b, none_p = np.zeros((0, 4)), np.zeros((0, 3, 2))
    n_end = 4
    speed, intervals = np.full(n_end, 0.5), np.full(n_end, 0.1)
    pred = np.zeros((0, n_end + 2, 2))
    full = np.full(2, 0.2)
    bounds = np.array([-7.0, -2.5, 7.0, 2.5])
    for p0 in rng.uniform([-6.0, -2.4], [6.0, 2.4], size=(50, 2)):
        a = group_state(pred, n_end, p0, speed, intervals, boxes, none_p, full, 0.0, 10.0)
        b = group_state(pred, n_end, p0, speed, intervals, none_b, pieces, full, 0.0, 10.0)
        for x, y in zip(a, b):
            np.testing.assert_allclose(x, y, atol=1e-12)
    values = rng.uniform(-6.0, 6.0, size=(30, 2))
    ca = plan_extremes(values, 20, 5, boxes, none_p, bounds, np.zeros((0, 20, 2)))[0]
    cb = plan_extremes(values, 20, 5, none_b, pieces, bounds, np.zeros((0, 20, 2)))[0]
    assert ca == pytest.approx(cb, abs=1e-12)


def box_polygon_ccw(box):
    x0, y0, x1, y1 = box
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
