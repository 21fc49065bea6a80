"""tools/replay_calls.py: a short trial's plan requests and control() calls, recorded and replayed
into new planners and controllers, get the trial's own answers every time; the digest notices one
changed number and not a wall time; bad input is one line and exit code 2."""

import pickle
from dataclasses import replace

import numpy as np
import pytest

from nodnav.control.mpc import BSplineMPC
from nodnav.planning.prioritized import PrioritizedPlanner
from nodnav.scenario.loading import load_scenario
from nodnav.sim.methods import PlannedMethod


@pytest.fixture(scope="module")
def tool(tool_script):
    return tool_script("replay_calls")


@pytest.fixture(scope="module")
def recorded(tool, tmp_path_factory):
    """The plan requests of 2r-case1, seed 1, its first 6 simulated seconds, through a file."""
    scenario = load_scenario("2r-case1").with_overrides(time_limit=6.0)
    path = tmp_path_factory.mktemp("replay") / "plans.pkl"
    plan = PrioritizedPlanner.__dict__["plan"]
    with open(path, "wb") as f:
        pickle.dump(tool.record("planner", scenario, [1]), f)
    assert PrioritizedPlanner.__dict__["plan"] is plan  # restored
    return path


def test_replays_answer_as_the_trial_did(tool, recorded):
    recording = tool.load(str(recorded))
    assert recording["kind"] == "planner" and len(recording["makers"]) == 1 and len(recording["calls"]) > 5
    first, second = tool.timed(recording)[1], tool.timed(recording)[1]
    assert len(first) == len(recording["calls"])
    # Each replay's planner is new (its caches empty), and both give the trial's answers.
    assert tool.digest(first) == tool.digest(second) == recording["digest"]
    assert all(a.trajectory.positions is not b.trajectory.positions for a, b in zip(first, second))


def test_digest_changes_with_one_number_of_one_answer(tool, recorded):
    answers = tool.timed(tool.load(str(recorded)))[1]
    before = tool.digest(answers)
    last = answers[-1].trajectory
    positions = last.positions.copy()
    positions[-1, -1, -1] = np.nextafter(positions[-1, -1, -1], np.inf)  # the last bit of one coordinate
    answers[-1] = replace(answers[-1], trajectory=replace(last, positions=positions))
    assert tool.digest(answers) != before


def test_digest_leaves_out_wall_times(tool, recorded):
    answers = tool.timed(tool.load(str(recorded)))[1]
    before = tool.digest(answers)
    answers[0].__dict__["compute_time"] += 1.0
    assert tool.digest(answers) == before


def test_bad_input_is_one_line_and_exit_code_2(tool, recorded, tmp_path, capsys):
    not_a_recording = tmp_path / "other.pkl"
    not_a_recording.write_bytes(pickle.dumps({"format": "something else"}))
    cases = [["replay", str(tmp_path / "missing.pkl")], ["replay", str(not_a_recording)],
             ["record", "solver", str(tmp_path / "x.pkl"), "2r-case1"],
             ["record", "planner", str(tmp_path / "x.pkl"), "no-such-scenario"],
             ["pair", str(recorded), str(tmp_path), str(tmp_path)]]
    for argv in cases:
        assert tool.main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith("replay_calls: error: ") and err.count("\n") == 1, err


def test_control_replays_answer_as_the_trial_did(tool, tmp_path):
    """The controllers' calls too: each method's controllers rebuilt, sharing their set-ups."""
    path = tmp_path / "control.pkl"
    init, control = PlannedMethod.__dict__["__init__"], BSplineMPC.__dict__["control"]
    with open(path, "wb") as f:
        pickle.dump(tool.record("control", load_scenario("2r-case1").with_overrides(time_limit=3.0), [1]), f)
    assert PlannedMethod.__dict__["__init__"] is init and BSplineMPC.__dict__["control"] is control  # restored
    recording = tool.load(str(path))
    assert recording["kind"] == "control" and len(recording["calls"]) > 20
    assert tool.digest(tool.timed(recording)[1]) == tool.digest(tool.timed(recording)[1]) == recording["digest"]
