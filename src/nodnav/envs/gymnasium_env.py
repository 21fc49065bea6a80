"""One controlled robot as a Gymnasium ``Env`` (extra ``nodnav[rl]``); see :mod:`nodnav.envs.corridor`."""

from __future__ import annotations

import gymnasium
import numpy as np
from gymnasium import spaces

from nodnav.envs.corridor import CorridorCore
from nodnav.envs.rendering import render_frame


class CorridorEnv(gymnasium.Env):
    """Robot ``controlled`` (numbered from 1) takes velocity commands; every other robot runs its
    method. Observations, actions and rewards: :mod:`nodnav.envs.corridor`."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, scenario, controlled: int = 1, seed: int | None = None, method: str = "nod",
                 neighbours: int = 3, render_mode: str | None = None):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: expected None or 'rgb_array', got {render_mode!r}")
        self.core = CorridorCore(scenario, [controlled], method, neighbours)
        self.index = self.core.controlled[0]
        self.render_mode = render_mode
        b = self.core.bound
        self.observation_space = spaces.Box(-b, b, shape=(self.core.observation_size,), dtype=np.float32)
        v = float(self.core.scenario.robots[self.index].max_speed)
        self.action_space = spaces.Box(-v, v, shape=(2,), dtype=np.float32)
        self._first_seed = seed

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """A new trial, seeded from ``seed`` (else the constructor's, else Gymnasium's generator)."""
        if seed is None and self._first_seed is not None:
            seed = self._first_seed
        self._first_seed = None
        super().reset(seed=seed)
        self.core.reset(int(self.np_random.integers(0, 2**31 - 1)))
        return self.core.observe(self.index), {}

    def step(self, action):
        out = self.core.step({self.index: np.asarray(action, dtype=float)}, {self.index})
        sim = self.core.sim
        assert sim is not None
        info = {"contact": out.contact[self.index], "outcome": sim.outcome, "t": sim.t}
        return (self.core.observe(self.index), out.rewards[self.index], out.terminated[self.index],
                out.truncated[self.index], info)

    def render(self):
        """The current state as an RGB array (``render_mode="rgb_array"``), else nothing."""
        if self.render_mode != "rgb_array" or self.core.sim is None:
            return None
        return render_frame(self.core.sim, self.core.controlled)
