"""The report: Wilson and Newcombe intervals against hand values, strategy tables and a whole
report rebuilt from a small synthetic results database (no trial is run)."""

import math

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.image import imread  # noqa: E402

from nodnav.experiments.analysis import (  # noqa: E402
    RateCell,
    closed_loop_grid,
    method_rows,
    methods_reading,
    paper_inside,
    sign_rule_agreement,
    strategy_frequencies,
    table_rows,
)
from nodnav.experiments.paper import (  # noqa: E402
    META_STUDY,
    STUDY_FIG2C,
    STUDY_METHODS,
    STUDY_PLANNERS,
    STUDY_SUCCESS,
    STUDY_TABLE1,
    STUDY_TABLE2,
)
from nodnav.experiments.statistics import (  # noqa: E402
    Interval,
    intervals_separate,
    newcombe_difference,
    planner_verdict,
    wilson_interval,
)
from nodnav.experiments.store import ResultStore, trial_config, trial_key  # noqa: E402
from nodnav.reporting.report import build_report  # noqa: E402
from nodnav.scenario.loading import load_scenario  #noqa: E402
from nodnav.scenario.schema import scenario_to_dict
from nodnav.viz.report import plot_rate_bars  # noqa: E402

Z = 1.959963984540054
Z2 = Z * Z  # 3.841458820694124


# -- Wilson intervals ------------------------------------------------------------------------------


def test_wilson_none_of_forty_by_hand():
    # k = 0: centre = (z^2/2)/(n + z^2) and half-width = (z^2/2)/(n + z^2), so [0, z^2/(n + z^2)].
    iv = wilson_interval(0, 40)
    assert iv.rate == 0.0
    assert iv.low == pytest.approx(0.0, abs=1e-15)
    assert iv.high == pytest.approx(Z2 / (40 + Z2), rel=1e-12)
    assert iv.high == pytest.approx(0.0876, abs=5e-5)  # 3.8415 / 43.8415


def test_wilson_all_of_forty_by_hand():
    # k = n: [n/(n + z^2), 1] = [40/43.8415, 1].
    iv = wilson_interval(40, 40)
    assert iv.rate == 1.0
    assert iv.low == pytest.approx(40 / (40 + Z2), rel=1e-12)
    assert iv.low == pytest.approx(0.9124, abs=5e-5)
    assert iv.high == pytest.approx(1.0, abs=1e-12)


def test_wilson_half_of_forty_by_hand():
    # k = n/2: centre 1/2, half-width z sqrt(n/4 + z^2/4) / (n + z^2) = 1.96 * sqrt(10.9604) / 43.8415.
    iv = wilson_interval(20, 40)
    half = Z * math.sqrt(10 + Z2 / 4) / (40 + Z2)
    assert half == pytest.approx(0.14801, abs=1e-5)
    assert (iv.low, iv.high) == pytest.approx((0.5 - half, 0.5 + half), rel=1e-12)
    assert (iv.low, iv.high) == pytest.approx((0.3520, 0.6480), abs=5e-5)


def test_wilson_one_of_two_and_vectorised():
    # n = 2, k = 1: half-width z sqrt(1/2 + z^2/4) / (2 + z^2) = 0.40547.
    iv = wilson_interval(np.array([0, 1, 2]), np.array([2, 2, 2]))
    half = Z * math.sqrt(0.5 + Z2 / 4) / (2 + Z2)
    assert iv.rate.shape == (3,)
    assert iv.low[1] == pytest.approx(0.5 - half) and iv.high[1] == pytest.approx(0.5 + half)
    assert iv.high[0] == pytest.approx(Z2 / (2 + Z2))


def test_wilson_symmetry_and_containment():
    k, n = np.arange(0, 41), np.full(41, 40)
    a, b = wilson_interval(k, n), wilson_interval(n - k, n)
    # Swapping successes and failures mirrors the interval about 1/2.
    np.testing.assert_allclose(a.low, 1 - b.high, atol=1e-12)
    np.testing.assert_allclose(a.high, 1 - b.low, atol=1e-12)
    assert np.all(a.low <= a.rate) and np.all(a.rate <= a.high)
    assert np.all(np.diff(a.low) > 0) and np.all(np.diff(a.high) > 0)


