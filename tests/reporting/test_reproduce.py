"""``nodnav reproduce``: the studies it plans, the Fig. 2c scenario files, the budget rounds, and a
tiny end-to-end run of real trials through the command line."""

import time

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from nodnav.cli import main  # noqa: E402
from nodnav.decision.heatmap import z_grid  # noqa: E402
from nodnav.errors import NodnavError  # noqa: E402
from nodnav.experiments.paper import META_STUDY, STUDY_METHODS, STUDY_PLANNERS, STUDY_SUCCESS, STUDY_TABLE1  # noqa: E402
from nodnav.experiments.store import ResultStore, trial_config, trial_key  # noqa: E402
from nodnav.experiments.study import SweepSpec  # noqa: E402
from nodnav.experiments.sweep import expand  # noqa: E402
from nodnav.reporting.reproduce import (  # noqa: E402
    CostModel,
    Part,
    ReproduceOptions,
    check_options,
    fig2c_scenario_files,
    next_round,
    pending,
    plan_parts,
    reproduce,
    round_cost,
    round_parts,
    seeds_at,
)
from nodnav.scenario.loading import load_scenario  #noqa: E402
from nodnav.scenario.schema import scenario_to_dict


def _part(name, target):
    return Part(name, name, SweepSpec(name, ("2r-case1",), trials=target))


def test_seeds_at_gives_every_part_the_same_seeds_up_to_its_target():
    parts = (_part("a", 40), _part("b", 2), _part("c", 10))
    none = {"a": 0, "b": 0, "c": 0}
    assert seeds_at(parts, 1, none) == {"a": 1, "b": 1, "c": 1}
    assert seeds_at(parts, 5, none) == {"a": 5, "b": 2, "c": 5}
    assert seeds_at(parts, 40, none) == {"a": 40, "b": 2, "c": 10}
    assert seeds_at(parts, 3, {"a": 7, "b": 2, "c": 0}) == {"a": 7, "b": 2, "c": 3}


def test_next_round_fits_the_time_left(tmp_path):
    options = ReproduceOptions(out=tmp_path, trials=3, scenarios=("2r-case1",), parts=("success", "table1"))
    parts = plan_parts(options)
    trials = {p.name: expand(p.spec).trials for p in parts}  # two cells each, none shared
    stored = {t.key for specs in trials.values() for t in specs if t.seed == 1}
    done = {"success": 1, "table1": 1}

    def plan(left):
        return next_round(parts, done, trials, stored, lambda t: 10.0, 1, left)

    # Seconds by hand: 1.15 * (trials * 10 s) + 4 s per sweep.
    assert round_cost([None] * 8, lambda t: 10.0, 1, 2) == pytest.approx(100.0)
    assert plan(1000.0) == {"success": 3, "table1": 3}  # 8 trials: 100 s
    assert plan(60.0) == {"success": 2, "table1": 2}  # 4 trials: 54 s
    assert plan(50.0) == {"success": 2, "table1": 1}  # 54 s is too much; success alone takes 27 s
    assert plan(20.0) == done  # nothing fits
    assert next_round(parts, {"success": 3, "table1": 3}, trials, stored, lambda t: 10.0, 1, 1e9) == {
        "success": 3, "table1": 3}


def test_plan_parts(tmp_path):
    options = ReproduceOptions(out=tmp_path, trials=3, scenarios=("2r-case1", "3r-case2"), methods=("nod",),
                               fig2c_grid=3, fig2c_trials=2)
    parts = {p.name: p for p in plan_parts(options)}
    # No planner besides the fast one: no planner comparison.
    assert list(parts) == ["success", "table1", "table2", "fig2c", "methods", "reduction", "scaling",
                           "mixed-teams"]
    # 3r-case2 with one game player as each of the four variants; 2r-case1 has no reduced game.
    assert len(parts["reduction"].spec.scenarios) == 4
    assert parts["success"].spec.players == (0, 1, 2) and parts["success"].spec.planners == ("fast",)
    assert parts["table1"].spec.scenarios == ("3r-case2",) and parts["table1"].spec.init == ("zero", "distance")
    assert parts["table2"].spec.bias == ((), (("S3", 150.0), ("S5", 150.0)))
    assert parts["fig2c"].target == 2 and len(parts["fig2c"].spec.scenarios) == 9
    assert parts["methods"].spec.methods == ("nod",) and parts["methods"].target == 3
    with_prm = plan_parts(ReproduceOptions(out=tmp_path, scenarios=("2r-case1",), planners=("prm",),
                                           parts=("planners",)))
    assert [p.name for p in with_prm] == ["planners"]
    assert with_prm[0].spec.planners == ("fast", "prm") and with_prm[0].spec.name == STUDY_PLANNERS


