"""Roadmap validity rules, the OMPL build and the on-disk cache, against independent references."""

import logging
import zipfile

import numpy as np
import pytest

from nodnav.geometry import segment_clearance
from nodnav.planning import joint_validity as jv
from nodnav.planning import roadmap as rm
from nodnav.planning import roadmap_cache as rc
from nodnav.scenario.world import paper_world

R = 0.2
MARGIN = 0.05
TINY = 100  # vertices per robot of the test roadmaps


@pytest.fixture(scope="module")
def world():
    return paper_world()


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("roadmaps")


@pytest.fixture(scope="module")
def built(world, cache):
    """A small two-robot head-on roadmap, built once into the module's cache."""
    key = rm.make_key(world, [R, R], (1, -1), MARGIN, 0.1, TINY)
    return key, rc.get_roadmap(key, cache)


# ---------------------------------------------------------------------------------------------
# Phi_proximity and the order rule, by hand


def test_proximity_penalty_hand_computation():
    # Three robots of radius 0.2: distances 1, 0.5 and sqrt(1.25) between centres.
    x = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.5])
    gaps = [1.0 - 0.4, 0.5 - 0.4, np.sqrt(1.25) - 0.4]
    # The second gap (0.1) sits exactly at varsigma = 0.1; with varsigma 0.2 it is capped at 0.2.
    assert rm.proximity_penalty(x, [R] * 3, 0.1) == pytest.approx(1 / 0.6 + 1 / 0.1 + 1 / gaps[2])
    assert rm.proximity_penalty(x, [R] * 3, 0.2) == pytest.approx(1 / 0.6 + 1 / 0.2 + 1 / gaps[2])
    # Overlapping robots are capped too, and a lone robot has no pairs.
    assert rm.proximity_penalty(np.array([0.0, 0.0, 0.1, 0.0]), [R, R], 0.1) == pytest.approx(10.0)
    assert rm.proximity_penalty(np.array([3.0, 1.0]), [R], 0.1) == 0.0


@pytest.mark.parametrize("xs, dirs, expected", [
    # Opposite directions, rank 0 left-to-right, rank 1 right-to-left.
    ((-5.0, 5.0), (1, -1), True),     # both before
    ((0.0, 5.0), (1, -1), True),      # first inside, second waits
    ((-5.0, 0.0), (1, -1), False),    # second inside while the first has not entered
    ((0.0, 2.0), (1, -1), False),     # both inside, head-on
    ((4.0, 2.0), (1, -1), True),      # first has left, second inside
    ((4.0, -4.0), (1, -1), True),     # both through
    ((-4.0, -4.0), (1, -1), False),   # second through, first not
    # Same direction: the second may follow inside, behind the first.
    ((1.0, -1.0), (1, 1), True),
    ((-1.0, 1.0), (1, 1), False),     # second ahead of the first
    ((1.0, 4.0), (1, 1), False),      # second out while the first is still inside
    ((4.0, 1.0), (1, 1), True),
    ((-1.0, 1.0), (-1, -1), True),    # leftwards: the first is ahead when further left
    # A robot that does not cross never enters; it does not constrain the others.
    ((0.0, 5.0), (0, -1), False),
    ((5.0, 0.0), (0, -1), True),
    # The entrance itself counts as inside (x = -3 is the left entrance).
    ((-3.0, 5.0), (1, -1), True),
    ((-5.0, 3.0), (1, -1), False),
])
def test_order_rule_hand_cases(world, xs, dirs, expected):
    assert bool(jv.order_holds(np.array(xs), np.array(dirs), world)) is expected
    # The compiled kernel gives the same verdict.
    x = np.array([[xs[0], 1.5], [xs[1], -1.5]]).ravel()
    x[1::2] = np.where(np.abs(np.array(xs)) <= 3.0, 0.0, x[1::2])  # inside robots on the axis
    rules = jv.CompiledRules.of(world, [R, R], dirs, [0.45])
    assert rules.state_ok(x) is expected


def test_three_robot_chain_rule(world):
    # Ranks 0 and 2 go right, rank 1 goes left: rank 2 may only enter once rank 1 has left.
    dirs = np.array([1, -1, 1])
    assert jv.order_holds(np.array([4.0, 0.0, -5.0]), dirs, world)
    assert not jv.order_holds(np.array([4.0, 0.0, -2.0]), dirs, world)
    assert jv.order_holds(np.array([4.5, -4.0, -2.0]), dirs, world)