def test_wilson_empty_and_invalid():
    iv = wilson_interval(0, 0)
    assert math.isnan(iv.rate) and math.isnan(iv.low) and math.isnan(iv.high)
    with pytest.raises(ValueError):
        wilson_interval(5, 4)


def test_newcombe_difference_matches_the_published_examples():
    # Newcombe (1998), Stat. Med. 17:873, Table II, method 10.
    d = newcombe_difference(56, 70, 48, 80)
    assert d.rate == pytest.approx(0.2)
    assert (d.low, d.high) == pytest.approx((0.0524, 0.3339), abs=5e-5)
    d = newcombe_difference(9, 10, 3, 10)
    assert (d.low, d.high) == pytest.approx((0.1705, 0.8090), abs=5e-5)
    # Swapping the groups negates the difference and its interval.
    e = newcombe_difference(3, 10, 9, 10)
    assert (e.rate, e.low, e.high) == pytest.approx((-d.rate, -d.high, -d.low))


def test_intervals_separate():
    a, b = Interval(0.9, 0.8, 0.95), Interval(0.2, 0.1, 0.4)
    assert intervals_separate(a, b) == 1 and intervals_separate(b, a) == -1
    assert intervals_separate(a, Interval(0.85, 0.7, 0.9)) == 0
    assert intervals_separate(a, wilson_interval(0, 0)) == 0


# -- a synthetic database --------------------------------------------------------------------------


def _config(name, method="nod", **overrides):
    s = load_scenario(name)
    if overrides:
        s = s.with_overrides(**overrides)
    return trial_config(scenario_to_dict(s), method)


def _add(store, study, config, seed, outcome="success", strategy=None, makespan=None, smooth=None, wall=2.0):
    summary = {"outcome": outcome, "success": outcome == "success", "makespan_s": makespan, "strategy": strategy,
               "consensus": True, "sim_time_s": 20.0, "wall_time_s": wall, "min_separation_m": 0.5}
    store.add_trial(key=trial_key(config, seed), study=study, config=config, seed=seed, outcome=outcome,
                    summary=summary, metrics={"smoothness_mps": smooth}, version="9.9.9")


TABLE1_ZERO = [1, 2, 2, 3, 6, 6, 6, None]  # realised strategies of 8 trials; the last one deadlocked
TABLE1_DIST = [3, 4, 4, 4]


def _synthetic_db(path):
    with ResultStore(path) as store:
        # Success rates: 2r-case1 with 0 players (2 deadlocks) and 1 player (1 of 2 succeeded).
        c0, c1 = _config("2r-case1", game_players=0), _config("2r-case1", game_players=1)
        _add(store, STUDY_SUCCESS, c0, 1, "deadlock", wall=9.0)
        _add(store, STUDY_SUCCESS, c0, 2, "deadlock", wall=9.0)
        _add(store, STUDY_SUCCESS, c1, 1, "success", strategy=1, makespan=20.0, smooth=0.04, wall=5.0)
        _add(store, STUDY_SUCCESS, c1, 2, "collision", strategy=2, smooth=0.06, wall=7.0)
        # Table I.
        zero, dist = _config("3r-case2"), _config("3r-case2", **{"opinion.init": "distance"})
        for seed, s in enumerate(TABLE1_ZERO, start=1):
            _add(store, STUDY_TABLE1, zero, seed, "success" if s else "deadlock", strategy=s)
        for seed, s in enumerate(TABLE1_DIST, start=1):
            _add(store, STUDY_TABLE1, dist, seed, strategy=s)
        # Table II: the biased row realises only S3 and S5.
        none, biased = _config("3r-case3"), _config("3r-case3", **{"opinion.bias": {"S3": 150.0, "S5": 150.0}})
        for seed, s in enumerate([2, 4, 6], start=1):
            _add(store, STUDY_TABLE2, none, seed, strategy=s)
        for seed, s in enumerate([3, 5, 5, 3], start=1):
            _add(store, STUDY_TABLE2, biased, seed, strategy=s)
        # Fig. 2c: four cells of a 2 x 2 grid; (10, 10) realises S1 twice, (-10, -10) S2, (-10, 10) no order.
        for (z11, z21), strategies in {(10.0, 10.0): [1, 1], (-10.0, -10.0): [2, 2], (10.0, -10.0): [1, 2],
                                       (-10.0, 10.0): [None]}.items():
            cfg = _config("2r-case2", **{"opinion.u": 10.0, "opinion.init": "given",
                                         "opinion.z0": [[z11, 0.0], [z21, 0.0]]})
            for seed, s in enumerate(strategies, start=1):
                _add(store, STUDY_FIG2C, cfg, seed, "success" if s else "deadlock", strategy=s)
        # Methods: nod (shares the success trials of k = 1) against 'other', which always deadlocks.
        store.link(STUDY_METHODS, [trial_key(c1, 1), trial_key(c1, 2)])
        other = _config("2r-case1", method="other")
        for seed in (1, 2):
            _add(store, STUDY_METHODS, other, seed, "deadlock", smooth=0.01)
        part = {"part": "success", "study": STUDY_SUCCESS, "title": "Fig. 3 success rates", "target": 40, "seeds": 2}
        store.save_study(META_STUDY, {
            "kind": "reproduce", "command": "nodnav reproduce --trials 2", "jobs": 2, "budget_s": 600.0,
            "trials_wall_s": 90.0, "levels": [{"success": 1}, {"success": 2}], "parts": [part],
            "cuts": ["the budget ran out: Fig. 3 success rates ran 2 of 40 trials per cell."], "notes": []})


