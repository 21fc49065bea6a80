"""Mutual braking: a robot's next step keeps both it and every other robot able to stop apart.

Every robot that cannot plan brakes along its velocity at its limit, and every robot predicts
the others that way (the *firm* predictions, :mod:`nodnav.sim.methods`). Keeping one's *plan*
clear of the others' braking trajectories is not enough between two robots that both move: each
is where its plan took it at the next step, and braking from there (its next fallback) can run
into the other's braking from where *its* plan took it. Two robots abreast at a mouth, each
sure it goes first, converged that way until both braked too late (``5r-mixed`` with one game
player, seeds 20, 23, 26; docs/safety.md, "Mutual braking").

The invariant kept here: *every two robots' braking trajectories, from their present states, never
touch.* It holds at the start (all at rest, apart). A robot accepts a plan only if its braking
trajectory from the state the plan's first step reaches, ``B_i(k+1)``, passes a check against
every other robot ``j``; otherwise it brakes (``B_i(k+1) = B_i(k)``). The check is

* **strong**: ``B_i(k+1)`` keeps contact plus :func:`braking_deviation` from ``j``'s braking
  trajectory ``B_j(k)`` at every instant, so it is clear of *every* braking trajectory ``j`` can
  have after its own step, whatever ``j`` does within its acceleration limit;
* **weak**: ``B_i(k+1)`` keeps contact from ``B_j(k)`` itself.

Of two robots that both keep the rule, one (by a fixed convention, ``execution.mutual_braking``)
takes the weak check towards the other and the other the strong one. Then after every step: if
the strong one passed, ``B_j(k+1)`` is clear of whatever ``i`` did; if it braked, ``B_j(k+1) =
B_j(k)``, from which ``i`` kept clear (weak) or which ``i`` did not change (``i`` braked: the
invariant at ``k``). The argument asks nothing of the convention but that, at every step and for
every pair, the two robots evaluate it from the same observation and it gives the weak check to
exactly one of them: any function of what both observe (their states, their accelerations, the
common clock) antisymmetric in the pair will do, however often it hands the role over; a hand-over
at ``k`` only changes which of the two cases above happens at ``k``. ``stopping``
(:func:`takes_weak_check`) is one: stopping times ``|v| / a`` and the test ``|v| / a <= dt`` are
computed alike by both from the same numbers, of two robots that both pass the test the turn
decides (``i < j`` xor ``turn``), of one that passes and one that does not the other, and of two
that do not the larger stopping time, the lower number at a tie.

Towards a robot that does not keep the rule (a person, another method) there is no check: it may
not brake, so braking is no safer than evading it, and the MPC's predictions and evasive plans
handle it as before (an ORCA robot ran into NOD robots that braked for it).

Assumptions: exact observations and exact motion (as the wall guarantee), and braking as the
only fallback; a robot whose straight braking would reach a wall follows its committed
trajectory instead (:mod:`nodnav.control.braking`), which the others do not predict.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from nodnav.compiled import compiled

SAMPLE_STEP = 0.01
"""Time between the samples of the check (s); the minimum between samples is bounded by the
relative speed (:func:`braking_slack`), so a coarser step is only more careful."""

MAX_SAMPLES = 4000
"""At most this many samples per pair; a longer stop (very slow braking) spaces them wider."""

CONVENTIONS = ("speed", "index", "strong", "stopping")
"""Who of two robots that keep the rule takes the weak check (``execution.mutual_braking``), in
the order of their codes in :class:`BrakingPartners`: the faster (of two standing still, the
lower- and the higher-numbered in turn, :attr:`BrakingPartners.turn`), the lower-numbered,
neither, and the one that needs longer to stop (``|v| / max_accel``), counting a robot that can
stop within one control step as standing still (:func:`takes_weak_check`)."""

REST_SPEED = 1e-3
"""Speed (m/s) at or below which the ``speed`` convention counts a robot as standing still
(``stopping`` counts one as standing still up to ``max_accel dt``, never below this)."""


class BrakingPartners(NamedTuple):
    """What a controller's next step is checked against (:mod:`nodnav.control.mutual_braking`):
    every robot's state as the robot sees it now, itself included."""

    robot: int
    """The robot's own index in the arrays."""
    positions: np.ndarray
    """Every robot's position now ``(N, 2)`` (m)."""
    velocities: np.ndarray
    """Every robot's velocity now ``(N, 2)`` (m/s)."""
    decels: np.ndarray
    """The deceleration each brakes at when it cannot plan, its ``max_accel`` ``(N,)`` (m/s^2)."""
    radii: np.ndarray
    """Every robot's radius ``(N,)`` (m)."""
    keeps_rule: np.ndarray
    """Which robots keep the rule ``(N,)`` (bool): towards the others there is no check (they may
    not brake, so braking is no safer than evading them: the MPC's predictions handle them)."""
    seen: np.ndarray
    """Which robots the robot sees now ``(N,)`` (bool); the others are not checked."""
    turn: int
    """0 or 1, the same for every robot at a given time: of two robots standing still (speed at
    most :data:`REST_SPEED`; with ``stopping``, able to stop within ``dt``), the lower-numbered
    takes the weak check when 0, the other when 1."""
    convention: int
    """Index in :data:`CONVENTIONS`."""
    dt: float
    """The control step (s)."""


