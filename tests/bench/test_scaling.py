"""``nodnav bench scaling``: its cells, plan queries per decision counted by hand, and a tiny run
through the command line (fresh worker processes)."""

import json
import math

import pytest

from nodnav.bench.scaling import measure_trial, plan_cells
from nodnav.cli import main
from nodnav.scenario.crowds import door_crowd


def test_cells_leave_out_impossible_games_and_refuse_all_players_above_six_robots():
    cells = {(n, p): (g, refused) for n, p, g, refused in plan_cells(range(2, 9), ("1", "2", "3", "all"))}
    # k game players need k + 1 robots: k = 2 starts at 3 robots, k = 3 at 4.
    assert {n for n, p in cells if p == "2"} == set(range(3, 9))
    assert {n for n, p in cells if p == "3"} == set(range(4, 9))
    # all = N_r - 1 players, a game of N_r robots: N_r! orders, at most 720 (6 robots).
    for n in range(2, 9):
        g, refused = cells[(n, "all")]
        assert g == n and bool(refused) == (math.factorial(n) > 720)
    assert cells[(4, "3")] == cells[(4, "all")] == (4, "")
    assert len(cells) == 7 + 6 + 5 + 7


@pytest.mark.parametrize("n_robots, k", [(2, 1), (3, 1), (3, 2), (4, 1)])
def test_plan_queries_per_decision_by_hand(n_robots, k):
    """Every robot asks for each of the (k+1)! orders of its game every decision, so the robots
    ask N_r (k+1)! plans. A query is the joint problem of the robots it plans (their states, their
    order): robots whose games hold the same robots pose the same (k+1)! queries and share the
    planner's answers, so while nobody is in the corridor (no robot joins a plan besides the game)
    the planner computes exactly (k+1)! plans per distinct game, and always between (k+1)! and
    N_r (k+1)!."""
    scenario = door_crowd(n_robots, k).with_overrides(time_limit=2.0)
    cost = measure_trial(scenario, seed=1, keep_result=True)
    orders = math.factorial(k + 1)
    history = cost.result.history
    assert len(cost.plan_requests) == len(history.decision_times) == 2  # decisions at t = 0 and 1 s
    assert (cost.plan_requests == n_robots * orders).all()
    assert ((orders <= cost.planner_calls) & (cost.planner_calls <= n_robots * orders)).all()
    # At t = 0 everyone is at its origin, outside the corridor.
    games = {tuple(row) for row in history.games[0].tolist()}
    assert all(sum(row) == k + 1 for row in games)
    assert cost.planner_calls[0] == len(games) * orders
    assert (cost.cpu > 0).all() and cost.sim_time == pytest.approx(2.0)


def test_tiny_run_prints_every_cell_and_draws_the_figures(tmp_path, capsys):
    import matplotlib

    matplotlib.use("Agg")
    out = tmp_path / "scaling.png"
    code = main(["bench", "scaling", "--robots", "2..3", "--players", "2,all", "--trials", "1", "--time-limit", "1",
                 "--json", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    report = json.loads(capsys.readouterr().out)
    cells = {(c["n_robots"], c["players"]): c for c in report["cells"]}
    # Two robots cannot have two game players: that cell is left out.
    assert set(cells) == {(2, "all"), (3, "2"), (3, "all")}
    for c in cells.values():
        assert c["decisions"] >= 1 and c["cpu_mean_s"] > 0 and c["realtime_factor"] > 0
        assert c["plan_requests_mean"] == c["n_robots"] * c["orders_per_robot"]
        assert c["orders_per_robot"] <= c["planner_calls_mean"] <= c["plan_requests_mean"]
        assert c["peak_rss_bytes"] >= c["baseline_rss_bytes"] > 0
    # With three robots, two players are all players: measured once (one worker), reported for both.
    assert cells[(3, "2")]["peak_rss_bytes"] == cells[(3, "all")]["peak_rss_bytes"]
    assert cells[(3, "2")]["orders_per_robot"] == 6 and cells[(2, "all")]["orders_per_robot"] == 2
    assert out.stat().st_size > 0