def test_strategy_frequencies_from_the_database(tmp_path):
    db = tmp_path / "r.sqlite"
    _synthetic_db(db)
    with ResultStore(db) as store:
        zero, dist = table_rows(store, STUDY_TABLE1, "init", ["zero", "distance"], 3)
    # Counted by hand from TABLE1_ZERO: S1 once, S2 twice, S3 once, S6 three times; one trial without an order.
    np.testing.assert_array_equal(zero.counts, [1, 2, 1, 0, 0, 3])
    assert (zero.trials, zero.realised, zero.incomplete) == (8, 7, 1)
    assert zero.share.rate[5] == pytest.approx(3 / 7)
    np.testing.assert_array_equal(dist.counts, [0, 0, 1, 3, 0, 0])
    assert dist.set_share((3, 4)).rate == 1.0
    assert dist.set_share((3, 4)).low == pytest.approx(4 / (4 + Z2))
    # The paper's row 2 (0, 0, 40, 60, 0, 0): 0 % lies in [0, 49.0] and 40 %, 60 % in their intervals.
    assert paper_inside(dist, (0.0, 0.0, 40.0, 60.0, 0.0, 0.0)) == 6
    # All on S1: only the zeros for S2, S5, S6 fit (S3 = 1/4 and S4 = 3/4 have intervals above 0).
    assert paper_inside(dist, (100.0, 0.0, 0.0, 0.0, 0.0, 0.0)) == 3


def test_strategy_frequencies_reject_an_impossible_strategy(tmp_path):
    db = tmp_path / "r.sqlite"
    with ResultStore(db) as store:
        _add(store, "s", _config("2r-case1"), 1, strategy=3)
        with pytest.raises(ValueError, match="strategy 3 outside S1..S2"):
            strategy_frequencies(store.records("s"), 2)


def test_closed_loop_grid_and_sign_rule(tmp_path):
    db = tmp_path / "r.sqlite"
    _synthetic_db(db)
    with ResultStore(db) as store:
        grid = closed_loop_grid(store.records(STUDY_FIG2C))
    np.testing.assert_array_equal(grid.z_values, [-10.0, 10.0])
    assert grid.u == 10.0
    # Rows z_11, columns z_21.
    np.testing.assert_array_equal(grid.trials, [[2, 1], [2, 2]])
    np.testing.assert_array_equal(grid.realised, [[2, 0], [2, 2]])
    np.testing.assert_array_equal(grid.s1, [[0, 0], [1, 2]])
    assert np.isnan(grid.fraction[0, 1]) and grid.fraction[1, 0] == 0.5
    # Off the anti-diagonal: (-10, -10) chose S2 and (10, 10) S1, both as the pure NOD does.
    assert sign_rule_agreement(grid) == (2, 2)


