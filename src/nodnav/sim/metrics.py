"""Per-trial metrics computed from a trial's :class:`~nodnav.sim.history.History` alone.

Every metric is defined in ``docs/metrics.md``; the functions here are that definition on
arrays. Robots are indexed from 0 in the arrays; lists in the returned mapping hold one entry per
robot in scenario order. Undefined values are NaN here and become ``None`` through
:func:`json_ready`.
"""

from __future__ import annotations

import math

import numpy as np

from nodnav.decision.games import selections_agree
from nodnav.decision.strategies import passing_orders
from nodnav.scenario.world import INSIDE, LEFT, RIGHT, Passage, World

#: A point beside a passage: between its mouths along its axis, but outside its clear rectangle
#: (in another room of a world with several passages).
AWAY = 2


def arrival_times(times: np.ndarray, positions: np.ndarray, destinations: np.ndarray, tolerance: float) -> np.ndarray:
    """First recorded time each robot is within ``tolerance`` of its destination, NaN if never ``(N_r,)`` (s).

    ``times`` ``(K,)``, ``positions`` ``(K, N_r, 2)``, ``destinations`` ``(N_r, 2)``.
    """
    arrived = np.linalg.norm(positions - destinations[None], axis=-1) <= tolerance  # (K, N_r)
    first = np.argmax(arrived, axis=0)
    return np.where(arrived.any(axis=0), times[first], np.nan)


def path_lengths(positions: np.ndarray) -> np.ndarray:
    """Length of each robot's recorded polyline ``(N_r,)`` (m), positions ``(K, N_r, 2)``."""
    return np.linalg.norm(np.diff(positions, axis=0), axis=-1).sum(axis=0)


