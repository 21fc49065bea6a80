"""Limited sight: which robots each robot sees, and what it keeps of those it no longer sees.

With the paper's sensing (``sensing.range`` 0, ``sensing.walls_block`` false) every robot sees
every other one and nothing here runs. Otherwise robot ``i`` sees robot ``k`` at a control step
when their centres are within ``sensing.range`` (if set) and, with ``sensing.walls_block``, the
segment between the centres keeps a positive clearance from every wall, obstacle, polygon piece
and map wall (:meth:`~nodnav.scenario.world.World.segment_clearance`). Sight is symmetric.

What a robot keeps of one it no longer sees (docs/sensing.md): the last state it observed, held
still (velocity zero) where it was seen, with its age; forgotten after ``sensing.memory``
seconds. A robot never seen (or forgotten) is unknown: its row in the observer's record holds a
placeholder (its destination, which the paper lets every robot know, at rest; or the state held
when it was forgotten) that nothing reads, because every consumer asks :class:`Sight` or the
view's ages first.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from nodnav.control.braking import tail_decel
from nodnav.geometry import segment_is_clear
from nodnav.scenario.params import MPCParams, SensingParams
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import World

#: Slack (m) kept between two robots that stop as they come into each other's range.
STOP_SLACK = 0.3
#: Time (s) before a robot brakes for one that comes into range: a decision or control step or two.
REACTION_TIME = 0.2


def sight_speeds(scenario: Scenario) -> np.ndarray:
    """Each robot's speed limit under ``sensing.stop_within_sight`` ``(N,)`` (m/s): the speed v
    from which it stops, reacting after ``REACTION_TIME`` t and braking at its ``max_accel`` a,
    within half of the sensor range less the largest two radii and ``STOP_SLACK`` (``d``):
    v t + v^2 / (2 a) = d / 2, v = a (sqrt(t^2 + d / a) - t). Two robots heading at each other that
    come into range both stop in their halves. The scenario's limit where that is lower."""
    sensing = scenario.sensing
    limits = scenario.max_speeds.astype(float).copy()
    if sensing.range <= 0 or not sensing.stop_within_sight:
        return limits
    room = max(sensing.range - 2 * float(scenario.radii.max()) - STOP_SLACK, 0.0)
    a = np.array([r.max_accel for r in scenario.robots])
    t = REACTION_TIME
    return np.maximum(np.minimum(limits, a * (np.sqrt(t * t + room / a) - t)), 1e-3)


def within_sight(scenario: Scenario) -> Scenario:
    """``scenario`` with every robot's ``max_speed`` limited by :func:`sight_speeds` (itself when
    nothing changes, as with the paper's sensing)."""
    speeds = sight_speeds(scenario)
    if np.array_equal(speeds, scenario.max_speeds):
        return scenario
    robots = tuple(dataclasses.replace(r, max_speed=float(v)) for r, v in zip(scenario.robots, speeds))
    return dataclasses.replace(scenario, robots=robots)


def visibility(world: World, positions: np.ndarray, params: SensingParams) -> np.ndarray:
    """Who sees whom ``(N, N)`` boolean (symmetric, true on the diagonal) for robots at
    ``positions`` ``(N, 2)``."""
    n = positions.shape[0]
    seen = np.ones((n, n), dtype=bool)
    i, k = np.triu_indices(n, 1)
    if i.size == 0:
        return seen
    pair = np.ones(i.size, dtype=bool)
    if params.range > 0.0:
        pair &= np.linalg.norm(positions[i] - positions[k], axis=1) <= params.range
    if params.walls_block:
        check = np.flatnonzero(pair)
        if check.size:
            # Clearance above 0, asked as a verdict: a map's world answers it from the walls
            # along the line of sight only (geometry.segment_is_clear, exactly the same).
            pair[check] = segment_is_clear(world, positions[i[check]], positions[k[check]], np.nextafter(0.0, 1.0))
    seen[i, k] = pair
    seen[k, i] = pair
    return seen