def test_method_rows_from_the_database(tmp_path):
    db = tmp_path / "r.sqlite"
    _synthetic_db(db)
    with ResultStore(db) as store:
        nod, other = method_rows(store.records(STUDY_METHODS))
    assert (nod.method, other.method) == ("nod", "other")
    assert nod.cell.counts == {"success": 1, "collision": 1} and other.cell.counts == {"deadlock": 2}
    # Makespan and smoothness over the one success (the collision's 0.06 is left out).
    assert nod.makespan == (20.0, 0.0, 1)
    assert nod.smoothness == (0.04, 0.0, 1)
    assert other.smoothness[2] == 0
    assert math.isnan(other.makespan[0]) and other.makespan[2] == 0


def test_methods_reading_follows_the_numbers():
    def rows(nod_success, other_success, n=40):
        return [_row("a", "nod", nod_success, n), _row("a", "other", other_success, n),
                _row("b", "nod", nod_success, n), _row("b", "other", nod_success, n)]

    text = " ".join(methods_reading(rows(40, 5)))
    assert ("per scenario, nod's success rate is higher on 1 scenario(s) (a), lower on 0, "
            "and not distinguishable on 1") in text
    # Pooled: 80 of 80 against 45 of 80.
    d = newcombe_difference(80, 80, 45, 80)
    assert f"pooled difference {100 * d.rate:+.1f} points [{100 * d.low:+.1f}, {100 * d.high:+.1f}]" in text
    assert "+43.8 points" in text
    text = " ".join(methods_reading(rows(5, 40)))
    assert "higher on 0 scenario(s), lower on 1 (a)" in text
    assert methods_reading([_row("a", "nod", 1, 2)]) == ["Only nod is in the database: there is nothing to compare."]


def _row(scenario, method, k, n):
    from nodnav.experiments.analysis import MethodRow

    counts = {"success": k, "deadlock": n - k} if k < n else {"success": k}
    return MethodRow(scenario, method, RateCell((scenario, method), counts), (10.0, 1.0, k), (0.05, 0.01, n))


def test_planner_verdict():
    # 60 of 60 against 60 of 60: difference 0 within [-(1 - 60/(60 + z^2)), +...] = [-6.0, +6.0] points.
    d = newcombe_difference(60, 60, 60, 60)
    assert (d.low, d.high) == pytest.approx((-(1 - 60 / (60 + Z2)), 1 - 60 / (60 + Z2)))
    assert "claim that the planner barely matters holds" in planner_verdict(d)
    assert "does matter" in planner_verdict(newcombe_difference(0, 30, 30, 30))
    assert "neither confirm nor refute" in planner_verdict(newcombe_difference(19, 20, 20, 20))


def test_planner_section_side_by_side(tmp_path):
    db = tmp_path / "r.sqlite"
    with ResultStore(db) as store:
        for planner, outcomes in (("fast", ["success", "success"]), ("prm", ["success", "deadlock"])):
            cfg = _config("2r-case1", game_players=1, **{"planner.name": planner})
            for seed, outcome in enumerate(outcomes, start=1):
                _add(store, STUDY_PLANNERS, cfg, seed, outcome, makespan=20.0 if outcome == "success" else None,
                     wall=3.0 if planner == "fast" else 9.0)
    result = build_report(db, tmp_path / "out", heatmap_grid=3, rerun_snapshots=False)
    text = result.path.read_text()
    assert STUDY_PLANNERS not in result.missing
    assert "| 2r-case1 | 1 | 100.0 [34.2, 100.0] (2) | 50.0 [9.5, 90.5] (2) |" in text
    assert "prm vs fast over 1 cells" in text and "neither confirm nor refute" in text
    assert "| prm | 2 | 20.0 | 9.00 ± 0.00 |" in text


def test_rate_bars_validates_shape_and_writes_png(tmp_path):
    rates = np.full((2, 3, 3), np.nan)
    rates[0, 1] = (0.5, 0.2, 0.8)
    path = plot_rate_bars(["x", "y"], ["a", "b", "c"], rates, tmp_path / "bars.png", title="t")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError):
        plot_rate_bars(["x"], ["a"], rates, tmp_path / "bad.png")


