"""Exports of a trial: CSV and Parquet read back by pandas, a ROS 2 bag read back by rosbags, bad input."""

import numpy as np
import pytest

from nodnav.cli import main
from nodnav.errors import NodnavError
from nodnav.export import check_format, export_history
from nodnav.export.plans import replay_plans
from nodnav.scenario.loading import load_scenario
from nodnav.sim.history import History
from nodnav.sim.simulator import run_trial

pd = pytest.importorskip("pandas")  # the extra nodnav[export]; the dev extra installs it


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """A short recorded trial (3 robots, 4 s: several decisions), saved as nodnav run --out does."""
    result = run_trial(load_scenario("3r-case4", {"time_limit": 4}), "nod", 1)
    return result.history.save(tmp_path_factory.mktemp("trial") / "trial.npz")


def _read_csv(path):
    major = int(pd.__version__.split(".")[0])
    return pd.read_csv(path) if major >= 3 else pd.read_csv(path, float_precision="round_trip")


def test_dataframe_rows_and_probabilities(saved):
    h = History.load(saved)
    frame = h.to_dataframe()
    n, steps = h.scenario.n_robots, len(h.times)
    assert len(frame) == n * steps and frame["robot"].tolist() == [1, 2, 3] * steps
    # Selection probabilities are a distribution over the orders of the robot's game.
    p = frame[[c for c in frame.columns if c.startswith("p_")]].to_numpy()
    assert np.allclose(np.nansum(p, axis=1), 1.0)
    # The selected order holds exactly the robots of the game, each once.
    for order, game in zip(frame["order"], frame["game"]):
        assert sorted(order.split(",")) == sorted(game.split(","))


def test_csv_round_trip_gives_the_positions_exactly(saved, tmp_path):
    h = History.load(saved)
    result = export_history(h, "csv", tmp_path / "t.csv")
    assert result.success and "with plans" in result.reason
    frame = _read_csv(tmp_path / "t.csv")
    positions = np.asarray(h.positions)
    assert np.array_equal(frame[["x", "y"]].to_numpy().reshape(positions.shape), positions)
    assert np.array_equal(frame[["vx", "vy"]].to_numpy().reshape(positions.shape), np.asarray(h.velocities))
    assert np.array_equal(frame["time"].to_numpy()[::3], np.asarray(h.times))


def test_parquet_round_trip_and_plans_start_where_the_robot_stands(saved, tmp_path):
    pytest.importorskip("pyarrow")
    h = History.load(saved)
    export_history(h, "parquet", tmp_path / "t.parquet")
    frame = pd.read_parquet(tmp_path / "t.parquet")
    positions = np.asarray(h.positions)
    assert np.array_equal(frame[["x", "y"]].to_numpy().reshape(positions.shape), positions)
    # A plan is made from where the robot stands, or kept from the decision before while every robot
    # is within planner.reuse_tolerance of it: at its decision time it is at most that far from the robot.
    at_decision = frame[np.isclose(frame["time"], frame["decision_time"])]
    assert len(at_decision) == 3 * len(h.decision_times)
    off = np.linalg.norm(at_decision[["plan_x", "plan_y"]].to_numpy() - at_decision[["x", "y"]].to_numpy(), axis=1)
    assert off.max() <= load_scenario("3r-case4").planner.reuse_tolerance + 1e-9
    assert np.sum(off < 1e-9) >= 3  # the first decision plans from where the robots stand