def test_fig2c_scenario_files_set_the_initial_opinions(tmp_path):
    paths = fig2c_scenario_files(tmp_path, 3)
    assert len(paths) == 9
    base = load_scenario("2r-case2")
    cells = set()
    for path in paths:
        s = load_scenario(path)
        assert s.name == "2r-case2" and s.opinion.u == 10.0 and s.opinion.init == "given"
        assert s.robots == base.robots and s.opinion.K1 == base.opinion.K1
        (z11, z12), (z21, z22) = s.opinion.z0
        assert z12 == 0.0 and z22 == 0.0
        cells.add((z11, z21))
    assert cells == {(a, c) for a in (-10.0, 0.0, 10.0) for c in (-10.0, 0.0, 10.0)}
    np.testing.assert_array_equal(z_grid(3), [-10.0, 0.0, 10.0])


def test_pending_counts_a_trial_shared_by_two_parts_once(tmp_path):
    options = ReproduceOptions(out=tmp_path, trials=2, scenarios=("2r-case1",), methods=("nod",),
                               parts=("success", "methods"))
    parts = plan_parts(options)
    trials = {p.name: expand(p.spec).trials for p in parts}
    # Success: k = 0 and k = 1; methods: nod with all players, which is k = 1 again.
    assert len(pending(trials, {"success": 2, "methods": 2}, set())) == 4
    assert len(pending(trials, {"success": 1, "methods": 2}, set())) == 3
    stored = {t.key for t in trials["methods"]}
    assert len(pending(trials, {"success": 2, "methods": 2}, stored)) == 2


def test_cost_model_falls_back_from_cell_to_robots_to_prior(tmp_path):
    db = tmp_path / "r.sqlite"
    s = load_scenario("2r-case1")
    cfg = trial_config(scenario_to_dict(s), "nod")
    with ResultStore(db) as store:
        for seed, wall in ((1, 2.0), (2, 4.0)):
            store.add_trial(key=trial_key(cfg, seed), study="x", config=cfg, seed=seed, outcome="success",
                            summary={"wall_time_s": wall}, metrics={}, version="0")
        cost = CostModel(store)
    trials = expand(SweepSpec("x", ("2r-case1", "3r-case1"), players=(0, 1), trials=1)).trials
    by = {(t.scenario.name, t.scenario.n_players): cost(t) for t in trials}
    assert by[("2r-case1", 1)] == 3.0  # its own cell: mean of 2 and 4
    assert by[("2r-case1", 0)] == 3.0  # same robots, method and planner
    assert by[("3r-case1", 0)] == 12.0  # nothing with three robots: the prior


def test_check_options():
    with pytest.raises(NodnavError, match="trials"):
        check_options(ReproduceOptions(trials=0))
    with pytest.raises(NodnavError, match="unknown part"):
        check_options(ReproduceOptions(parts=("tables",)))
    with pytest.raises(NodnavError, match="unknown method"):
        check_options(ReproduceOptions(methods=("teleport",)))
    with pytest.raises(NodnavError, match="budget"):
        check_options(ReproduceOptions(budget_minutes=-1.0))


def test_rounds_complete_the_papers_evaluation_before_the_comparisons():
    parts = plan_parts(ReproduceOptions(trials=3, scenarios=("2r-case1",), methods=("nod",),
                                        parts=("success", "methods", "table1")))
    assert [p.name for p in round_parts(parts, {"success": 1, "table1": 3, "methods": 1})] == ["success"]
    assert [p.name for p in round_parts(parts, {"success": 3, "table1": 3, "methods": 1})] == ["methods"]
    assert round_parts(parts, {"success": 3, "table1": 3, "methods": 3}) == ()


# -- the budget, with a stand-in trial that claims to have taken a minute ---------------------------


RUNS = []


@pytest.fixture
def minute_trial(trial_result):
    """Instant, but stores a wall time of 60 s, so the cost model expects every trial to take a minute."""
    def trial(scenario, method, seed):
        RUNS.append((scenario.name, scenario.n_players, seed))
        return trial_result("success", {"strategy": 1, "wall_time_s": 60.0, "sim_time_s": 1.0, "makespan_s": 1.0})

    return trial


