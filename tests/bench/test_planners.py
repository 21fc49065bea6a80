"""``bench planners``: the numbers it reports against an independent recomputation."""

import itertools
import json

import numpy as np
import pytest

from nodnav.bench.planners import format_benchmark, main_bench_planners, run_planner_benchmark
from nodnav.planning import make_planner
from nodnav.planning.base import PlanRequest
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import PRMParams

VERTICES = 150


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return str(tmp_path_factory.mktemp("roadmaps"))


@pytest.fixture(scope="module")
def result(cache):
    return run_planner_benchmark(planners=("prm",), scenarios=("2r-case1",), cache_dir=cache,
                                 roadmap_vertices=VERTICES)


def test_prm_counts_and_roadmaps(result):
    (b,) = result.planners
    assert b.planner == "prm" and result.scenarios == ("2r-case1",)
    assert b.queries == 2 and b.successes == 2 and b.failures == ()
    assert 0 < b.latency_median_ms <= b.latency_p95_ms
    # Two orders of a head-on pair need the patterns (+, -) and (-, +): two roadmaps, just built.
    (r,) = b.roadmaps
    assert (r.n_robots, r.roadmaps, r.from_cache) == (2, 2, 0)
    assert r.vertices == 2 * VERTICES and r.edges > r.vertices and r.build_seconds > 0


def test_separation_and_cost_match_a_recomputation(result, cache):
    (b,) = result.planners
    sc = load_scenario("2r-case1")
    planner = make_planner(PRMParams(name="prm", roadmap_vertices=VERTICES, cache_dir=cache), sc.world)
    # The bench plans as a trial does (its module docstring): from rest, each robot within its
    # own speed and acceleration limit, so the recomputation passes both limits too.
    accels = np.array([r.max_accel for r in sc.robots], dtype=float)
    dists, costs, durations = [], [], []
    for order in itertools.permutations(range(2)):
        res = planner.plan(PlanRequest(sc.world, sc.origins, np.zeros((2, 2)), sc.destinations, sc.radii,
                                       sc.max_speeds, order, max_accels=accels))
        tr = res.trajectory
        t = np.linspace(tr.times[0], tr.times[-1], 5 * (len(tr.times) - 1) + 1)
        p = tr.positions_at(t)
        dists.append(np.sqrt(((p[:, 0] - p[:, 1]) ** 2).sum(axis=1)).min())
        costs.append(res.cost)
        durations.append(tr.duration)
    assert b.min_separation == pytest.approx(min(dists))
    assert b.min_gap == pytest.approx(min(dists) - 0.4)
    assert b.min_gap >= 0.0
    assert b.mean_cost == pytest.approx(np.mean(costs))
    assert b.mean_duration == pytest.approx(np.mean(durations))


def test_second_run_uses_the_cache_and_renders(cache):
    again = run_planner_benchmark(planners=("prm",), scenarios=("2r-case1",), cache_dir=cache,
                                  roadmap_vertices=VERTICES)
    (r,) = again.planners[0].roadmaps
    assert r.from_cache == 2
    text = format_benchmark(again)
    assert "prm" in text and "2/2" in text and "roadmaps" in text
    data = json.loads(json.dumps(again.to_dict()))
    assert data["planners"][0]["successes"] == 2


def test_both_planners_through_the_text_entry_point(cache):
    text = main_bench_planners(json_output=True, planners=("fast", "prm"), scenarios=("2r-case1",),
                               cache_dir=cache, roadmap_vertices=VERTICES)
    data = json.loads(text)
    assert [p["planner"] for p in data["planners"]] == ["fast", "prm"]
    assert all(p["queries"] == 2 for p in data["planners"])
    assert data["planners"][0]["roadmaps"] == []