# ---------------------------------------------------------------------------------------------
# Exact geometry along segments against hand values and dense sampling


def _rect_distance(p, rect):
    x0, y0, x1, y1 = rect
    dx = np.maximum(np.maximum(x0 - p[..., 0], p[..., 0] - x1), 0.0)
    dy = np.maximum(np.maximum(y0 - p[..., 1], p[..., 1] - y1), 0.0)
    return np.hypot(dx, dy)


def test_segment_geometry_matches_dense_sampling(world):
    rng = np.random.default_rng(3)
    p0 = rng.uniform([-7, -2.5], [7, 2.5], size=(200, 2))
    p1 = p0 + rng.normal(0, 1.5, size=(200, 2))
    t = np.linspace(0, 1, 4001)[:, None, None]
    pts = (1 - t) * p0 + t * p1
    # Both clipped at zero: inside a wall the exact value is 0, outside the bounds it is negative.
    exact = np.maximum(segment_clearance(world, p0, p1), 0.0)
    sampled = np.maximum(world.clearance(pts), 0.0).min(axis=0)
    # Sampling can only overestimate the minimum, by at most the step length.
    step = np.linalg.norm(p1 - p0, axis=1) / 4000
    assert np.all(exact <= sampled + 1e-12)
    assert np.all(sampled - exact <= step + 1e-12)
    # Pairwise distance along joint edges, the same way.
    a, b = rng.normal(0, 2, size=(200, 6)), rng.normal(0, 2, size=(200, 6))
    xs = (1 - t) * a + t * b
    pa = xs.reshape(4001, 200, 3, 2)
    dist = np.stack([np.linalg.norm(pa[:, :, i] - pa[:, :, j], axis=-1).min(axis=0)
                     for i, j in [(0, 1), (0, 2), (1, 2)]], axis=1)
    exact_pairs = jv.segment_pair_distance(a, b, 3)
    assert np.all(exact_pairs <= dist + 1e-12)
    assert np.all(dist - exact_pairs <= 2 * np.linalg.norm(b - a, axis=1)[:, None] / 4000 + 1e-12)


def test_head_on_pair_distance_is_analytical():
    # Robots at (-1, 0.1) and (1, -0.1) swap places: they pass at t = 1/2, 0.2 m apart.
    a = np.array([[-1.0, 0.1, 1.0, -0.1]])
    b = np.array([[1.0, 0.1, -1.0, -0.1]])
    assert jv.segment_pair_distance(a, b, 2)[0, 0] == pytest.approx(0.2)


def _fine_edge_valid(world, a, b, radii, dirs, sep, spacing=0.002, chunk=64):
    """Independent reference: the rules at points along each edge at most ``spacing`` apart
    for every robot."""
    n = len(radii)
    pairs = list(zip(*np.triu_indices(n, 1)))
    out = []
    for lo in range(0, len(a), chunk):
        ca, cb = a[lo:lo + chunk], b[lo:lo + chunk]
        move = np.linalg.norm((cb - ca).reshape(len(ca), n, 2), axis=-1).max()
        t = np.linspace(0, 1, int(np.ceil(move / spacing)) + 2)[:, None, None]
        p = ((1 - t) * ca + t * cb).reshape(len(t), len(ca), n, 2)
        ok = np.all(world.clearance(p) >= np.asarray(radii) - 1e-9, axis=(0, 2))
        for k, (i, j) in enumerate(pairs):
            ok &= np.all(np.linalg.norm(p[..., i, :] - p[..., j, :], axis=-1) >= sep[k] - 1e-9, axis=0)
        out.append(ok & np.all(jv.order_holds(p[..., 0], dirs, world), axis=0))
    return np.concatenate(out)


def test_exact_edge_check_against_fine_sampling(world):
    rng = np.random.default_rng(5)
    dirs = np.array([1, -1, 1])
    radii = np.full(3, R)
    sep = jv.separation_thresholds(radii, MARGIN)
    key = rm.make_key(world, radii, dirs, MARGIN, 0.1, 100)
    cand = rm.sample_candidates(rng, key, 20000)
    cand = cand[jv.configurations_valid(world, cand, radii, dirs, sep)]
    pick = rng.permutation(len(cand))
    a, b = cand[pick[:400]], cand[pick[400:800]]
    b = a + rng.uniform(0.05, 0.6, size=(400, 1)) * (b - a)  # shorter edges: valid and invalid ones
    exact = jv.edges_valid(world, a, b, radii, dirs, sep)
    fine = _fine_edge_valid(world, a, b, radii, dirs, sep)
    assert 50 < exact.sum() < len(exact) - 50
    assert not np.any(exact & ~fine), "an edge accepted exactly fails at a fine step"
    # The sampled check can miss a brief violation, never invent one.
    assert np.mean(fine == exact) > 0.97
    # The compiled kernel agrees with the vectorised check edge by edge.
    assert np.array_equal(jv.CompiledRules.of(world, radii, dirs, sep).motions_ok(a, b), exact)