def test_budget_cuts_every_part_evenly_and_a_rerun_continues(tmp_path, minute_trial):
    RUNS.clear()
    options = ReproduceOptions(out=tmp_path, trials=3, jobs=1, scenarios=("2r-case1",), methods=("nod",),
                               parts=("success", "table1"), budget_minutes=1.5, heatmap_grid=3,
                               rerun_snapshots=False, quiet=True)
    result = reproduce(options, trial_fn=minute_trial)
    # After seed 1 of every cell, one more round would take minutes: the budget stops there.
    assert result.report.success and not result.complete
    assert {p.part: p.seeds for p in result.progress} == {"success": 1, "table1": 1}
    assert len(RUNS) == 4  # table1: zero, distance; success: k = 0, 1
    assert "Fig. 3 success rates ran 1 of 3 trials per cell" in result.cuts[0]
    with ResultStore(options.db_path) as store:
        meta = store.studies()[META_STUDY]
        assert meta["levels"] == [{"success": 1, "table1": 1}] and meta["cuts"] == list(result.cuts)
        assert store.count(STUDY_SUCCESS) == 2 and store.count(STUDY_TABLE1) == 2
    assert "- Cut: the 1.5-minute budget ran out" in result.report.path.read_text()
    # No limit: everything else runs, and nothing stored runs again.
    RUNS.clear()
    again = reproduce(ReproduceOptions(**{**options.__dict__, "budget_minutes": 0.0}), trial_fn=minute_trial)
    assert again.complete and not again.cuts and len(RUNS) == 8 and all(seed > 1 for *_, seed in RUNS)


@pytest.fixture
def slow_trial(minute_trial):
    """:func:`minute_trial` that really takes 1.5 s."""
    def trial(scenario, method, seed):
        time.sleep(1.5)
        return minute_trial(scenario, method, seed)

    return trial


def test_no_sweep_starts_once_the_budget_is_spent(tmp_path, monkeypatch, slow_trial):
    import nodnav.reporting.reproduce as module

    # Budget 60 s with 58 s kept for the report: sweeps may start only in the first 2 s.
    monkeypatch.setattr(module, "REPORT_RESERVE", 58.0)
    RUNS.clear()
    options = ReproduceOptions(out=tmp_path, trials=2, jobs=1, scenarios=("2r-case1",), parts=("success", "table1"),
                               budget_minutes=1.0, heatmap_grid=3, rerun_snapshots=False, quiet=True)
    result = reproduce(options, trial_fn=slow_trial)
    # The success pilot (two trials, 3 s) ran; table1 did not start.
    assert {p.part: p.seeds for p in result.progress} == {"success": 1, "table1": 0}
    assert len(RUNS) == 2 and "Table I (3-Robot Case-2, initial opinions) ran 0 of 2" in result.cuts[0]
    assert "paper-table1" in result.report.missing


# -- end to end, real trials ------------------------------------------------------------------------


def test_tiny_reproduce_then_report_from_the_database(tmp_path, capsys):
    out = tmp_path / "rep"
    code = main(["reproduce", "--trials", "1", "--jobs", "2", "--out", str(out), "--scenarios", "2r-case1",
                 "--parts", "success,methods", "--methods", "nod", "--heatmap-grid", "3", "--budget", "0",
                 "--quiet"])
    assert code == 0, capsys.readouterr().err
    text = (out / "report.md").read_text()
    with ResultStore(out / "results.sqlite") as store:
        # k = 0 and k = 1; the methods study shares the k = 1 trial.
        assert store.count() == 2 and store.count(STUDY_METHODS) == 1
        cells = {k: c for k, c in store.outcome_counts(study=STUDY_SUCCESS).items()}
    assert set(cells) == {("2r-case1", 0), ("2r-case1", 1)}
    assert "## Success rates (Fig. 3)" in text and "| 2r-case1 |" in text
    assert (out / "fig3-success-rates.png").exists() and (out / "methods-success-rates.png").exists()
    assert "*Produced by `nodnav reproduce --trials 1 --jobs 2" in text
    # The report rebuilt from the database alone shows the same numbers.
    code = main(["report", str(out / "results.sqlite"), "--out", str(tmp_path / "again"), "--no-rerun",
                 "--heatmap-grid", "3"])
    assert code == 0
    again = (tmp_path / "again" / "report.md").read_text()
    row = next(line for line in text.splitlines() if line.startswith("| 2r-case1 |"))
    assert row in again
    assert "*Produced by `nodnav report" in again
