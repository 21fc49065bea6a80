"""The planner interface: joint trajectories for a passing order (Sections II-B-1, IV-A-2).

Every planner takes a :class:`PlanRequest` and returns a :class:`PlanResult`; the closed loop,
the CLI and the conformance tests use nothing else. Arrays are indexed by the robots of the
request (0..n-1), which may be a subset of the scenario's robots (a robot and its game players).

Orders that history has ruled out
---------------------------------
A robot that has already entered the corridor cannot be made to pass after one that has not.
The request carries ``entered``: the robots that have entered, in the order they did. A planner
never plans an impossible order; it plans :func:`feasible_order` instead, which keeps the
realised entries at the front and the other robots in the requested relative order, and says so
in the result (``order_planned`` differs from ``order``, ``repaired`` is true). Strategies that
differ only in the part of the order already decided therefore get the same joint path, so the
opinion layer sees them as equally consistent with what it observes: a well-defined signal,
with no missing plans and no infinite deviations.

What history fixes (issue 19, ``planner.inside: back-out``, the fast planner's default): robots
inside heading the same way cannot pass each other, and a robot that has crossed stays crossed;
but of two robots inside heading opposite ways either may still go first, at the price of the
other backing out. So :func:`feasible_order` keeps the requested order between those, and the
planner plans the back-out (docs/meet-inside.md). ``planner.inside: literal`` keeps every entered
robot in entry order, as before.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from nodnav.compiled import compiled
from nodnav.scenario.world import World


@compiled
def interpolate_positions(times: np.ndarray, positions: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Positions ``(len(query), n, 2)`` at the times ``query`` of the joint path sampled at
    ``times`` (strictly increasing) as ``positions`` ``(K, n, 2)``: linear between samples,
    held after the last and, before the first, the first segment's start."""
    out = np.empty((query.shape[0], positions.shape[1], 2))
    k = times.shape[0]
    for q in range(query.shape[0]):
        if k == 1:
            out[q] = positions[0]
            continue
        i = min(max(np.searchsorted(times, query[q], side="right") - 1, 0), k - 2)
        w = min(max((query[q] - times[i]) / (times[i + 1] - times[i]), 0.0), 1.0)
        for m in range(positions.shape[1]):
            for d in range(2):
                start = positions[i, m, d]
                out[q, m, d] = start + w * (positions[i + 1, m, d] - start)
    return out


@dataclass(frozen=True)
class JointTrajectory:
    """A time-parameterised joint path of ``n`` robots sampled every ``dt``.

    Between samples motion is linear (constant velocity); after the last sample every robot
    stays where it is.
    """

    times: np.ndarray
    """Sample times ``(K,)`` (s), strictly increasing, starting at the request's time."""
    positions: np.ndarray
    """Positions ``(K, n, 2)`` (m)."""
    velocities: np.ndarray
    """Velocities ``(K, n, 2)`` (m/s); ``velocities[k]`` is the velocity on ``[t_k, t_{k+1})``."""

    @property
    def n_robots(self) -> int:
        """Number of robots in the trajectory."""
        return self.positions.shape[1]

    @property
    def duration(self) -> float:
        """Time from the first to the last sample (s)."""
        return float(self.times[-1] - self.times[0])

    def positions_at(self, t: np.ndarray | float) -> np.ndarray:
        """Positions at times ``t`` by linear interpolation, shape ``t.shape + (n, 2)``; held after the end."""
        t = np.asarray(t, dtype=float)
        flat = interpolate_positions(self.times, self.positions, t.reshape(-1))
        return flat.reshape(t.shape + self.positions.shape[1:])

    def velocities_at(self, t: np.ndarray | float) -> np.ndarray:
        """Velocities at times ``t``, shape ``t.shape + (n, 2)``; zero after the end."""
        t = np.asarray(t, dtype=float)
        idx = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 1)
        v = self.velocities[idx]
        return np.where((t >= self.times[-1])[..., None, None], 0.0, v)

    def subset(self, robots) -> "JointTrajectory":
        """The trajectory of some of the robots only."""
        robots = list(robots)
        return JointTrajectory(self.times, self.positions[:, robots], self.velocities[:, robots])

    @staticmethod
    def from_positions(times: np.ndarray, positions: np.ndarray) -> "JointTrajectory":
        """Build from positions, with velocities as forward differences (zero on the last sample)."""
        times = np.asarray(times, dtype=float)
        positions = np.asarray(positions, dtype=float)
        vel = np.zeros(positions.shape)
        if len(times) > 1:
            # np.diff's subtractions written out (the same operations, without its wrapper).
            np.subtract(positions[1:], positions[:-1], out=vel[:-1])
            vel[:-1] /= (times[1:] - times[:-1])[:, None, None]
        return JointTrajectory(times, positions, vel)

    @staticmethod
    def hold(t0: float, positions: np.ndarray) -> "JointTrajectory":
        """Every robot standing still at ``positions`` from ``t0`` on."""
        p = np.asarray(positions, dtype=float)[None]
        return JointTrajectory(np.array([float(t0)]), p, np.zeros_like(p))


