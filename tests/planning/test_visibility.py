"""Visibility graphs and shortest paths against hand computations, analytical shortest paths and dense sampling."""

import math

import numpy as np
import pytest
from scipy.sparse.csgraph import dijkstra

from nodnav.geometry import segment_box_distance
from nodnav.planning.polylines import arc_length_grid, polyline_length, polyline_point_distance
from nodnav.planning.visibility import (
    VisibilityGraph,
    chamfered_vertices,
    disc_violations,
    octagon_exits,
    shortest_chain,
)
from nodnav.scenario.world import Corridor, World, paper_world

UNIT_BOX = np.array([[-1.0, -1.0, 1.0, 1.0]])


def open_world(half: float = 10.0) -> World:
    """A square room without walls (the corridor fields are unused here)."""
    return World(bounds=(-half, -half, half, half), obstacles=(),
                 corridor=Corridor(-0.5, 0.5, -0.5, 0.5), entrances=((-0.5, 0.0), (0.5, 0.0)))


def dense(a, b, n=4001):
    """Points densely along each segment, ``(S, n, 2)``."""
    t = np.linspace(0.0, 1.0, n)
    return a[:, None] + t[None, :, None] * (b - a)[:, None]


def test_chamfered_octagon_of_a_point_is_regular():
    v = chamfered_vertices(np.array([[1.0, 2.0, 1.0, 2.0]]), 0.5)
    r = np.linalg.norm(v - [1.0, 2.0], axis=1)
    # Circumscribed about a circle of radius 0.5: every vertex at 0.5 / cos(pi/8).
    assert r == pytest.approx(np.full(8, 0.5 / math.cos(math.pi / 8)))
    # Every edge is tangent to the circle: its midpoint is exactly 0.5 from the centre.
    mid = 0.5 * (v + np.roll(v, -1, axis=0))
    assert np.linalg.norm(mid - [1.0, 2.0], axis=1) == pytest.approx(np.full(8, 0.5))


def test_chamfered_box_edges_keep_the_inflation():
    box = np.array([[-1.0, -1.0, 2.0, 0.5]])
    v = chamfered_vertices(box, 0.3)
    # Every edge of the octagon keeps exactly 0.3 from the box (sides and tangent chamfers).
    d = segment_box_distance(v, np.roll(v, -1, axis=0), box)[:, 0]
    assert d == pytest.approx(np.full(8, 0.3))


def test_arc_length_grid():
    poly = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.25], [1.0, 0.25]])
    grid = arc_length_grid(poly, 0.3)
    # 1 m in 4 pieces of 0.25, then 0.25 m in 1 piece; the duplicate point adds nothing.
    assert grid.arc_length == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0, 1.25])
    assert grid.points[4].tolist() == [1.0, 0.0]  # the corner is a grid point
    assert grid.points[-1].tolist() == [1.0, 0.25]
    step = np.linalg.norm(np.diff(grid.points, axis=0), axis=1)
    assert np.all(step <= 0.3) and step.sum() == pytest.approx(polyline_length(poly))
    single = arc_length_grid(np.array([[2.0, 3.0]]), 0.1)
    assert single.points.tolist() == [[2.0, 3.0]] and single.arc_length.tolist() == [0.0]


def test_polyline_point_distance():
    poly = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    d = polyline_point_distance(poly, np.array([[1.0, 1.0], [3.0, 1.0], [2.0, 3.0]]))
    assert d == pytest.approx([1.0, 1.0, 1.0])


def test_visible_goal_is_a_straight_line():
    g = VisibilityGraph(paper_world(), 0.2, 0.025)
    path = g.shortest_path(np.array([-5.5, 0.0]), np.array([5.5, 0.0]))
    assert path.success and path.points.tolist() == [[-5.5, 0.0], [5.5, 0.0]]
    assert path.length == pytest.approx(11.0)


