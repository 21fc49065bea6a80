"""The corridor as a multi-agent environment, without any RL library: what the PettingZoo and
Gymnasium wrappers (:mod:`nodnav.envs.pettingzoo_env`, :mod:`nodnav.envs.gymnasium_env`) share.

Some robots of a scenario (``controlled``, numbered from 1) take velocity commands from outside;
every other robot runs its method (``robots[i].method``, else the trial's method) in the same
closed loop as ``nodnav run`` (:class:`~nodnav.sim.simulator.Simulation`): decisions every
opinion period, physics and contact checks every control step, the same outcome.

Action of a controlled robot: a velocity command ``(vx, vy)`` (m/s), each component in
``[-max_speed, max_speed]``. The robot gets as close to it as its limits allow over one control
step: the change of velocity is clipped to ``max_accel * dt`` and the speed to ``max_speed``
(both from its :class:`~nodnav.scenario.params.RobotSpec`); it then moves in a straight line.
Nothing keeps it off walls or others: a contact is the policy's.

Observation of a controlled robot (float32, ``6 + 6 K + 6`` numbers, ``K = neighbours``):

========  =====================================================================================
0-5       own state: position x, y (m), velocity vx, vy (m/s), goal minus position dx, dy (m)
6-6K+5    the K nearest other robots as it senses them (with the scenario's observation noise),
          nearest first, each: relative position dx, dy (m), relative velocity dvx, dvy (m/s),
          radius (m), 1 (0 for the padding when there are fewer than K others)
last 6    the passage: left and right entrance minus position (m, 2 x 2), the corridor's half
          width (m), and 1 if the robot is inside the corridor, else 0
========  =====================================================================================

Reward of a controlled robot at each step (documented in docs/mixed-teams.md)::

    r = progress - 0.01 + 10 [arrived this step] - 10 [in contact at the end of the step]

``progress`` is how much its distance to go (along the corridor,
:func:`~nodnav.scenario.world.distance_to_go`) shrank over the step (m). A robot that arrives is
done (it is held still at its destination afterwards); the episode ends for everyone when the
trial ends (``success`` or ``collision``: terminated; ``deadlock`` or ``timeout``: truncated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodnav.control import ControlResult
from nodnav.errors import NodnavError
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import distance_to_go
from nodnav.sim.agent import Decision, RobotView
from nodnav.sim.simulator import Simulation

#: Reward terms (see the module docstring).
STEP_COST = 0.01
ARRIVAL_REWARD = 10.0
CONTACT_PENALTY = 10.0


@dataclass(frozen=True)
class StepOutcome:
    """What one environment step did to each controlled robot (0-based index)."""

    rewards: dict[int, float]
    terminated: dict[int, bool]
    truncated: dict[int, bool]
    contact: dict[int, bool]


def command_step(position: np.ndarray, velocity: np.ndarray, command: np.ndarray, max_speed: float,
                 max_accel: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """A robot's next position and velocity under a velocity ``command``: the change of velocity
    clipped to ``max_accel * dt``, the speed to ``max_speed``, then a straight step of ``dt``."""
    v = np.asarray(velocity, dtype=float)
    change = np.asarray(command, dtype=float) - v
    norm = float(np.hypot(*change))
    if norm > max_accel * dt:
        change *= max_accel * dt / norm
    new = v + change
    speed = float(np.hypot(*new))
    if speed > max_speed:
        new *= max_speed / speed
    return np.asarray(position, dtype=float) + new * dt, new


class Commanded:
    """The trial's method for the robots that are not controlled; stored commands for the rest."""

    def __init__(self, inner, controlled: tuple[int, ...], scenario: Scenario, dt: float):
        self.inner = inner
        self.name = inner.name
        self.controlled = controlled
        self.scenario = scenario
        self.dt = dt
        self.commands = {i: np.zeros(2) for i in controlled}
        self.held: set[int] = set()
        """Controlled robots that arrived: they stay where they are."""

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        return self.inner.decide({i: v for i, v in views.items() if i not in self.controlled})

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        out = self.inner.act(t, {i: v for i, v in views.items() if i not in self.controlled})
        for i in self.controlled:
            view, r = views[i], self.scenario.robots[i]
            command = np.zeros(2) if i in self.held else self.commands[i]
            p, v = command_step(view.positions[i], view.velocities[i], command, r.max_speed, r.max_accel, self.dt)
            out[i] = ControlResult(success=True, reason="", velocity=v, next_position=p, next_velocity=v,
                                   planned_positions=np.repeat(p[None], 1, axis=0))
        return dict(sorted(out.items()))


def resolve_scenario(scenario: str | Scenario) -> Scenario:
    """A scenario given by name, file or ``FAMILY:SEED``, or as a :class:`Scenario` already."""
    return scenario if isinstance(scenario, Scenario) else load_scenario(scenario)


