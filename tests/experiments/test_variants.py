"""Game-reduction variants: the scenario files they run and the table that compares them."""

from nodnav.experiments.analysis import RateCell
from nodnav.experiments.variants import VARIANTS, reduction_rows, split_name, variant_name, variant_scenario_files
from nodnav.scenario.loading import load_scenario


def test_every_scenario_of_three_or_more_robots_runs_as_every_variant_for_every_reduced_k(tmp_path):
    paths = variant_scenario_files(tmp_path, ("2r-case1", "3r-case2", "4r-case1"))
    # 3 robots: k = 1; 4 robots: k = 1, 2; two robots have no reduced game.
    assert len(paths) == (1 + 2) * len(VARIANTS)
    loaded = [load_scenario(p) for p in paths]
    seen = {(split_name(s.name), s.game_players) for s in loaded}
    assert (("4r-case1", "paper"), 2) in seen and (("3r-case2", "undecided-entered"), 1) in seen
    for s in loaded:
        v = next(v for v in VARIANTS if v.name == split_name(s.name)[1])
        assert s.opinion.conflict == v.overrides["opinion.conflict"]
        assert s.opinion.nonplayers == v.overrides["opinion.nonplayers"]


def test_the_table_puts_variants_side_by_side_and_pools_them():
    cells = [RateCell((variant_name("4r-case2", "paper"), 1), {"success": 1, "deadlock": 3}),
             RateCell((variant_name("4r-case2", "entered"), 1), {"success": 4}),
             RateCell((variant_name("3r-case1", "paper"), 1), {"success": 2}),
             RateCell(("4r-case2", 1), {"success": 9})]  # not a variant: left out
    header, rows, totals = reduction_rows(cells)
    assert header[:3] == ["scenario", "k", "`paper`"]
    assert rows[0][:2] == ["3r-case1", "1"] and rows[1][:2] == ["4r-case2", "1"]
    assert totals == {"paper": (3, 6), "entered": (4, 4)}
    assert rows[-1][0] == "**pooled**"
