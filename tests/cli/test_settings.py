"""``--set KEY=VALUE`` and its shorthands: one mechanism, merged before the one validation, errors as typed."""

import json

import pytest
import yaml

import nodnav
from nodnav.cli import main
from nodnav.experiments.study import StudyError, SweepSpec, study_from_dict
from nodnav.experiments.sweep import expand
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.files import builtin_text
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.overrides import key_path, parse_setting, setting_text
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict


def _error(argv, capsys) -> str:
    assert main(argv, execute=False) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nodnav: error: ") and "\n" not in err and "Traceback" not in err
    return err.removeprefix("nodnav: error: ")


def _with_file_keys(name: str, extra: str, tmp_path):
    """The built-in scenario ``name`` with ``extra`` YAML written into its file: the reference."""
    data = yaml.safe_load(builtin_text(name))
    data.update(yaml.safe_load(extra))
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_scenario(path)


def test_values_are_yaml():
    assert parse_setting("sensing.range=3")[:2] == ("sensing.range", 3)
    assert parse_setting("opinion.bias={S3: 150}")[:2] == ("opinion.bias", {"S3": 150})
    assert parse_setting("world.entrances=[[-3, 0], [3, 0]]")[1] == [[-3, 0], [3, 0]]
    assert parse_setting("planner.name=prm")[1] == "prm"
    assert parse_setting("game_players=all")[1] == "all"
    assert key_path("robots[1].max_speed") == ["robots", 1, "max_speed"]
    assert key_path("world.obstacles[0][2]") == ["world", "obstacles", 0, 2]


@pytest.mark.parametrize("key, value", [("robots[1].max_speed", 0.5), ("planner.name", "prm"),
                                        ("opinion.bias", {"S3": 150.0}), ("note", "a: b"), ("x", "  y"),
                                        ("x", "yes"), ("x", "3"), ("x", ""), ("x", [1, [2.5]])])
def test_setting_text_reads_back(key, value):
    assert parse_setting(setting_text(key, value))[:2] == (key, value)


def test_a_set_key_is_the_key_written_in_the_file(tmp_path):
    """The reference is the file with the key written in it, validated as any file."""
    overrides = {"planner.name": "prm", "opinion.u": 50, "sim.observation_noise": 0.01}
    expected = _with_file_keys("3r-case4", "{planner: {name: prm}, opinion: {u: 50}, sim: {observation_noise: 0.01}}",
                               tmp_path)
    got = load_scenario("3r-case4", overrides)
    assert scenario_to_dict(got) == {**scenario_to_dict(expected), "name": got.name}
    assert got.planner.name == "prm" and got.opinion.u == 50 and got.sim.observation_noise == 0.01


def test_robot_entries_and_robot_defaults():
    base = load_scenario("4r-case2")
    s = load_scenario("4r-case2", {"robots[1].max_speed": 0.5})
    assert [r.max_speed for r in s.robots] == [r.max_speed if k != 1 else 0.5 for k, r in enumerate(base.robots)]
    assert s.robots[0] == base.robots[0] and s.robots[2:] == base.robots[2:]
    # robot_defaults set as an override reaches every robot, also a draw's (which give their own values),
    # and a robot's own override still applies on top of it, whatever the order they were given in.
    drawn = load_scenario("mixed:5")
    assert any(r.max_accel != 0.5 for r in drawn.robots)
    s = load_scenario("mixed:5", {"robots[0].max_accel": 1.5, "robot_defaults.max_accel": 0.5})
    assert [r.max_accel for r in s.robots] == [1.5] + [0.5] * (drawn.n_robots - 1)
    assert s.world == drawn.world and s.origins.tolist() == drawn.origins.tolist()


def test_api_takes_overrides():
    s = nodnav.load_scenario("2r-case1", overrides={"game_players": 0, "time_limit": 30})
    assert s.game_players == 0 and s.time_limit == 30
    import numpy as np  # values from code may be NumPy's; they are taken as a file's lists and numbers

    s = nodnav.load_scenario("2r-case1", overrides={"robots[0].origin": np.array([-5.0, 0.5]),
                                                    "robot_defaults.radius": np.float64(0.25)})
    assert s.robots[0].origin == (-5.0, 0.5) and s.radii.tolist() == [0.25, 0.25]


