"""Scenario loading: the built-ins, and one clear line for every kind of malformed input."""

import math
import textwrap

import numpy as np
import pytest

from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.files import builtin_names
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict
from nodnav.scenario.world import LEFT, RIGHT


def test_builtin_names():
    paper = ["2r-case1", "2r-case2"] + [f"{n}r-case{k}" for n in (3, 4) for k in range(1, 5)]
    crowds = ["5r-mixed", "5r-one-sided", "6r-head-on", "6r-one-sided", "7r-mixed", "8r-head-on", "8r-mixed"]
    assert builtin_names() == sorted(paper + crowds)


@pytest.mark.parametrize("name", builtin_names())
def test_builtin_scenarios_load_and_cross(name):
    s = load_scenario(name)
    assert s.n_robots == int(name[0])
    assert s.description
    # Every built-in robot crosses the corridor: origin and destination on opposite sides.
    sides = s.world.side_of(s.origins), s.world.side_of(s.destinations)
    assert np.all(sides[0] * sides[1] == -1)


def test_traffic_patterns_covered():
    kinds = set()
    for name in builtin_names():
        s = load_scenario(name)
        start = tuple(sorted(s.world.side_of(s.origins).tolist()))
        kinds.add("same" if len(set(start)) == 1 else "opposed")
    assert kinds == {"same", "opposed"}


def test_3r_case2_matches_the_paper_text():
    s = load_scenario("3r-case2")
    side = s.world.side_of(s.origins)
    assert side.tolist() == [LEFT, RIGHT, LEFT]
    d = s.world.corridor_distance(s.origins, side)
    assert d[1] < d[0] and math.isclose(d[0], d[2])


def test_3r_case4_robot3_closest_on_its_side():
    s = load_scenario("3r-case4")
    side = s.world.side_of(s.origins)
    assert side.tolist() == [LEFT, RIGHT, RIGHT]
    d = s.world.corridor_distance(s.origins, side)
    assert d[2] < d[1]


def test_defaults_are_the_papers():
    s = load_scenario("3r-case1")
    o = s.opinion
    assert (o.u, o.d, o.eta, o.K1, o.T, o.alpha_min, o.K2, o.delta) == (100, 1, 1, 5, 1, 0.05, 10, 1)
    prm = s.with_overrides(**{"planner.name": "prm"}).planner
    assert prm.w1 == 0.4 and prm.varsigma == 0.1
    assert s.controller.horizon == 0.8 and s.controller.w2 == 1e-6
    assert s.game_players is None and s.n_players == 2


def test_given_initial_opinions():
    s = load_scenario("2r-case2").with_overrides(**{"opinion.init": "given", "opinion.z0": [[3.0, 0.0], [-2.0, 0.0]]})
    assert s.opinion.z0 == ((3.0, 0.0), (-2.0, 0.0))
    assert scenario_from_dict(scenario_to_dict(s)) == s


def test_per_robot_opinion_parameters():
    raw = scenario_to_dict(load_scenario("2r-case2"))
    raw["robots"][1]["opinion"] = {"u": 7.0, "bias": {"S2": 3.0}}
    s = scenario_from_dict(raw)
    assert s.robot_opinion(0) == s.opinion and s.robot_opinion(1).u == 7.0
    assert s.robot_opinion(1).K1 == s.opinion.K1  # the rest comes from the scenario's opinion
    assert scenario_from_dict(scenario_to_dict(s)) == s
    raw["robots"][1]["opinion"] = {"T": 2.0}
    with pytest.raises(ScenarioError, match=r"robots\[1\].opinion.T: the opinion period is shared"):
        scenario_from_dict(raw)
    raw["robots"][1]["opinion"] = {"bias": {"S9": 1.0}}
    with pytest.raises(ScenarioError, match=r"robots\[1\].opinion.bias: unknown strategy 'S9'"):
        scenario_from_dict(raw)


def test_round_trip():
    s = load_scenario("4r-case4").with_overrides(game_players=1, **{"opinion.bias": {"S3": 150.0}})
    assert scenario_from_dict(scenario_to_dict(s)) == s
    assert s.n_players == 1
    assert s.opinion.bias_vector(24)[2] == 150.0


def _load(tmp_path, text):
    p = tmp_path / "s.yaml"
    p.write_text(textwrap.dedent(text))
    return load_scenario(p)


