"""What an agent reads of the last decision's plans for eq. (4) is computed once per round for
every agent that shares the list of plans and the window (sim/agent.py, ``_eq4_of_plans``).

The reference is the same trial with :meth:`PlanCache.once` remembering nothing, so that every
agent works out its own: the opinions, probabilities and strategies of every decision are the
same bit for bit, with every robot a game player (one game, one list of plans) and with one
player each (games and lists of their own)."""

import numpy as np
import pytest

from nodnav import load_scenario
from nodnav.sim.plan_cache import PlanCache
from nodnav.sim.simulator import Simulation


def decisions(scenario, periods: int, seed: int) -> dict[str, list[np.ndarray]]:
    sim = Simulation(scenario, "nod", seed)
    for _ in range(periods * sim.steps_per_decision):
        if sim.step():
            break
    h = sim.history
    return {"opinions": h.opinions, "probabilities": h.probabilities, "strategies": h.strategies}


@pytest.mark.parametrize("players", ["all", 1])
def test_the_round_s_shared_eq4_is_each_agent_s_own(monkeypatch, players):
    scenario = load_scenario("4r-case1").with_overrides(game_players=players)
    shared = decisions(scenario, 5, 2)
    monkeypatch.setattr(PlanCache, "once", lambda self, key, compute, keep=None: compute())
    own = decisions(scenario, 5, 2)
    for name, values in shared.items():
        assert len(values) == len(own[name]) >= 5
        for a, b in zip(values, own[name]):
            assert np.array_equal(a, b, equal_nan=True), name