def test_report_rebuilt_from_a_database_without_running_trials(tmp_path, monkeypatch):
    import nodnav.sim.simulator as simulator

    def no_trials(*args, **kwargs):
        raise AssertionError("the report must not run trials here")

    monkeypatch.setattr(simulator, "run_trial", no_trials)
    db = tmp_path / "r.sqlite"
    _synthetic_db(db)
    result = build_report(db, tmp_path / "out", command="nodnav report r.sqlite --out out", heatmap_grid=5,
                          rerun_snapshots=False)
    assert result.success, result.reason
    text = result.path.read_text()
    for heading in ("## What was run", "## Success rates (Fig. 3)", "## Table I", "## Table II", "## Fig. 2",
                    "### Fig. 2c", "## Snapshots (Figs. 4 and 5)", "## Methods compared", "## Cost of a trial"):
        assert heading in text
    # Written by nodnav reproduce, with five of its eight parts: the title says which.
    assert text.startswith("# nodnav: the paper's evaluation, in part: the success rates (Fig. 3) and the snapshots "
                           "(Figs. 4 and 5); Table I (initial opinions); Table II (bias); Fig. 2 (strategy selection "
                           "over initial opinions); the navigation methods compared\n")
    assert "- Study `paper-table1` (the paper's evaluation: Table I (initial opinions)): 1 scenario (3r-case2) x 2 " \
           "initial opinion settings (distance, zero) x 8 seeds, 12 trials (every other robot a game player, " \
           "method nod, fast planner)." in text
    # Success rates: 0 of 2 and 1 of 2 with their Wilson intervals (hand values above: [0, 65.8], [9.5, 90.5]).
    assert "| 2r-case1 | 0.0 [0.0, 65.8] (2) | 50.0 [9.5, 90.5] (2) |" in text
    assert "Without game players, 0 of 2 trials succeeded" in text
    # Table I, paper rows beside ours: 3 of 7 realised orders were S6 = 42.9 %; the incomplete trial is counted.
    assert "| 0 (paper) | 10.00 | 21.67 | 10.00 | 18.33 | 6.67 | 33.33 |  |  |" in text
    assert "42.9 [" in text and "| 8 | 1 |" in text
    assert "S3 or S4 (the paper's only choices) took 100.0 [51.0, 100.0] % of ours (paper: 100 %)" in text
    assert "S3 or S5 (the paper's only choices) took 100.0 [51.0, 100.0] %" in text
    # Fig. 2c and the cut reported by the metadata.
    assert "In 2 of 2 cells off the anti-diagonal with a majority" in text
    assert "Cut: the budget ran out" in text
    # The planner study is absent: no section, and the one line says how to add it and the other two.
    assert STUDY_SUCCESS not in result.missing and "planners" in result.missing
    assert "## Does the planner matter?" not in text and text.count("Not in this database") == 1
    parts = "planners,reduction,scaling,mixed-teams"
    assert f"`nodnav reproduce --parts {parts} --planners fast,prm --db {db} --out DIR`" in text
    # Snapshots: no successful 3r-case4 / 4r-case4 trial is stored.
    assert all(not s.success for s in result.snapshots)
    # Methods: 'other' never succeeded; nod 1 of 2.
    assert "| 2r-case1 | other | 2 | 0.0 [0.0, 65.8] |" in text
    assert "nod vs other" in text
    # Every figure exists, is shown in the report, and names the command that produced it.
    assert len(result.figures) == 7
    for fig in result.figures:
        assert fig.exists() and imread(fig).ndim == 3
        assert f"]({fig.name})" in text
    assert text.count("*Produced by `nodnav report r.sqlite --out out`") == len(result.figures)


def test_snapshot_picks_the_lowest_successful_seed(tmp_path):
    db = tmp_path / "r.sqlite"
    with ResultStore(db) as store:
        fig4, fig5 = _config("3r-case4"), _config("4r-case4", game_players=1)
        for seed, outcome in ((1, "deadlock"), (2, "success"), (3, "success")):
            _add(store, STUDY_SUCCESS, fig4, seed, outcome)
        for seed in (4, 5):
            _add(store, STUDY_SUCCESS, fig5, seed, "collision")
    result = build_report(db, tmp_path / "out", heatmap_grid=3, rerun_snapshots=False)
    fig4_snap, fig5_snap = result.snapshots
    assert (fig4_snap.scenario, fig4_snap.seed) == ("3r-case4", 2)
    assert (fig5_snap.scenario, fig5_snap.seed) == ("4r-case4", 4)
    assert "none of the 2 stored trials succeeded" in fig5_snap.reason


def test_report_of_a_missing_database(tmp_path):
    result = build_report(tmp_path / "none.sqlite", tmp_path / "out")
    assert not result.success and "no such results database" in result.reason