def controlled_indices(scenario: Scenario, controlled) -> tuple[int, ...]:
    """Controlled robots (numbered from 1 by the user) as 0-based indices; one line if invalid."""
    numbers = [controlled] if isinstance(controlled, int) else list(controlled)
    if not numbers or any(isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= scenario.n_robots
                          for k in numbers) or len(set(numbers)) != len(numbers):
        raise NodnavError(f"controlled: expected distinct robot numbers from 1 to {scenario.n_robots}, "
                          f"got {controlled!r}")
    return tuple(sorted(int(k) - 1 for k in numbers))


class CorridorCore:
    """One episode at a time of ``scenario`` with the ``controlled`` robots commanded from outside."""

    def __init__(self, scenario: str | Scenario, controlled, method: str = "nod", neighbours: int = 3):
        self.scenario = resolve_scenario(scenario)
        self.controlled = controlled_indices(self.scenario, controlled)
        self.method = method
        self.neighbours = int(neighbours)
        s = self.scenario
        extent = float(max(s.world.bounds[2] - s.world.bounds[0], s.world.bounds[3] - s.world.bounds[1]))
        self.bound = extent + 2.0 * float(s.max_speeds.max()) + 1.0
        """Every observed number lies in ``[-bound, bound]`` (clipped there)."""
        self.sim: Simulation | None = None
        self.team: Commanded | None = None

    @property
    def observation_size(self) -> int:
        return 6 + 6 * self.neighbours + 6

    def reset(self, seed: int) -> None:
        """Start a new trial with ``seed`` (every robot's decisions and sensing are seeded by it)."""
        self.sim = Simulation(self.scenario, self.method, seed)
        self.team = Commanded(self.sim.method, self.controlled, self.scenario, self.sim.dt)
        self.sim.method = self.team

    def observe(self, i: int) -> np.ndarray:
        """Robot ``i``'s observation (see the module docstring)."""
        assert self.sim is not None
        s, sim = self.scenario, self.sim
        seen = sim.observed[i][-1]
        p, v = sim.positions[i], sim.velocities[i]
        own = np.concatenate([p, v, s.destinations[i] - p])
        others = [k for k in range(s.n_robots) if k != i]
        others.sort(key=lambda k: (float(np.linalg.norm(seen[k, :2] - p)), k))
        rows = np.zeros((self.neighbours, 6))
        for row, k in zip(rows, others[: self.neighbours]):
            row[:] = [*(seen[k, :2] - p), *(seen[k, 2:] - v), s.radii[k], 1.0]
        ent = np.asarray(s.world.entrances, dtype=float) - p[None]
        passage = np.array([*ent[0], *ent[1], s.world.passage.width / 2.0, float(s.world.in_corridor(p[None])[0])])
        obs = np.concatenate([own, rows.ravel(), passage])
        return np.clip(obs, -self.bound, self.bound).astype(np.float32)

    def in_contact(self, i: int) -> bool:
        """Whether robot ``i`` touches another robot or a wall where it is now."""
        assert self.sim is not None
        s, pos = self.scenario, self.sim.positions
        tol = s.sim.collision_tolerance
        gaps = np.linalg.norm(pos - pos[i], axis=1) - (s.radii + s.radii[i])
        gaps[i] = np.inf
        return bool((gaps < -tol).any() or s.world.clearance(pos[i][None])[0] < s.radii[i] - tol)

    def step(self, commands: dict[int, np.ndarray], active: set[int]) -> StepOutcome:
        """Apply ``commands`` (0-based robot to velocity) for one control step; ``active`` are the
        controlled robots still acting (not arrived)."""
        assert self.sim is not None and self.team is not None
        s, sim = self.scenario, self.sim
        for i, command in commands.items():
            self.team.commands[i] = np.asarray(command, dtype=float).reshape(2)
        before = distance_to_go(s.world, sim.positions, s.destinations, sim.sides)
        over = sim.step()
        after = distance_to_go(s.world, sim.positions, s.destinations, sim.sides)
        arrived = np.linalg.norm(sim.positions - s.destinations, axis=1) <= s.sim.goal_tolerance
        rewards, terminated, truncated, contact = {}, {}, {}, {}
        for i in active:
            touching = self.in_contact(i)
            reward = float(before[i] - after[i]) - STEP_COST
            reward += ARRIVAL_REWARD * bool(arrived[i]) - CONTACT_PENALTY * touching
            rewards[i] = reward
            contact[i] = touching
            ended = over and sim.outcome in ("success", "collision")
            terminated[i] = bool(arrived[i]) or ended
            truncated[i] = over and not terminated[i]
            if arrived[i]:
                self.team.held.add(i)
        return StepOutcome(rewards, terminated, truncated, contact)
