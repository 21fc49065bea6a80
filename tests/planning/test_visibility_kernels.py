"""The disc search's compiled steps against the NumPy lines they replace, bit for bit: which
ring points keep clear of every disc (:func:`_outside_mask`) and which edges keep clear of the
discs, with the start's and goal's relaxed limits (:func:`_keep_clear_of_discs`)."""

import numpy as np

from nodnav.geometry import TOL, segment_point_distance
from nodnav.planning.visibility import _keep_clear_of_discs, _outside_mask


def test_outside_mask_is_the_norm_test():
    rng = np.random.default_rng(31)
    for _ in range(300):
        points = rng.normal(size=(int(rng.integers(0, 30)), 2))
        centres = rng.normal(size=(int(rng.integers(0, 5)), 2))
        radii = rng.uniform(0.0, 1.5, len(centres))
        if len(points) and len(centres) and rng.random() < 0.3:
            points[0] = centres[0] + [radii[0] - TOL, 0.0]  # on the limit
        want = (np.linalg.norm(points[:, None] - centres[None], axis=2) >= radii - TOL).all(axis=1)
        assert _outside_mask(points, centres, radii).tolist() == want.tolist()


def _plain(nodes, i, j, ok, centres, radii, d_start, d_goal):
    """The NumPy lines of ``_search_with_discs`` the kernel replaces."""
    ok = ok.copy()
    e = np.flatnonzero(ok)
    limit = np.repeat(radii[None], len(e), axis=0)
    first = i[e] == 0
    limit[first] = np.minimum(limit[first], d_start)
    last = (i[e] == 1) | (j[e] == 1)
    limit[last] = np.minimum(limit[last], d_goal)
    ok[e] = (segment_point_distance(nodes[i[e]], nodes[j[e]], centres) >= limit - TOL).all(axis=1)
    return ok


def test_keep_clear_of_discs_is_the_numpy_lines():
    rng = np.random.default_rng(37)
    for _ in range(300):
        nodes = rng.normal(size=(int(rng.integers(2, 14)), 2)) * 2
        i, j = np.triu_indices(len(nodes), 1)
        centres = rng.normal(size=(int(rng.integers(0, 4)), 2)) * 2
        radii = rng.uniform(0.1, 1.0, len(centres))
        d_start = np.hypot(*(centres - nodes[0]).T)
        d_goal = np.hypot(*(centres - nodes[1]).T)
        ok = rng.random(len(i)) < 0.7
        got = ok.copy()
        _keep_clear_of_discs(nodes, i, j, got, centres, radii, d_start, d_goal)
        assert got.tolist() == _plain(nodes, i, j, ok, centres, radii, d_start, d_goal).tolist()


def test_edge_through_a_disc_by_hand():
    # The edge (2, 0) -> (4, 0) passes through the disc of radius 1 at (3, 0): cleared; the edge
    # (2, 2) -> (4, 2) passes 2 m from it: kept.
    nodes = np.array([[-9.0, 9.0], [9.0, 9.0], [2.0, 0.0], [4.0, 0.0], [2.0, 2.0], [4.0, 2.0]])
    i, j = np.array([2, 4]), np.array([3, 5])
    ok = np.ones(2, dtype=bool)
    _keep_clear_of_discs(nodes, i, j, ok, np.array([[3.0, 0.0]]), np.array([1.0]), np.array([5.0]), np.array([5.0]))
    assert ok.tolist() == [False, True]
