"""The decision's shortcuts answer as the work they skip would have (sim/agent.py, sim/parked.py).

Each shortcut is checked against the plain computation written out here: packed_crossed against
its loop over every robot without the pruning, eq. (7) with every other robot as a player
against select_game_players, the local orders against local_order, the reductions against
NumPy's mean, max, sum and cumsum bit for bit."""

from pathlib import Path

import numpy as np
import pytest

from nodnav.decision.opinion import relative_opinions, strategy_probabilities
from nodnav.decision.players import conflict_likelihood, select_game_players
from nodnav.scenario.loading import load_scenario
from nodnav.sim.agent_queries import local_order
from nodnav.sim.parked import _packed_round, crossed_and_arriving, packed_crossed

WORLD = load_scenario(Path(__file__).parent / "regression" / "destination-behind-parked-robots.yaml").world
TOL, MARGIN = 0.15, 0.05


def packed_crossed_every_way(positions, destinations, radii, known, planning):
    """packed_crossed as it was before the pruning: the way of every robot of the plan or crossed
    that has not arrived is searched."""
    crossed, arriving = crossed_and_arriving(WORLD, positions, destinations, known, TOL)
    mine = np.zeros(len(positions), dtype=bool)
    mine[planning] = True
    joining = np.zeros(len(positions), dtype=bool)
    for k in np.flatnonzero(arriving & (mine | crossed)):
        packed = _packed_round(WORLD, positions, destinations, radii, crossed, int(k), MARGIN, {})
        if mine[k] or (packed & mine).any():
            joining |= packed
            joining[k] = True
    return np.flatnonzero(joining & ~mine).tolist()


def test_packed_crossed_with_its_pruning_answers_as_the_search_of_every_way():
    rng = np.random.default_rng(5)
    # Points in the right room (x in [4.925, 8.5], y in [-3.281, 6.688]), some in the corridor
    # and the left room, so that robots have crossed, are crossing or have not.
    rooms = [((5.3, 8.1), (-2.9, 6.3)), ((-4.5, 4.5), (-0.2, 0.2)), ((-8.1, -5.3), (-2.9, 6.3))]
    checked = 0
    for _ in range(60):
        n = int(rng.integers(3, 8))
        where = rng.integers(0, 3, n)
        positions = np.array([[rng.uniform(*rooms[w][0]), rng.uniform(*rooms[w][1])] for w in where])
        goal_room = rng.choice([0, 2], n)
        destinations = np.array([[rng.uniform(*rooms[w][0]), rng.uniform(*rooms[w][1])] for w in goal_room])
        parked = rng.random(n) < 0.4  # standing at their destinations
        destinations[parked] = positions[parked]
        radii = np.full(n, 0.351)
        known = rng.random(n) < 0.9
        for _ in range(3):
            planning = sorted(rng.choice(n, int(rng.integers(1, n + 1)), replace=False).tolist())
            expected = packed_crossed_every_way(positions, destinations, radii, known, planning)
            assert packed_crossed(WORLD, positions, destinations, radii, known, planning, TOL, MARGIN) == expected
            checked += bool(expected)
    assert checked  # some draws have robots joining


@pytest.mark.parametrize("n", [2, 3, 4, 6])
def test_every_other_robot_is_the_game_of_k_equal_n_minus_1(n):
    rng = np.random.default_rng(n)
    positions = rng.uniform(-5, 5, (n, 2))
    L = conflict_likelihood(positions, rng.uniform(0, 4, n), 0.5)
    L[0, 1] = np.nan  # a NaN row is ranked by numpy's argsort: all others still
    for i in range(n):
        assert tuple(sorted(select_game_players(L, i, n - 1))) == tuple(j for j in range(n) if j != i)