# ---------------------------------------------------------------------------------------------
# Building with OMPL


def test_built_roadmap_has_only_valid_vertices_and_edges(world, built):
    key, got = built
    assert got.success and not got.report.from_cache
    road = got.roadmap
    assert road.vertices.shape == (2 * TINY, 4)
    radii, dirs = np.full(2, R), np.array(key.directions)
    sep = jv.separation_thresholds(radii, MARGIN)
    assert np.all(jv.configurations_valid(world, road.vertices, radii, dirs, sep))
    a, b = road.vertices[road.edges[:, 0]], road.vertices[road.edges[:, 1]]
    assert len(road.edges) > 2 * len(road.vertices)
    assert np.all(_fine_edge_valid(world, a, b, radii, dirs, sep))
    assert road.dropped_edges == 0  # OMPL used the exact motion validator
    # The stored penalty is the appendix's Phi with varsigma = 0.1, from the vertices.
    p = road.vertices.reshape(-1, 2, 2)
    gap = np.linalg.norm(p[:, 0] - p[:, 1], axis=1) - 2 * R
    assert np.allclose(road.proximity, 1.0 / np.maximum(gap, 0.1))


def test_build_is_deterministic(world, built):
    key, got = built
    again = rm.build_roadmap(key)
    assert np.array_equal(again.roadmap.vertices, got.roadmap.vertices)
    assert np.array_equal(again.roadmap.edges, got.roadmap.edges)


def test_roadmap_reaches_through_the_corridor(world, built):
    # Lane samples: for each robot there are vertices all along the corridor while the other
    # waits (head-on pattern: rank 0 inside only while rank 1 is before, and vice versa).
    _, got = built
    x = got.roadmap.vertices[:, [0, 2]]
    for k in range(2):
        inside = x[:, k][np.abs(x[:, k]) <= 3.0]
        assert np.histogram(inside, bins=6, range=(-3, 3))[0].min() >= 3


# ---------------------------------------------------------------------------------------------
# The cache


def test_second_load_comes_from_the_cache_and_is_faster(world, built, cache):
    key, first = built
    second = rc.get_roadmap(key, cache)
    assert second.report.from_cache and second.success and second.report.reason == ""
    assert np.array_equal(second.roadmap.vertices, first.roadmap.vertices)
    assert np.array_equal(second.roadmap.edges, first.roadmap.edges)
    assert second.report.seconds < 0.5 * first.report.seconds
    assert second.report.build_seconds == pytest.approx(first.report.build_seconds)
    assert not list(cache.glob(".tmp-*")), "a temporary file was left behind"