def test_path_through_the_corridor_matches_the_hand_construction():
    world = paper_world()
    r, e = 0.2, 0.025
    g = VisibilityGraph(world, r, e)
    path = g.shortest_path(np.array([-5.5, 1.5]), np.array([5.5, 1.5]))
    # It enters the grown corridor at the lower chamfer vertices of the upper wall,
    # (-/+ (3 + R tan(pi/8)), 0.35 - R) with R = r + e, and runs straight between them.
    R = r + e
    corner = np.array([3.0 + R * math.tan(math.pi / 8), 0.35 - R])
    expected = 2 * np.linalg.norm(np.array([5.5, 1.5]) - corner) + 2 * corner[0]
    assert path.success and path.length == pytest.approx(expected)
    assert path.points[1] == pytest.approx(corner * [-1, 1])
    pts = dense(path.points[:-1], path.points[1:])
    assert world.clearance(pts).min() >= r + e - 1e-9


def test_path_around_a_disc_is_near_the_analytic_optimum():
    g = VisibilityGraph(open_world(), 0.2)
    start, goal = np.array([-5.0, 0.0]), np.array([5.0, 0.0])
    path = g.shortest_path(start, goal, discs=np.array([[0.0, 0.0]]), disc_radii=np.array([1.0]))
    assert path.success
    pts = dense(path.points[:-1], path.points[1:])
    assert np.linalg.norm(pts, axis=-1).min() >= 1.0 - 1e-9

    def around(rho):  # two tangents and the arc between them, around a circle of radius rho
        return 2 * math.sqrt(25 - rho**2) + rho * (math.pi - 2 * math.acos(rho / 5))

    # The octagon lies between the circle and the circle of radius 1/cos(pi/8).
    assert around(1.0) <= path.length <= around(1.0 / math.cos(math.pi / 8)) + 1e-9


def test_discs_off_the_path_are_ignored():
    g = VisibilityGraph(open_world(), 0.2)
    path = g.shortest_path(np.array([-5.0, 0.0]), np.array([5.0, 0.0]),
                           discs=np.array([[0.0, 3.0]]), disc_radii=np.array([1.0]))
    assert path.points.tolist() == [[-5.0, 0.0], [5.0, 0.0]]


def test_start_inside_a_disc_may_leave_but_not_approach():
    g = VisibilityGraph(open_world(), 0.2)
    centre = np.array([[0.0, 0.0]])
    path = g.shortest_path(np.array([-0.5, 0.0]), np.array([-5.0, 0.0]), discs=centre, disc_radii=np.array([1.0]))
    assert path.success and path.points.tolist() == [[-0.5, 0.0], [-5.0, 0.0]]
    # Going to the far side it must not come closer to the centre than where it starts.
    path = g.shortest_path(np.array([-0.5, 0.0]), np.array([5.0, 0.0]), discs=centre, disc_radii=np.array([1.0]))
    assert path.success
    pts = dense(path.points[:-1], path.points[1:])
    assert np.linalg.norm(pts, axis=-1).min() >= 0.5 - 1e-6


def test_blocked_passage_fails_with_a_reason():
    g = VisibilityGraph(paper_world(), 0.2, 0.025)
    # A disc plugging the corridor: no way from one room to the other.
    path = g.shortest_path(np.array([-5.0, 0.0]), np.array([5.0, 0.0]),
                           discs=np.array([[0.0, 0.0]]), disc_radii=np.array([0.5]))
    assert not path.success and "no collision-free path" in path.reason
    assert path.length == float("inf") and path.points.tolist() == [[-5.0, 0.0]]


def test_goal_in_a_wall_fails():
    g = VisibilityGraph(paper_world(), 0.2)
    path = g.shortest_path(np.array([-5.0, 0.0]), np.array([0.0, 1.0]))
    assert not path.success and "not in free space" in path.reason
    # Too close to the outer boundary for the robot's radius.
    path = g.shortest_path(np.array([-5.0, 0.0]), np.array([-6.9, 0.0]))
    assert not path.success and "clearance 0.100" in path.reason


def test_start_squeezed_against_a_wall_can_leave():
    world = paper_world()
    g = VisibilityGraph(world, 0.2, 0.05)
    start = np.array([0.0, 0.15])  # clearance exactly the radius, inside the 0.05 margin band
    path = g.shortest_path(start, np.array([5.5, 0.0]))
    assert path.success
    pts = dense(path.points[:-1], path.points[1:])
    assert world.clearance(pts).min() >= 0.2 - 1e-9


