"""The compiled steps of the walls-only queries (planning/wall_paths.py) against the NumPy lines
they replace, bit for bit: the segments to check (with one start listed once), and the paths'
points and lengths (the chain followed back along the predecessors, ``polyline_length``)."""

import numpy as np

from nodnav.geometry import TOL
from nodnav.planning.polylines import polyline_length
from nodnav.planning.visibility import VisibilityGraph
from nodnav.planning.wall_paths import (
    DIRECT,
    NONE,
    VIA,
    best_via_plain,
    segments_to_check,
    walls_answers,
    walls_paths,
)
from nodnav.scenario.world import paper_world


def test_segments_are_the_stacked_ones():
    rng = np.random.default_rng(3)
    for _ in range(100):
        m, nv = int(rng.integers(1, 6)), int(rng.integers(0, 9))
        starts, goals, v = rng.normal(size=(m, 2)), rng.normal(size=(m, 2)), rng.normal(size=(nv, 2))
        cs, cg = rng.uniform(-0.2, 1, m), rng.uniform(-0.2, 1, m)
        ts, tg = np.minimum(0.5, cs) - TOL, np.minimum(0.5, cg) - TOL
        a, b, need, one = segments_to_check(starts, goals, v, cs, cg, 0.5, TOL)
        assert not one or bool((starts == starts[0]).all() and (ts == ts[0]).all())
        assert np.array_equal(a, np.vstack([starts, np.repeat(starts, nv, axis=0), np.repeat(goals, nv, axis=0)]))
        assert np.array_equal(b, np.vstack([goals, np.tile(v, (2 * m, 1))]))
        assert np.array_equal(need, np.concatenate([np.minimum(ts, tg), np.repeat(ts, nv), np.repeat(tg, nv)]))
        starts[:], cs[:] = starts[0], cs[0]
        ts = np.minimum(0.5, cs) - TOL
        a1, b1, need1, one = segments_to_check(starts, goals, v, cs, cg, 0.5, TOL)
        assert one == (m > 1)
        if one:  # the first start's segments only
            a_ref = np.vstack([starts, np.repeat(starts[:1], nv, axis=0), np.repeat(goals, nv, axis=0)])
            assert np.array_equal(a1, a_ref)
            assert np.array_equal(b1, np.vstack([goals, np.tile(v, (1 + m, 1))]))
            assert np.array_equal(need1, np.concatenate([np.minimum(ts, tg), np.repeat(ts[:1], nv), np.repeat(tg, nv)]))


def test_answers_are_the_numpy_ones():
    rng = np.random.default_rng(4)
    nv = 7
    v = rng.normal(size=(nv, 2))
    dist = rng.uniform(0, 3, (nv, nv))
    dist[rng.random((nv, nv)) < 0.2] = np.inf
    pred = np.tile(np.arange(nv, dtype=np.int32)[:, None], (1, nv))  # every chain one step: first, last
    for _ in range(300):
        m = int(rng.integers(1, 5))
        starts, goals = rng.normal(size=(m, 2)), rng.normal(size=(m, 2))
        one = bool(m > 1 and rng.random() < 0.5)
        if one:
            starts[:] = starts[0]
        ns = 1 if one else m
        seen = rng.random(m + ns * nv + m * nv) < 0.6
        cs, cg = rng.uniform(-0.1, 1, m), rng.uniform(-0.1, 1, m)
        kind, points, offsets, lengths = walls_answers(starts, goals, v, seen, one, dist, pred, cs, cg, 0.2)
        from_start = np.repeat(seen[m:m + ns * nv].reshape(ns, nv), m // ns, axis=0)
        to_goal = seen[m + ns * nv:].reshape(m, nv)
        d_start = np.where(from_start, np.hypot(v[:, 0] - starts[:, 0:1], v[:, 1] - starts[:, 1:2]), np.inf)
        d_goal = np.where(to_goal, np.hypot(v[:, 0] - goals[:, 0:1], v[:, 1] - goals[:, 1:2]), np.inf)
        best, cost = best_via_plain(d_start, dist, d_goal, from_start, to_goal)
        ok = (cs >= 0.0) & (cg >= 0.2)
        want = np.where(ok & seen[:m], DIRECT, np.where(ok & np.isfinite(cost), VIA, NONE))
        assert kind.tolist() == want.tolist()
        assert np.array_equal(points, walls_paths(starts, goals, v, pred, kind, best)[0])


def test_paths_follow_the_predecessors():
    rng = np.random.default_rng(5)
    nv = 12
    v = rng.normal(size=(nv, 2))
    pred = rng.integers(0, nv, size=(nv, nv)).astype(np.int32)
    for first in range(nv):  # a chain first <- ... <- last without loops: predecessors lower
        for last in range(nv):
            pred[first, last] = first if last <= first + 1 else rng.integers(first, last)
    for _ in range(200):
        m = int(rng.integers(1, 6))
        starts, goals = rng.normal(size=(m, 2)), rng.normal(size=(m, 2))
        kind = rng.choice([NONE, DIRECT, VIA], m)
        best = np.array([f * nv + la for f, la in zip(rng.integers(0, nv, m), rng.integers(0, nv, m))])
        best = np.where(best // nv > best % nv, (best % nv) * nv + best // nv, best)  # first <= last
        points, offsets, lengths = walls_paths(starts, goals, v, pred, kind, best)
        for i in range(m):
            got = points[offsets[i]:offsets[i + 1]]
            if kind[i] == NONE:
                assert len(got) == 0 and lengths[i] == -1.0
                continue
            if kind[i] == DIRECT:
                want = np.array([starts[i], goals[i]])
            else:
                first, last = divmod(int(best[i]), nv)
                chain = [last]
                while chain[-1] != first:
                    chain.append(pred[first, chain[-1]])
                want = np.vstack([starts[i], v[chain[::-1]], goals[i]])
            assert np.array_equal(got, want)
            assert lengths[i] == (polyline_length(want) if len(want) <= 8 else -1.0)


def test_ways_from_one_spot_are_the_single_queries():
    world = paper_world()
    rng = np.random.default_rng(9)
    pts = rng.uniform([-6.7, -2.2], [6.7, 2.2], (200, 2))
    goals = pts[world.clearance(pts) >= 0.25][:30]
    start = np.array([-5.5, 0.3])
    batch = VisibilityGraph(world, 0.2, 0.025).shortest_paths(np.repeat(start[None], len(goals), 0), goals)
    fresh = VisibilityGraph(world, 0.2, 0.025)
    for g, path in zip(goals, batch):
        single = fresh.shortest_path(start, g)
        assert path.success == single.success and np.array_equal(path.points, single.points)
        assert path.length == polyline_length(path.points)