def _damage_truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _damage_flip(path):
    data = bytearray(path.read_bytes())
    for i in range(len(data) // 3, len(data) // 3 + 64):
        data[i] ^= 0xFF
    path.write_bytes(bytes(data))


def _damage_key(path):
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["key"] = np.array(str(arrays["key"]).replace('"margin":0.05', '"margin":0.07'))
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def _damage_vertices(path):
    # A consistent zip whose vertices were changed: only the checksum can tell.
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["vertices"] = arrays["vertices"] + 1e-6
    with open(path, "wb") as f:
        np.savez(f, **arrays)


@pytest.mark.parametrize("damage, expect", [(_damage_truncate, "unreadable"), (_damage_flip, ""),
                                            (_damage_key, "stored key"), (_damage_vertices, "checksum")])
def test_damaged_file_is_detected_and_rebuilt(world, tmp_path, caplog, damage, expect):
    key = rm.make_key(world, [R], (1,), MARGIN, 0.1, 60)
    first = rc.get_roadmap(key, tmp_path)
    path = tmp_path / key.filename()
    damage(path)
    assert not rc.load_roadmap(path, key).success
    with caplog.at_level(logging.WARNING, logger="nodnav.planning.roadmap_cache"):
        again = rc.get_roadmap(key, tmp_path)
    assert again.success and not again.report.from_cache
    assert "rejected" in again.report.reason and expect in again.report.reason
    assert any("rejected" in r.getMessage() for r in caplog.records)
    assert np.array_equal(again.roadmap.vertices, first.roadmap.vertices)
    # The rebuilt file is sound again.
    assert rc.load_roadmap(path, key).success
    with zipfile.ZipFile(path) as z:
        assert z.testzip() is None


def test_stale_key_is_not_trusted(world, built, cache):
    key, _ = built
    other = rm.make_key(world, [R, R], (1, -1), MARGIN, 0.2, TINY)  # another varsigma
    got = rc.load_roadmap(cache / key.filename(), other)
    assert not got.success and "stored key" in got.reason


def test_keys_name_patterns_not_scenarios(world):
    a = rm.make_key(world, [R, R], (1, -1), MARGIN, 0.1, 100)
    assert a.filename() == rm.make_key(world, (R, R), [1, -1], MARGIN, 0.1, 100).filename()
    assert a.filename() != rm.make_key(world, [R, R], (-1, 1), MARGIN, 0.1, 100).filename()
    assert a.n_vertices == 200 and a.pattern == "+-"


def test_cache_dir_precedence(monkeypatch, tmp_path):
    monkeypatch.setenv("NODNAV_CACHE", str(tmp_path / "env"))
    assert rc.resolve_cache_dir(str(tmp_path / "explicit")) == tmp_path / "explicit"
    assert rc.resolve_cache_dir("") == tmp_path / "env"
    monkeypatch.delenv("NODNAV_CACHE")
    assert rc.resolve_cache_dir("").parts[-2:] == (".cache", "nodnav")


def test_direction_patterns_counts():
    # 2^n crossing patterns, plus 2^n - 1 with a prefix of robots that have passed.
    for n in (1, 2, 3, 4):
        pats = rm.direction_patterns(n)
        assert len(pats) == len(set(pats)) == 2 ** (n + 1) - 1
        assert len(rm.direction_patterns(n, exited=False)) == 2 ** n
    assert (0, 1) in rm.direction_patterns(2) and (1, 0) not in rm.direction_patterns(2)


def test_build_all_roadmaps_reports_every_pattern(world, tmp_path):
    reports = rc.build_all_roadmaps(world, R, robot_counts=(1,), vertices_per_robot=40, cache_dir=str(tmp_path),
                                    n_jobs=1)
    assert [r.pattern for r in reports] == ["+", "-", "0"]
    assert all(r.success and not r.from_cache for r in reports)
    again = rc.build_all_roadmaps(world, R, robot_counts=(1,), vertices_per_robot=40, cache_dir=str(tmp_path),
                                  n_jobs=1)
    assert all(r.from_cache for r in again)
    assert "robots" in rc.format_build_reports(again)


def test_map_roadmap_key_does_not_depend_on_where_the_map_lies(tmp_path):
    """Issue 20: the key held the map file's absolute path, so each checkout (and each copy of a
    scenario) seeded and built other roadmaps for the same walls, and PRM* trials on maps gave
    other results in every checkout. The same map in two directories must give the same key;
    other walls must not."""
    import dataclasses
    import shutil
    from pathlib import Path

    from nodnav.scenario.loading import load_scenario

    src = Path(__file__).resolve().parents[2] / "examples" / "building"
    worlds = []
    for name in ("one", "two"):
        d = tmp_path / name
        d.mkdir()
        for f in ("building-one-door-8.yaml", "one_door.yaml", "one_door.pgm"):
            shutil.copy(src / f, d / f)
        worlds.append(load_scenario(d / "building-one-door-8.yaml").world)
    assert worlds[0].map_file != worlds[1].map_file and worlds[0].map_walls > 0
    keys = [rm.make_key(w, [R, R], (1, -1), MARGIN, 0.1, 100) for w in worlds]
    assert keys[0].digest() == keys[1].digest()
    assert keys[0].filename() == keys[1].filename()
    obstacles = list(worlds[0].obstacles)
    x0, y0, x1, y1 = obstacles[0]
    obstacles[0] = (x0, y0, x1 + 0.01, y1)
    moved = dataclasses.replace(worlds[0], obstacles=tuple(obstacles))
    assert rm.make_key(moved, [R, R], (1, -1), MARGIN, 0.1, 100).digest() != keys[0].digest()