@pytest.mark.parametrize("seed", range(5))
def test_shortest_chain_matches_scipy(seed):
    rng = np.random.default_rng(seed)
    n = 25
    i, j = np.triu_indices(n, 1)
    keep = rng.random(len(i)) < 0.15
    i, j = i[keep], j[keep]
    w = rng.uniform(0.1, 2.0, len(i))
    dense_w = np.zeros((n, n))
    dense_w[i, j] = dense_w[j, i] = w
    ref = dijkstra(dense_w, directed=False, indices=0)
    lookup = {(a, b): x for a, b, x in zip(i, j, w)} | {(b, a): x for a, b, x in zip(i, j, w)}
    for target in range(1, n):
        chain = shortest_chain(n, i, j, w, 0, target)
        if not np.isfinite(ref[target]):
            assert chain == []
            continue
        assert chain[0] == 0 and chain[-1] == target
        assert sum(lookup[(a, b)] for a, b in zip(chain, chain[1:])) == pytest.approx(ref[target])


def test_batched_paths_are_valid_and_match_single_queries():
    world = paper_world()
    rng = np.random.default_rng(7)
    pts = rng.uniform([-6.7, -2.2], [6.7, 2.2], (200, 2))
    pts = pts[world.clearance(pts) >= 0.25][:40]
    starts, goals = pts[:20], pts[20:40]
    batch = VisibilityGraph(world, 0.2, 0.025).shortest_paths(starts, goals)
    fresh = VisibilityGraph(world, 0.2, 0.025)
    for s, g, path in zip(starts, goals, batch):
        single = fresh.shortest_path(s, g)
        assert path.success and single.success
        assert np.array_equal(path.points, single.points)
        assert path.length >= np.linalg.norm(g - s) - 1e-12
        assert path.points[0].tolist() == s.tolist() and path.points[-1].tolist() == g.tolist()
        assert world.clearance(dense(path.points[:-1], path.points[1:], 500)).min() >= 0.2 - 1e-9


def test_disc_violations_by_hand():
    centres = np.array([[0.0, 0.0], [3.0, 0.0]])
    radii = np.array([1.0, 1.0])
    poly = np.array([[-0.5, 0.0], [-0.5, 2.0], [3.0, 2.0], [3.0, 0.5]])
    d_start = np.linalg.norm(centres - poly[0], axis=1)  # 0.5, 3.5
    d_goal = np.linalg.norm(centres - poly[-1], axis=1)  # 3.04, 0.5
    # Leaves disc 0 straight up (never closer than 0.5), passes both discs 2 m away, and enters
    # disc 1 along the last segment, straight towards its goal 0.5 from the centre: allowed.
    assert disc_violations(poly, centres, radii, d_start, d_goal).tolist() == [False, False]
    # Leaving disc 0 towards its centre first is not.
    bad = np.array([[-0.5, 0.0], [0.2, 0.0], [0.2, 2.0]])
    d = np.linalg.norm(centres - bad[0], axis=1)
    assert disc_violations(bad, centres, radii, d, np.linalg.norm(centres - bad[-1], axis=1)).tolist() == [True, False]
    # Coming back into disc 0 after leaving it (a middle segment 0.6 from its centre) is not either.
    back = np.array([[-0.5, 0.0], [-2.0, 0.0], [-0.6, 0.6], [-0.6, 3.0]])
    d = np.linalg.norm(centres - back[0], axis=1)
    assert disc_violations(back, centres, radii, d, np.linalg.norm(centres - back[-1], axis=1)).tolist() == [True,
                                                                                                             False]