def test_bag_read_back(saved, tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    h = History.load(saved)
    result = export_history(h, "rosbag2", tmp_path / "bag")
    store = get_typestore(Stores.ROS2_HUMBLE)
    steps, decisions = len(h.times), len(h.decision_times)
    with Reader(tmp_path / "bag") as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        types = {c.topic: c.msgtype for c in reader.connections}
        poses = {k: [] for k in range(3)}
        for conn, stamp, raw in reader.messages():
            msg = store.deserialize_cdr(raw, conn.msgtype)
            assert msg.header.frame_id == "map"
            if conn.topic.endswith("/pose"):
                k = int(conn.topic.split("/")[1].removeprefix("robot_")) - 1
                t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
                poses[k].append((stamp, t, msg.pose.position.x, msg.pose.position.y, msg.pose.orientation))
            elif conn.topic.endswith("/plan"):
                assert len(msg.poses) > 1 and msg.poses[0].header.stamp.sec == msg.header.stamp.sec
    assert counts == result.counts
    for k in range(3):
        assert counts[f"/robot_{k + 1}/pose"] == steps
        assert types[f"/robot_{k + 1}/pose"] == "geometry_msgs/msg/PoseStamped"
        assert counts[f"/robot_{k + 1}/plan"] == decisions and types[f"/robot_{k + 1}/plan"] == "nav_msgs/msg/Path"
        assert counts[f"/robot_{k + 1}/path"] == decisions
        stamps, times, xs, ys, quats = zip(*poses[k])
        assert list(stamps) == [round(t * 1e9) for t in h.times]  # the bag's clock is the simulated time
        np.testing.assert_allclose(times, h.times, atol=1e-9)
        assert np.array_equal(np.c_[xs, ys], np.asarray(h.positions)[:, k])
        assert all(abs(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2 - 1.0) < 1e-12 for q in quats)  # unit quaternions


def test_a_history_that_does_not_replay_is_exported_without_plans(saved, tmp_path):
    h = History.load(saved)
    h.positions[5] = h.positions[5] + 1e-6  # not what this code drives any more
    plans = replay_plans(h)
    assert not plans.success and not plans.plans
    result = export_history(h, "csv", tmp_path / "t.csv")
    assert "without plans" in result.reason and "plan_x" not in _read_csv(tmp_path / "t.csv").columns


def test_missing_extra_is_one_line(monkeypatch, saved):
    import sys

    import nodnav.export

    monkeypatch.setattr(nodnav.export, "missing_libraries", lambda fmt: ["rosbags"])
    with pytest.raises(NodnavError, match=r"--format rosbag2: needs rosbags: pip install 'nodnav\[export\]'"):
        check_format("rosbag2")
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(NodnavError, match=r"needs pandas: pip install 'nodnav\[export\]'"):
        History.load(saved).to_dataframe()


def test_command(saved, tmp_path, capsys):
    assert main(["export", str(saved), "--format", "csv", "--out", str(tmp_path / "t.csv"), "--no-plans"]) == 0
    assert "without plans (--no-plans)" in capsys.readouterr().out


@pytest.mark.parametrize("case, message", [
    ("missing", "no such file"),
    ("corrupt", "not a nodnav history file"),
    ("format", "--format: unknown format 'xls'; give one of csv, parquet, rosbag2"),
    ("unwritable", "--out: "),
    ("bag exists", "exists; a bag is written as a new directory"),
    ("out is a directory", "is a directory"),
])
def test_bad_input_is_one_line_and_exit_2(saved, tmp_path, capsys, case, message):
    history, fmt, out = str(saved), "csv", str(tmp_path / "t.csv")
    if case == "missing":
        history = str(tmp_path / "none.npz")
    elif case == "corrupt":
        (tmp_path / "bad.npz").write_bytes(b"PK\x03\x04 not really a zip")
        history = str(tmp_path / "bad.npz")
    elif case == "format":
        fmt = "xls"
    elif case == "unwritable":
        (tmp_path / "file").write_text("")
        out = str(tmp_path / "file" / "t.csv")  # below a file: no directory can be made there
    elif case == "bag exists":
        fmt, out = "rosbag2", str(tmp_path)
    else:
        out = str(tmp_path)
    assert main(["export", history, "--format", fmt, "--out", out], execute=False) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nodnav: error: ") and message in err and "\n" not in err