def min_separation(positions: np.ndarray) -> float:
    """Smallest centre-to-centre distance between any two robots over the whole motion (m).

    Between two recorded states each robot moves on a straight segment at constant speed, so the
    relative position of a pair is ``r(s) = r0 + s d`` for ``s`` in [0, 1] and its closest
    approach is at ``s* = clip(-(r0 . d) / |d|^2, 0, 1)``: the minimum is exact, not sampled.
    Infinite for fewer than two robots.
    """
    p = np.asarray(positions, dtype=float)
    n = p.shape[1]
    if n < 2:
        return math.inf
    a, b = np.triu_indices(n, k=1)
    rel = p[:, a] - p[:, b]  # (K, pairs, 2)
    if len(rel) == 1:
        return float(np.linalg.norm(rel, axis=-1).min())
    r0, d = rel[:-1], np.diff(rel, axis=0)
    dd = np.einsum("kpi,kpi->kp", d, d)
    s = np.clip(-np.einsum("kpi,kpi->kp", r0, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    return float(np.linalg.norm(r0 + s[..., None] * d, axis=-1).min())


def corridor_crossings(times: np.ndarray, x: np.ndarray, world: World) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit times of every complete crossing of the corridor by one robot (s).

    ``x`` ``(K,)`` is the robot's recorded coordinate along the passage's axis
    (:meth:`~nodnav.scenario.world.World.along`; the abscissa for the paper's corridor). A
    crossing is a pair of consecutive recorded samples outside the corridor, on opposite sides,
    with only samples inside the corridor between them. Entry and exit are the times the straight
    segment between samples passes the mouth it goes through, by linear interpolation. A robot
    that enters and backs out, or starts inside, makes no crossing.
    """
    g = world.passage
    side = g.side_of_along(x)
    outside = np.flatnonzero(side != INSIDE)
    k1, k2 = outside[:-1], outside[1:]
    crossing = side[k1] == -side[k2]
    k1, k2 = k1[crossing], k2[crossing]
    entry_x = np.where(side[k1] < 0, g.s_start, g.s_end)
    exit_x = np.where(side[k2] < 0, g.s_start, g.s_end)

    def cross_time(k: np.ndarray, line: np.ndarray) -> np.ndarray:
        w = (line - x[k]) / (x[k + 1] - x[k])
        return times[k] + w * (times[k + 1] - times[k])

    return cross_time(k1, entry_x), cross_time(k2 - 1, exit_x)


def flow_rate(times: np.ndarray, positions: np.ndarray, world: World) -> tuple[int, float]:
    """Robots that crossed the corridor, and the flow rate through it (robots/s).

    Flow rate = (number of robots with at least one crossing) / (latest crossing exit - earliest
    crossing entry), over the crossings of :func:`corridor_crossings`; NaN when no robot crossed.
    """
    entries, exits, crossed = [], [], 0
    for i in range(positions.shape[1]):
        t_in, t_out = corridor_crossings(times, world.along(positions[:, i]), world)
        if len(t_in):
            crossed += 1
            entries.append(t_in.min())
            exits.append(t_out.max())
    if not crossed:
        return 0, math.nan
    return crossed, float(crossed / (max(exits) - min(entries)))


def passage_states(points: np.ndarray, passage: Passage) -> np.ndarray:
    """Where each point is relative to one passage of several, shape of ``points`` ``(..., 2)``
    without its last axis: ``INSIDE`` its clear rectangle (between the mouths and within half its
    width of the centreline), ``LEFT`` before its first mouth, ``RIGHT`` beyond its second, and
    :data:`AWAY` between the mouths along the axis but off the rectangle (another room: with
    several passages, the band between one passage's mouths crosses the others' rooms)."""
    s = passage.along(points)
    side = passage.side_of_along(s)
    beside = np.abs(passage.across(points) - passage.t_centre) > 0.5 * passage.width + 1e-9
    return np.where((side == INSIDE) & beside, AWAY, side)


def passage_crossings(times: np.ndarray, points: np.ndarray, passage: Passage) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit times of every complete crossing of one passage of several by one robot (s).

    ``points`` ``(K, 2)`` is the robot's recorded positions. As :func:`corridor_crossings`, with
    the places of :func:`passage_states`: a crossing is a pair of consecutive recorded samples
    not inside the passage, one ``LEFT`` and one ``RIGHT``, with only samples inside it between
    them; a sample :data:`AWAY` from it breaks a crossing. Entry and exit are interpolated on the
    along-coordinate at the mouth gone through."""
    state = passage_states(points, passage)
    x = passage.along(points)
    outside = np.flatnonzero(state != INSIDE)
    k1, k2 = outside[:-1], outside[1:]
    crossing = ((state[k1] == LEFT) | (state[k1] == RIGHT)) & (state[k2] == -state[k1])
    k1, k2 = k1[crossing], k2[crossing]
    entry_x = np.where(state[k1] == LEFT, passage.s_start, passage.s_end)
    exit_x = np.where(state[k2] == LEFT, passage.s_start, passage.s_end)

    def cross_time(k: np.ndarray, line: np.ndarray) -> np.ndarray:
        w = (line - x[k]) / (x[k + 1] - x[k])
        return times[k] + w * (times[k + 1] - times[k])

    return cross_time(k1, entry_x), cross_time(k2 - 1, exit_x)


def per_passage(times: np.ndarray, positions: np.ndarray, world: World) -> dict:
    """The crossing metrics of each passage of a world with several (docs/metrics.md), from the
    recorded positions ``(K, N_r, 2)``: per passage, each robot's entry time into its first
    complete crossing (NaN without one), the robots in the order of those times (1-based, ties
    by number), how many crossed, and the flow rate (as :func:`flow_rate`)."""
    entry_times, orders, crossed, flows = [], [], [], []
    for passage in world.passages:
        first = np.full(positions.shape[1], np.nan)
        starts, ends = [], []
        for i in range(positions.shape[1]):
            t_in, t_out = passage_crossings(times, positions[:, i], passage)
            if len(t_in):
                first[i] = t_in[0]
                starts.append(t_in.min())
                ends.append(t_out.max())
        done = np.flatnonzero(np.isfinite(first))
        entry_times.append([float(t) for t in first])
        orders.append([int(k) + 1 for k in done[np.argsort(first[done], kind="stable")]])
        crossed.append(len(done))
        flows.append(float(len(done) / (max(ends) - min(starts))) if len(done) else math.nan)
    return {"passage_entry_times_s": entry_times, "passage_entry_orders": orders, "passage_robots_crossed": crossed,
            "passage_flow_rate_rps": flows}


def smoothness(velocities: np.ndarray) -> float:
    """Mean over robots and control steps of ``|v_{k+1} - v_k|`` (m/s); NaN with fewer than two steps.

    ``velocities`` ``(K, N_r, 2)``.
    """
    if len(velocities) < 2:
        return math.nan
    return float(np.linalg.norm(np.diff(velocities, axis=0), axis=-1).mean())


def opinion_switches(selections: np.ndarray) -> np.ndarray:
    """Changes of each robot's selection between consecutive decisions ``(N_r,)``.

    ``selections`` is ``(D, N_r)``, the selected strategy index per decision, or ``(D, N_r, N_r)``,
    the selected orders as ranks (:attr:`~nodnav.sim.history.History.ranks`).
    """
    changed = np.diff(np.asarray(selections), axis=0) != 0
    return (changed.any(axis=-1) if changed.ndim == 3 else changed).sum(axis=0)


def time_to_consensus(decision_times: np.ndarray, selections: np.ndarray, undecided: np.ndarray | None = None) -> float:
    """First decision time from which the robots agreed at every later decision while an order was still open (s).

    ``selections`` is ``(D, N_r)``, the selected strategy index per decision (-1: none), or
    ``(D, N_r, N_r)``, the selected orders of every robot's game as ranks
    (:attr:`~nodnav.sim.history.History.ranks`). Without ``undecided``, robots agree when they
    selected the same strategy. With ``undecided`` ``(D, N_r)``, the robots that had not yet
    entered the corridor at each decision, they agree when no two selections order two of those
    robots differently (:func:`~nodnav.decision.games.selections_agree`), and decisions with fewer
    than two such robots are left out (the order was settled). NaN when they disagree at the last
    decision that counts, when there is none, or when the method selects nothing.
    """
    selections = np.asarray(selections)
    if len(selections) == 0:
        return math.nan
    if undecided is None:  # the same selection, whatever it is
        flat = selections.reshape(len(selections), selections.shape[1], -1)
        agree = np.array([bool((r >= 0).any(axis=1).all() and np.all(r == r[:1])) for r in flat])
        times = np.asarray(decision_times)
    else:
        if selections.ndim == 2:  # strategy indices (of all N_r! orders) as the orders' ranks
            n = selections.shape[1]
            orders = passing_orders(n)
            ranks = np.full(selections.shape + (n,), -1)
            for d, i in zip(*np.nonzero(selections >= 0)):
                ranks[d, i, orders[selections[d, i]]] = np.arange(n)
            selections = ranks
        open_ = np.asarray(undecided, dtype=bool)
        counts = open_.sum(axis=1) >= 2
        if not counts.any():
            return math.nan
        agree = np.array([selections_agree(r, np.flatnonzero(o)) for r, o in zip(selections[counts], open_[counts])])
        times = np.asarray(decision_times)[counts]
    if not agree[-1]:
        return math.nan
    disagree = np.flatnonzero(~agree)
    start = disagree[-1] + 1 if len(disagree) else 0
    return float(times[start])


def compute_metrics(history) -> dict:
    """Every metric of ``docs/metrics.md`` for one finished trial (a :class:`~nodnav.sim.history.History`).

    Scalars are floats (NaN when undefined) or ints; per-robot metrics are lists in robot order.
    """
    s = history.scenario
    a = history.arrays()
    times, positions, velocities = a["times"], a["positions"], a["velocities"]
    goal = arrival_times(times, positions, s.destinations, s.sim.goal_tolerance)
    lengths = path_lengths(positions)
    straight = np.linalg.norm(s.destinations - s.origins, axis=-1)
    ratio = np.divide(lengths, straight, out=np.full_like(lengths, np.nan), where=straight > 0)
    crossed, flow = flow_rate(times, positions, s.world)
    switches = opinion_switches(a["ranks"])
    makespan = float(goal.max()) if history.outcome == "success" and np.isfinite(goal).all() else math.nan
    passages = per_passage(times, positions, s.world) if len(s.world.passages) > 1 else {}
    if passages:  # the first passage's, off its clear rectangle's band (another room) not counted
        crossed, flow = passages["passage_robots_crossed"][0], passages["passage_flow_rate_rps"][0]
    return {
        "makespan_s": makespan,
        "time_to_goal_s": [float(t) for t in goal],
        "path_length_m": [float(v) for v in lengths],
        "path_deviation_m": [float(v) for v in lengths - straight],
        "path_ratio": [float(v) for v in ratio],
        "min_separation_m": min_separation(positions),
        "robots_crossed": crossed,
        "flow_rate_rps": flow,
        "smoothness_mps": smoothness(velocities),
        "opinion_switches": int(switches.sum()),
        "opinion_switches_per_robot": [int(v) for v in switches],
        "time_to_consensus_s": time_to_consensus(a["decision_times"], a["ranks"], a["undecided"]),
        **passages,
    }


def json_ready(value):
    """``value`` with every non-finite float (NaN, inf) replaced by ``None``, recursively, and
    NumPy scalars and arrays turned into Python numbers and lists."""
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [json_ready(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value