def test_start_inside_a_disc_does_not_pass_around_it_closely():
    g = VisibilityGraph(open_world(), 0.2)
    centre = np.array([[0.0, 0.0]])
    start, goal = np.array([-0.5, 0.0]), np.array([5.0, 0.0])
    path = g.shortest_path(start, goal, discs=centre, disc_radii=np.array([1.0]))
    assert path.success
    # After its first segment the path keeps the whole radius: it leaves the disc, then goes around.
    rest = dense(path.points[1:-1], path.points[2:])
    assert np.linalg.norm(rest, axis=-1).min() >= 1.0 - 1e-9
    first = dense(path.points[:1], path.points[1:2])
    assert np.linalg.norm(first, axis=-1).min() >= 0.5 - 1e-9
    # Reference optimum by brute force: straight out to a point Q of the unit circle (moving away
    # from the centre all along), then the shortest way around the circle to the goal.
    theta = np.linspace(0.0, np.pi, 200001)
    q = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    outward = (q - start) @ start >= 0.0
    tangent = math.acos(1.0 / 5.0)
    around = np.where(theta <= tangent, np.linalg.norm(goal - q, axis=1), math.sqrt(24.0) + theta - tangent)
    best = (np.linalg.norm(q - start, axis=1) + around)[outward].min()
    # The octagon path is no shorter, and longer by at most the octagon's excess (1/cos(pi/8)).
    assert best - 1e-6 <= path.length <= best / math.cos(math.pi / 8)
    # Passing around a disc of the start's distance instead (the arc from the start to the
    # goal's tangent point, plus that tangent) would be shorter: the rule is not that one.
    assert path.length > 0.5 * (math.pi - math.acos(0.1)) + math.sqrt(24.75)


def test_goal_inside_a_disc_is_entered_along_the_last_segment():
    g = VisibilityGraph(open_world(), 0.2)
    centre = np.array([[0.0, 0.0]])
    start, goal = np.array([-5.0, 0.0]), np.array([0.6, 0.0])
    path = g.shortest_path(start, goal, discs=centre, disc_radii=np.array([1.0]))
    assert path.success
    pts = dense(path.points[:-2], path.points[1:-1])
    assert np.linalg.norm(pts, axis=-1).min() >= 1.0 - 1e-9
    last = dense(path.points[-2:-1], path.points[-1:])
    assert np.linalg.norm(last, axis=-1).min() >= 0.6 - 1e-9
    # Reversing start and goal gives the same length (the rule is symmetric).
    back = g.shortest_path(goal, start, discs=centre, disc_radii=np.array([1.0]))
    assert back.length == pytest.approx(path.length)


def test_batched_paths_survive_a_full_memo(monkeypatch):
    import nodnav.planning.memo as memo

    world = paper_world()
    starts = np.array([[-5.0, 0.0], [-5.0, 1.0], [-5.0, -1.0], [-6.0, 0.0]])
    goals = np.array([[5.0, 0.0], [5.0, 1.0], [5.0, -1.0], [6.0, 0.0]])
    monkeypatch.setattr(memo, "MEMO_SIZE", 2)
    g = VisibilityGraph(world, 0.2, 0.025)
    g.shortest_paths(starts[:2], goals[:2])
    # One remembered query and three new ones: storing the new ones evicts the remembered one.
    got = g.shortest_paths(starts, goals)
    fresh = VisibilityGraph(world, 0.2, 0.025)
    for s, e, path in zip(starts, goals, got):
        assert np.array_equal(path.points, fresh.shortest_path(s, e).points)


def test_octagon_exit_moves_a_point_radially_to_the_octagon_boundary():
    # Disc of radius 1 about the origin; its octagon's sides have normals every 45 degrees.
    inside = np.array([np.cos(np.radians(10.0)), np.sin(np.radians(10.0))]) * 1.001
    exit_ = octagon_exits(inside, np.zeros((1, 2)), np.array([1.0]))[0]
    assert np.hypot(*exit_) == pytest.approx(1.0 / np.cos(np.radians(10.0)), abs=1e-8)
    assert exit_[0] * inside[1] - exit_[1] * inside[0] == pytest.approx(0.0, abs=1e-12)  # same ray
    far = np.array([0.0, 1.2])  # beyond the octagon (its side at 90 degrees is 1 m away)
    np.testing.assert_array_equal(octagon_exits(far, np.zeros((1, 2)), np.array([1.0]))[0], far)


def test_a_path_from_the_edge_of_a_disc_goes_round_it_without_turning_back():
    """A robot standing just outside the required distance of another (between the disc and its
    octagon) goes round it the short way: the angle about the disc's centre never goes back."""
    world = paper_world(room_height=10.0)
    graph = VisibilityGraph(world, 0.2)
    centre = np.array([-5.0, 0.0])
    start = centre + 1.0002 * np.array([np.cos(np.radians(-141.6)), np.sin(np.radians(-141.6))])
    goal = centre + np.array([1.5, -0.5])
    path = graph.shortest_path(start, goal, centre[None], np.array([1.0]))
    assert path.success
    angles = np.unwrap(np.arctan2(*(path.points - centre).T[::-1]))
    assert np.all(np.diff(angles) >= -1e-9)
    assert np.all(np.hypot(*(path.points[1:] - centre).T) >= 1.0 - 1e-9)


