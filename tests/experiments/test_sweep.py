"""Sweeps: study files, the cross product, resuming after SIGKILL, worker-count invariance, errors."""

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from contextlib import closing

import cloudpickle
import numpy as np
import pytest

from nodnav.experiments.batch import run_sweep
from nodnav.experiments.store import ResultStore
from nodnav.experiments.study import StudyError, SweepSpec, load_study, parse_bias, study_from_dict
from nodnav.experiments.sweep import execute_trial, expand
from nodnav.scenario.loading import load_scenario

# Worker processes cannot import this test module by name: send its functions by value
# (loky pickles with cloudpickle, which the [cluster] extra brings in).
cloudpickle.register_pickle_by_value(sys.modules[__name__])


@pytest.fixture
def cheap_trial(trial_result):
    """A deterministic stand-in for run_trial: its numbers depend on the configuration and the seed only.

    Seed 3 raises, so every sweep over seeds 1..3 or more meets an error.
    """
    def trial(scenario, method, seed):
        if seed == 3:
            raise RuntimeError(f"seed {seed} exploded\nwith a second line that must not be stored")
        rng = np.random.default_rng([seed, scenario.n_robots, scenario.n_players, len(method)])
        outcome = "success" if rng.random() < 0.7 else "deadlock"
        summary = {"scenario": scenario.name, "method": method, "seed": seed, "outcome": outcome,
                   "success": outcome == "success",
                   "makespan_s": float(10 + rng.random()) if outcome == "success" else None,
                   "min_separation_m": float(0.4 + rng.random()), "strategy": int(rng.integers(1, 3)),
                   "consensus": True, "sim_time_s": 20.0, "wall_time_s": float(rng.random())}
        metrics = {"flow_rate_rps": float(rng.random()), "time_to_consensus_s": float("nan")}
        return trial_result(outcome, summary, metrics)

    return trial


@pytest.fixture
def slow_trial(cheap_trial):
    """:func:`cheap_trial` taking 0.1 s, so that a sweep can be killed part-way."""
    def trial(scenario, method, seed):
        time.sleep(0.1)
        return cheap_trial(scenario, method, seed)

    return trial


def _stored(db):
    with ResultStore(db) as store:
        return {r.key: (r.outcome, r.error, r.metrics, {k: v for k, v in r.summary.items()
                                                       if k not in ("wall_time_s", "traceback")})
                for r in store.records()}


# -- study files -------------------------------------------------------------------------------


def test_study_file_round_trip(tmp_path):
    path = tmp_path / "reduction.yaml"
    path.write_text("scenarios: [3r-case1, 4r-case4]\nplayers: [0, 1, all]\ninit: distance\n"
                    "bias: [none, {S3: 150, S5: 150}, 'S2=1.5']\nplanners: fast\ntrials: 40\n")
    spec = load_study(path)
    assert spec == SweepSpec(name="reduction", scenarios=("3r-case1", "4r-case4"), players=(0, 1, "all"),
                             init=("distance",), bias=((), (("S3", 150.0), ("S5", 150.0)), (("S2", 1.5),)),
                             planners=("fast",), methods=("nod",), trials=40)
    assert study_from_dict(spec.to_dict()) == spec
    assert load_study(path, overrides={"trials": 2, "name": "quick"}).trials == 2
    # On the command line every value arrives as text.
    cli = study_from_dict({"scenarios": ["2r-case1"], "players": ["1", "all"], "bias": ["S1=2"], "trials": "5"},
                          "command line")
    assert (cli.name, cli.players, cli.bias, cli.trials) == ("sweep", (1, "all"), ((("S1", 2.0),),), 5)
    every = study_from_dict({"scenarios": ["all"]}, "command line").scenarios
    assert len(every) == 17 and {"2r-case1", "4r-case4", "8r-head-on"} <= set(every)
    # The paper's ten, and the crowds (5 to 8 robots, which refuse all players above 6 robots).
    paper = study_from_dict({"scenarios": "paper"}, "command line").scenarios
    crowds = study_from_dict({"scenarios": "crowds"}, "command line").scenarios
    assert len(paper) == 10 and {"2r-case1", "4r-case4"} <= set(paper)
    assert len(crowds) == 7 and sorted(paper + crowds) == sorted(every)


