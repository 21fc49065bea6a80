"""The corridor as a PettingZoo ``ParallelEnv`` (extra ``nodnav[rl]``); see :mod:`nodnav.envs.corridor`."""

from __future__ import annotations

import functools

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from nodnav.envs.corridor import CorridorCore
from nodnav.envs.rendering import render_frame


class CorridorParallelEnv(ParallelEnv):
    """Agents ``robot_K`` for the controlled robots K (numbered from 1); every other robot runs
    its method. Observations, actions and rewards: :mod:`nodnav.envs.corridor`."""

    metadata = {"name": "nodnav_corridor_v0", "render_modes": ["rgb_array"], "render_fps": 10,
                "is_parallelizable": True}

    def __init__(self, scenario, controlled=(1,), seed: int | None = None, method: str = "nod", neighbours: int = 3,
                 render_mode: str | None = None):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: expected None or 'rgb_array', got {render_mode!r}")
        self.core = CorridorCore(scenario, controlled, method, neighbours)
        self.render_mode = render_mode
        self.possible_agents = [f"robot_{i + 1}" for i in self.core.controlled]
        self.agents: list[str] = []
        self._index = {name: i for name, i in zip(self.possible_agents, self.core.controlled)}
        self._rng = np.random.default_rng(seed)
        self._first_seed = seed

    @functools.lru_cache(maxsize=None)  # noqa: B019 - one space object per agent, as PettingZoo requires
    def observation_space(self, agent: str) -> spaces.Box:
        b = self.core.bound
        return spaces.Box(-b, b, shape=(self.core.observation_size,), dtype=np.float32)

    @functools.lru_cache(maxsize=None)  # noqa: B019
    def action_space(self, agent: str) -> spaces.Box:
        v = float(self.core.scenario.robots[self._index[agent]].max_speed)
        return spaces.Box(-v, v, shape=(2,), dtype=np.float32)

    def _trial_seed(self, seed: int | None) -> int:
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        elif self._first_seed is not None:
            self._rng = np.random.default_rng(self._first_seed)
        self._first_seed = None
        return int(self._rng.integers(0, 2**31 - 1))

    def reset(self, seed: int | None = None, options: dict | None = None):
        """A new trial; its seed comes from ``seed`` (else the constructor's, else the next of the last)."""
        self.core.reset(self._trial_seed(seed))
        self.agents = list(self.possible_agents)
        observations = {a: self.core.observe(self._index[a]) for a in self.agents}
        infos: dict[str, dict] = {a: {} for a in self.agents}
        return observations, infos

    def step(self, actions: dict):
        """One control step: the live agents' velocity commands, everyone else by its method."""
        commands = {self._index[a]: np.asarray(actions[a], dtype=float) for a in self.agents if a in actions}
        active = {self._index[a] for a in self.agents}
        out = self.core.step(commands, active)
        sim = self.core.sim
        assert sim is not None
        names = list(self.agents)
        observations = {a: self.core.observe(self._index[a]) for a in names}
        rewards = {a: out.rewards[self._index[a]] for a in names}
        terminations = {a: out.terminated[self._index[a]] for a in names}
        truncations = {a: out.truncated[self._index[a]] for a in names}
        infos = {a: {"contact": out.contact[self._index[a]], "outcome": sim.outcome, "t": sim.t} for a in names}
        self.agents = [a for a in names if not (terminations[a] or truncations[a])]
        return observations, rewards, terminations, truncations, infos

    def render(self):
        """The current state as an RGB array (``render_mode="rgb_array"``), else nothing."""
        if self.render_mode != "rgb_array" or self.core.sim is None:
            return None
        return render_frame(self.core.sim, self.core.controlled)

    def close(self):
        pass