def _python_chain(n_nodes, i, j, length, source, target):
    """The binary-heap Dijkstra on adjacency lists in edge order, as written before it was compiled."""
    import heapq

    adjacent = [[] for _ in range(n_nodes)]
    for a, b, w in zip(i.tolist(), j.tolist(), length.tolist()):
        adjacent[a].append((w, b))
        adjacent[b].append((w, a))
    dist, prev = [np.inf] * n_nodes, [-1] * n_nodes
    dist[source] = 0.0
    heap = [(0.0, source)]
    while heap:
        d, u = heapq.heappop(heap)
        if u == target:
            break
        if d > dist[u]:
            continue
        for w, v in adjacent[u]:
            if d + w < dist[v]:
                dist[v], prev[v] = d + w, u
                heapq.heappush(heap, (d + w, v))
    if not np.isfinite(dist[target]):
        return []
    chain = [target]
    while chain[-1] != source:
        chain.append(prev[chain[-1]])
    return chain[::-1]


@pytest.mark.parametrize("seed", range(6))
def test_compiled_chain_is_the_python_heaps_chain_ties_included(seed):
    """Whole-number lengths make many equal paths: the compiled search must pick the same one."""
    rng = np.random.default_rng(seed)
    n = 60
    i, j = np.triu_indices(n, 1)
    keep = rng.random(len(i)) < 0.1
    order = rng.permutation(int(keep.sum()))
    i, j = i[keep][order], j[keep][order]
    swap = rng.random(len(i)) < 0.5
    i, j = np.where(swap, j, i), np.where(swap, i, j)
    w = rng.integers(1, 4, len(i)).astype(float)
    for target in range(1, n):
        assert shortest_chain(n, i, j, w, 0, target) == _python_chain(n, i, j, w, 0, target)


def test_compiled_disc_checks_match_their_numpy_forms():
    """The compiled checks of the fast planner's paths against the NumPy expressions they
    replace, on random polylines and discs (also single points, starts inside discs, radii at
    and below TOL): the same decisions; disc_violations against its NumPy form."""
    from nodnav.geometry import TOL, segment_point_distance
    from nodnav.planning.disc_checks import _crosses_any, corner_cuts_close, disc_violations, disc_violations_plain

    rng = np.random.default_rng(3)
    for _ in range(500):
        poly = rng.uniform(-3, 3, (int(rng.integers(1, 6)), 2))
        m = int(rng.integers(0, 5))
        centres = rng.uniform(-3, 3, (m, 2))
        if m and rng.random() < 0.3:
            centres[0] = poly[0] + rng.normal(0, 0.05, 2)  # a disc holding the start
        radii = rng.choice([0.0, TOL / 2, 0.3, 0.8, 1.5], m)
        start, goal = poly[0], poly[-1]
        keep = radii > TOL
        c, r = centres[keep], radii[keep]
        want = bool(disc_violations_plain(poly, c, r, np.hypot(*(c - start).T), np.hypot(*(c - goal).T)).any())
        # disc_violations' compiled loops: the same decisions, disc by disc (also with limits
        # from other distances than the start's and the goal's, as the planner passes them)
        d_start, d_goal = rng.uniform(0, 2, m), rng.uniform(0, 2, m)
        assert np.array_equal(disc_violations(poly, centres, radii, d_start, d_goal),
                              disc_violations_plain(poly, centres, radii, d_start, d_goal))
        assert np.array_equal(disc_violations(poly, c, r, np.hypot(*(c - start).T), np.hypot(*(c - goal).T)),
                              disc_violations_plain(poly, c, r, np.hypot(*(c - start).T), np.hypot(*(c - goal).T)))
        assert _crosses_any(poly, centres, radii, start, goal) == want
        k = int(rng.integers(1, 6))
        a, b = rng.uniform(-3, 3, (k, 2)), rng.uniform(-3, 3, (k, 2))
        near = np.minimum(radii, polyline_point_distance(poly, centres))
        want_bad = (segment_point_distance(a, b, centres) < near - TOL).any(axis=1)
        assert np.array_equal(corner_cuts_close(poly, a, b, centres, radii), want_bad)


