"""The plan cache's per-round memo of the robots done with the corridor that join a plan, and the
visibility graphs it shares between the agents of a trial (sim/agent.py, issue 23).

The answers are the hand-worked ones of tests/sim/test_parked.py (the same world and robots);
what is checked here is that the memo gives them whoever asks, recomputes when any argument
differs, forgets at the end of a round, and that agents sharing a plan cache share graphs."""

from pathlib import Path

import numpy as np

import nodnav.sim.plan_cache as plan_cache_module
from nodnav import load_scenario
from nodnav.planning.prioritized import PrioritizedPlanner
from nodnav.sim.methods import make_method
from nodnav.sim.plan_cache import PlanCache

WORLD = load_scenario(Path(__file__).parent / "regression" / "destination-behind-parked-robots.yaml").world
R, MARGIN, TOL = 0.351, 0.05, 0.15


def robots():
    """Robot 0 at (6.2, 0.5) going to (6.2, -2.5); robots 1-4 parked at their destinations, 1 on
    its way, 2 packed round it (0.198 m gap), 3 packed round 2, 4 far off; robot 5 has not
    crossed (test_parked.py works the distances out)."""
    positions = np.array([[6.2, 0.5], [6.2, -1.4], [7.1, -1.4], [8.0, -1.4], [7.5, 3.0], [5.3, 0.3]])
    destinations = np.array([[6.2, -2.5], [6.2, -1.4], [7.1, -1.4], [8.0, -1.4], [7.5, 3.0], [-8.0, 2.0]])
    return positions, destinations, np.full(6, R), np.ones(6, dtype=bool)


def counting(monkeypatch):
    calls = []
    original = plan_cache_module.packed_crossed

    def wrapped(*args, **kwargs):
        calls.append(args)
        return original(*args, **kwargs)

    monkeypatch.setattr(plan_cache_module, "packed_crossed", wrapped)
    return calls


def test_the_memo_answers_as_worked_out_by_hand_once_per_round(monkeypatch):
    calls = counting(monkeypatch)
    cache = PlanCache(PrioritizedPlanner(WORLD))
    positions, destinations, radii, known = robots()
    args = (WORLD, positions, destinations, radii, known, [0], TOL, MARGIN)
    assert cache.packed_crossed(*args) == (1, 2, 3)
    # Another agent asking the same (equal arrays, not the same objects) is answered from the memo.
    assert cache.packed_crossed(WORLD, positions.copy(), destinations.copy(), radii.copy(), known.copy(), [0],
                                TOL, MARGIN) == (1, 2, 3)
    assert len(calls) == 1
    # Any argument that differs is asked again: a robot not seen breaks the chain through it.
    unseen = known.copy()
    unseen[2] = False
    assert cache.packed_crossed(WORLD, positions, destinations, radii, unseen, [0], TOL, MARGIN) == (1,)
    assert cache.packed_crossed(WORLD, positions, destinations, radii, known, [3, 4], TOL, MARGIN) == (0, 1, 2)
    assert cache.packed_crossed(WORLD, positions, destinations, radii, known, [4], TOL, MARGIN) == ()
    assert len(calls) == 4
    # The next round starts afresh.
    cache.clear()
    assert cache.packed_crossed(*args) == (1, 2, 3)
    assert len(calls) == 5


def test_a_moved_robot_is_a_new_question():
    cache = PlanCache(PrioritizedPlanner(WORLD))
    positions, destinations, radii, known = robots()
    assert cache.packed_crossed(WORLD, positions, destinations, radii, known, [0], TOL, MARGIN) == (1, 2, 3)
    arrived = positions.copy()
    arrived[0] = [6.3, -2.5]  # 0.1 m from its destination: arrived, nobody joins
    assert cache.packed_crossed(WORLD, arrived, destinations, radii, known, [0], TOL, MARGIN) == ()


def test_the_agents_of_a_trial_share_their_visibility_graphs():
    scenario = load_scenario("4r-case1")
    method = make_method("nod", scenario, [np.random.default_rng(k) for k in range(scenario.n_robots)])
    graphs = {id(a._graphs) for a in method.agents}
    assert graphs == {id(method.plans.graphs)}


def test_the_stacked_states_of_a_round_are_each_plans_states_once():
    from nodnav.planning.base import JointTrajectory, PlanResult

    cache = PlanCache(PrioritizedPlanner(WORLD))
    times = np.array([0.0, 1.0, 2.0])
    # Two plans of two robots moving at constant velocity: at time t robot k of plan g stands at
    # (g + k + t, 0) with velocity (1, 0).
    plans = []
    for g in range(2):
        t = np.array([0.0, 4.0])
        positions = np.array([[[g + k + s, 0.0] for k in range(2)] for s in t])
        plans.append(PlanResult(True, "", 1.0, JointTrajectory.from_positions(t, positions), (0, 1), (0, 1), 0.0))
    stacked = cache.stacked_states(plans, times)
    assert stacked.shape == (2, 2, 3, 4)
    assert np.allclose(stacked[1, 0, :, 0], [1.0, 2.0, 3.0]) and np.allclose(stacked[:, :, :, 2], 1.0)
    for g, plan in enumerate(plans):
        assert np.array_equal(stacked[g], cache.states_at(plan, times))
    assert cache.stacked_states(list(plans), times.copy()) is stacked  # asked again: the same array
    cache.clear()
    assert cache.stacked_states(plans, times) is not stacked


def test_a_callers_state_key_is_the_key_the_cache_builds():
    from nodnav.sim.plan_cache import crossed_state, hashable

    cache = PlanCache(PrioritizedPlanner(WORLD))
    positions, destinations, radii, known = robots()
    state = crossed_state(WORLD, *(hashable(a) for a in (positions, destinations, radii, known)), TOL, MARGIN)
    assert cache.packed_crossed(WORLD, positions, destinations, radii, known, [0], TOL, MARGIN, state) == (1, 2, 3)
    # The cache's own key of the same arguments finds the answer given for the caller's.
    assert cache._crossed and cache.packed_crossed(WORLD, positions, destinations, radii, known, [0], TOL,
                                                   MARGIN) == (1, 2, 3)
    assert len(cache._crossed) == 1 and len(cache._packed) == 1


def test_a_callers_stack_key_is_the_key_the_cache_builds():
    from nodnav.planning.base import JointTrajectory, PlanResult
    from nodnav.sim.plan_cache import stack_key

    cache = PlanCache(PrioritizedPlanner(WORLD))
    times = np.array([0.0, 1.0])
    t = np.array([0.0, 4.0])
    plans = [PlanResult(True, "", 1.0, JointTrajectory.from_positions(t, np.zeros((2, 1, 2))), (0,), (0,), 0.0)]
    stacked = cache.stacked_states(plans, times, stack_key(plans, times))
    assert cache.stacked_states(plans, times) is stacked