@pytest.mark.parametrize("text, message", [
    ("scenario: [2r-case1]\n", "unknown key 'scenario'; did you mean 'scenarios'?"),
    ("scenarios: [2r-case1]\ntrails: 4\n", "did you mean 'trials'?"),
    ("trials: 4\n", "missing key 'scenarios'"),
    ("scenarios: [2r-case1]\ntrials: 0\n", "trials: expected a whole number >= 1"),
    ("scenarios: [2r-case1]\nplayers: [-1]\n", "players: expected 'all' or a whole number >= 0, got -1"),
    ("scenarios: [2r-case1]\ninit: [distanse]\n", "unknown initial-opinion mode 'distanse'; did you mean 'distance'?"),
    ("scenarios: [2r-case1]\nplanners: [prn]\n", "unknown planner 'prn'; did you mean 'prm'?"),
    ("scenarios: [2r-case1]\nmethods: [nodd]\n", "unknown method 'nodd'; did you mean 'nod'?"),
    ("scenarios: [2r-case1]\nbias: [{X3: 1}]\n", "unknown strategy 'X3'"),
    ("scenarios: [2r-case1]\nbias: ['S3:150']\n", "expected entries like S3=150"),
    ("scenarios: [2r-case1]\nbias: [{S3: lots}]\n", "bias.S3: expected a number"),
    ("scenarios: [2r-case1\n", "invalid YAML at line 2"),
    ("- 2r-case1\n", "expected a mapping"),
])
def test_study_file_errors_are_one_line(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(StudyError) as info:
        load_study(path)
    assert message in str(info.value) and str(info.value).startswith(str(path))
    assert "\n" not in str(info.value)


def test_parse_bias_orders_strategies():
    assert parse_bias("S5=150, S3=150") == (("S3", 150.0), ("S5", 150.0))
    assert parse_bias("none") == () and parse_bias({}) == ()


# -- the cross product -------------------------------------------------------------------------


def test_expansion_is_the_cross_product_less_what_does_not_apply():
    spec = SweepSpec(name="x", scenarios=("2r-case1", "3r-case1"), players=(0, 2, "all"), init=("zero", "distance"),
                     bias=((), (("S3", 150.0),)), trials=2)
    ex = expand(spec)
    # 2 robots: K = 2 is invalid, 'all' = 1; bias S3 is invalid (S1..S2) -> 2 x 2 x 1 x 2 seeds = 8.
    # 3 robots: K = 2 and 'all' are the same trial -> 2 x 2 x 2 x 2 seeds = 16.
    assert len(ex.trials) == 8 + 16
    assert len({t.key for t in ex.trials}) == len(ex.trials)
    assert ex.notes == ("2r-case1: players 2 skipped (2 robots allow 0..1)",
                        "2r-case1: bias S3=150 skipped (2 robots have strategies S1..S2)")
    first = ex.trials[0]
    assert (first.scenario.name, first.scenario.n_players, first.scenario.opinion.init, first.seed) == ("2r-case1", 0,
                                                                                                        "zero", 1)
    three = [t for t in ex.trials if t.scenario.n_robots == 3]
    assert {t.scenario.n_players for t in three} == {0, 2}
    assert {tuple(t.scenario.opinion.bias.items()) for t in three} == {(), (("S3", 150.0),)}
    assert [t.seed for t in ex.trials[:2]] == [1, 2]


def test_expansion_leaves_out_games_above_the_size_limit():
    # 7 robots: 'all' and 6 players are games of 7 robots, 7! = 5040 orders: left out; 5 players
    # (6! = 720 orders) and the scenario's own 2 are kept.
    ex = expand(SweepSpec(name="x", scenarios=("7r-mixed",), players=("all", 6, 5, None), trials=1))
    assert sorted(t.scenario.n_players for t in ex.trials) == [2, 5]
    assert ex.notes == ("7r-mixed: players all skipped (7! orders per robot, more than 720)",
                        "7r-mixed: players 6 skipped (7! orders per robot, more than 720)")


def test_axes_left_out_keep_the_scenario_settings():
    [t] = expand(SweepSpec(name="x", scenarios=("3r-case3",))).trials
    assert t.scenario == load_scenario("3r-case3") and t.method == "nod" and t.seed == 1


def test_an_init_mode_replaces_initial_opinions_given_in_the_scenario_file(tmp_path):
    path = tmp_path / "given.yaml"
    path.write_text("name: given\nrobots:\n  - {origin: [-5, 0], destination: [5, 0]}\n"
                    "  - {origin: [5, 0], destination: [-5, 0]}\nopinion: {init: given, z0: [[1, 0], [0, 1]]}\n")
    kept, replaced = expand(SweepSpec(name="x", scenarios=(str(path),), init=(None, "distance"))).trials
    assert kept.scenario.opinion.init == "given" and kept.scenario.opinion.z0 == ((1.0, 0.0), (0.0, 1.0))
    assert replaced.scenario.opinion.init == "distance" and replaced.scenario.opinion.z0 == ()


# -- running -----------------------------------------------------------------------------------


def test_a_trial_that_raises_is_stored_as_an_error_and_the_sweep_goes_on(tmp_path, cheap_trial):
    db = tmp_path / "r.sqlite"
    spec = SweepSpec(name="e", scenarios=("2r-case1",), trials=5)
    summary = run_sweep(spec, db, quiet=True, trial_fn=cheap_trial)
    assert (summary.total, summary.done, summary.skipped, summary.errors) == (5, 5, 0, 1)
    assert not summary.success and sum(summary.outcomes.values()) == 5
    with ResultStore(db) as store:
        [err] = store.records(outcome="error")
        assert err.seed == 3 and err.error == "RuntimeError: seed 3 exploded"
        assert "Traceback" in err.summary["traceback"] and err.metrics == {}
        assert store.count("e") == 5
    # A second run does nothing; with retry_errors it runs the failed trial again, in place.
    again = run_sweep(spec, db, quiet=True, trial_fn=cheap_trial)
    assert (again.done, again.skipped) == (0, 5)
    retried = run_sweep(spec, db, quiet=True, trial_fn=cheap_trial, retry_errors=True)
    assert (retried.done, retried.skipped, retried.errors) == (1, 4, 1)
    assert len(_stored(db)) == 5


def test_execute_trial_measures_the_error(cheap_trial):
    out = execute_trial(cheap_trial, expand(SweepSpec(name="x", scenarios=("2r-case1",))).trials[0].scenario,
                        "nod", 3, "k")
    assert out.outcome == "error" and out.error == "RuntimeError: seed 3 exploded" and out.key == "k"
    assert out.summary["wall_time_s"] >= 0


def test_one_and_two_workers_store_the_same_results(tmp_path, cheap_trial):
    spec = SweepSpec(name="w", scenarios=("2r-case1", "3r-case2"), players=(1, "all"), trials=4)
    one = run_sweep(spec, tmp_path / "one.sqlite", jobs=1, quiet=True, trial_fn=cheap_trial)
    two = run_sweep(spec, tmp_path / "two.sqlite", jobs=2, quiet=True, trial_fn=cheap_trial)
    assert one.done == two.done == 12 and one.errors == two.errors == 3
    a, b = _stored(tmp_path / "one.sqlite"), _stored(tmp_path / "two.sqlite")
    assert a == b and len(a) == 12


def test_progress_bar_goes_to_stderr_unless_quiet(tmp_path, capsys, cheap_trial):
    spec = SweepSpec(name="p", scenarios=("2r-case1",), trials=2)
    run_sweep(spec, tmp_path / "a.sqlite", quiet=True, trial_fn=cheap_trial)
    assert capsys.readouterr().err == ""
    run_sweep(spec, tmp_path / "b.sqlite", quiet=False, trial_fn=cheap_trial)
    err = capsys.readouterr().err
    assert "2/2" in err and "trial/s" in err


KILL_SCRIPT = """
import sys
from pathlib import Path

import cloudpickle

from nodnav.experiments.study import SweepSpec
from nodnav.experiments.batch import run_sweep

slow_trial = cloudpickle.loads(Path(sys.argv[2]).read_bytes())
spec = SweepSpec(name="kill", scenarios=("2r-case1", "3r-case1"), trials=20)
run_sweep(spec, sys.argv[1], jobs=2, quiet=True, trial_fn=slow_trial)
"""


def test_sigkill_part_way_loses_nothing_and_a_rerun_completes_the_sweep(tmp_path, cheap_trial, slow_trial):
    db = tmp_path / "r.sqlite"
    (tmp_path / "trial.pickle").write_bytes(cloudpickle.dumps(slow_trial))
    with open(tmp_path / "out.txt", "w") as log:
        proc = subprocess.Popen([sys.executable, "-c", KILL_SCRIPT, str(db), str(tmp_path / "trial.pickle")],
                                stdout=log, stderr=log, start_new_session=True)
        try:
            deadline = time.monotonic() + 60
            count = 0
            while count < 8 and time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.05)
                if db.exists():
                    with closing(sqlite3.connect(db)) as con:
                        try:
                            count = con.execute("SELECT COUNT(*) FROM trials").fetchone()[0]
                        except sqlite3.OperationalError:  # the table is not created yet
                            count = 0
            assert proc.poll() is None, (tmp_path / "out.txt").read_text()
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)
        finally:
            try:  # the sweep's worker processes, left behind by the killed parent
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    assert proc.returncode == -signal.SIGKILL
    con = sqlite3.connect(db)
    assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    before = dict(con.execute("SELECT key, rowid FROM trials").fetchall())
    con.close()
    spec = SweepSpec(name="kill", scenarios=("2r-case1", "3r-case1"), trials=20)
    assert 8 <= len(before) < 40
    # Every row written before the kill is whole: it reads back and matches what the trial gives.
    expected = {t.key: t for t in expand(spec).trials}
    stored = _stored(db)
    for key, (outcome, error, metrics, summary) in stored.items():
        t = expected[key]
        if t.seed == 3:
            assert outcome == "error" and error == "RuntimeError: seed 3 exploded"
        else:
            ref = cheap_trial(t.scenario, t.method, t.seed)
            assert outcome == ref.outcome and summary["seed"] == t.seed
            assert metrics == {"flow_rate_rps": ref.metrics["flow_rate_rps"], "time_to_consensus_s": None}
    summary = run_sweep(spec, db, jobs=2, quiet=True, trial_fn=cheap_trial)
    assert summary.skipped == len(before) and summary.done == 40 - len(before)
    con = sqlite3.connect(db)
    after = dict(con.execute("SELECT key, rowid FROM trials").fetchall())
    assert set(after) == set(expected) and len(after) == 40
    assert all(after[k] == rowid for k, rowid in before.items())  # nothing was run twice
    assert con.execute("SELECT COUNT(*) FROM study_trials WHERE study = 'kill'").fetchone()[0] == 40
    con.close()


def test_real_two_robot_trials_with_one_and_two_workers(tmp_path):
    spec = SweepSpec(name="real", scenarios=("2r-case1",), trials=2)
    one = run_sweep(spec, tmp_path / "one.sqlite", jobs=1, quiet=True)
    two = run_sweep(spec, tmp_path / "two.sqlite", jobs=2, quiet=True)
    assert one.errors == two.errors == 0 and one.done == two.done == 2
    a, b = _stored(tmp_path / "one.sqlite"), _stored(tmp_path / "two.sqlite")
    assert a == b
    for outcome, _, metrics, summary in a.values():
        assert outcome in ("success", "collision", "deadlock", "timeout")
        assert summary["outcome"] == outcome and "min_separation_m" in summary
        json.dumps(metrics, allow_nan=False)