class Sight:
    """Every robot's memory of the others under limited sight (one per trial).

    :meth:`update` takes the true positions after a step; :meth:`apply` turns what an observer
    would observe of everyone (noisy, as today) into what it actually has: seen robots as
    observed, remembered ones held still where last seen, unknown ones as placeholders.
    """

    def __init__(self, world: World, params: SensingParams, destinations: np.ndarray):
        self.world = world
        self.params = params
        n = destinations.shape[0]
        self.placeholder = np.concatenate([destinations, np.zeros_like(destinations)], axis=1)
        self.held = np.repeat(self.placeholder[None], n, axis=0)
        """Each observer's last observed state of every robot ``(N, N, 4)``, velocity zeroed."""
        self.last_seen = np.full((n, n), -np.inf)
        """Time each observer last saw each robot (s); -inf if never."""
        self.visible = np.ones((n, n), dtype=bool)

    def update(self, t: float, positions: np.ndarray) -> None:
        """Who sees whom at time ``t`` (s) with the robots at their true ``positions``."""
        self.visible = visibility(self.world, positions, self.params)
        self.last_seen[self.visible] = t

    def apply(self, observer: int, states: np.ndarray) -> np.ndarray:
        """What ``observer`` has of every robot ``(N, 4)``, from what it would observe of
        everyone ``states`` ``(N, 4)``: seen rows as observed, the others held still."""
        seen = self.visible[observer]
        self.held[observer, seen, :2] = states[seen, :2]
        self.held[observer, seen, 2:] = 0.0
        return np.where(seen[:, None], states, self.held[observer])

    def ages(self, observer: int, t: float) -> np.ndarray:
        """Time since ``observer`` last saw each robot ``(N,)`` (s): 0 while seen, inf if never
        seen or forgotten (longer ago than ``sensing.memory``)."""
        age = t - self.last_seen[observer]
        return np.where(age > self.params.memory + 1e-9, np.inf, np.maximum(age, 0.0))


class Tracker:
    """One observer's constant-velocity Kalman filters of every robot (docs/sensing.md).

    Per robot and per axis the state is (p, v); between control steps ``dt`` it moves at
    constant velocity, disturbed by white acceleration of standard deviation ``accel`` (the
    observed robot's acceleration limit: the most it can change its motion), so
    Q = accel^2 [[dt^4/4, dt^3/2], [dt^3/2, dt^2]]. A measurement is the observed (p, v) with
    the sensor's independent noise ``sigma`` on each, R = sigma^2 I; a lost observation
    (dropped, or out of sight) is a prediction only. The first observation initialises the
    state with covariance R. The two axes share the model, so one 2 x 2 covariance per robot
    serves both.
    """

    def __init__(self, dt: float, accel: np.ndarray, sigma: float):
        n = accel.shape[0]
        self.F = np.array([[1.0, dt], [0.0, 1.0]])
        a2 = (np.asarray(accel, dtype=float) ** 2)[:, None, None]
        self.Q = a2 * np.array([[dt ** 4 / 4, dt ** 3 / 2], [dt ** 3 / 2, dt ** 2]])[None]
        self.R = max(sigma, 1e-6) ** 2 * np.eye(2)
        self.mean = np.zeros((n, 4))
        self.cov = np.repeat(self.R[None], n, axis=0)
        self.started = np.zeros(n, dtype=bool)

    def update(self, states: np.ndarray, measured: np.ndarray) -> np.ndarray:
        """Fold one step's observations ``states`` ``(N, 4)`` of the robots ``measured`` ``(N,)``
        into the estimates; return the estimated states ``(N, 4)``."""
        F = self.F
        fresh = measured & ~self.started
        self.mean[fresh] = states[fresh]
        self.started |= fresh
        old = self.started & ~fresh
        # Predict: x = F x per axis; P = F P F' + Q.
        px, py, vx, vy = self.mean[:, 0].copy(), self.mean[:, 1].copy(), self.mean[:, 2], self.mean[:, 3]
        dt = F[0, 1]
        self.mean[old, 0] = px[old] + dt * vx[old]
        self.mean[old, 1] = py[old] + dt * vy[old]
        self.cov[old] = F @ self.cov[old] @ F.T + self.Q[old]
        # Correct where there is a measurement: K = P (P + R)^-1.
        upd = measured & old
        if upd.any():
            P = self.cov[upd]
            K = P @ np.linalg.inv(P + self.R)
            for axis in range(2):
                z = states[upd][:, [axis, 2 + axis]]
                x = self.mean[upd][:, [axis, 2 + axis]]
                x = x + np.einsum("nij,nj->ni", K, z - x)
                rows = np.flatnonzero(upd)
                self.mean[rows, axis] = x[:, 0]
                self.mean[rows, 2 + axis] = x[:, 1]
            self.cov[upd] = (np.eye(2)[None] - K) @ P
        return np.where(self.started[:, None], self.mean, states)

    @property
    def position_sigma(self) -> np.ndarray:
        """Standard deviation of each robot's estimated position along either axis ``(N,)`` (m)."""
        return np.sqrt(self.cov[:, 0, 0])


