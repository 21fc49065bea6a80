"""Opinions over the orders of a robot's game give exactly what opinions over all N_r! orders give.

The reference below is eq. (5)/(8) over every strategy of all robots, as the paper writes it (and
as nodnav computed it before opinions were kept per game): consistency weights A^{jl} over all
N_r! strategies, the estimates of eq. (4) for every strategy from the plan of its projection.
While a robot's game does not change, each order of the game must carry the opinion of every
strategy that projects onto it, and its probability must be theirs together.
"""

import numpy as np
import pytest

from nodnav.decision.estimation import estimate_social_term, estimated_opinions
from nodnav.decision.opinion import opinion_update, social_sum, step_size, strategy_probabilities
from nodnav.decision.strategies import consistency_weights, passing_orders
from nodnav.scenario.loading import load_scenario
from nodnav.sim import agent as agent_module
from nodnav.sim.simulator import Simulation


def _projection_index(orders, game):
    """For every strategy, the index of its projection among the orders of ``game``."""
    local = {tuple(int(k) for k in o): m for m, o in enumerate(agent_module.game_orders(game))}
    return np.array([local[tuple(int(k) for k in o if k in game)] for o in orders])


@pytest.mark.parametrize("name, players, seed", [("3r-case4", None, 1), ("4r-case2", None, 2), ("4r-case2", 1, 1)])
def test_opinions_per_game_equal_opinions_per_strategy_while_the_game_stays(monkeypatch, name, players, seed):
    # The paper's eq. (4) (opinion.estimation: paper), as the reference computes it: what is
    # compared is opinions per game against opinions per strategy, not the estimation's mode.
    scenario = load_scenario(name, {"opinion.estimation": "paper"})
    if players is not None:
        scenario = scenario.with_overrides(game_players=players)
    n = scenario.n_robots
    orders = passing_orders(n)
    reference: dict[int, tuple[tuple, np.ndarray]] = {}  # robot -> (game it has kept, z over all orders)
    compared = []
    original_update = agent_module.NODAgent._update_opinion
    original_decide = agent_module.NODAgent.decide

    def update(self, view):
        planning, players_, game, plans = self.previous
        kept, z_all = reference.get(self.index, (None, None))
        if kept == game:  # the reference over all orders, from the same plans
            of = _projection_index(orders, game)
            social = np.zeros(len(orders))
            if players_:
                columns = [planning.index(k) for k in players_]
                planned = np.stack([self.plans.states_at(plans[of[j]], view.window_times)[columns]
                                    for j in range(len(orders))])
                dt = float(view.window_times[1] - view.window_times[0])
                z_prime = estimated_opinions(view.window_states[list(players_)], planned, dt, self.params.K1)
                r = estimate_social_term(z_prime, np.array([plans[of[j]].success for j in range(len(orders))]))
                weights = consistency_weights(orders, self.index, players_)
                social = social_sum(r, np.ones((1, len(players_))), weights)[0]
            z_all = opinion_update(z_all, social, self.params.u, self.params.d, np.zeros(len(orders)),
                                   step_size(view.t, self.params.alpha_min))
            reference[self.index] = (game, z_all)
        original_update(self, view)
        kept, z_all = reference.get(self.index, (None, None))
        if kept == self.game:
            of = _projection_index(orders, self.game)
            np.testing.assert_allclose(z_all, self.z[of], rtol=1e-9, atol=1e-9)
            x_all = strategy_probabilities(z_all, self.params.eta)
            x_game = np.bincount(of, weights=x_all, minlength=len(self.z))
            np.testing.assert_allclose(x_game, strategy_probabilities(self.z, self.params.eta), atol=1e-12)
            compared.append(self.index)

    def decide(self, view):
        first = not self.game
        decision = original_decide(self, view)
        if first:  # zero initial opinions over all orders, and the game they start in
            reference[self.index] = (self.game, np.zeros(len(orders)))
        elif reference.get(self.index, (None,))[0] != self.game:
            reference[self.index] = (None, None)  # the game changed: from here on the two differ
        return decision

    monkeypatch.setattr(agent_module.NODAgent, "_update_opinion", update)
    monkeypatch.setattr(agent_module.NODAgent, "decide", decide)
    sim = Simulation(scenario.with_overrides(time_limit=12.0), seed=seed)
    while not sim.step():
        pass
    assert len(compared) >= n * 5  # every robot, several decisions