def braking_deviation(speed: np.ndarray | float, decel: np.ndarray | float, dt: float,
                      elapsed: np.ndarray | float) -> np.ndarray:
    """Upper bound (m) on how far a robot's braking trajectory after one control step can be
    from its braking trajectory now, ``elapsed`` seconds after that step.

    Braking for the step leaves the robot at ``p + v g(|v|, dt) / |v|`` with speed
    ``max(|v| - a dt, 0)``, where ``g(w, s) = w sigma - a sigma^2 / 2``, ``sigma = min(s, w / a)``.
    Any other step within the limit ends within ``dp = |v| dt - g(|v|, dt) + a dt^2 / 2`` of that
    position and ``dv = min(|v|, a dt) + a dt`` of that velocity. Braking from ``(p, v)`` is at
    ``p + v g(|v|, s) / |v|`` after ``s``, whose Jacobian in ``v`` has norm ``sigma``, at most
    ``min(s, w / a)`` for speeds up to ``w = |v| + a dt`` on the way. Hence ``dp + dv min(s, (|v| +
    a dt) / a)``: 0.02 m right after the step and 0.26 m once stopped at 1 m/s and 2 m/s^2 over
    0.1 s; 0.03 m at most from rest.
    """
    speed = np.asarray(speed, dtype=float)
    decel = np.asarray(decel, dtype=float)
    dp, dv = _step_deviation(speed, decel, dt)
    return dp + dv * np.minimum(np.asarray(elapsed, dtype=float), (speed + decel * dt) / decel)


RESTART_HEADROOM = 1e-4
"""What a robot keeps beyond :func:`restart_gap` from a robot that keeps the rule (m): room for the
rounding of the QP and of the exact checks (the MPC's ``check_tolerance`` by default), so that a
plan that keeps the gap leaves the strong check's slack at least zero."""


def restart_gap(decel_i: float, decels_j: np.ndarray | float, dt: float) -> np.ndarray:
    """The gap beyond contact (m) from which either of two robots at rest passes the strong check
    towards the other while holding still: :func:`braking_deviation` of the other at rest once
    it has grown fully, ``1.5 a dt^2``, plus what the check subtracts between its samples
    (``growth h / 2``, :func:`_pair_slack`), at the larger of the two decelerations (0.031 m at
    2 m/s^2 and 0.1 s). Robots that park closer than this cannot start again towards each other,
    and a knot of them, each the strong one towards a neighbour, cannot start at all
    (docs/safety.md, "Parking where one can start again")."""
    decel = np.maximum(float(decel_i), np.asarray(decels_j, dtype=float))
    out = np.empty(decel.shape)
    for k, a in np.ndenumerate(decel):
        dp, growth = _deviation_terms(0.0, float(a), dt, True)
        _, h = _sample_grid(0.0, 0.0, float(a), dt, True, SAMPLE_STEP, MAX_SAMPLES)
        out[k] = dp + growth * dt + 0.5 * h * growth
    return out


def _step_deviation(speed, decel, dt):
    """``(dp, dv)`` of :func:`braking_deviation` (NumPy arrays or floats alike)."""
    sigma = np.minimum(dt, speed / decel)
    dp = speed * dt - (speed * sigma - 0.5 * decel * sigma * sigma) + 0.5 * decel * dt * dt
    return dp, np.minimum(speed, decel * dt) + decel * dt


@compiled
def _braked(px: float, py: float, vx: float, vy: float, speed: float, decel: float, s: float) -> tuple[float, float]:
    """Where braking along ``(vx, vy)`` at ``decel`` from ``(px, py)`` is after ``s`` seconds."""
    if speed == 0.0:
        return px, py
    sigma = min(s, speed / decel)
    g = (speed * sigma - 0.5 * decel * sigma * sigma) / speed
    return px + vx * g, py + vy * g


