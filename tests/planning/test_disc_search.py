"""The search around standing robots in one compiled call (:func:`disc_search`) against the
NumPy steps it replaces (``VisibilityGraph._search_with_discs_plain``), bit for bit: the same
path or the same failure, on random discs in the paper's world and in a world with a polygon
wall, with starts and goals inside octagons (where NumPy's exits are passed in), on octagon
boundaries and in corners."""

import math

import numpy as np
import pytest

from nodnav.geometry import TOL
from nodnav.planning.disc_checks import disc_violations_plain
from nodnav.planning.disc_search import (
    FOUND,
    NEEDS_EXITS,
    OCTAGON_REACH,
    add_crossed,
    disc_search,
    discs_met,
    without_repeats,
)
from nodnav.planning.visibility import VisibilityGraph, _without_repeats
from nodnav.scenario.world import Passage, World, paper_world


def _polygon_world() -> World:
    """A room with a notched L-shaped wall beside a passage (convex pieces for the clearances)."""
    shape = ((0.0, -3.0), (0.0, 0.0), (1.0, 0.0), (1.0, -2.0), (2.0, -1.5), (3.0, -2.0), (3.0, -3.0))
    return World(bounds=(-5.0, -5.0, 5.0, 5.0), obstacles=((-3.0, 1.0, -2.0, 2.0),),
                 passages=(Passage((-4.0, 4.0), (4.0, 4.0), 0.7),), polygons=(shape,))


def _query(graph: VisibilityGraph, rng, start_near: bool):
    """A start and goal in free space and a few discs, one of them perhaps close to the start."""
    world = graph.world
    lo, hi = np.array(world.bounds[:2]), np.array(world.bounds[2:])
    free = rng.uniform(lo, hi, (400, 2))
    free = free[world.clearance(free) >= graph.clearance]
    start, goal = free[0], free[1]
    m = int(rng.integers(1, 5))
    centres = (start + (goal - start) * rng.uniform(0.1, 0.9, m)[:, None] + rng.normal(0, 0.6, (m, 2)))
    radii = rng.uniform(0.3, 1.0, m)
    if start_near:  # inside, on or just outside an octagon: the exits' cases
        centres[0] = start + rng.normal(0, 1, 2) * radii[0] * rng.choice([0.5, 1.0, OCTAGON_REACH, 1.2]) / math.sqrt(2)
    d_start, d_goal = np.hypot(*(centres - start).T), np.hypot(*(centres - goal).T)
    limits = np.minimum(graph.clearance, world.clearance(np.array([start, goal]))) - TOL
    return start, goal, limits[0], limits[1], centres, radii, d_start, d_goal


@pytest.mark.parametrize("world", [paper_world(), _polygon_world()], ids=["paper", "polygon"])
def test_disc_search_is_the_numpy_search(world):
    graph = VisibilityGraph(world, 0.2, 0.05)
    rng = np.random.default_rng(41)
    found = failed = needed = 0
    for q in range(250):
        args = _query(graph, rng, start_near=q % 2 == 1)
        got, want = graph._search_with_discs(*args), graph._search_with_discs_plain(*args)
        assert (got.success, got.reason) == (want.success, want.reason)
        assert got.points.shape == want.points.shape and np.array_equal(got.points, want.points)
        found += got.success
        failed += not got.success
        start, goal, ts, tg, centres, radii, ds, dg = args
        outcome, _ = disc_search(start, goal, ts, tg, centres, radii, ds, dg, graph.vertices, graph._visible,
                                 graph.clearance, world.bounds_array, world.obstacle_array, world.piece_array,
                                 np.zeros((0, 2)))
        needed += outcome == NEEDS_EXITS
    assert found > 100 and failed and needed > 20  # every branch taken


def test_exits_needed_only_near_an_octagon():
    # A unit disc at the origin: from (2, 0) (outside every octagon it could have) the exit is
    # the start itself; from (1, 0) (on the disc, inside its octagon) NumPy's exit is needed.
    world = World(bounds=(-10.0, -10.0, 10.0, 10.0), obstacles=(), passages=(Passage((-4.0, 4.0), (4.0, 4.0), 0.7),))
    graph = VisibilityGraph(world, 0.2)
    centres, radii = np.zeros((1, 2)), np.ones(1)

    def outcome(start):
        goal = np.array([-5.0, 0.0])
        return disc_search(start, goal, 0.0, 0.0, centres, radii, np.hypot(*start[None].T), np.array([5.0]),
                           graph.vertices, graph._visible, graph.clearance, world.bounds_array,
                           world.obstacle_array, world.piece_array, np.zeros((0, 2)))

    status, points = outcome(np.array([2.0, 0.0]))
    assert status == FOUND and points[0].tolist() == [2.0, 0.0] and points[-1].tolist() == [-5.0, 0.0]
    # around the disc: every vertex at least its radius from the centre
    assert (np.hypot(*points.T) >= 1.0 - TOL).all()
    assert outcome(np.array([1.0, 0.0]))[0] == NEEDS_EXITS


def test_without_repeats_is_the_numpy_steps():
    rng = np.random.default_rng(5)
    for _ in range(300):
        nodes = rng.integers(0, 3, (6, 2)).astype(float)
        nodes[rng.random(6) < 0.3] += TOL / 2  # within TOL of a copy
        chain = rng.integers(0, 6, int(rng.integers(2, 7)))
        got = without_repeats(nodes, chain)
        assert np.array_equal(got, _without_repeats(nodes[chain]))
    # by hand: a goal repeating the vertex before it takes that vertex's place
    nodes = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    assert without_repeats(nodes, np.array([0, 1, 2])).tolist() == [[0.0, 0.0], [1.0, 0.0]]


def test_discs_met_and_add_crossed_are_the_numpy_lines():
    """``shortest_path``'s NumPy lines: the discs above TOL with ``np.hypot`` of their centres'
    offsets from the start and the goal, then ``~active & disc_violations(...)`` added to the
    active ones, bit for bit (radii at and below TOL, discs holding the start among them)."""
    rng = np.random.default_rng(17)
    for _ in range(400):
        poly = rng.uniform(-3, 3, (int(rng.integers(1, 6)), 2))
        m = int(rng.integers(0, 6))
        centres = rng.uniform(-3, 3, (m, 2)) * rng.choice([1e-3, 1.0, 1e3])
        if m and rng.random() < 0.3:
            centres[0] = poly[0] + rng.normal(0, 0.05, 2)
        radii = rng.choice([0.0, TOL / 2, TOL, 0.3, 0.8, 1.5], m)
        start, goal = poly[0], poly[-1]
        keep = radii > TOL
        want_c, want_r = centres[keep], radii[keep]
        want_s = np.hypot(want_c[:, 0] - start[0], want_c[:, 1] - start[1])
        want_g = np.hypot(want_c[:, 0] - goal[0], want_c[:, 1] - goal[1])
        got = discs_met(centres, radii, start, goal)
        for a, b in zip(got, (want_c, want_r, want_s, want_g)):
            assert a.shape == b.shape and np.array_equal(a, b)
        active = rng.random(len(want_r)) < 0.4
        crossed = ~active & disc_violations_plain(poly, want_c, want_r, want_s, want_g)
        grown = active.copy()
        assert add_crossed(np.ascontiguousarray(poly), *got, grown) == bool(crossed.any())
        assert np.array_equal(grown, active | crossed)
