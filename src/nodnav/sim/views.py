"""What a robot observes at a decision time and what it decides (:mod:`nodnav.sim.agent`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodnav.planning.base import JointTrajectory, PlanResult


@dataclass(frozen=True)
class RobotView:
    """What one robot observes at a decision time: everyone's recent motion, as it sees it."""

    t: float
    """Current time (s)."""
    window_times: np.ndarray
    """Sample times of the last window [t - T, t] ``(M,)`` (s)."""
    window_states: np.ndarray
    """Observed states (px, py, vx, vy) of every robot over the window ``(N_r, M, 4)``; own row is exact."""
    entered: tuple[int, ...]
    """Robots the observer has seen enter the corridor, in the order they did."""
    age: np.ndarray | None = None
    """Time since the observer last saw each robot ``(N_r,)`` (s): 0 while seen, inf if unknown
    (never seen, or forgotten); None with the paper's sensing, where everyone is always seen
    (:mod:`nodnav.sim.sensing`). A robot not seen now is held still where it was last seen."""
    sigma: np.ndarray | None = None
    """Standard deviation of the estimate of each robot's position along either axis ``(N_r,)``
    (m), from the observer's filters; None when observations are exact or not filtered."""
    passage_entered: tuple[tuple[int, ...], ...] = ()
    """With several passages, the robots the observer has seen enter each passage, in order
    (``entered`` is the first passage's); empty with one passage."""

    @classmethod
    def built(cls, t: float, window_times: np.ndarray, window_states: np.ndarray, entered: tuple[int, ...],
              age: np.ndarray | None = None, sigma: np.ndarray | None = None,
              passage_entered: tuple[tuple[int, ...], ...] = ()) -> "RobotView":
        """The view the constructor builds, with the same fields, without the frozen dataclass's
        assignment of one field at a time (the simulator builds one or more every control step,
        as :meth:`~nodnav.control.base.ControlRequest.built`)."""
        view = object.__new__(cls)
        view.__dict__.update(t=t, window_times=window_times, window_states=window_states, entered=entered, age=age,
                             sigma=sigma, passage_entered=passage_entered)
        return view

    @property
    def seen(self) -> np.ndarray:
        """Which robots the observer sees now ``(N_r,)``."""
        if self.age is None:
            return np.ones(self.window_states.shape[0], dtype=bool)
        return self.age == 0.0

    @property
    def known(self) -> np.ndarray:
        """Which robots the observer sees or remembers ``(N_r,)``."""
        if self.age is None:
            return np.ones(self.window_states.shape[0], dtype=bool)
        return np.isfinite(self.age)

    @property
    def positions(self) -> np.ndarray:
        """Current observed positions ``(N_r, 2)`` (m)."""
        return self.window_states[:, -1, :2]

    @property
    def velocities(self) -> np.ndarray:
        """Current observed velocities ``(N_r, 2)`` (m/s)."""
        return self.window_states[:, -1, 2:]


@dataclass(frozen=True)
class Decision:
    """A robot's decision for the coming period: what it follows and what it expects of others."""

    strategy: int
    """Index of the selected order among the orders of ``game`` (0-based,
    :func:`~nodnav.decision.games.game_orders`), or -1 for methods without strategies."""
    robots: tuple[int, ...]
    """Robots in the plan: the agent first, then its game players, then any robot already
    committed to the corridor that it plans with (scenario indices)."""
    plan: PlanResult
    """The joint plan for the selected order over ``robots``."""
    opinions: np.ndarray
    """Opinion state z_i after the update, over the orders of ``game`` ``((k+1)!,)`` (empty
    for methods without opinions)."""
    probabilities: np.ndarray
    """Selection probabilities x_i over the orders of ``game`` ``((k+1)!,)`` (empty without opinions)."""
    players: tuple[int, ...]
    """Game players N_i(t)."""
    game: tuple[int, ...] = ()
    """The robots the opinions and the selected order are about, in increasing index: the agent
    and its game players (every robot for a method that follows one full order)."""
    order: tuple[int, ...] = ()
    """The selected passing order of ``game`` (scenario indices); empty without one."""

    @classmethod
    def built(cls, strategy: int, robots: tuple[int, ...], plan: PlanResult, opinions: np.ndarray,
              probabilities: np.ndarray, players: tuple[int, ...], game: tuple[int, ...] = (),
              order: tuple[int, ...] = ()) -> "Decision":
        """The decision the constructor builds, with the same fields, without the frozen
        dataclass's assignment of one field at a time (every agent builds one every period)."""
        decision = object.__new__(cls)
        decision.__dict__.update(strategy=strategy, robots=robots, plan=plan, opinions=opinions,
                                 probabilities=probabilities, players=players, game=game, order=order)
        return decision

    @property
    def own_trajectory(self) -> JointTrajectory:
        """The agent's own reference path."""
        return self.plan.trajectory.subset([0])