# -- what a database holds: title, opening and the paper's sections --------------------------------


def _sweep_db(path, spec=None):
    """A sweep of one's own: two 3-robot scenarios x players 1 and all x seeds 1..3."""
    with ResultStore(path) as store:
        for name in ("3r-case4", "3r-case2"):
            for players in (1, 2):
                cfg = _config(name, game_players=players)
                for seed in (1, 2, 3):
                    _add(store, "mine", cfg, seed, "success" if seed < 3 else "deadlock", makespan=20.0)
        if spec:
            store.save_study("mine", spec)


def test_report_of_ones_own_sweep_says_what_it_holds(tmp_path):
    db = tmp_path / "r.sqlite"
    _sweep_db(db, {"name": "mine", "scenarios": ["3r-case4", "3r-case2"], "players": [1, "all"], "methods": ["nod"],
                   "trials": 3})
    result = build_report(db, tmp_path / "out", heatmap_grid=3, rerun_snapshots=False)
    text = result.path.read_text()
    lines = text.splitlines()
    assert lines[0] == "# nodnav report: sweep `mine`"
    assert "It holds:" in lines[2]
    assert lines[4] == ("- Sweep `mine`: 2 scenarios (3r-case2, 3r-case4) x 2 player settings (1, all) x 3 seeds, "
                        "12 trials (method nod, fast planner).")
    # None of the paper's sections, and one line naming them with the command that adds them.
    assert "reproduced" not in text and "## Success rates" not in text and "## Table I" not in text
    assert "## Snapshots" not in text and "## What was run" not in text and "Fig. 2a" not in text
    assert text.count("Not in this database") == 1
    assert ("`nodnav reproduce --parts success,table1,table2,fig2c,planners,methods,reduction,scaling,mixed-teams "
            f"--planners fast,prm --db {db} --out DIR` adds them") in text
    assert set(result.missing) == {STUDY_SUCCESS, STUDY_TABLE1, STUDY_TABLE2, STUDY_FIG2C, STUDY_PLANNERS,
                                   STUDY_METHODS, "game-reduction-variants", "beyond-scaling", "mixed-teams"}
    assert result.figures == ()
    # What it holds: 8 of 12 succeeded (seed 3 of every cell deadlocked), in the breakdown.
    assert "## What this database holds" in text and "| `3r-case4` | 1 | nod | fast | 66.7 [20.8, 93.9] (3) |" in text
    assert "## Cost of a trial" in text


def test_a_study_cut_short_and_one_stored_without_its_specification(tmp_path):
    db = tmp_path / "r.sqlite"
    _sweep_db(db, {"name": "mine", "scenarios": ["3r-case4", "3r-case2"], "players": [1, "all"], "trials": 5})
    with ResultStore(db) as store:
        for seed in (1, 2):  # a family sweep, no specification stored: described from its trials
            config = trial_config(scenario_to_dict(load_scenario(f"mixed:{seed}")), "closest-first")
            _add(store, "fam", config, seed, "success")
        for seed, s in enumerate([3, 4], start=1):
            _add(store, STUDY_TABLE1, _config("3r-case2", **{"opinion.init": "distance"}), seed, strategy=s)
    result = build_report(db, tmp_path / "out", heatmap_grid=3, rerun_snapshots=False)
    text = result.path.read_text()
    assert text.startswith("# nodnav report: 3 studies (`fam`, `mine`, `paper-table1`)\n")
    assert ("- Sweep `mine`: 2 scenarios (3r-case2, 3r-case4) x 2 player settings (1, all) x 3 of 5 seeds, "
            "12 trials") in text
    assert ("- Sweep `fam`: family `mixed` (2 draws), 2 trials (every other robot a game player, method "
            "closest-first, fast planner).") in text
    assert ("- Study `paper-table1` (the paper's evaluation: Table I (initial opinions)): 1 scenario (3r-case2) x 2 "
            "seeds, 2 trials (every other robot a game player, method nod, fast planner, initial opinions "
            "distance).") in text
    # Table I is there, so is its section; the rest of the paper is one line.
    assert "## Table I: initial opinions (3-Robot Case-2)" in text and "## Table II" not in text
    assert STUDY_TABLE1 not in result.missing
    assert "--parts success,table2,fig2c,planners,methods,reduction,scaling,mixed-teams --planners fast,prm" in text
