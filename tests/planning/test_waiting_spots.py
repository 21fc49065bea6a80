"""Waiting spots: the rings against a hand computation and the rings computed afresh; the
shortest ways found lazily against computing every way and sorting them all, bit for bit; the
dash-first order against a stable sort by clash."""

import itertools
import math

import numpy as np
import pytest

from nodnav.planning.making_way import clear_first
from nodnav.planning.visibility import VisibilityGraph
from nodnav.planning.waiting_spots import nearest_ways, ring_spots
from nodnav.scenario.world import paper_world

WORLD = paper_world()
GRAPH = VisibilityGraph(WORLD, 0.18, 0.02)


def every_way(graph, start, spots, count):
    """The reference: every way in one batch, a stable sort of all their lengths, the first ``count``."""
    ways = graph.with_own_memos().shortest_paths(np.repeat(np.asarray(start, dtype=float)[None], len(spots), 0), spots)
    near = np.argsort([w.length for w in ways], kind="stable")[:count]
    return near, [ways[q] for q in near]


def lazily(graph, start, spots, count, batch=4):
    """Every way :func:`nearest_ways` gives, as the reference's ``(indices, ways)``."""
    got = list(nearest_ways(graph, start, spots, count, batch))
    return np.array([q for q, _ in got], dtype=int), [w for _, w in got]


def same(got, want):
    """Indices, success, points (bitwise) and lengths (bitwise) of two answers."""
    (gi, gw), (wi, ww) = got, want
    assert gi.tolist() == wi.tolist()
    assert len(gw) == len(ww)
    for g, w in zip(gw, ww):
        assert g.success == w.success
        assert g.points.tobytes() == w.points.tobytes()
        assert np.float64(g.length).tobytes() == np.float64(w.length).tobytes()


def spot_sets(seed):
    """Starts and spots of every kind the planner offers: rings around the start (a ring's spots
    equally far in a straight line, to rounding), spots repeated (exactly equal ways), spots
    behind the walls (ways around them, longer than the straight line) and in walls or out of the
    world (failed ways)."""
    rng = np.random.default_rng(seed)
    x0, y0, x1, y1 = WORLD.bounds
    for _ in range(12):
        start = rng.uniform([x0 + 0.3, y0 + 0.3], [x1 - 0.3, y1 - 0.3])
        while WORLD.clearance(start[None])[0] < 0.2:
            start = rng.uniform([x0 + 0.3, y0 + 0.3], [x1 - 0.3, y1 - 0.3])
        rings = ring_spots(start, (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 7.0), 16)
        scattered = rng.uniform([x0 - 0.5, y0 - 0.5], [x1 + 0.5, y1 + 0.5], size=(int(rng.integers(1, 200)), 2))
        spots = np.vstack([rings, scattered])
        spots = np.vstack([spots, spots[rng.integers(0, len(spots), size=20)]])  # exact ties
        yield start, spots[rng.permutation(len(spots))]


@pytest.mark.parametrize("seed", range(4))
def test_nearest_ways_are_those_of_sorting_every_way(seed):
    for start, spots in spot_sets(seed):
        for count in (1, 3, 24, len(spots) - 1, len(spots), len(spots) + 5):
            for keep in (len(spots), 30, 5, 0):  # many spots, a few (all kept), fewer than count, none
                for batch in (1, 4, 50):
                    got = lazily(GRAPH.with_own_memos(), start, spots[:keep], count, batch)
                    same(got, every_way(GRAPH, start, spots[:keep], count))


def test_nearest_ways_skip_the_far_spots():
    # A ring's spots near the start, then a hundred far off: the far ones' ways are never computed.
    start = np.array([-4.5, 0.0])
    spots = np.vstack([ring_spots(start, (0.5,), 16), ring_spots(start, (3.0,), 100)])
    graph = GRAPH.with_own_memos()
    same(lazily(graph, start, spots, 8), every_way(GRAPH, start, spots, 8))
    assert len(graph._plain) == 16
    # Asked for the first way only, the ring's spots alone are computed (each could be it).
    graph = GRAPH.with_own_memos()
    q, way = next(nearest_ways(graph, start, spots, 8, batch=1))
    assert len(graph._plain) == 16
    assert q == int(every_way(GRAPH, start, spots, 1)[0][0])


def test_a_way_is_the_same_in_any_batch():
    # What nearest_ways relies on: a query's answer does not depend on the others asked with it.
    for start, spots in itertools.islice(spot_sets(7), 3):
        starts = np.repeat(start[None], len(spots), 0)
        together = GRAPH.with_own_memos().shortest_paths(starts, spots)
        for q in range(0, len(spots), 7):
            alone = GRAPH.with_own_memos().shortest_paths(starts[q:q + 1], spots[q:q + 1])[0]
            assert alone.points.tobytes() == together[q].points.tobytes()
            assert np.float64(alone.length).tobytes() == np.float64(together[q].length).tobytes()


def test_clear_first_is_a_stable_sort_by_clash_read_lazily():
    rng = np.random.default_rng(3)
    for _ in range(50):
        clash = rng.random(int(rng.integers(0, 30))) < rng.random()
        got = [q for q, _ in clear_first(enumerate(clash.tolist()), lambda item: item[1])]
        assert got == np.argsort(clash, kind="stable").tolist()
    read, checked = [], []
    items = (read.append(q) or q for q in range(4))
    first = next(clear_first(items, lambda q: checked.append(q) or q in (0, 2)))
    assert first == 1
    assert read == checked == [0, 1]  # the ways after the first clear one are neither read nor checked


@pytest.mark.parametrize("turn", [0.0, 0.3, -1.2])
def test_ring_spots_around_a_centre(turn):
    centre, radii = np.array([0.3, -1.7]), (0.5, 1.0, 2.5)
    spots = ring_spots(centre, radii, 16, turn)
    # Spot j of ring i at radius radii[i], angle turn + 2 pi j / 16.
    angle = [turn + 2 * math.pi * j / 16 for j in range(16)]
    want = [[centre[0] + r * math.cos(a), centre[1] + r * math.sin(a)] for r in radii for a in angle]
    assert spots == pytest.approx(np.array(want), abs=1e-12)
    # Bit for bit the rings computed afresh every call (the unit ring is remembered).
    angles = 2.0 * np.pi * np.arange(16) / 16
    ring = np.stack([np.cos(angles + turn if turn else angles), np.sin(angles + turn if turn else angles)], axis=1)
    fresh = (centre[None, None] + np.asarray(radii)[:, None, None] * ring[None]).reshape(-1, 2)
    assert spots.tobytes() == fresh.tobytes()
    assert spots.flags.writeable  # the caller's own array
