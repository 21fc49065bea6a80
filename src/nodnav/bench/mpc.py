"""Timing of the MPC on a standard four-robot situation (``nodnav bench``-style figures).

The situation: the four origins of the built-in scenario ``4r-case1`` (queueing in the left
room), crossing to the right room with the destinations swapped between the inner and the outer
robots, so that the robots that go first park farthest away and no reference passes through a
parked robot. Each robot's reference is the polyline origin -> left entrance approach -> right
entrance approach -> destination at a constant speed, departures staggered so that the robots
reach the corridor one after another; each robot's predictions of the others are their
references (as the paper's MPC uses the other robots' planned paths). Every robot runs its own
:class:`~nodnav.control.mpc.BSplineMPC` in closed loop, applying ``next_position`` and
``next_velocity`` exactly. Nothing is random.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodnav.control.base import ControlRequest
from nodnav.control.mpc import BSplineMPC
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import MPCParams
from nodnav.scenario.world import World


@dataclass(frozen=True)
class MPCBenchmark:
    """Solve-time statistics of the closed-loop benchmark."""

    solves: int
    """Number of controller calls."""
    median: float
    """Median wall time of a controller call (s)."""
    p95: float
    """95th percentile of the wall time of a controller call (s)."""
    max: float
    """Longest controller call (s)."""
    qp_median: float
    """Median time spent inside the QP solver per call (s)."""
    qp_p95: float
    """95th percentile of the time spent inside the QP solver per call (s)."""
    infeasible: int
    """Calls that returned ``success=False`` (the robot evaded or braked)."""
    steps_median: float
    """Median active-set changes of the QP solver per call."""
    min_separation: float
    """Smallest centre distance between two robots, minus the sum of their radii, along the
    motion at ten points a step (m)."""
    min_clearance: float
    """Smallest wall clearance of a robot, minus its radius, along the motion (m)."""
    arrived: int
    """Robots within 0.15 m of their destination at the end."""


def queue_references(world: World, origins: np.ndarray, destinations: np.ndarray, speed: float,
                     headway: float, times: np.ndarray) -> np.ndarray:
    """Reference positions ``(len(times), n, 2)``: each robot on its polyline through the corridor.

    Waypoints: origin, a point 0.5 m before the near entrance, 0.5 m past the far entrance,
    destination. Robots leave in order of their distance to the corridor, timed so that they
    reach the near approach point ``headway`` seconds apart; before leaving they wait at their
    origin and after arriving at their destination.
    """
    left, right = np.asarray(world.entrances, dtype=float)
    approach = np.array([left - [0.5, 0.0], right + [0.5, 0.0]])
    n = len(origins)
    paths = [np.vstack([origins[k], approach, destinations[k]]) for k in range(n)]
    lengths = [np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]) for p in paths]
    to_corridor = np.array([lk[1] for lk in lengths])
    order = np.argsort(to_corridor, kind="stable")
    arrival = to_corridor[order[0]] / speed + headway * np.arange(n)
    start = np.empty(n)
    start[order] = arrival - to_corridor[order] / speed
    out = np.empty((len(times), n, 2))
    for k in range(n):
        s = np.clip((times - start[k]) * speed, 0.0, lengths[k][-1])
        out[:, k, 0] = np.interp(s, lengths[k], paths[k][:, 0])
        out[:, k, 1] = np.interp(s, lengths[k], paths[k][:, 1])
    return out


def benchmark_mpc(duration: float = 25.0, speed: float = 0.8, headway: float = 1.2,
                  params: MPCParams | None = None) -> MPCBenchmark:
    """Run the four-robot closed loop for ``duration`` seconds and time every MPC call
    (``params``: the MPC's settings, by default the scenario's)."""
    scenario = load_scenario("4r-case1")
    world = scenario.world
    mpc = params or scenario.controller
    if not isinstance(mpc, MPCParams):
        raise ValueError(f"the benchmark measures the MPC; 4r-case1 names the controller {mpc.name!r}")
    destinations = scenario.destinations[[2, 3, 0, 1]]
    dt = mpc.dt
    n_h = int(round(mpc.horizon / dt))
    sample_offsets = dt * np.arange(1, n_h + 1)
    steps = int(round(duration / dt))
    grid = dt * np.arange(steps + n_h + 1)
    refs = queue_references(world, scenario.origins, destinations, speed, headway, grid)
    robots = scenario.robots
    n = len(robots)
    ctls = [BSplineMPC(world, r, mpc) for r in robots]
    radii = scenario.radii
    pos = scenario.origins.copy()
    vel = np.zeros_like(pos)
    # Load (or, once per machine, compile) the solver's kernels outside the timing.
    BSplineMPC(world, robots[0], mpc).control(ControlRequest(
        position=pos[0], velocity=vel[0], reference=refs[1:1 + n_h, 0], sample_times=sample_offsets,
        others=np.transpose(refs[1:1 + n_h, 1:], (1, 0, 2)), other_radii=radii[1:]))
    times, qp_times, steps_taken = [], [], []
    infeasible = 0
    min_sep, min_clear = np.inf, np.inf
    fine = np.linspace(0.0, dt, 11)[1:]
    for step in range(steps):
        window = refs[step + 1: step + 1 + n_h]
        new_pos, new_vel = pos.copy(), vel.copy()
        for i in range(n):
            others = [j for j in range(n) if j != i]
            req = ControlRequest(position=pos[i], velocity=vel[i], reference=window[:, i],
                                 sample_times=sample_offsets, others=np.transpose(window[:, others], (1, 0, 2)),
                                 other_radii=radii[others])
            res = ctls[i].control(req)
            times.append(res.solve_time)
            qp_times.append(res.info["qp_time"])
            steps_taken.append(res.info["qp_steps"])
            infeasible += not res.success
            new_pos[i], new_vel[i] = res.next_position, res.next_velocity
        # Separation and clearance along the motion each controller chose, at ten points a step.
        path = np.stack([c.motion(fine) for c in ctls], axis=1)  # (10, n, 2)
        d = np.linalg.norm(path[:, :, None] - path[:, None], axis=-1) - (radii[:, None] + radii[None])
        d[:, np.arange(n), np.arange(n)] = np.inf
        min_sep = min(min_sep, float(d.min()))
        min_clear = min(min_clear, float((world.clearance(path) - radii[None]).min()))
        pos, vel = new_pos, new_vel
    arrived = int(np.sum(np.linalg.norm(pos - destinations, axis=1) < 0.15))
    t = np.array(times)
    o = np.array(qp_times)
    return MPCBenchmark(solves=len(t), median=float(np.median(t)), p95=float(np.percentile(t, 95)),
                        max=float(t.max()), qp_median=float(np.median(o)), qp_p95=float(np.percentile(o, 95)),
                        infeasible=infeasible, steps_median=float(np.median(steps_taken)),
                        min_separation=min_sep, min_clearance=min_clear, arrived=arrived)
