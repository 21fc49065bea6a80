"""Executing a joint plan by its precedences, not by its clock.

A joint plan (a :class:`~nodnav.planning.base.JointTrajectory`) says where every robot is at
every sample time. Followed by the clock, it only works if every robot keeps to its timing: a
follower that drives up to the mouth on time meets a leader that started late, and the two
press the mouth together. Robust execution of multi-robot schedules (the temporal plan graph of
Hoenig et al., 2016, and the action dependency graph of Hoenig et al., 2019) keeps instead what
the plan's timing was *for*: the order in which robots use the same space. A robot may go where
another robot was earlier in the plan only once that robot has actually moved on.

Here, robot ``m`` at sample ``k`` *depends on* robot ``j`` at an earlier sample ``k'`` when
``m``, at ``k``, comes closer than the conflict distance ``rho_mj`` to where ``j`` stood at
``k'``, and closer than ``m`` itself was to it then (:func:`plan_dependencies`): ``m`` moves
into the room ``j`` vacates. Two robots that move apart, or one that stands still, create no
dependency, so pairs that start closer than the conflict distance (jammed robots being pulled
apart by the plan) do not wait for each other. Dependencies reach back at least ``lag`` samples,
which rules out cycles between robots that pass each other closely within one sample, except to
the plan's first sample, where every robot actually stands: nobody may move into the room of a
robot that has not yet moved, however soon the plan has it go.

At run time each robot estimates how far every robot of its plan has got along its own planned
path from what it observes (:func:`observed_progress`), and may advance along its own path up to
the last sample whose every dependency is met (:func:`gate_sample`). Everything here is pure and
works on arrays; the closed loop keeps the state (``nodnav.sim``).
"""

from __future__ import annotations

import numpy as np

from nodnav.compiled import compiled

#: How much closer than before (m) a robot must come to another's earlier place to depend on it.
APPROACH_EPSILON = 1e-6


def plan_dependencies(positions: np.ndarray, conflict: np.ndarray, lag: int) -> np.ndarray:
    """The precedences of a joint plan, ``(K, n, n)`` integers.

    ``positions`` ``(K, n, 2)`` is the plan at its samples, ``conflict`` ``(n, n)`` the distance
    (m) within which two robots' places conflict (e.g. the sum of their radii and a margin).
    Entry ``[k, m, j]`` is the latest sample ``k' <= max(k - lag, 0)`` (``k >= 1``) such that robot ``m`` at some
    sample ``k'' <= k`` depends on robot ``j`` at ``k'`` (see the module docstring), or -1 if there
    is none: robot ``m`` may be where the plan has it at sample ``k`` once robot ``j`` has got
    past sample ``[k, m, j]``. The entries are non-decreasing in ``k`` (a running maximum).
    """
    p = np.ascontiguousarray(positions, dtype=float)
    if p.ndim != 3 or p.shape[2] != 2:
        raise ValueError(f"positions must be (K, n, 2), got {p.shape}")
    rho = np.ascontiguousarray(conflict, dtype=float)
    return _dependencies_kernel(p, rho, max(int(lag), 1), APPROACH_EPSILON)


@compiled
def _dependencies_kernel(p, rho, lag, epsilon):
    """The loops of :func:`plan_dependencies`: for each pair, scan every earlier sample of the
    other robot for a place this one moves into, then take the running maximum."""
    n_samples, n = p.shape[0], p.shape[1]
    out = np.full((n_samples, n, n), -1, dtype=np.int64)
    for m in range(n):
        for j in range(n):
            if j == m:
                continue
            r2 = rho[m, j] * rho[m, j]
            best = -1
            for k in range(n_samples):
                mx, my = p[k, m, 0], p[k, m, 1]
                # Scan back from the latest admissible sample: the first hit is the latest. The
                # plan's first sample (where everybody stands now) is admissible from k = 1 on.
                latest = max(k - lag, 0) if k >= 1 else -1
                for kk in range(latest, best, -1):
                    jx, jy = p[kk, j, 0], p[kk, j, 1]
                    dx, dy = mx - jx, my - jy
                    d2 = dx * dx + dy * dy
                    if d2 >= r2:
                        continue
                    ex, ey = p[kk, m, 0] - jx, p[kk, m, 1] - jy
                    before = np.sqrt(ex * ex + ey * ey)
                    if np.sqrt(d2) < before - epsilon:
                        best = kk
                        break
                out[k, m, j] = best
    return out



def observed_progress(path: np.ndarray, position: np.ndarray, since: int, tolerance: float) -> int:
    """How far a robot has got along its planned samples ``path`` ``(K, 2)``, judged from where
    it is observed, ``position`` ``(2,)``: the sample nearest to it among ``since..K-1`` (progress
    never goes back), the earliest of those within ``tolerance`` (m) of the nearest distance.

    Taking the earliest near-nearest sample keeps a robot that waits in place at the waiting
    sample where its wait begins until it actually moves on, and a path that comes back over
    itself from counting as travelled before it has been.
    """
    return int(progress_kernel(np.ascontiguousarray(path, dtype=float), np.asarray(position, dtype=float),
                                int(since), float(tolerance)))


@compiled
def progress_kernel(path, position, since, tolerance):
    """The scan of :func:`observed_progress`."""
    n_samples = path.shape[0]
    since = min(max(since, 0), n_samples - 1)
    best = np.inf
    for k in range(since, n_samples):
        d = np.hypot(path[k, 0] - position[0], path[k, 1] - position[1])
        best = min(best, d)
    for k in range(since, n_samples):
        if np.hypot(path[k, 0] - position[0], path[k, 1] - position[1]) <= best + tolerance:
            return k
    return since


def gate_sample(dependencies: np.ndarray, robot: int, progress: np.ndarray) -> int:
    """The last sample of robot ``robot``'s plan whose every dependency is met, given each robot's
    ``progress`` ``(n,)`` (samples, :func:`observed_progress`); ``K - 1`` when nothing holds it, 0
    when even the next sample is held (the robot stays where the plan starts it).

    A dependency ``[k, robot, j]`` is met when robot ``j`` has got past it:
    ``progress[j] > dependencies[k, robot, j]``.
    """
    return int(gate_kernel(np.ascontiguousarray(dependencies[:, robot, :]),
                            np.ascontiguousarray(progress, dtype=np.int64), int(robot)))


@compiled
def gate_kernel(row, progress, robot):
    """The scan of :func:`gate_sample` over the running maxima ``row`` ``(K, n)``."""
    n_samples, n = row.shape[0], row.shape[1]
    for k in range(n_samples):
        for j in range(n):
            if j != robot and row[k, j] >= progress[j]:
                return max(k - 1, 0)
    return n_samples - 1
