"""NODAgent (Algorithm 1) on its own: its opinion update from a given history, against eqs. (4),
(2), (9), (8) computed by hand.

Two robots, two strategies: S1 = robot 1 first, S2 = robot 2 first. A scripted planner says
that under S1 robot 2 holds still and under S2 it drives towards the corridor at 0.5 m/s. Over
the window [0, 1] s robot 2 is then observed to move exactly as S2 says.
"""

import math

import numpy as np
import pytest

from nodnav.planning.base import JointTrajectory, PlanResult
from nodnav.scenario.loading import load_scenario
from nodnav.sim.agent import NODAgent, RobotView
from nodnav.sim.plan_cache import PlanCache

SPEED = 0.5  # m/s, robot 2 under S2
DT = 0.1     # s, the window's sampling (the scenario's control step)


class ScriptedPlanner:
    """Robot 1 holds still in every plan; robot 2 holds still under order (0, 1) and drives at
    SPEED along -x under order (1, 0); plans start at the request's time and last 3 s."""

    def plan(self, request):
        times = request.t0 + np.arange(0.0, 3.0 + 1e-9, DT)
        positions = np.repeat(request.positions[None], len(times), axis=0)
        if tuple(request.order) == (1, 0):
            positions[:, 1, 0] -= SPEED * (times - request.t0)
        return PlanResult(True, "", 1.0, JointTrajectory.from_positions(times, positions), tuple(request.order),
                          tuple(request.order))


def observed_view(scenario, t, moving):
    """Both robots over [t - 1, t], robot 2 moving along -x at SPEED when ``moving``."""
    times = np.round(np.arange(max(t - 1.0, 0.0), t + 1e-9, DT), 12)
    states = np.zeros((2, len(times), 4))
    states[:, :, :2] = scenario.origins[:, None]
    if moving:
        states[1, :, 0] -= SPEED * (times - times[0])
        states[1, :, 2] = -SPEED
    return RobotView(t=t, window_times=times, window_states=states, entered=())


def test_opinion_update_matches_eqs_4_and_8_by_hand():
    # Eq. (4) as the paper writes it: against the planned states as they are.
    scenario = load_scenario("2r-case1", {"opinion.estimation": "paper"})
    o = scenario.opinion
    assert (o.u, o.d, o.K1, o.T, o.init) == (100.0, 1.0, 5.0, 1.0, "zero")  # the values used below
    agent = NODAgent(scenario, 0, np.random.default_rng(1), PlanCache(ScriptedPlanner()))
    first = agent.decide(observed_view(scenario, 0.0, moving=False))
    assert first.players == (1,) and np.all(first.opinions == 0.0)  # z(0) = 0, nothing observed yet

    second = agent.decide(observed_view(scenario, 1.0, moving=True))
    # Eq. (4a), trapezoidal rule with h = 0.1 over [0, 1] s: under S2 the deviation is 0; under S1
    # the position is off by SPEED tau and the velocity by SPEED, and the trapezoidal rule
    # integrates tau^2 to 1/3 + h^2/6.
    deviation_s1 = SPEED**2 * (1 / 3 + DT**2 / 6) + SPEED**2 * 1.0
    z_prime = np.array([-o.K1 * deviation_s1, 0.0])
    zbar = z_prime - z_prime.mean()                                  # eq. (4b)
    r = (np.tanh(zbar) + 1) / 2                                      # eq. (9)
    social = r          # two robots: strategy j of robot 1 agrees with strategy l of robot 2 iff j = l
    alpha = max(1 / (1.0 + 1), o.alpha_min)                          # alpha(t = 1 s)
    z = 0.0 - alpha * o.d * (0.0 - o.u * social - 0.0)               # eq. (8) from z = 0, no bias
    assert second.opinions == pytest.approx(z, rel=1e-12)
    assert z[1] > z[0]
    # The probabilities of eq. (3) follow: softmax of the opinions.
    x = np.exp(z - z.max()) / np.exp(z - z.max()).sum()
    assert second.probabilities == pytest.approx(x, rel=1e-9)
    assert math.isclose(x[1], 1.0, rel_tol=1e-9)  # 50 x tanh(0.83) apart: robot 1 yields with certainty


def test_robots_seen_in_the_corridor_join_the_plan_only_of_a_robot_with_game_players():
    # Three robots; robot 3 stands in the middle of the corridor and has entered it. With
    # nonplayers: entered it joins robot 1's plan when robot 1 plays with robot 2, and not when
    # robot 1 has no game players: the paper's no-coordination case plans alone.
    scenario = load_scenario("3r-case1")
    states = np.zeros((3, 2, 4))
    states[:, :, :2] = scenario.origins[:, None]
    states[2, :, :2] = [0.0, 0.0]
    view = RobotView(t=1.0, window_times=np.array([0.9, 1.0]), window_states=states, entered=(2,))
    with_player = NODAgent(scenario, 0, np.random.default_rng(1), PlanCache(ScriptedPlanner()), n_players=1)
    alone = NODAgent(scenario, 0, np.random.default_rng(1), PlanCache(ScriptedPlanner()), n_players=0)
    assert with_player.committed(view, (1,)) == (2,)
    assert alone.committed(view, ()) == ()
    static = NODAgent(scenario.with_overrides(**{"opinion.nonplayers": "static"}), 0, np.random.default_rng(1),
                      PlanCache(ScriptedPlanner()), n_players=1)
    assert static.committed(view, (1,)) == ()