@dataclass(frozen=True)
class PlanRequest:
    """One planning query: the robots concerned, where they are, where they go, and the order."""

    world: World
    """The environment."""
    positions: np.ndarray
    """Current positions ``(n, 2)`` (m)."""
    velocities: np.ndarray
    """Current velocities ``(n, 2)`` (m/s)."""
    destinations: np.ndarray
    """Destinations ``(n, 2)`` (m)."""
    radii: np.ndarray
    """Radii ``(n,)`` (m)."""
    max_speeds: np.ndarray
    """Speed limits ``(n,)`` (m/s)."""
    order: tuple[int, ...]
    """Requested passing order, a permutation of ``0..n-1``."""
    entered: tuple[int, ...] = ()
    """Robots that have already entered the corridor, in the order they entered."""
    t0: float = 0.0
    """Time of the request (s); the trajectory starts here."""
    max_accels: np.ndarray | None = None
    """Acceleration limits ``(n,)`` (m/s^2); None: unlimited, the paths are timed by speed alone."""


@dataclass(frozen=True)
class PlanResult:
    """What a planner returns: never ``None``; on failure ``success`` is false and ``reason`` says why."""

    success: bool
    """Whether ``trajectory`` reaches every destination respecting ``order_planned``."""
    reason: str
    """Empty on plain success; why it failed, or what was repaired."""
    cost: float
    """Path cost (planner-specific; ``inf`` on failure)."""
    trajectory: JointTrajectory
    """The joint trajectory; on failure every robot holds its position."""
    order: tuple[int, ...]
    """The order that was requested."""
    order_planned: tuple[int, ...]
    """The order actually planned (see :func:`feasible_order`)."""
    compute_time: float = 0.0
    """Wall time spent answering the query (s)."""
    info: dict = field(default_factory=dict)
    """Planner-specific diagnostics; per-robot entries are numbered as the query's robots (after
    :func:`relabel`, ``info["query_robots"][j]`` is the query's number of robot ``j``)."""

    @property
    def repaired(self) -> bool:
        """Whether history ruled the requested order out and a feasible one was planned instead."""
        return self.order_planned != self.order

    @staticmethod
    def failure(request: PlanRequest, reason: str, compute_time: float = 0.0) -> "PlanResult":
        """A failed result: robots hold their positions."""
        return PlanResult(False, reason, float("inf"), JointTrajectory.hold(request.t0, request.positions),
                          tuple(request.order), feasible_order(request.order, request.entered), compute_time)


def relabel(result: PlanResult, robots: list[int]) -> PlanResult:
    """The same plan with its robots listed as ``robots`` (old indices, in the new order).

    The planner's ``info`` is left in the query's numbering (its contents are planner-specific);
    ``info["query_robots"]`` says which query robot each new robot is.
    """
    new_of = {old: new for new, old in enumerate(robots)}
    query = result.info.get("query_robots", tuple(range(result.trajectory.n_robots)))
    # dataclasses.replace's result, without its field-by-field rebuild (no __post_init__): every
    # agent relabels its selected plan every period.
    out = object.__new__(type(result))  # a subclass stays one, as with replace
    out.__dict__.update(result.__dict__, trajectory=result.trajectory.subset(robots),
                        order=tuple(new_of[k] for k in result.order),
                        order_planned=tuple(new_of[k] for k in result.order_planned),
                        info={**result.info, "query_robots": tuple(query[k] for k in robots)})
    return out