#: Spacing (m) of the candidate places another robot could stand, for :class:`OcclusionLimit`.
OCCLUSION_CELL = 0.1
#: Least speed limit (m/s) :class:`OcclusionLimit` sets, so that a robot beside a corner still creeps
#: forward and sees round it instead of standing still for ever.
OCCLUSION_CREEP = 0.05


def stopping_speed(room: float, decel: float, reaction: float = REACTION_TIME) -> float:
    """The speed v (m/s) from which a robot, reacting after ``reaction`` t and braking at ``decel``
    a, stops within half of ``room`` d (m): v t + v^2 / (2 a) = d / 2, v = a (sqrt(t^2 + d / a) - t)."""
    d = max(room, 0.0)
    return decel * (math.sqrt(reaction * reaction + d / decel) - reaction)


class OcclusionLimit:
    """Each robot's speed limit under limited sight from the places it cannot see (docs/sensing.md).

    A robot keeps a speed from which it stops within half of ``d``: the distance from its body to
    the body of a robot (the largest other one) standing at the nearest place it cannot see, out
    of range or behind a wall, where the smallest other robot fits. Another robot hidden there
    keeps the same rule, so the two stop within the gap between them. The places are the centres
    of a grid of ``OCCLUSION_CELL``; ``d`` is lowered by the grid's half diagonal. Braking is at the
    braking tail's deceleration (:func:`nodnav.control.braking.tail_decel`), below ``max_accel``.
    """

    def __init__(self, scenario: Scenario):
        self.world = scenario.world
        self.params = scenario.sensing
        self.radii = scenario.radii.astype(float)
        ctrl = scenario.controller
        # The braking tail's deceleration; a controller of another kind brakes as the MPC's defaults assume.
        mpc = ctrl if isinstance(ctrl, MPCParams) else MPCParams()
        self.decel = np.array([tail_decel(r.max_accel, mpc.terminal_decel, mpc.accel_polygon_sides)
                               for r in scenario.robots])
        x0, y0, x1, y1 = (float(v) for v in self.world.bounds)
        h = OCCLUSION_CELL
        xs, ys = np.arange(x0 + h / 2, x1, h), np.arange(y0 + h / 2, y1, h)
        grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        n = scenario.n_robots
        smallest = float(self.radii.min()) if n else 0.0
        self.places = grid[self.world.is_free(grid, smallest)] if n > 1 else np.zeros((0, 2))
        self.slack = h * math.sqrt(0.5)

    def speed(self, i: int, position: np.ndarray, limit: float) -> float:
        """Robot ``i``'s speed limit (m/s) at ``position``, at most ``limit``."""
        if self.places.shape[0] == 0:
            return limit
        others = np.delete(self.radii, i)
        body = float(self.radii[i] + others.max()) + self.slack
        a = float(self.decel[i])
        # Places farther than the room needed to stop from the limit do not lower it.
        reach = 2.0 * (limit * REACTION_TIME + limit * limit / (2.0 * a)) + body
        dist = np.linalg.norm(self.places - position, axis=1)
        near = dist <= reach
        cand, cdist = self.places[near], dist[near]
        unseen = np.zeros(cand.shape[0], dtype=bool)
        if self.params.range > 0.0:
            unseen |= cdist > self.params.range
        if self.params.walls_block:
            check = np.flatnonzero(~unseen)
            if check.size:
                start = np.broadcast_to(position, (check.size, 2))
                unseen[check] = ~segment_is_clear(self.world, start, cand[check], np.nextafter(0.0, 1.0))
        if not unseen.any():
            return limit
        v = stopping_speed(float(cdist[unseen].min()) - body, a)
        return float(min(limit, max(v, OCCLUSION_CREEP)))


def slowed_reference(position: np.ndarray, reference: np.ndarray, times: np.ndarray, speed: float) -> np.ndarray:
    """``reference`` ``(K, 2)`` at ``times`` ``(K,)`` after now, advanced along the same polyline
    from ``position`` no faster than ``speed`` (m/s): the MPC tracks it, so the robot slows down."""
    path = np.vstack([position, reference])
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    want = np.minimum(arc[1:], speed * np.asarray(times))
    if np.all(want >= arc[1:] - 1e-12):
        return reference
    x = np.interp(want, arc, path[:, 0])
    y = np.interp(want, arc, path[:, 1])
    return np.stack([x, y], axis=1)
