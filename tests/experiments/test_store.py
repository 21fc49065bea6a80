"""The results database: keys, one row per trial, study links, queries, durability settings."""

import sqlite3

import pytest

from nodnav.experiments.store import ResultStore, StoreError, bias_label, canonical_json, trial_config, trial_key
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_to_dict


def _config(name="2r-case1", method="nod", **overrides):
    s = load_scenario(name)
    if overrides:
        s = s.with_overrides(**overrides)
    return trial_config(scenario_to_dict(s), method)


def _summary(outcome="success", makespan=12.5, strategy=2, consensus=True):
    return {"outcome": outcome, "success": outcome == "success", "makespan_s": makespan, "min_separation_m": 0.61,
            "strategy": strategy, "consensus": consensus, "sim_time_s": 13.0, "wall_time_s": 0.8}


def _add(store, config, seed, study="s1", outcome="success", **kw):
    key = trial_key(config, seed)
    store.add_trial(key=key, study=study, config=config, seed=seed, outcome=outcome,
                    summary=_summary(outcome, **kw), metrics={"flow_rate_rps": 0.2}, version="9.9.9",
                    error="ValueError: bad" if outcome == "error" else None)
    return key


def test_trial_key_depends_on_what_determines_the_trial():
    base = _config()
    assert trial_key(base, 1) == trial_key(_config(), 1)
    assert len(trial_key(base, 1)) == 64
    assert trial_key(base, 1) != trial_key(base, 2)
    assert trial_key(base, 1) != trial_key(_config(method="other"), 1)
    assert trial_key(base, 1) != trial_key(_config(**{"opinion.u": 10.0}), 1)
    assert trial_key(base, 1) != trial_key(_config(**{"opinion.bias": {"S2": 5.0}}), 1)
    # Not the description; and 'all' players is the same trial as N_r - 1 = 1 for two robots.
    assert trial_key(base, 1) == trial_key(_config(description="another text"), 1)
    assert trial_key(_config(game_players="all"), 3) == trial_key(_config(game_players=1), 3)
    assert trial_key(_config(game_players=0), 3) != trial_key(_config(game_players=1), 3)


def test_canonical_json_and_bias_label():
    assert canonical_json({"b": 1, "a": [1.5, None]}) == '{"a":[1.5,null],"b":1}'
    with pytest.raises(ValueError):
        canonical_json({"a": float("nan")})
    assert bias_label({}) == ""
    assert bias_label({"S5": 150.0, "S3": 150}) == "S3=150,S5=150"
    assert bias_label({"S12": 1.5, "S2": 0.0}) == "S12=1.5"


def test_round_trip_of_one_trial(tmp_path):
    db = tmp_path / "r.sqlite"
    config = _config("3r-case3", game_players="all", **{"opinion.bias": {"S5": 150.0, "S3": 150.0}})
    with ResultStore(db) as store:
        key = _add(store, config, 7, consensus=False)
        [r] = store.records()
    assert r.key == key and r.study == "s1" and r.seed == 7
    assert (r.scenario, r.n_robots, r.method, r.planner, r.players, r.init, r.bias) == \
        ("3r-case3", 3, "nod", "fast", 2, "zero", "S3=150,S5=150")
    assert r.config == config and r.outcome == "success" and r.success and r.error is None
    assert r.summary["makespan_s"] == 12.5 and r.metrics == {"flow_rate_rps": 0.2}
    assert r.version == "9.9.9" and r.created.endswith("+00:00")
    con = sqlite3.connect(db)
    row = con.execute("SELECT success, makespan, min_separation, strategy, consensus, sim_time, wall_time "
                      "FROM trials").fetchone()
    assert row == (1, 12.5, 0.61, 2, 0, 13.0, 0.8)
    assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_errors_and_missing_numbers_are_stored_as_null(tmp_path):
    with ResultStore(tmp_path / "r.sqlite") as store:
        _add(store, _config(), 1, outcome="error", makespan=None, strategy=None, consensus=None)
        [r] = store.records(outcome="error")
        assert r.error == "ValueError: bad" and not r.success
        with pytest.raises(StoreError, match="unknown outcome"):
            _add(store, _config(), 2, outcome="exploded")
        assert store.count() == 1
    con = sqlite3.connect(tmp_path / "r.sqlite")
    assert con.execute("SELECT success, makespan, strategy, consensus FROM trials").fetchone() == (0, None, None, None)


def test_each_trial_is_visible_to_readers_as_soon_as_it_is_added(tmp_path):
    db = tmp_path / "r.sqlite"
    with ResultStore(db) as writer:
        reader = sqlite3.connect(db)
        for seed in (1, 2, 3):
            _add(writer, _config(), seed)
            assert reader.execute("SELECT COUNT(*) FROM trials").fetchone()[0] == seed
        reader.close()


def test_studies_share_trials_and_queries_filter_them(tmp_path):
    with ResultStore(tmp_path / "r.sqlite") as store:
        c2, c3 = _config(), _config("3r-case1")
        k1 = _add(store, c2, 1, study="a")
        _add(store, c2, 2, study="a", outcome="deadlock")
        _add(store, c3, 1, study="a", outcome="collision")
        _add(store, c3, 2, study="b")
        store.link("b", [k1])
        store.save_study("a", {"name": "a", "trials": 2})
        assert store.studies() == {"a": {"name": "a", "trials": 2}}
        assert store.count() == 4 and store.count("a") == 3 and store.count("b") == 2
        assert [(r.scenario, r.seed) for r in store.records("b")] == [("2r-case1", 1), ("3r-case1", 2)]
        # The trial shared with 'b' keeps the study that first ran it.
        assert {r.study for r in store.records("b")} == {"a", "b"}
        assert [r.seed for r in store.records(scenario="2r-case1", outcome=["success", "deadlock"])] == [1, 2]
        assert store.records(n_robots=3, seed=1)[0].outcome == "collision"
        assert store.outcome_counts() == {("2r-case1", 1): {"success": 1, "deadlock": 1},
                                          ("3r-case1", 2): {"collision": 1, "success": 1}}
        assert store.outcome_counts(by=(), study="a") == {(): {"success": 1, "deadlock": 1, "collision": 1}}
        assert store.outcome_counts(by=("n_robots",), study="b") == {(2,): {"success": 1}, (3,): {"success": 1}}
        with pytest.raises(StoreError, match="cannot filter on 'colour'"):
            store.records(colour="red")
        with pytest.raises(StoreError, match="cannot group by"):
            store.outcome_counts(by=("key",))


def test_adding_a_trial_again_replaces_it_and_keeps_one_row(tmp_path):
    with ResultStore(tmp_path / "r.sqlite") as store:
        _add(store, _config(), 1, study="a", outcome="error")
        _add(store, _config(), 1, study="b", outcome="success")
        [r] = store.records()
        assert r.outcome == "success" and r.study == "a"
        assert store.count("a") == 1 and store.count("b") == 1


def test_a_file_that_is_not_a_database_is_a_one_line_error(tmp_path):
    bad = tmp_path / "notes.txt"
    bad.write_text("these are not results\n" * 100)
    with pytest.raises(StoreError, match="not a usable results database") as info:
        ResultStore(bad)
    assert "\n" not in str(info.value)