@compiled
def takes_weak_check(i: int, j: int, speed_i: float, speed_j: float, keeps_j: bool, convention: int,
                     turn: int, a_i: float, a_j: float, dt: float) -> bool:
    """Whether robot ``i`` (at ``speed_i`` now) takes the weak check towards robot ``j``: only if
    ``j`` keeps the rule, and then by the convention (:data:`CONVENTIONS`); ``j`` evaluates the
    same from the same observation and takes the other check. With ``speed``, of two robots
    standing still the role alternates with ``turn``: with the strong check a robot cannot start
    past one standing closer than :func:`braking_deviation` beyond contact, and a fixed choice
    would keep the same robot from ever doing so.

    With ``stopping`` robots are compared by their stopping times ``|v| / a`` (``a_i``, ``a_j``:
    their decelerations), and one that can stop within the control step ``dt`` counts as standing
    still: a robot starting (or crawling, or trembling at a few mm/s as the MPC's plans at rest
    do) keeps the role ``turn`` gave it for the whole period, where with ``speed`` the role went to
    whichever of two such robots was a hair faster at the moment and flipped from step to step,
    each flip stopping the one that had just started; and of two moving robots the one that needs
    longer to stop keeps its plan, the other (whose strong check is then against the smaller
    deviation of a robot that brakes gently) gives way (docs/mutual-braking-restart.md)."""
    if not keeps_j or convention == 2:
        return False
    if convention == 0 or convention == 3:
        key_i, key_j = speed_i, speed_j
        still_i, still_j = REST_SPEED, REST_SPEED
        if convention == 3:
            key_i, key_j = speed_i / a_i, speed_j / a_j
            still_i, still_j = max(REST_SPEED / a_i, dt), max(REST_SPEED / a_j, dt)
        rest_i, rest_j = key_i <= still_i, key_j <= still_j
        if rest_i and rest_j:
            return (i < j) != (turn == 1)
        if rest_i or rest_j or key_i != key_j:
            return (0.0 if rest_i else key_i) > (0.0 if rest_j else key_j)
    return i < j


@compiled
def _deviation_terms(speed_j: float, a_j: float, dt: float, strong: bool) -> tuple[float, float]:
    """:func:`braking_deviation`'s ``dp`` and, for the strong check, ``dv``, the rate at which the
    margin grows until ``speed_j + a_j dt`` would have stopped (0 for the weak check)."""
    sigma = min(dt, speed_j / a_j)
    dp = speed_j * dt - (speed_j * sigma - 0.5 * a_j * sigma * sigma) + 0.5 * a_j * dt * dt
    return dp, ((min(speed_j, a_j * dt) + a_j * dt) if strong else 0.0)


@compiled
def _sample_grid(own_span: float, speed_j: float, a_j: float, dt: float, strong: bool, step: float,
                 max_samples: int) -> tuple[int, float]:
    """How many samples, how far apart (s), from the next step until the robot's own fallback
    (``own_span`` seconds) and ``j``'s braking (read from one step on) have both stopped, and for
    the strong check until ``j``'s fastest alternative would have."""
    span = max(own_span, max(speed_j / a_j - dt, 0.0))
    if strong:
        span = max(span, (speed_j + a_j * dt) / a_j)
    n = min(max_samples, int(math.ceil(span / step)) + 1)
    return n, (span / (n - 1) if n > 1 else 0.0)


@compiled
def _pair_slack(xi: float, yi: float, vxi: float, vyi: float, a_i: float, xj: float, yj: float, vx: float,
                vy: float, a_j: float, contact: float, strong: bool, dt: float, step: float,
                max_samples: int) -> float:
    """:func:`braking_slack` for one pair."""
    speed_i, speed_j = math.hypot(vxi, vyi), math.hypot(vx, vy)
    dp, growth = _deviation_terms(speed_j, a_j, dt, strong)
    worst = (dp + growth * (speed_j + a_j * dt) / a_j) if strong else 0.0
    gap = math.hypot(xj - xi, yj - yi)
    if gap - speed_i * speed_i / (2.0 * a_i) - speed_j * speed_j / (2.0 * a_j) - worst - contact > 1.0:
        return gap - contact  # neither braking can come near the other: far enough
    # From the next step on: j's braking is dt further along; the deviation stops growing once
    # j's fastest alternative has stopped.
    n, h = _sample_grid(speed_i / a_i, speed_j, a_j, dt, strong, step, max_samples)
    best = math.inf
    for k in range(n):
        s = k * h
        ax, ay = _braked(xi, yi, vxi, vyi, speed_i, a_i, s)
        bx, by = _braked(xj, yj, vx, vy, speed_j, a_j, dt + s)
        margin = (dp + growth * min(s, (speed_j + a_j * dt) / a_j)) if strong else 0.0
        best = min(best, math.hypot(ax - bx, ay - by) - contact - margin)
    # Between samples the slack changes no faster than both speeds and the margin's growth.
    return best - 0.5 * h * (speed_i + speed_j + growth)


