"""Every reproducer of issue 14 as a plain regression test: one line naming what the user wrote,
exit code 2, before any long work; and files that stay where they are asked to go."""

from __future__ import annotations

import json
import os
import time

import numpy as np
import pytest

import nodnav.sim.simulator as simulator
from nodnav.cli import main
from nodnav.paths import safe_filename
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.limits import MAX_ROBOTS, MAX_STRATEGIES
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict

GOOD = {"robots": [{"origin": [-5.0, 0.0], "destination": [5.0, 0.0]}, {"origin": [5.0, 0.0], "destination": [-5.0,
                                                                                                              0.0]}]}


def _raw(**top):
    raw = json.loads(json.dumps(GOOD))
    raw.update(top)
    return raw


def _error(raw) -> str:
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(raw)
    text = str(info.value)
    assert "\n" not in text and len(text) < 600
    return text


def _cli(capsys, *argv) -> str:
    code = main(list(argv))
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert err.startswith("nodnav: error: ") and "\n" not in err, err
    return err


@pytest.fixture
def no_trials(monkeypatch):
    """Any trial started fails the test: the checks must come first."""
    def refuse(*args, **kwargs):
        raise AssertionError("a trial ran before the input was checked")
    monkeypatch.setattr(simulator, "run_trial", refuse)


# -- the loader ----------------------------------------------------------------------------------


@pytest.mark.parametrize("raw, key", [
    (_raw(planner={"w1": 10**400}), "planner.w1"),
    (_raw(controller={"dt": 5e-324}), "controller.dt"),
    (_raw(controller={"dt": 0.5, "horizon": 0.2}), "controller.dt"),  # longer than the horizon
    (_raw(controller={"horizon": 1e4}), "controller.horizon"),
    (_raw(robot_defaults={"max_accel": 5e-324}), "robot_defaults.max_accel"),
    (_raw(opinion={"bias": {"S²": 5}}), "opinion.bias"),
    (_raw(opinion={"bias": {"S①": 5}}), "opinion.bias"),
    (_raw(opinion={"bias": {"S" + "9" * 5000: 5}}), "opinion.bias"),
    (_raw(opinion={"u": [[[[[[[[1.0]]]]]]]]}), "opinion.u"),
    (_raw(time_limit=3600, controller={"dt": 0.01}), "time_limit"),  # 360,000 control steps
    (_raw(planner={"roadmap_vertices": 10**9}), "planner.roadmap_vertices"),
    (_raw(sim={"observation_noise": float("nan")}), "sim.observation_noise"),
    (_raw(opinion={"d": 3.0}), "opinion.d"),  # the discrete update (8) diverges
    (_raw(name="a\nb"), "name"),
])
def test_values_that_break_the_controller_or_the_clock_are_refused_at_load(raw, key):
    assert _error(raw).startswith(key + ": ")


def test_nesting_a_thousand_deep_is_one_line():
    value = 1.0
    for _ in range(1000):
        value = [value]
    assert _error(_raw(time_limit=value)).startswith("time_limit: expected a number")
    deep = {"robots": GOOD["robots"]}
    target = deep
    for _ in range(1000):
        target["opinion"] = {}
        target = target["opinion"]
    assert "opinion" in _error(deep)


def test_geometry_that_cannot_work():
    # A robot wider than the corridor: named by where its radius was written.
    assert _error(_raw(robot_defaults={"radius": 0.4})).startswith("robot_defaults.radius: robot 1 (radius 0.4 m) "
                                                                    "does not fit through the corridor")
    raw = _raw()
    raw["robots"][1]["radius"] = 0.36
    assert _error(raw).startswith("robots[1].radius: robot 2")
    # The default radius in a corridor made too narrow: the corridor is to blame.
    assert _error(_raw(world={"corridor_width": 0.3})).startswith("world.corridor_width: robot 1 (radius 0.2 m)")
    world = {"corridor": {"x_min": -3, "x_max": 3, "y_min": 10, "y_max": 11}}
    assert "is not inside world.bounds" in _error(_raw(world=world))
    assert "the same point" in _error(_raw(world={"entrances": [[-3, 0], [-3, 0]]}))
    assert "not on the corridor's right end" in _error(_raw(world={"entrances": [[-3, 0], [2, 0]]}))
    assert "not on the corridor's left end" in _error(_raw(world={"entrances": [[-3, 0.5], [3, 0]]}))


