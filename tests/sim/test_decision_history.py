"""The history's per-decision record (``Simulation._decide``) against the same record built the
plain way, robot by robot, from the decisions themselves."""

import numpy as np

from nodnav.decision.strategies import strategy_index
from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import Simulation


def test_decision_record_equals_the_plain_construction():
    for name, overrides in (("4r-case2", {}), ("8r-head-on", {"game_players": 2})):
        sim = Simulation(load_scenario(name, overrides), seed=2)
        seen = []
        method_decide = sim.method.decide

        def decide(views, method_decide=method_decide, seen=seen, sim=sim):
            decisions = method_decide(views)
            seen.append((decisions, list(sim.entered_true)))
            return decisions

        sim.method.decide = decide
        for _ in range(45):
            if sim.step():
                break
        n, h = sim.scenario.n_robots, sim.history
        assert len(seen) == len(h.games) >= 4
        for j, (decisions, entered) in enumerate(seen):
            games, players = np.zeros((n, n), dtype=bool), np.zeros((n, n), dtype=bool)
            ranks, strategies = np.full((n, n), -1), np.full(n, -1)
            for i, d in decisions.items():
                games[i, list(d.game)] = True
                players[i, list(d.players)] = True
                ranks[i, list(d.order)] = np.arange(len(d.order))
                if len(d.order) == n:
                    strategies[i] = strategy_index(d.order)
            assert np.array_equal(h.games[j], games) and np.array_equal(h.players[j], players)
            assert np.array_equal(h.ranks[j], ranks) and h.ranks[j].dtype == ranks.dtype
            assert np.array_equal(h.strategies[j], strategies) and h.strategies[j].dtype == strategies.dtype
            assert np.array_equal(h.undecided[j], ~np.isin(np.arange(n), entered))
            assert np.isnan(h.chosen[j]).sum() == sum(d.strategy < 0 or not len(d.probabilities)
                                                      for d in decisions.values())


def test_stacked_records_are_padded_with_nan_only_where_narrower():
    from nodnav.sim.history import _stack_padded

    same = [np.arange(6.0).reshape(3, 2) + d for d in range(4)]
    got = _stack_padded(same, 4, 3)
    assert got.shape == (4, 3, 2) and got.dtype == float and all(np.array_equal(got[d], same[d]) for d in range(4))
    mixed = [np.ones((3, 2)), np.full((3, 6), 2.0), np.zeros((3, 0))]
    got = _stack_padded(mixed, 3, 3)
    assert got.shape == (3, 3, 6)
    assert np.array_equal(got[0, :, :2], mixed[0]) and np.isnan(got[0, :, 2:]).all()
    assert np.array_equal(got[1], mixed[1]) and np.isnan(got[2]).all()
    assert _stack_padded([], 0, 3).shape == (0, 3, 0)