@compiled
def _sampled_slack(own, h, own_speed, xj, yj, vx, vy, a_j, contact, strong, dt, step, max_samples):
    """:func:`_pair_slack` with the robot's own fallback given as positions ``own`` ``(n, 2)``
    every ``h`` seconds from the next step on (it stands at the last one afterwards), moving at
    most ``own_speed``."""
    speed_j = math.hypot(vx, vy)
    dp, growth = _deviation_terms(speed_j, a_j, dt, strong)
    n, g = _sample_grid((own.shape[0] - 1) * h, speed_j, a_j, dt, strong, step, max_samples)
    best = math.inf
    for k in range(n):
        s = k * g
        m = min(int(s / h + 0.5), own.shape[0] - 1) if h > 0.0 else 0  # the nearest sample of its own
        bx, by = _braked(xj, yj, vx, vy, speed_j, a_j, dt + s)
        margin = (dp + growth * min(s, (speed_j + a_j * dt) / a_j)) if strong else 0.0
        best = min(best, math.hypot(own[m, 0] - bx, own[m, 1] - by) - contact - margin)
    # Between samples: both speeds and the margin's growth over half a step of either grid.
    return best - 0.5 * max(g, h) * (own_speed + speed_j + growth) - 0.5 * h * own_speed


@compiled
def _slack_kernel(i, p_next, v_next, own, h, own_speed, positions, velocities, decels, radii, keeps, seen, turn,
                  convention, dt, step, max_samples, out):
    """Every other robot's slack into ``out`` (``inf`` for ``i``, robots not seen and robots that do
    not keep the rule); the index
    of the smallest (-1: none). The robot's own fallback is straight braking from ``(p_next,
    v_next)`` when ``own`` is empty, else the sampled positions ``own``."""
    speed_i = math.hypot(velocities[i, 0], velocities[i, 1])
    worst, worst_j = math.inf, -1
    for j in range(positions.shape[0]):
        out[j] = math.inf
        if j == i or not seen[j] or not keeps[j]:  # the rule is mutual: not checked towards others
            continue
        speed_j = math.hypot(velocities[j, 0], velocities[j, 1])
        strong = not takes_weak_check(i, j, speed_i, speed_j, keeps[j], convention, turn, decels[i], decels[j], dt)
        if own.shape[0] == 0:
            out[j] = _pair_slack(p_next[0], p_next[1], v_next[0], v_next[1], decels[i], positions[j, 0],
                                 positions[j, 1], velocities[j, 0], velocities[j, 1], decels[j], radii[i] + radii[j],
                                 strong, dt, step, max_samples)
        else:
            out[j] = _sampled_slack(own, h, own_speed, positions[j, 0], positions[j, 1], velocities[j, 0],
                                    velocities[j, 1], decels[j], radii[i] + radii[j], strong, dt, step, max_samples)
        if out[j] < worst:
            worst, worst_j = out[j], j
    return worst_j


_NO_SAMPLES = np.zeros((0, 2))


def braking_slack(position: np.ndarray, velocity: np.ndarray, partners: BrakingPartners,
                  step: float = SAMPLE_STEP, fallback: tuple[np.ndarray, float, float] | None = None
                  ) -> tuple[np.ndarray, int]:
    """A lower bound (m) on how far the braking trajectory from ``(position, velocity)`` (robot
    ``partners.robot`` after its next step, at its own deceleration) stays outside contact, plus
    the strong check's :func:`braking_deviation` where the convention gives it that one, from
    each other robot's braking trajectory now, read from one step on ``(N,)`` (``inf`` for
    itself and robots not seen); the check passes where it is >= 0. Also the index of the
    smallest (-1: none). Sampled every ``step`` seconds (at most :data:`MAX_SAMPLES` per pair)
    until both have stopped, the minimum between samples bounded by the relative speed.

    ``fallback``: the robot's own fallback when it is not straight braking (a robot whose straight
    braking would reach a wall follows its committed trajectory instead): ``(positions, h,
    speed)``, its positions every ``h`` seconds from the next step until it stops and a bound of
    its speed."""
    out = np.empty(len(partners.positions))
    own, h, own_speed = fallback if fallback is not None else (_NO_SAMPLES, 0.0, 0.0)
    worst = _slack_kernel(partners.robot, np.asarray(position, dtype=float), np.asarray(velocity, dtype=float),
                          np.ascontiguousarray(own, dtype=float), float(h), float(own_speed), partners.positions,
                          partners.velocities, partners.decels, partners.radii,
                          partners.keeps_rule, partners.seen, int(partners.turn), partners.convention,
                          float(partners.dt), float(step),
                          MAX_SAMPLES, out)
    return out, int(worst)


