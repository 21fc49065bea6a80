"""A family sweep stores its draws; the report's first section breaks any database down by
scenario or family, players, method and failure class (no trial is simulated)."""

import math

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402

from nodnav.experiments.batch import run_sweep  # noqa: E402
from nodnav.experiments.statistics import wilson_interval  #noqa: E402
from nodnav.experiments.store import ResultStore, trial_config, trial_key  # noqa: E402
from nodnav.experiments.study import StudyError, SweepSpec, study_from_dict  # noqa: E402
from nodnav.experiments.sweep import expand  # noqa: E402
from nodnav.reporting.breakdown import breakdown_lines, fmt_success  # noqa: E402
from nodnav.reporting.report import build_report
from nodnav.scenario.draws import draw  # noqa: E402
from nodnav.scenario.families import load_family, redo_spec  # noqa: E402
from nodnav.scenario.loading import load_scenario  #noqa: E402
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict


@pytest.fixture
def stub_trial(trial_result):
    """Seed 1 succeeds, seed 2 jams; the summary carries what the store reads."""
    def trial(scenario, method, seed):
        outcome = "success" if seed == 1 else "deadlock"
        return trial_result(outcome, {"scenario": scenario.name, "seed": seed, "consensus": True,
                                      "failure_class": "success" if seed == 1 else "jam", "sim_time_s": 1.0})

    return trial


def test_family_sweep_stores_each_draw_with_its_seed(tmp_path, stub_trial):
    db = tmp_path / "f.sqlite"
    summary = run_sweep(SweepSpec(name="mixed", scenarios=(), families=("mixed",), trials=2), db, quiet=True,
                        trial_fn=stub_trial)
    assert summary.done == 2 and summary.success
    with ResultStore(db) as store:
        records = store.records()
    assert [(r.scenario, r.seed, r.study) for r in records] == [("mixed:1", 1, "mixed"), ("mixed:2", 2, "mixed")]
    for r in records:
        drawn = draw(load_family("mixed"), r.seed)
        assert r.config["scenario"] == scenario_to_dict(drawn)
        assert scenario_from_dict(r.config["scenario"]) == load_scenario(f"mixed:{r.seed}")


def test_family_players_that_do_not_fit_a_draw_are_noted_once():
    # paper-like draws 2-4 robots: 3 players fit only the 4-robot draws.
    expansion = expand(SweepSpec(name="x", scenarios=(), families=("paper-like",), players=(3,), trials=12))
    n4 = sum(draw(load_family("paper-like"), s).n_robots == 4 for s in range(1, 13))
    assert len(expansion.trials) == n4
    assert all(note.startswith("paper-like: players 3 skipped") for note in expansion.notes)


def test_study_files_take_families():
    spec = study_from_dict({"families": ["mixed"], "trials": 3}, "t")
    assert spec.families == ("mixed",) and spec.scenarios == () and spec.to_dict()["families"] == ["mixed"]
    with pytest.raises(StudyError, match="families: mixd: no such built-in family"):
        study_from_dict({"families": ["mixd"]}, "t")


def test_the_reports_wilson_interval_matches_scipys():
    from scipy.stats import binomtest

    for k, n in [(0, 40), (20, 40), (1, 2), (39, 40), (7, 9)]:
        iv = wilson_interval(k, n)
        ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
        assert (iv.low, iv.high) == pytest.approx((ci.low, ci.high), abs=1e-12)
    # 1 of 2: z sqrt(1/2 + z^2/4) / (2 + z^2) = 0.40547 about 1/2.
    assert fmt_success(1, 2) == "50.0 [9.5, 90.5] (2)"


def _add(store, scenario, seed, outcome, summary, method="nod", study="s"):
    config = trial_config(scenario_to_dict(scenario), method)
    store.add_trial(key=trial_key(config, seed), study=study, config=config, seed=seed, outcome=outcome,
                    summary={"outcome": outcome, **summary}, metrics={}, version="test")


@pytest.fixture
def db(tmp_path):
    path = tmp_path / "r.sqlite"
    mixed2 = load_scenario("mixed:2").with_overrides(game_players=1)
    with ResultStore(path) as store:
        _add(store, load_scenario("mixed:1"), 1, "success", {"failure_class": "success"})
        _add(store, mixed2, 2, "deadlock", {"failure_class": "jam", "consensus": True}, method="closest-first")
        _add(store, load_scenario("mixed:3"), 3, "collision", {"failure_class": "collision-wall"})
        _add(store, load_scenario("2r-case1"), 1, "success", {"failure_class": "success"})
        # Stored before failure classes existed: the class comes from the outcome.
        _add(store, load_scenario("2r-case1"), 2, "collision", {"collision_kind": None})
        _add(store, load_scenario("2r-case1"), 3, "error", {})
    return path


def test_breakdown_groups_families_and_lists_redo_commands(db):
    with ResultStore(db) as store:
        text = "\n".join(breakdown_lines(store))
    assert "| `mixed` (family) | all | nod | fast | 50.0 [9.5, 90.5] (2) | collision-wall 1 |" in text
    assert "| `mixed` (family) | 1 | closest-first | fast | 0.0 [0.0, 79.3] (1) | jam 1 |" in text
    assert "| `2r-case1` | all | nod | fast | 33.3 [6.1, 79.2] (3) | collision-robot-robot 1, error 1 |" in text
    assert "- `jam`: `nodnav run mixed:2 --seed 2 --players 1 --method closest-first`" in text
    assert "- `collision-wall`: `nodnav run mixed:3 --seed 3`" in text
    assert "nodnav run 2r-case1" not in text  # only family trials are listed
    # Wilson's upper end for 0 of 1 is z^2 / (1 + z^2) = 0.7934.
    z2 = 1.959963984540054 ** 2
    assert f"{100 * z2 / (1 + z2):.1f}" == "79.3"


def test_report_opens_with_the_breakdown(db, tmp_path):
    result = build_report(db, tmp_path / "out", heatmap_grid=3, rerun_snapshots=False)
    text = result.path.read_text()
    assert result.success
    assert text.index("## What this database holds") < text.index("## Cost of a trial")
    assert "## Success rates" not in text  # a sweep of one's own holds none of the paper's studies
    assert "### Failure classes" in text and "`jam`" in text


def test_redo_spec_of_a_family_file(tmp_path):
    path = tmp_path / "fam.yaml"
    path.write_text("family: fam\nrobots: {count: 2}\n")
    s = load_scenario(f"{path}:5")
    assert redo_spec(s.name, s.description) == f"{path}:5"
    assert redo_spec("mixed:5", load_scenario("mixed:5").description) == "mixed:5"
    assert redo_spec("3r-case1", "anything") is None
    assert math.isfinite(s.time_limit)


def test_sweep_command_names_the_study_after_the_family(tmp_path, monkeypatch, capsys, stub_trial):
    import nodnav.experiments.sweep as sweep
    from nodnav.cli import main

    monkeypatch.setattr(sweep, "_default_trial_fn", lambda: stub_trial)
    db = tmp_path / "c.sqlite"
    assert main(["sweep", "--family", "paper-like", "--trials", "2", "--db", str(db), "--quiet"]) == 0
    assert "paper-like: 2 trials, 2 run" in capsys.readouterr().out
    with ResultStore(db) as store:
        assert [(r.study, r.scenario, r.seed) for r in store.records()] == [
            ("paper-like", "paper-like:1", 1), ("paper-like", "paper-like:2", 2)]