GOOD = """
name: t
robots:
  - {origin: [-5, 0], destination: [5, 0]}
  - {origin: [5, 0], destination: [-5, 0]}
"""


def test_minimal_file(tmp_path):
    s = _load(tmp_path, GOOD)
    assert s.n_robots == 2 and s.world.entrances == ((-3.0, 0.0), (3.0, 0.0))


@pytest.mark.parametrize("text, message", [
    ("name: t\nrobots: [\n", "invalid YAML at line"),
    ("- 1\n- 2\n", "expected a mapping"),
    (GOOD + "tim_limit: 5\n", "unknown key 'tim_limit'; did you mean 'time_limit'?"),
    (GOOD + "opinion: {uu: 3}\n", "opinion: unknown key 'uu'; did you mean 'u'?"),
    (GOOD + "opinion: {u: fast}\n", "opinion.u: expected a number"),
    (GOOD + "opinion: {init: random}\n", "opinion.init: expected 'zero', 'distance' or 'given'"),
    (GOOD + "opinion: {init: given, z0: [[1, 2]]}\n", "opinion.z0: with init 'given', give 2 rows of 2 numbers"),
    (GOOD + "opinion: {bias: {S7: 1}}\n", "unknown strategy 'S7'"),
    (GOOD + "game_players: 2\n", "game_players: expected 'all' or a whole number 0..1"),
    (GOOD + "planner: {name: prn}\n", "did you mean 'prm'?"),
    (GOOD + "execution: {surprise: 0}\n", "execution.surprise: must be"),
    (GOOD + "baselines: {closest_first_tie: 0}\n", "baselines.closest_first_tie: must be"),
    (GOOD + "baselines: {orca_radius: 1}\n", "baselines: unknown key 'orca_radius'"),
    (GOOD + "world: {bounds: [1, 2, 3]}\n", "world.bounds: expected a list of 4 numbers"),
    ("robots:\n  - {origin: [-5, 0]}\n", "robots[0]: missing 'destination' for robot 1"),
    ("robots:\n  - {origin: [-5, 0], destination: [5, 0], colour: red}\n", "robots[0]: unknown key 'colour'"),
    ("robots:\n  - {origin: [0, 0.3], destination: [5, 0]}\n",
     "robots[0].origin: [0.0, 0.3] puts robot 1 (radius 0.2 m) inside a wall"),
    ("robots:\n  - {origin: [-5, 0], destination: [9, 0]}\n",
     "robots[0].destination: [9.0, 0.0] puts robot 1 outside the world bounds"),
    ("robots:\n  - {origin: [-5, 0], destination: [5, 0]}\n  - {origin: [-5, 0.3], destination: [5, 1]}\n",
     "robots[1].origin: robot 1 and robot 2: origins overlap"),
    ("robots:\n  - {origin: [-5, 0], destination: [5, 0], radius: -1}\n",
     "robots[0].radius: must be from 0.01 to 5, got -1"),
])
def test_malformed_is_one_clear_line(tmp_path, text, message):
    with pytest.raises(ScenarioError) as exc:
        _load(tmp_path, text)
    assert message in str(exc.value)
    assert "\n" not in str(exc.value)


def test_every_behaviour_setting_reads_back_from_the_file(tmp_path):
    # The reaction margin's, the baselines' and PRM*'s settings are scenario keys like the rest.
    s = _load(tmp_path, GOOD + "execution: {surprise: 0.01, surprise_memory: 2.0, reaction_slack: 0.002}\n"
              "baselines: {closest_first_tie: 0.05, orca_time_horizon: 3.0}\n"
              "planner: {name: prm, connect_factor: 4, link_widening: 2}\n")
    assert (s.execution.surprise, s.execution.surprise_memory, s.execution.reaction_slack) == (0.01, 2.0, 0.002)
    assert (s.baselines.closest_first_tie, s.baselines.orca_time_horizon) == (0.05, 3.0)
    assert (s.planner.connect_factor, s.planner.link_widening) == (4, 2)
    assert scenario_from_dict(scenario_to_dict(s)) == s


def test_unknown_builtin_suggests():
    with pytest.raises(ScenarioError, match="did you mean '3r-case2'"):
        load_scenario("3r-cas2")
