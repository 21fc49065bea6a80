"""The full record of a trial, and its file format (replayable without re-simulating).

A history is saved as one ``.npz`` file holding every array and, under the key ``meta``, a JSON
document with the scenario (as a mapping that :func:`scenario_from_dict` reads back), the
method, the seed, the events and the outcome.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from nodnav.errors import NodnavError, shown, shown_path
from nodnav.scenario.schema import Scenario, scenario_from_dict, scenario_to_dict

FORMAT_VERSION = 2


def _stack_padded(rows: list[np.ndarray], decisions: int, n: int) -> np.ndarray:
    """Per-decision ``(N_r, w_d)`` arrays as one ``(D, N_r, max w_d)`` array, NaN-padded."""
    width = max([r.shape[-1] for r in rows] + [0])
    if rows and len(rows) == decisions and all(r.shape == (n, width) for r in rows):
        return np.array(rows, dtype=float)  # nothing to pad: the rows stacked
    out = np.full((decisions, n, width), np.nan)
    for d, r in enumerate(rows):
        r = np.asarray(r, dtype=float).reshape(n, -1)
        out[d, :, :r.shape[1]] = r
    return out


@dataclass
class History:
    """States at every control step and decisions at every opinion period, keyed by robot index."""

    scenario: Scenario
    """The scenario that was simulated."""
    method: str
    """Name of the navigation method."""
    seed: int
    """Seed of the trial."""
    times: list[float] = field(default_factory=list)
    """Control-step times (s)."""
    positions: list[np.ndarray] = field(default_factory=list)
    """True positions ``(N_r, 2)`` per control step (m)."""
    velocities: list[np.ndarray] = field(default_factory=list)
    """True velocities ``(N_r, 2)`` per control step (m/s)."""
    decision_times: list[float] = field(default_factory=list)
    """Times of the opinion updates (s)."""
    opinions: list[np.ndarray] = field(default_factory=list)
    """Opinion states z per decision ``(N_r, W)``: robot ``i``'s over the orders of its game
    (:func:`~nodnav.decision.games.game_orders` of ``games[i]``), NaN beyond them and for methods
    without opinions."""
    probabilities: list[np.ndarray] = field(default_factory=list)
    """Selection probabilities x per decision ``(N_r, W)``, laid out as ``opinions``."""
    strategies: list[np.ndarray] = field(default_factory=list)
    """Selected strategy index per robot ``(N_r,)`` per decision (0-based, among all N_r! orders)
    when the robot's game holds every robot; -1 otherwise or when none."""
    chosen: list[np.ndarray] = field(default_factory=list)
    """Probability of the selected order per robot ``(N_r,)`` per decision (NaN without opinions)."""
    games: list[np.ndarray] = field(default_factory=list)
    """Game mask ``(N_r, N_r)`` per decision: ``games[i, k]`` when robot k is in robot i's game
    (itself and its game players, or every robot for a method that follows a full order)."""
    ranks: list[np.ndarray] = field(default_factory=list)
    """Selected orders ``(N_r, N_r)`` per decision: ``ranks[i, k]`` is robot k's place in the
    order robot i selected, -1 when k is not in it (a row of -1: none selected)."""
    players: list[np.ndarray] = field(default_factory=list)
    """Game-player mask ``(N_r, N_r)`` per decision: ``players[i, k]`` when k is in N_i."""
    undecided: list[np.ndarray] = field(default_factory=list)
    """Robots that had not yet entered the corridor ``(N_r,)`` per decision: the order still open."""
    events: list[dict] = field(default_factory=list)
    """Discrete events: MPC infeasibility, plan failures, corridor entries, the outcome."""
    entry_order: list[int] = field(default_factory=list)
    """Robots (0-based) in the order they entered the corridor."""
    outcome: str = ""
    """The trial's outcome once finished."""

    def arrays(self) -> dict[str, np.ndarray]:
        """Every per-step and per-decision series as stacked arrays."""
        n, d = self.scenario.n_robots, len(self.decision_times)
        return {
            "times": np.asarray(self.times, dtype=float),
            "positions": np.asarray(self.positions, dtype=float).reshape(-1, n, 2),
            "velocities": np.asarray(self.velocities, dtype=float).reshape(-1, n, 2),
            "decision_times": np.asarray(self.decision_times, dtype=float),
            "opinions": _stack_padded(self.opinions, d, n),
            "probabilities": _stack_padded(self.probabilities, d, n),
            "strategies": np.asarray(self.strategies, dtype=int).reshape(-1, n),
            "chosen": np.asarray(self.chosen, dtype=float).reshape(-1, n),
            "games": np.asarray(self.games, dtype=bool).reshape(-1, n, n),
            "ranks": np.asarray(self.ranks, dtype=int).reshape(-1, n, n),
            "players": np.asarray(self.players, dtype=bool).reshape(-1, n, n),
            "undecided": np.asarray(self.undecided, dtype=bool).reshape(-1, n),
        }

    def to_dataframe(self) -> Any:
        """One row per robot and control step, for pandas (needs ``pip install 'nodnav[export]'``).

        Columns: ``step``, ``time`` (s), ``robot`` (1..N_r), ``x``, ``y`` (m), ``vx``, ``vy`` (m/s),
        and from the robot's latest decision at or before the step: ``decision_time`` (s),
        ``order`` (its selected passing order as robot numbers, ``2,1,3``; empty without one),
        ``strategy`` (``S3`` when its game holds every robot, else empty), ``game`` (the robots
        its opinions are about), ``chosen_probability`` and ``p_1`` .. ``p_W``: its selection
        probabilities over the orders of its game (:func:`~nodnav.decision.games.game_orders`;
        with every robot in the game, p_j is strategy S_j's), NaN beyond them. A history does
        not hold the plans; ``nodnav export`` adds them by replaying the trial.
        """
        try:
            import pandas as pd
        except ImportError:
            raise NodnavError("History.to_dataframe needs pandas: pip install 'nodnav[export]'") from None
        a = self.arrays()
        n, steps = self.scenario.n_robots, len(a["times"])
        # The decision each step follows: the latest at or before it (the first one is at t = 0).
        d = np.clip(np.searchsorted(a["decision_times"], a["times"] + 1e-9, side="right") - 1, 0, None)
        has = len(a["decision_times"]) > 0
        columns: dict[str, Any] = {
            "step": np.repeat(np.arange(steps), n), "time": np.repeat(a["times"], n),
            "robot": np.tile(np.arange(1, n + 1), steps),
            "x": a["positions"][:, :, 0].ravel(), "y": a["positions"][:, :, 1].ravel(),
            "vx": a["velocities"][:, :, 0].ravel(), "vy": a["velocities"][:, :, 1].ravel(),
            "decision_time": np.repeat(a["decision_times"][d], n) if has else np.full(steps * n, np.nan),
        }

        def order_text(ranks: np.ndarray) -> str:
            placed = np.flatnonzero(ranks >= 0)
            return ",".join(str(k + 1) for k in placed[np.argsort(ranks[placed])])

        per_decision = [[order_text(a["ranks"][j, i]) for i in range(n)] for j in range(len(a["ranks"]))]
        games = [[",".join(str(k + 1) for k in np.flatnonzero(a["games"][j, i])) for i in range(n)]
                 for j in range(len(a["games"]))]
        rows = [(j, i) for j in (d if has else ()) for i in range(n)]
        columns["order"] = [per_decision[j][i] for j, i in rows] if has else [""] * (steps * n)
        columns["strategy"] = ([f"S{a['strategies'][j, i] + 1}" if a["strategies"][j, i] >= 0 else "" for j, i in rows]
                               if has else [""] * (steps * n))
        columns["game"] = [games[j][i] for j, i in rows] if has else [""] * (steps * n)
        columns["chosen_probability"] = a["chosen"][d].ravel() if has else np.full(steps * n, np.nan)
        probabilities = a["probabilities"][d].reshape(steps * n, -1) if has else np.zeros((steps * n, 0))
        for w in range(probabilities.shape[1]):
            columns[f"p_{w + 1}"] = probabilities[:, w]
        return pd.DataFrame(columns)

    def save(self, path: str | Path) -> Path:
        """Write the history to ``path`` (``.npz``), with the code version and the numerics
        (:func:`nodnav.provenance.numerics`) that produced it."""
        from nodnav.provenance import code_version, numerics

        meta = {"format": FORMAT_VERSION, "scenario": scenario_to_dict(self.scenario), "method": self.method,
                "seed": self.seed, "events": self.events, "entry_order": self.entry_order,
                "outcome": self.outcome, "code_version": code_version(), "numerics": numerics()}
        path = Path(path)
        with open(path, "wb") as fh:
            arrays: dict[str, Any] = {"meta": np.array(json.dumps(meta)), **self.arrays()}
            np.savez_compressed(fh, **arrays)
        return path

    @staticmethod
    def load(path: str | Path) -> "History":
        """Read a history written by :meth:`save`; anything else is one :class:`NodnavError` line."""
        name = shown_path(path)
        not_history = f"{name}: not a nodnav history file (one is written by nodnav run SCENARIO --out DIR)"
        try:
            p = Path(path)
            blocking = p.exists() and not p.is_file() and not p.is_dir()  # a pipe or a device: read forever
        except (OSError, ValueError):
            blocking = False  # np.load refuses the name below
        if blocking:
            raise NodnavError(not_history)
        try:
            with np.load(path, allow_pickle=False) as data:
                meta = json.loads(str(data["meta"]))
                arrays = {k: data[k] for k in data.files if k != "meta"}
        except FileNotFoundError:
            raise NodnavError(f"{name}: no such file") from None
        except IsADirectoryError:
            raise NodnavError(f"{name}: is a directory; give a .npz history file") from None
        except Exception:  # whatever the file holds, it is not what save() writes
            raise NodnavError(not_history) from None
        if not isinstance(meta, dict):
            raise NodnavError(not_history)
        if meta.get("format") != FORMAT_VERSION:
            raise NodnavError(f"{name}: history format {shown(meta.get('format'))} is not {FORMAT_VERSION}; "
                              "re-run the trial")
        try:
            scenario = scenario_from_dict(meta["scenario"])
        except NodnavError as exc:
            raise NodnavError(f"{name}: its scenario is not valid here ({exc})") from None
        except Exception:
            raise NodnavError(not_history) from None
        try:
            h = History(scenario=scenario, method=str(meta["method"]), seed=int(meta["seed"]))
            n = scenario.n_robots
            h.times = list(arrays["times"])
            h.positions = list(arrays["positions"])
            h.velocities = list(arrays["velocities"])
            h.decision_times = list(arrays["decision_times"])
            h.opinions = list(arrays["opinions"])
            h.probabilities = list(arrays["probabilities"])
            h.strategies = list(arrays["strategies"])
            h.chosen = list(arrays["chosen"])
            h.games = list(arrays["games"])
            h.ranks = list(arrays["ranks"])
            h.players = list(arrays["players"])
            h.undecided = list(arrays["undecided"])
            h.events = list(meta["events"])
            h.entry_order = [int(k) for k in meta["entry_order"]]
            h.outcome = str(meta["outcome"])
            h.arrays()  # every array has the shape the scenario implies
            if not h.times or arrays["positions"].shape[1:] != (n, 2):
                raise ValueError("no states")
        except Exception:
            raise NodnavError(not_history) from None
        return h