@runtime_checkable
class Planner(Protocol):
    """A multi-robot path planner for a given passing order."""

    name: str

    def plan(self, request: PlanRequest) -> PlanResult:
        """Plan a joint trajectory from the request's state to its destinations in its order."""
        ...


def feasible_order(order: tuple[int, ...], entered: tuple[int, ...],
                   directions: np.ndarray | list[int] | None = None) -> tuple[int, ...]:
    """The closest order that history still allows: robots that have entered the corridor first,
    then the others in the requested relative order.

    Without ``directions`` (``planner.inside: literal``, as before issue 19) the entered robots
    keep the order they entered in. With ``directions`` (each robot's
    :func:`crossing_directions`, ``planner.inside: back-out``) history fixes less: entered robots
    heading the same way cannot pass each other inside (single file), so they keep their entry
    order, and a robot that has crossed (direction 0) stays ahead; but of entered robots heading
    opposite ways either may go first, the requested one: the other backs out of the passage
    (with the robots behind it) and waits for it. Each direction keeps the places the requested
    order gives its entered robots, filled in entry order.
    """
    if not len(entered):  # nobody has entered: the requested order itself (what the rest gives)
        return tuple(int(k) for k in order)
    done = tuple(int(k) for k in entered)
    ints = [int(k) for k in order]
    rest = tuple(k for k in ints if k not in done)
    if directions is None:
        return done + rest
    # Python ints: the same comparisons, without NumPy scalars (a list is taken as it is).
    dirs = directions if type(directions) is list else np.asarray(directions).tolist()
    crossed = tuple(k for k in done if dirs[k] == 0)
    # The entered crossing robots in the requested relative order (entered robots the request
    # leaves out keep their entry places at the end), each place refilled from its direction's
    # queue: the i-th of a direction's places gets that direction's i-th robot to enter.
    requested = [k for k in ints if k in done and dirs[k] != 0]
    requested += [k for k in done if dirs[k] != 0 and k not in requested]
    ahead = [k for k in done if dirs[k] == 1]
    behind = [k for k in done if dirs[k] == -1]
    taken = [0, 0]
    inside = []
    for k in requested:
        if dirs[k] == 1:
            inside.append(ahead[taken[0]])
            taken[0] += 1
        else:
            inside.append(behind[taken[1]])
            taken[1] += 1
    return crossed + tuple(inside) + rest


def crossing_directions(world: World, positions: np.ndarray, destinations: np.ndarray) -> np.ndarray:
    """Direction each robot crosses the passage in: +1 from its first mouth's side to its second's
    (the paper's left to right), -1 the other way, 0 none.

    A robot inside the corridor crosses towards its destination's side.
    """
    from nodnav.scenario.world import LEFT, RIGHT

    start = world.side_of(positions)
    goal = world.side_of(destinations)
    d = np.zeros(len(start), dtype=int)
    d[(goal == RIGHT) & (start != RIGHT)] = 1
    d[(goal == LEFT) & (start != LEFT)] = -1
    return d


def corridor_entry_order(world: World, trajectory: JointTrajectory) -> tuple[int, ...]:
    """Robots in the order they first enter the corridor along a trajectory (ties by index).

    A robot that is already inside at the first sample counts as entering at that time.
    """
    inside = world.in_corridor(trajectory.positions)  # (K, n)
    first = np.where(inside.any(axis=0), inside.argmax(axis=0), np.iinfo(int).max)
    entering = [k for k in np.argsort(first, kind="stable") if first[k] != np.iinfo(int).max]
    return tuple(int(k) for k in entering)