def test_local_orders_of_robots_all_in_the_plan_renumber_only():
    planning = (1, 3, 4, 6)
    local_of = {k: m for m, k in enumerate(planning)}
    for order in [(3, 1, 6, 4), (6, 4, 3, 1), (1, 3, 4, 6)]:
        assert tuple(local_of[k] for k in order) == local_order(order, planning)


def test_reductions_without_wrappers_are_numpys_bit_for_bit():
    rng = np.random.default_rng(3)
    for shape in [(1,), (7,), (24,), (120,), (5, 24), (3, 9)]:
        z = rng.normal(0, 50, shape)
        assert np.array_equal(relative_opinions(z), z - z.mean(axis=-1, keepdims=True))
        s = z / 0.7
        e = np.exp(s - s.max(axis=-1, keepdims=True))
        assert np.array_equal(strategy_probabilities(z, 0.7), e / e.sum(axis=-1, keepdims=True))


def test_scalar_paths_of_the_opinion_update_are_the_array_paths_bit_for_bit():
    from nodnav.decision.opinion import _per_robot, opinion_update, step_size
    from nodnav.decision.standoff import progress_beyond_best

    rng = np.random.default_rng(4)
    for t in [0.0, 0.5, 3.0, 19.0, 1e6, float("nan")]:
        for h in [0.05, 0.0, 0.5]:
            assert np.array_equal(step_size(t, h), np.maximum(1.0 / (np.asarray(t) + 1.0), h), equal_nan=True)
    z, social, b = rng.normal(0, 40, 24), rng.uniform(0, 30, 24), rng.normal(0, 1, 24)
    for u, d, alpha in [(100.0, 1.0, 0.05), (3.7, 0.3, 0.41), (0.0, 1.9, 1.0)]:
        expected = z - alpha * (_per_robot(d) * (z - _per_robot(u) * social - b))
        assert np.array_equal(opinion_update(z, social, u, d, b, alpha), expected)
    rows = [rng.uniform(0, 9, 6) for _ in range(4)]
    now = rng.uniform(0, 9, 6)
    assert np.array_equal(progress_beyond_best(now, rows), np.vstack(rows).min(axis=0) - now)


def test_a_decision_built_is_the_constructors():
    from nodnav.sim.views import Decision

    z = np.array([0.5, -0.5])
    fields = dict(strategy=1, robots=(2, 0), plan=None, opinions=z, probabilities=z, players=(0,), game=(0, 2),
                  order=(2, 0))
    built, constructed = Decision.built(**fields), Decision(**fields)
    assert type(built) is Decision and built.__dict__ == constructed.__dict__
    assert Decision.built(**{k: v for k, v in fields.items() if k not in ("game", "order")}).game == ()


def test_the_agents_known_robots_are_the_views():
    from nodnav.sim.agent import NODAgent
    from nodnav.sim.plan_cache import PlanCache
    from nodnav.sim.views import RobotView

    scenario = load_scenario("4r-case1")
    agent = NODAgent(scenario, 0, np.random.default_rng(0), PlanCache(None))
    window = np.zeros((4, 3, 4))
    exact = RobotView.built(0.0, np.zeros(3), window, ())
    assert np.array_equal(agent._known(exact), exact.known) and not agent._known(exact).flags.writeable
    ages = RobotView.built(0.0, np.zeros(3), window, (), age=np.array([0.0, np.inf, 1.0, 0.0]))
    assert agent._known(ages).tolist() == [True, False, True, True]


def test_the_sides_key_follows_the_sides_an_agent_is_given():
    from nodnav.sim.agent import NODAgent
    from nodnav.sim.agent_queries import approach_sides
    from nodnav.sim.plan_cache import PlanCache

    scenario = load_scenario("4r-case1")
    agent = NODAgent(scenario, 0, np.random.default_rng(0), PlanCache(None))
    assert agent._sides_key == approach_sides(scenario).tobytes()
    agent.sides = -agent.sides  # as a passage's agent is given its passage's sides
    assert agent._sides_key == (-approach_sides(scenario)).tobytes()