def test_more_robots_than_strategies_allow():
    n = 7
    assert np.prod(np.arange(1, n + 1)) > MAX_STRATEGIES
    robots = [{"origin": [-6.0, -2.0 + 0.6 * k], "destination": [6.0, -2.0 + 0.6 * k]} for k in range(n)]
    # With every other robot a game player each robot would weigh 7! orders; with 2 it weighs 3!.
    assert _error({"robots": robots, "game_players": "all"}).startswith(
        "game_players: all game players make every robot weigh 7! = 5040")
    assert scenario_from_dict({"robots": robots}).game_players == 2  # unnamed: the crowds' default above 6
    assert _error({"robots": robots, "game_players": 6}).startswith("game_players: 6 game players")
    scenario_from_dict({"robots": robots, "game_players": 2})
    many = [{"origin": [-6.0, -2.0 + 0.4 * k], "destination": [6.0, -2.0 + 0.4 * k]} for k in range(MAX_ROBOTS + 1)]
    assert _error({"robots": many, "game_players": 2}).startswith(f"robots: {MAX_ROBOTS + 1} robots; at most")


def _write(tmp_path, name, content: bytes):
    path = tmp_path / name
    path.write_bytes(content)
    return path


@pytest.mark.parametrize("content, message", [
    (b"time_limit: " + b"9" * 400 + b"\nrobots: []\n", "time_limit: expected a number of ordinary size"),
    (b"time_limit: " + b"9" * 5000 + b"\n", "invalid YAML"),
    (b"a: " + b"[" * 500 + b"]" * 500 + b"\n", "invalid YAML"),
    (b"name: \xff\xfe\n", "not UTF-8 text"),
])
def test_files_the_loader_cannot_use(tmp_path, content, message):
    path = _write(tmp_path, "s.yaml", content.replace(b"robots: []",
                                                      b"robots: [{origin: [-5, 0], destination: [5, 0]}]"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_a_directory_given_as_scenario(tmp_path, capsys):
    err = _cli(capsys, "show", str(tmp_path), "--out", str(tmp_path / "x.png"))
    assert "is a directory" in err


def test_a_pipe_is_refused_instead_of_read_forever(tmp_path, capsys):
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    assert "not a regular file" in _cli(capsys, "show", str(fifo), "--out", str(tmp_path / "x.png"))
    assert "not a regular file" in _cli(capsys, "sweep", "--scenario", "2r-case1", "--db", str(fifo))
    assert "not a nodnav history file" in _cli(capsys, "replay", str(fifo), "--out", str(tmp_path / "o"))


def test_a_file_over_the_size_limit(tmp_path):
    path = _write(tmp_path, "big.yaml", b"# " + b"x" * (2 << 20) + b"\n")
    with pytest.raises(ScenarioError, match="may have at most"):
        load_scenario(path)


# -- the command line ----------------------------------------------------------------------------


@pytest.mark.parametrize("argv, start", [
    (["run", "2r-case1", "--seed", "-1"], "nodnav: error: --seed: expected a whole number from 0"),
    (["run", "2r-case1", "--bias", "S²=5"], "nodnav: error: --bias: unknown strategy 'S²'"),
    (["run", "2r-case1", "--players", "5"], "nodnav: error: --players: expected 'all' or a whole number 0..1"),
    (["run", "2r-case1", "--noise", "nan"], "nodnav: error: --noise: expected a finite number"),
    (["run", "2r-case1", "--u", "1e9"], "nodnav: error: --u: must be from 0 to 10000"),
    (["run", "2r-case1", "--method", "nodd"], "nodnav: error: --method: unknown method 'nodd'; did you mean 'nod'?"),
    (["sweep", "--scenario", "2r-case1", "--bias", "S²=5"], "nodnav: error: --bias: unknown strategy 'S²'"),
    (["sweep", "--scenario", "2r-case1", "--players", "²"], "nodnav: error: --players: expected 'all' or a whole"),
    (["sweep", "--scenario", "2r-case1", "--trials", "10" + "0" * 400], "nodnav: error: --trials: expected a whole"),
    (["show", "2r-case1", "--out", "x.xyz"], "nodnav: error: --out: cannot write .xyz pictures"),
    (["roadmaps", "build", "--robots", "foo"], "nodnav: error: --robots: expected robot counts"),
    (["roadmaps", "build", "--robots", "-1"], "nodnav: error: --robots: expected robot counts"),
    (["roadmaps", "build", "--jobs", "0"], "nodnav: error: --jobs: expected a whole number from 1"),
    (["heatmap", "--u", "nan", "--grid", "3"], "nodnav: error: --u: expected a number from -1000 to 1000"),
    (["heatmap", "--u", "inf", "--grid", "3"], "nodnav: error: --u: expected a number from -1000 to 1000"),
    (["report", "missing.sqlite", "--out", "r"], "nodnav: error: missing.sqlite: no such results database"),
    (["reproduce", "--parts", "bogus"], "nodnav: error: --parts: unknown part 'bogus'"),
    (["nope"], "nodnav: error: COMMAND: invalid choice: 'nope'"),
])
def test_command_line_mistakes_are_one_line_and_exit_2(tmp_path, monkeypatch, capsys, no_trials, argv, start):
    monkeypatch.chdir(tmp_path)
    started = time.perf_counter()
    assert _cli(capsys, *argv).startswith(start)
    assert time.perf_counter() - started < 30  # no hang (heatmap --u nan used to run forever)


def test_run_out_is_checked_before_the_trial(tmp_path, capsys, no_trials):
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert "exists and is not a directory" in _cli(capsys, "run", "2r-case1", "--out", str(afile))
    assert "cannot create the directory" in _cli(capsys, "run", "2r-case1", "--out", str(afile / "sub"))


def test_show_out_names_a_directory(tmp_path, capsys):
    (tmp_path / "adir").mkdir()
    assert "is a directory; give a file name" in _cli(capsys, "show", "2r-case1", "--out", str(tmp_path / "adir"))


def test_show_without_suffix_says_what_it_wrote(tmp_path, capsys):
    assert main(["show", "2r-case1", "--out", str(tmp_path / "picture")]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {tmp_path / 'picture.png'}"
    assert (tmp_path / "picture.png").is_file()


def test_damaged_database_is_one_line(tmp_path, capsys):
    from nodnav.experiments.store import ResultStore

    db = tmp_path / "r.sqlite"
    with ResultStore(db) as store:
        store.save_study("s", {"x": "y" * 20000})
    data = bytearray(db.read_bytes())
    for k in range(1024, len(data), 97):  # flip bytes all through the file, header kept
        data[k] ^= 0xFF
    db.write_bytes(bytes(data))
    (tmp_path / "r.sqlite-wal").unlink(missing_ok=True)
    err = _cli(capsys, "sweep", "--scenario", "2r-case1", "--db", str(db))
    assert str(db) in err and ("damaged" in err or "not a usable results database" in err)


def test_replay_of_a_text_file_gives_no_numpy_advice(tmp_path, capsys):
    text = tmp_path / "notes.npz"
    text.write_text("hello\n")
    err = _cli(capsys, "replay", str(text), "--out", str(tmp_path / "o"))
    assert "not a nodnav history file" in err and "pickle" not in err


def test_cached_roadmap_with_nan_vertices_is_rebuilt_not_trusted(tmp_path):
    from nodnav.planning.roadmap import Roadmap, make_key
    from nodnav.planning.roadmap_cache import load_roadmap, save_roadmap
    from nodnav.scenario.world import paper_world

    key = make_key(paper_world(), [0.2], (1,), 0.05, 0.1, 10)
    vertices = np.array([[np.nan, 0.0], [1.0, 0.0]])
    roadmap = Roadmap(key, vertices, np.zeros((0, 2), dtype=np.int32), np.zeros(2), 0, 0.0)
    path = save_roadmap(roadmap, tmp_path)  # a valid checksum over NaN vertices
    loaded = load_roadmap(path, key)
    assert not loaded.success and "inconsistent" in loaded.reason


def test_stale_temporary_roadmap_files_are_removed(tmp_path):
    from nodnav.planning.roadmap_cache import STALE_TEMPORARY_AGE, clean_stale_temporaries

    old, fresh = tmp_path / ".tmp-old.npz", tmp_path / ".tmp-fresh.npz"
    old.write_bytes(b"partial")
    fresh.write_bytes(b"being written")
    past = time.time() - STALE_TEMPORARY_AGE - 60
    os.utime(old, (past, past))
    assert clean_stale_temporaries(tmp_path) == [old]
    assert not old.exists() and fresh.exists()


# -- files stay where they are asked to go ---------------------------------------------------------


def test_safe_filename():
    assert safe_filename("../escaped") == "_escaped"
    assert safe_filename("/etc/passwd") == "_etc_passwd"
    assert safe_filename("3r-case4") == "3r-case4"
    assert safe_filename("...") == "scenario"


def test_a_scenario_named_to_escape_writes_inside_out(tmp_path, capsys):
    raw = scenario_to_dict(load_scenario("2r-case1"))
    raw.update(name="../escaped", time_limit=0.5)
    path = tmp_path / "s.yaml"
    path.write_text(json.dumps(raw))
    out = tmp_path / "deep" / "out"
    assert main(["run", str(path), "--out", str(out)]) == 0
    written = {p.name for p in out.iterdir()}
    assert "_escaped-nod-seed1.npz" in written and "_escaped-nod-seed1-snapshots.png" in written
    assert not list((tmp_path / "deep").glob("escaped*"))
    assert capsys.readouterr().out.count("wrote") >= 3


# -- help, words and the README --------------------------------------------------------------------


def test_reproduce_help_shows_parts_and_defaults(capsys):
    assert main(["reproduce", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "--parts" in out and "default DIR/results.sqlite" in out and "(default 40)" in out
    assert main(["sweep", "--help"]) == 0
    assert "default nodnav-results.sqlite" in " ".join(capsys.readouterr().out.split())


def test_summaries_in_plain_words(capsys):
    from nodnav.cli.terminal import trial_summary_lines
    from nodnav.scenario.loading import load_scenario as load
    from nodnav.sim.simulator import run_trial

    scenario = load("2r-case1").with_overrides(game_players=1)
    text = "\n".join(trial_summary_lines(run_trial(scenario, "nod", 1), scenario, "nod", 1))
    assert "1 game player per robot" in text and "MPC infeasible" not in text
    if "strategy" in text:  # the order is spelled out beside the strategy's name
        assert "strategy S1 (1,2)" in text or "strategy S2 (2,1)" in text
    pytest.importorskip("pyrvo")
    text = "\n".join(trial_summary_lines(run_trial(scenario, "orca", 1), scenario, "orca", 1))
    assert "strategy" not in text and "agree" not in text


def test_opinion_panel_names_every_order_a_flipping_robot_used():
    from nodnav.sim.history import History
    from nodnav.viz.scenario import new_figure
    from nodnav.viz.trial import draw_opinion_panel

    scenario = load_scenario("2r-case1")
    h = History(scenario, "nod", 1)
    h.times = [0.0, 1.0, 2.0, 3.0, 4.0]
    h.positions = [scenario.origins] * 5
    h.velocities = [np.zeros((2, 2))] * 5
    h.decision_times = [0.0, 1.0, 2.0, 3.0]
    half = np.array([[0.5, 0.5], [0.9, 0.1]])
    h.opinions, h.probabilities = [half] * 4, [half] * 4
    h.strategies = [np.array([0, 0]), np.array([1, 0]), np.array([0, 0]), np.array([1, 0])]  # robot 1 flips
    first, second = np.array([0, 1]), np.array([1, 0])  # ranks of orders (1,2) and (2,1)
    h.ranks = [np.stack(r) for r in ([first, first], [second, first], [first, first], [second, first])]
    h.chosen = [np.array([0.5, 0.9])] * 4
    h.players = [np.ones((2, 2), dtype=bool)] * 4
    h.undecided = [np.ones(2, dtype=bool)] * 4
    fig = new_figure(8, 3)
    ax = fig.add_subplot(1, 1, 1)
    draw_opinion_panel(ax, h, h.arrays(), np.array([2.0]))
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["order S1 (1,2)", "order S2 (2,1)"]
    beside = [t.get_text() for t in ax.texts]
    assert any("S1 (1,2) 50 %" in t and "S2 (2,1) 50 %" in t for t in beside)
    assert [t.get_text() for t in ax.get_yticklabels()] == ["robot 2", "robot 1"]


def test_docs_are_not_both_committed_and_ignored():
    import shutil
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    if not shutil.which("git") or not (root / ".git").exists():
        pytest.skip("not a git checkout")
    out = subprocess.run(["git", "ls-files", "-ci", "--exclude-standard"], cwd=root, capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == ""