def _eight_robots(tmp_path, players: str | None):
    data = yaml.safe_load(builtin_text("8r-head-on"))
    data.pop("game_players")
    if players is not None:
        data["game_players"] = players
    path = tmp_path / "eight.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def test_options_apply_before_validation(tmp_path, capsys):
    # The file alone is refused (8! orders per robot); --players 2 (or --set) rescues it.
    every = _eight_robots(tmp_path, "all")
    assert "8! = 40320" in _error(["run", every, "--seed", "1"], capsys)
    assert main(["run", every, "--seed", "1", "--players", "2"], execute=False) == 0
    assert main(["run", every, "--seed", "1", "--set", "game_players=2"], execute=False) == 0
    assert load_scenario(every, {"game_players": 2}).n_players == 2


def test_unnamed_game_players_default(tmp_path, capsys):
    # Up to 6 robots every other robot is a game player (the paper's); above, 2 (the crowds').
    assert load_scenario(_eight_robots(tmp_path, None)).game_players == 2
    assert main(["run", _eight_robots(tmp_path, None), "--seed", "1", "--players", "2"], execute=False) == 0
    six = yaml.safe_load(builtin_text("6r-head-on"))
    six.pop("game_players")
    assert scenario_from_dict(six).n_players == 5


@pytest.mark.parametrize("argv, message", [
    (["run", "4r-case2", "--set", "robots[7].radius=0.3"],
     "--set robots[7].radius=0.3: the scenario has 4 robots (robots[0] to robots[3])"),
    (["run", "2r-case1", "--set", "robots[1].radius=abc"], "--set robots[1].radius=abc: expected a number, got 'abc'"),
    (["run", "2r-case1", "--set", "planner.nmae=prm"],
     "--set planner.nmae=prm: unknown key 'nmae'; did you mean 'name'?"),
    (["plan", "2r-case1", "--order", "1,2", "--set", "planner.name=prmm"], "--set planner.name=prmm: unknown planner"),
    (["run", "2r-case1", "--set", "opinion.u"], "--set opinion.u: expected KEY=VALUE"),
    (["run", "2r-case1", "--set", "a..b=1"], "--set a..b=1: 'a..b' is not a scenario key"),
    (["run", "2r-case1", "--set", "opinion.u=[1"], "--set opinion.u=[1: invalid YAML"),
    (["run", "2r-case1", "--set", "time_limit.x=3"], "--set time_limit.x=3: time_limit: expected a number"),
    (["run", "2r-case1", "--set", "world.obstacles[0]=[0, 0, 1, 1]"],
     "--set world.obstacles[0]=[0, 0, 1, 1]: world.obstacles is not written in the scenario"),
    (["run", "2r-case1", "--set", "robot_defaults.radius=9"], "--set robot_defaults.radius=9: must be"),
    (["run", "2r-case1", "--players", "1", "--set", "game_players=0"],
     "--set game_players=0: --players sets game_players too; give it once"),
    (["run", "2r-case1", "--players", "3"], "--players: expected 'all' or a whole number 0..1, got 3"),
    (["show", "all", "--out", "x.png", "--set", "robots[2].radius=0.1"], "(in 2r-case1)"),
    (["show", "mixed", "--out", "x.png", "--set", "robots[5].radius=0.1"], "the scenario has"),
    (["sweep", "--scenario", "2r-case1", "--set", "robots[3].radius=0.1", "--db", "x.sqlite"],
     "--set robots[3].radius=0.1: the scenario has 2 robots"),
    (["sweep", "--scenario", "2r-case1", "--players", "0", "--set", "game_players=1", "--db", "x.sqlite"],
     "--set: game_players is also the study's axis --players; give it in one place"),
])
def test_bad_settings_are_one_line_naming_what_was_typed(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert message in _error(argv, capsys)


def test_same_value_twice_is_no_conflict():
    assert main(["run", "2r-case1", "--players", "1", "--set", "game_players=1", "--u", "50", "--set",
                 "opinion.u=50"], execute=False) == 0


def test_family_draws_with_overrides_are_the_trials_run_redoes():
    """A sweep over a family with set: runs, for draw s, exactly the scenario FAMILY:s --set ... loads,
    and stores the settings as --set takes them."""
    overrides = {"robots[2].max_speed": 0.6, "opinion.u": 50}
    spec = SweepSpec(name="t", scenarios=(), families=("mixed",), trials=6, overrides=overrides)
    expansion = expand(spec)
    seeds = {t.seed for t in expansion.trials}
    short = [s for s in range(1, 7) if load_scenario(f"mixed:{s}").n_robots < 3]
    assert seeds == set(range(1, 7)) - set(short) and short  # 2-robot draws have no robots[2]: left out
    assert any("left out" in n for n in expansion.notes)
    for t in expansion.trials:
        texts = t.config["set"]
        assert texts == ["robots[2].max_speed=0.6", "opinion.u=50"]
        again = dict(parse_setting(text)[:2] for text in texts)
        assert scenario_to_dict(load_scenario(f"mixed:{t.seed}", again)) == scenario_to_dict(t.scenario)
    # The key is that of the scenario: the same trial set another way (a study axis) has the same key.
    by_set = expand(SweepSpec(name="a", scenarios=("3r-case4",), overrides={"planner.name": "prm"}))
    by_axis = expand(SweepSpec(name="b", scenarios=("3r-case4",), planners=("prm",)))
    assert [t.key for t in by_set.trials] == [t.key for t in by_axis.trials]


def test_study_set_key(tmp_path):
    spec = study_from_dict({"scenarios": ["2r-case1"], "set": {"sim.observation_noise": 0.01}})
    assert spec.overrides == {"sim.observation_noise": 0.01}
    assert study_from_dict(spec.to_dict()) == spec
    [trial] = expand(spec).trials
    assert trial.scenario.sim.observation_noise == 0.01
    with pytest.raises(StudyError, match="study: set: expected a mapping"):
        study_from_dict({"scenarios": ["2r-case1"], "set": ["x=1"]})
    with pytest.raises(StudyError, match="is not a scenario key"):
        study_from_dict({"scenarios": ["2r-case1"], "set": {"a b": 1}})
    with pytest.raises(ScenarioError, match="robots\\[4\\].radius: the scenario has 2 robots"):
        expand(study_from_dict({"scenarios": ["2r-case1"], "set": {"robots[4].radius": 0.2}}))


def test_study_file_and_command_line_sets_merge(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.yaml").write_text("scenarios: [2r-case1]\nset: {opinion.u: 50, time_limit: 30}\n")
    from nodnav.experiments.study import load_study

    spec = load_study(tmp_path / "s.yaml", overrides={"set": {"time_limit": 40}})
    assert spec.overrides == {"opinion.u": 50, "time_limit": 40}
    assert main(["sweep", "--study", "s.yaml", "--set", "time_limit=40", "--db", "x.sqlite"], execute=False) == 0


def test_run_with_set_json(capsys):
    assert main(["run", "2r-case1", "--seed", "1", "--set", "time_limit=0.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["outcome"] == "timeout" and out["sim_time_s"] == pytest.approx(0.5)


KEYS = ["game_players", "time_limit", "opinion.u", "opinion.bias", "opinion.init", "opinion.z0", "planner.name",
        "planner", "robots", "robots[0]", "robots[1].radius", "robots[3].origin", "robots[0].opinion.u",
        "robot_defaults.radius", "robot_defaults", "world", "world.obstacles", "world.obstacles[0]",
        "world.entrances[1][0]", "world.corridor.x_min", "sim.observation_noise", "controller.dt", "name",
        "description", "nonsense.key", "time_limit.x", "robots[0][0]", "opinion.bias.S3"]


def _fuzz_strategies():
    from hypothesis import strategies as st

    leaves = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(), st.text(max_size=8),
                       st.sampled_from(["all", "prm", "fast", "zero", "given", "[1, 2]", "{S3: 150}", "1e3"]))
    values = st.recursive(leaves, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                          st.dictionaries(st.text(max_size=6), inner, max_size=3)),
                          max_leaves=8)
    key = st.one_of(st.sampled_from(KEYS), st.text(max_size=12))
    setting = st.one_of(st.tuples(key, values).map(lambda kv: setting_text(kv[0], kv[1]) if isinstance(kv[0], str)
                                                   and kv[0] else f"{kv[0]}={kv[1]}"),
                        st.text(max_size=20))
    return st.lists(setting, min_size=1, max_size=4)


def test_any_setting_answers_in_one_line():
    """Whatever is typed after --set, the command answers 0 or 2 with at most one error line."""
    import contextlib
    import io

    from hypothesis import HealthCheck, given, settings

    @settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(_fuzz_strategies())
    def check(texts):
        argv = ["run", "3r-case4"] + [w for text in texts for w in ("--set", text)]
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(argv, execute=False)
        lines = [line for line in err.getvalue().splitlines() if not line.startswith("nodnav: compiling")]
        assert code in (0, 2), err.getvalue()
        assert len(lines) == (code == 2) and all(line.startswith("nodnav: error: ") for line in lines)

    check()
