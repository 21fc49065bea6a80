"""The scaling part of ``nodnav reproduce`` and its report section, from a small synthetic
results database (no trial is run); intervals against the Wilson formula by hand."""

import math

import matplotlib

matplotlib.use("Agg")

from nodnav.experiments.scaling import STUDY_SCALING  # noqa: E402
from nodnav.experiments.store import ResultStore, trial_config, trial_key  # noqa: E402
from nodnav.reporting.report import build_report  # noqa: E402
from nodnav.reporting.reproduce import ReproduceOptions, plan_parts  # noqa: E402
from nodnav.scenario.catalogue import PAPER_SCENARIOS, crowd_scenarios  # noqa: E402
from nodnav.scenario.loading import load_scenario  # noqa: E402
from nodnav.scenario.schema import scenario_to_dict  # noqa: E402

Z = 1.959963984540054


def wilson_by_hand(k: int, n: int) -> str:
    """``centre +- half`` with centre (k + z^2/2)/(n + z^2), half z sqrt(k(n-k)/n + z^2/4)/(n + z^2), in %."""
    centre = (k + Z * Z / 2) / (n + Z * Z)
    half = Z * math.sqrt(k * (n - k) / n + Z * Z / 4) / (n + Z * Z)
    high = 1.0 if k == n else centre + half
    return f"{100 * k / n:.1f} [{100 * (centre - half):.1f}, {100 * high:.1f}]"


def test_hand_formula_matches_known_values():
    assert wilson_by_hand(3, 4) == "75.0 [30.1, 95.4]"


def test_reproduce_runs_the_crowds_only_in_the_scaling_part(tmp_path):
    parts = {p.name: p for p in plan_parts(ReproduceOptions(out=tmp_path, trials=3, methods=("nod",)))}
    assert list(parts) == ["success", "table1", "table2", "fig2c", "methods", "reduction", "scaling",
                           "mixed-teams"]
    # The paper's parts and the comparisons stay on the paper's ten scenarios.
    for name in ("success", "methods"):
        assert parts[name].spec.scenarios == PAPER_SCENARIOS
    assert parts["success"].spec.players == (0, 1, 2, 3)
    scaling = parts["scaling"].spec
    assert scaling.name == STUDY_SCALING and scaling.scenarios == crowd_scenarios()
    assert scaling.players == (1, 2, 3) and scaling.planners == ("fast",) and scaling.trials == 3


def _add(store, name, players, seed, outcome, makespan=None, wall=4.0):
    config = trial_config(scenario_to_dict(load_scenario(name).with_overrides(game_players=players)), "nod")
    summary = {"outcome": outcome, "success": outcome == "success", "makespan_s": makespan, "sim_time_s": 20.0,
               "wall_time_s": wall}
    store.add_trial(key=trial_key(config, seed), study=STUDY_SCALING, config=config, seed=seed, outcome=outcome,
                    summary=summary, metrics={}, version="9.9.9")


def test_section_reads_success_and_time_against_robots_and_players(tmp_path):
    db = tmp_path / "r.sqlite"
    with ResultStore(db) as store:
        for seed, makespan in ((1, 20.0), (2, 22.0), (3, 24.0)):
            _add(store, "5r-mixed", 1, seed, "success", makespan)
        _add(store, "5r-mixed", 1, 4, "collision")
        _add(store, "8r-head-on", 2, 1, "success", 30.0, wall=8.0)
        _add(store, "8r-head-on", 2, 2, "success", 30.0, wall=8.0)
        _add(store, "8r-mixed", 2, 1, "deadlock", wall=8.0)
    result = build_report(db, tmp_path / "out", heatmap_grid=3, rerun_snapshots=False)
    text = result.path.read_text()
    assert "## Beyond the paper: 5 to 8 robots" in text and STUDY_SCALING not in result.missing
    # Pooled by robot count: 5 robots at k = 1, 3 of 4; 8 robots at k = 2, 2 of 3 (two scenarios).
    assert f"| 5 | 1 | 4 | {wilson_by_hand(3, 4)} | 1 | 0 | 0 | 22.0 ± 2.0 | 4.0 ± 0.0 | 5.0x |" in text
    assert f"| 8 | 2 | 3 | {wilson_by_hand(2, 3)} | 0 | 1 | 0 | 30.0 ± 0.0 | 8.0 ± 0.0 | 2.5x |" in text
    assert f"| 8r-mixed | 2 | 1 | {wilson_by_hand(0, 1)} |" in text
    assert "`nodnav run 5r-mixed --seed 4 --players 1` (collision)" in text
    assert "k = 1: 3 of 4 trials succeeded" in text and "1 collision(s)" in text
    assert (tmp_path / "out" / "scaling-5-8-robots.png").stat().st_size > 0


def test_section_says_how_to_add_missing_trials(tmp_path):
    db = tmp_path / "r.sqlite"
    with ResultStore(db):
        pass
    result = build_report(db, tmp_path / "out", heatmap_grid=3, rerun_snapshots=False)
    assert STUDY_SCALING in result.missing
    assert "## Beyond the paper" not in result.path.read_text()
    assert "nodnav reproduce --parts success,table1,table2,fig2c,planners,methods,reduction,scaling" in \
        result.path.read_text()

