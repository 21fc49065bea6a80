"""A trial as a ROS 2 bag (rosbag2, SQLite storage), written with the ``rosbags`` library (no ROS
install needed), to replay in RViz: ``ros2 bag play DIR``.

Topics, per robot k = 1..N_r, frame ``map`` (the scenario's metres), stamps the simulated time
(the bag starts at 0 s):

- ``/robot_k/pose`` (``geometry_msgs/msg/PoseStamped``): the driven pose at every control step,
  heading along the velocity (kept while the robot stands still; the first heading points at
  the robot's destination).
- ``/robot_k/plan`` (``nav_msgs/msg/Path``): the robot's own plan at every decision, its poses
  stamped with their planned times (only when the trial replays, :mod:`nodnav.export.plans`).
- ``/robot_k/path`` (``nav_msgs/msg/Path``): the path driven so far, at every decision.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from nodnav.export.plans import Plans
from nodnav.sim.history import History

FRAME = "map"
"""frame_id of every message."""
TYPESTORE = "ROS2_HUMBLE"
"""The message definitions written into the bag (rosbags' typestore; Humble's are Jazzy's for these)."""


def _headings(positions: np.ndarray, velocities: np.ndarray, destinations: np.ndarray) -> np.ndarray:
    """Heading (rad) per step and robot: along the velocity, else the last one (first: towards the goal)."""
    steps, n = positions.shape[:2]
    out = np.zeros((steps, n))
    last = np.arctan2(destinations[:, 1] - positions[0, :, 1], destinations[:, 0] - positions[0, :, 0])
    for s in range(steps):
        moving = np.hypot(velocities[s, :, 0], velocities[s, :, 1]) > 1e-6
        last = np.where(moving, np.arctan2(velocities[s, :, 1], velocities[s, :, 0]), last)
        out[s] = last
    return out


def _nanoseconds(t: float) -> int:
    return int(round(t * 1e9))


def write_bag(history: History, plans: Plans | None, out: Path) -> dict[str, int]:
    """Write the bag directory ``out`` (it must not exist); returns the number of messages per topic."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(getattr(Stores, TYPESTORE))
    types = store.types
    Header, Time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    Pose, Point, Quaternion = types["geometry_msgs/msg/Pose"], types["geometry_msgs/msg/Point"], \
        types["geometry_msgs/msg/Quaternion"]
    PoseStamped, Path_ = types["geometry_msgs/msg/PoseStamped"], types["nav_msgs/msg/Path"]

    def header(t: float):
        ns = _nanoseconds(t)
        return Header(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id=FRAME)

    def pose(t: float, x: float, y: float, yaw: float):
        q = Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
        return PoseStamped(header=header(t), pose=Pose(position=Point(x=float(x), y=float(y), z=0.0), orientation=q))

    a = history.arrays()
    times, positions, velocities = a["times"], a["positions"], a["velocities"]
    n = history.scenario.n_robots
    yaw = _headings(positions, velocities, history.scenario.destinations)
    counts: dict[str, int] = {}
    with Writer(out, version=9) as writer:
        def topic(name: str, msgtype: str):
            counts[name] = 0
            return writer.add_connection(name, msgtype, typestore=store)

        def write(conn, name: str, t: float, message, msgtype: str) -> None:
            writer.write(conn, _nanoseconds(t), bytes(store.serialize_cdr(message, msgtype)))
            counts[name] += 1

        for k in range(n):
            name = f"/robot_{k + 1}/pose"
            conn = topic(name, "geometry_msgs/msg/PoseStamped")
            for s, t in enumerate(times):
                message = pose(float(t), positions[s, k, 0], positions[s, k, 1], yaw[s, k])
                write(conn, name, float(t), message, "geometry_msgs/msg/PoseStamped")
        if plans is not None and plans.success:
            conns = {k: topic(f"/robot_{k + 1}/plan", "nav_msgs/msg/Path") for k in range(n)}
            for p in plans.plans:
                steps = np.diff(p.positions, axis=0)
                heading = np.arctan2(steps[:, 1], steps[:, 0]) if len(steps) else np.zeros(0)
                heading = np.append(heading, heading[-1] if len(heading) else 0.0)
                message = Path_(header=header(p.decision_time),
                                poses=[pose(float(t), x, y, h) for t, (x, y), h in zip(p.times, p.positions, heading)])
                write(conns[p.robot], f"/robot_{p.robot + 1}/plan", p.decision_time, message, "nav_msgs/msg/Path")
        conns = {k: topic(f"/robot_{k + 1}/path", "nav_msgs/msg/Path") for k in range(n)}
        for t_d in a["decision_times"]:
            upto = int(np.searchsorted(times, t_d + 1e-9, side="right"))
            for k in range(n):
                message = Path_(header=header(float(t_d)),
                                poses=[pose(float(times[s]), positions[s, k, 0], positions[s, k, 1], yaw[s, k])
                                       for s in range(upto)])
                write(conns[k], f"/robot_{k + 1}/path", float(t_d), message, "nav_msgs/msg/Path")
    return counts