@compiled
def _pair_bound(xi: float, yi: float, vxi: float, vyi: float, a_i: float, xj: float, yj: float, vx: float,
                vy: float, a_j: float, contact: float, strong: bool, dt: float, step: float,
                max_samples: int) -> float:
    """:func:`passing_bound` for one pair: at sampled instants ``s`` after the next step, the
    distance between both robots' braking trajectories now (each read ``dt + s`` seconds on), plus
    how far any one step within ``a_i`` can move the robot's own (:func:`braking_deviation`), less
    contact and the strong check's margin towards ``j``. Any instant bounds the slack of every
    plan from above; ``inf`` where the two are too far apart for the bound to be negative."""
    speed_i, speed_j = math.hypot(vxi, vyi), math.hypot(vx, vy)
    dp_i, grow_i = _deviation_terms(speed_i, a_i, dt, True)
    dp_j, grow_j = _deviation_terms(speed_j, a_j, dt, strong)
    stop_i, stop_j = (speed_i + a_i * dt) / a_i, (speed_j + a_j * dt) / a_j
    worst_j = (dp_j + grow_j * stop_j) if strong else 0.0
    gap = math.hypot(xj - xi, yj - yi)
    if gap - speed_i * speed_i / (2.0 * a_i) - speed_j * speed_j / (2.0 * a_j) - contact - worst_j > 0.0:
        return math.inf  # the distance never falls below what could make the bound negative
    # Beyond the slower of both robots' stops (and their alternatives'), nothing changes.
    span = max(stop_i, stop_j)
    n = min(max_samples, int(math.ceil(span / step)) + 1)
    h = span / (n - 1) if n > 1 else 0.0
    best = math.inf
    for k in range(n):
        s = k * h
        ax, ay = _braked(xi, yi, vxi, vyi, speed_i, a_i, dt + s)
        bx, by = _braked(xj, yj, vx, vy, speed_j, a_j, dt + s)
        own = dp_i + grow_i * min(s, stop_i)
        margin = (dp_j + grow_j * min(s, stop_j)) if strong else 0.0
        best = min(best, math.hypot(ax - bx, ay - by) + own - contact - margin)
    return best


@compiled
def _bound_kernel(i, position, velocity, positions, velocities, decels, radii, keeps, seen, turn, convention, dt,
                  step, max_samples):
    """The smallest :func:`_pair_bound` over the robots checked (as :func:`_slack_kernel`) and its
    index (-1: none below ``inf``)."""
    speed_i = math.hypot(velocities[i, 0], velocities[i, 1])
    worst, worst_j = math.inf, -1
    for j in range(positions.shape[0]):
        if j == i or not seen[j] or not keeps[j]:
            continue
        speed_j = math.hypot(velocities[j, 0], velocities[j, 1])
        strong = not takes_weak_check(i, j, speed_i, speed_j, keeps[j], convention, turn, decels[i], decels[j], dt)
        bound = _pair_bound(position[0], position[1], velocity[0], velocity[1], decels[i], positions[j, 0],
                            positions[j, 1], velocities[j, 0], velocities[j, 1], decels[j], radii[i] + radii[j],
                            strong, dt, step, max_samples)
        if bound < worst:
            worst, worst_j = bound, j
    return worst, worst_j


def passing_bound(position: np.ndarray, velocity: np.ndarray, partners: BrakingPartners,
                  step: float = SAMPLE_STEP) -> tuple[float, int]:
    """An upper bound (m) on the :func:`braking_slack` that *any* plan from ``(position,
    velocity)`` now can reach with straight braking as its fallback, and the robot it is for
    (-1: none).

    A plan's next state is one step within the acceleration limit, so its braking trajectory is
    within :func:`braking_deviation` of the robot's braking trajectory now, at every instant
    after that step. The check's slack is a lower bound on the true smallest distance (less
    contact and margin), which at any one instant is at most the distance of the braking
    trajectories now plus that deviation. Where this bound is negative no plan can pass (with
    straight braking as its fallback), so the MPC need not solve for one."""
    # The partners' fields after ``robot`` are the kernel's arguments in their order; it returns a
    # Python float and int.
    return _bound_kernel(partners.robot, np.asarray(position, dtype=float), np.asarray(velocity, dtype=float),
                         *partners[1:], float(step), MAX_SAMPLES)