def test_polyline_length_is_the_sum_of_segment_norms():
    """polyline_length against np.linalg.norm of the differences, summed (bit for bit): the
    compiled loop up to eight points, the NumPy form beyond."""

    rng = np.random.default_rng(5)
    for n in (*range(1, 13), 17, 40):
        for _ in range(2000 if n <= 9 else 50):
            p = rng.normal(size=(n, 2)) * rng.uniform(0.01, 100)
            assert polyline_length(p) == float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())
    assert polyline_length(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 0.0]])) == 9.0


def test_octagon_exits_halves_round_to_even():
    """octagon_exits rounds the ray's angle to the nearest side normal with halves to even (as
    np.round did): a point at 22.5 degrees from the centre, exactly between two normals, leaves
    the octagon of radius 1 at 1 / cos(22.5 deg) + 2 TOL (either side gives that distance)."""
    from nodnav.geometry import TOL

    angle = np.pi / 8.0
    inside = 0.5 * np.array([np.cos(angle), np.sin(angle)])
    exit_ = octagon_exits(inside, np.zeros((1, 2)), np.array([1.0]))[0]
    assert np.hypot(*exit_) == pytest.approx(1.0 / np.cos(np.pi / 8.0) + 2 * TOL, abs=1e-12)


def test_planners_share_graphs_with_memos_of_their_own():
    """Two fast planners of equal worlds share one visibility graph's construction (the same
    read-only arrays) but not its memos, and answer as a graph built anew does."""
    from nodnav.planning.prioritized import PrioritizedPlanner
    from nodnav.scenario.world import paper_world

    a, b = PrioritizedPlanner(paper_world()), PrioritizedPlanner(paper_world())
    ga, gb = a.graph(a.world, 0.2), b.graph(b.world, 0.2)
    assert ga is not gb and ga._dist is gb._dist and ga._plain is not gb._plain
    assert not ga._dist.flags.writeable
    fresh = VisibilityGraph(paper_world(), 0.2, ga.inflation)
    start, goal = np.array([-4.0, 0.5]), np.array([4.0, -0.5])
    got = ga.shortest_path(start, goal, np.array([[0.0, 0.0]]), np.array([0.6]))
    assert gb._plain == {} and gb._around == {}
    want = fresh.shortest_path(start, goal, np.array([[0.0, 0.0]]), np.array([0.6]))
    assert np.array_equal(got.points, want.points) and got.length == want.length


def test_disc_search_kernels_match_their_numpy_forms():
    """The disc search's compiled steps against the NumPy expressions they replace, bit for bit:
    the octagons of discs (chamfered_vertices of zero-size boxes) and the wall vertices outside
    every disc (norms exactly at the limit included)."""
    from nodnav.geometry import TOL
    from nodnav.planning.visibility import _disc_octagons, _outside_all

    rng = np.random.default_rng(8)
    for _ in range(300):
        m = int(rng.integers(0, 6))
        centres = rng.uniform(-4, 4, (m, 2))
        radii = rng.choice([0.0, 0.25, 0.55, 1.3], m) + rng.uniform(0, 0.1, m)
        want = chamfered_vertices(np.hstack([centres, centres]), radii)
        assert np.array_equal(_disc_octagons(centres, radii), want)
        vertices = rng.uniform(-4, 4, (int(rng.integers(0, 30)), 2))
        if m and len(vertices):
            vertices[0] = centres[0] + [radii[0] - TOL, 0.0]  # on the limit
        outside = np.linalg.norm(vertices[:, None] - centres[None], axis=2) >= radii - TOL
        assert np.array_equal(_outside_all(vertices, centres, radii), np.flatnonzero(outside.all(axis=1)))
    # by hand: the octagon of the unit disc at the origin has its first vertex at (1, -tan(pi/8))
    assert _disc_octagons(np.zeros((1, 2)), np.ones(1))[0] == pytest.approx([1.0, -math.tan(math.pi / 8)])
