"""Several studies in one pool (:mod:`nodnav.experiments.batch`): each simulation once, twins stored
from it, the long trials first, studies in order, and the deadline between studies."""

import time

import pytest
import yaml

from nodnav.experiments.batch import run_studies, run_sweep
from nodnav.experiments.store import ResultStore, run_key, trial_key
from nodnav.experiments.study import SweepSpec
from nodnav.experiments.sweep import expand
from nodnav.experiments.variants import variant_scenario_files
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_to_dict
from nodnav.sim.simulator import run_trial

CALLS = []


@pytest.fixture
def counted_trial(trial_result):
    """A stand-in trial that records each call; its numbers depend on the robots and the seed only."""
    CALLS.clear()

    def trial(scenario, method, seed):
        CALLS.append((scenario.name, scenario.n_robots, seed))
        return trial_result("success", {"scenario": scenario.name, "seed": seed, "sim_time_s": 10.0 + seed,
                                        "wall_time_s": 0.01 * scenario.n_robots})

    return trial


def _renamed(tmp_path, name, new_name):
    """``name`` written as a scenario file under another name and description: a twin of every trial."""
    raw = scenario_to_dict(load_scenario(name))
    raw["name"], raw["description"] = new_name, "the same scenario under another name"
    path = tmp_path / f"{new_name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return str(path)


def _runs(*specs):
    return [(s, expand(s)) for s in specs]


def test_twins_are_simulated_once_and_stored_under_each_key(tmp_path, counted_trial):
    a = SweepSpec("a", ("2r-case1",), trials=3)
    b = SweepSpec("b", (_renamed(tmp_path, "2r-case1", "copy"),), trials=3)
    db = tmp_path / "r.sqlite"
    batch = run_studies(_runs(a, b), db, trial_fn=counted_trial, quiet=True)
    assert len(CALLS) == 3 and batch.simulated == 3 and batch.copied == 3
    assert [(s.study, s.done, s.outcomes) for s in batch.studies] == [("a", 3, {"success": 3}),
                                                                       ("b", 3, {"success": 3})]
    with ResultStore(db) as store:
        assert store.count("a") == 3 and store.count("b") == 3 and store.count() == 6
        for ra, rb in zip(store.records("a"), store.records("b")):
            assert (ra.scenario, rb.scenario) == ("2r-case1", "copy") and ra.seed == rb.seed
            assert rb.summary == {**ra.summary, "scenario": "copy", "same_run_as": ra.key}
            assert rb.study == "b" and rb.code_version == ra.code_version and rb.outcome == ra.outcome


def test_a_twin_stored_before_gives_its_result_without_a_run(tmp_path, counted_trial):
    db = tmp_path / "r.sqlite"
    a = SweepSpec("a", ("2r-case1",), trials=2)
    run_sweep(a, db, trial_fn=counted_trial, quiet=True)
    CALLS.clear()
    batch = run_studies(_runs(a, SweepSpec("b", (_renamed(tmp_path, "2r-case1", "copy"),), trials=3)), db,
                        trial_fn=counted_trial, quiet=True)
    assert CALLS == [("copy", 2, 3)]  # seeds 1 and 2 are study a's, stored
    assert batch.copied == 2 and [(s.done, s.skipped) for s in batch.studies] == [(0, 2), (3, 0)]


def test_a_trial_in_two_studies_belongs_to_the_first_and_is_linked_to_both(tmp_path, counted_trial):
    db = tmp_path / "r.sqlite"
    batch = run_studies(_runs(SweepSpec("first", ("2r-case1",), players=(0, 1), trials=1),
                              SweepSpec("second", ("2r-case1",), players=(1,), trials=1)), db,
                        trial_fn=counted_trial, quiet=True)
    assert len(CALLS) == 2 and batch.copied == 0
    with ResultStore(db) as store:
        assert store.count("first") == 2 and store.count("second") == 1
        assert [r.study for r in store.records("second")] == ["first"]


def test_studies_run_in_order_and_each_the_most_expensive_first(tmp_path, counted_trial):
    runs = _runs(SweepSpec("one", ("2r-case1", "4r-case1", "3r-case1"), players=(1,), trials=1),
                 SweepSpec("two", ("2r-case2", "3r-case2"), players=(1,), trials=1))
    run_studies(runs, tmp_path / "r.sqlite", trial_fn=counted_trial, quiet=True,
                cost=lambda t: t.scenario.n_robots)
    assert [n for _, n, _ in CALLS] == [4, 3, 2, 3, 2]


def test_no_study_starts_after_the_deadline(tmp_path, counted_trial):
    db = tmp_path / "r.sqlite"
    runs = _runs(SweepSpec("one", ("2r-case1",), trials=2), SweepSpec("two", ("3r-case1",), trials=2))
    batch = run_studies(runs, db, trial_fn=counted_trial, quiet=True, deadline=time.perf_counter() - 1.0)
    assert batch.stopped and CALLS == [] and batch.simulated == 0
    # A deadline that passes while the first study runs lets it finish and stops the second.
    slow = time.perf_counter() + 0.05

    def trial(scenario, method, seed):
        time.sleep(0.1)
        return counted_trial(scenario, method, seed)

    batch = run_studies(runs, db, trial_fn=trial, quiet=True, deadline=slow)
    assert batch.stopped and [s.done for s in batch.studies] == [2, 0]


def test_run_keys_leave_out_the_name_only():
    raw = scenario_to_dict(load_scenario("3r-case1"))
    config = {"scenario": raw, "method": "nod"}
    renamed = {"scenario": {**raw, "name": "other", "description": "else"}, "method": "nod", "set": ["a=1"]}
    assert trial_key(config, 1) != trial_key(renamed, 1)
    assert run_key(config, 1) == run_key(renamed, 1)
    assert run_key(config, 1) != run_key(config, 2)
    assert run_key(config, 1) != run_key({**config, "method": "orca"}, 1)
    assert run_key(config, 1) != run_key({"scenario": {**raw, "game_players": 1}, "method": "nod"}, 1)


def test_the_reductions_entered_variant_is_the_success_rates_trial(tmp_path):
    """The only twins of ``nodnav reproduce``: the variant that is the scenarios' own setting at k players
    (``entered``, the default of ``opinion.nonplayers``) is the scenario at k players."""
    files = variant_scenario_files(tmp_path, ("3r-case1", "4r-case1"))
    variants = expand(SweepSpec("reduction", tuple(map(str, files)), trials=1)).trials
    success = expand(SweepSpec("success", ("3r-case1", "4r-case1"), players=(0, 1, 2, 3), trials=1)).trials
    plain = {run_key(t.config, t.seed): t for t in success}
    twins = [t for t in variants if run_key(t.config, t.seed) in plain]
    assert sorted((t.scenario.name, t.scenario.n_players) for t in twins) == [
        ("3r-case1 [entered]", 1), ("4r-case1 [entered]", 1), ("4r-case1 [entered]", 2)]
    assert all(load_scenario("3r-case1").opinion.nonplayers == t.scenario.opinion.nonplayers for t in twins)
    # And the name does not change the simulation: the twin run for real gives the same summary.
    twin = next(t for t in twins if t.scenario.n_robots == 3)
    a = run_trial(twin.scenario, "nod", 1).to_dict()
    b = run_trial(plain[run_key(twin.config, 1)].scenario, "nod", 1).to_dict()
    for d in (a, b):
        d.pop("wall_time_s")
    assert a == {**b, "scenario": "3r-case1 [entered]"}
