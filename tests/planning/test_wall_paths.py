"""The compiled steps of the walls-only queries (planning/wall_paths.py) against the NumPy lines
they replace, bit for bit: the segments to check (with one start listed once), and the paths'
points and lengths (the chain followed back along the predecessors, ``polyline_length``)."""

import numpy as np

from nodnav.planning.polylines import polyline_length
from nodnav.planning.visibility import VisibilityGraph
from nodnav.planning.wall_paths import DIRECT, NONE, VIA, segments_to_check, walls_paths
from nodnav.scenario.world import paper_world


def test_segments_are_the_stacked_ones():
    rng = np.random.default_rng(3)
    for _ in range(100):
        m, nv = int(rng.integers(1, 6)), int(rng.integers(0, 9))
        starts, goals, v = rng.normal(size=(m, 2)), rng.normal(size=(m, 2)), rng.normal(size=(nv, 2))
        ts, tg = rng.uniform(0, 1, m), rng.uniform(0, 1, m)
        a, b, need = segments_to_check(starts, goals, v, ts, tg, False)
        assert np.array_equal(a, np.vstack([starts, np.repeat(starts, nv, axis=0), np.repeat(goals, nv, axis=0)]))
        assert np.array_equal(b, np.vstack([goals, np.tile(v, (2 * m, 1))]))
        assert np.array_equal(need, np.concatenate([np.minimum(ts, tg), np.repeat(ts, nv), np.repeat(tg, nv)]))
        starts[:], ts[:] = starts[0], ts[0]
        a1, b1, need1 = segments_to_check(starts, goals, v, ts, tg, True)
        a, b, need = segments_to_check(starts, goals, v, ts, tg, False)
        keep = np.r_[0:m + nv, m + m * nv:m + 2 * m * nv]  # the first start's segments only
        assert np.array_equal(a1, a[keep]) and np.array_equal(b1, b[keep]) and np.array_equal(need1, need[keep])


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
