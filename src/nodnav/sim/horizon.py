"""The compiled steps of a planned method's ``act`` (:mod:`nodnav.sim.methods`): the other robots'
predictions over the MPC horizon, the gated execution's reading of the plan, and one robot's whole
step of bookkeeping before its controller in one call (:func:`gated_step`)."""

from __future__ import annotations

import math

import numpy as np

from nodnav.compiled import compiled
from nodnav.sim.execution import _observe_held_kernel, _observe_kernel, careful_radii, read_kernel


@compiled
def braking_extrapolation(positions: np.ndarray, velocities: np.ndarray, decel: np.ndarray,
                          times: np.ndarray) -> np.ndarray:
    """Where robots moving at ``velocities`` are at ``times`` if they brake at once along their
    velocity with deceleration ``decel`` until they stop, ``(n, K, 2)``."""
    out = np.empty((positions.shape[0], times.shape[0], 2))
    for j in range(positions.shape[0]):
        vx, vy = velocities[j, 0], velocities[j, 1]
        speed = math.sqrt(vx * vx + vy * vy)
        hx, hy = (vx / speed, vy / speed) if speed > 0 else (0.0, 0.0)
        stop = speed / decel[j]
        for s in range(times.shape[0]):
            tau = min(times[s], stop)  # braking time so far
            travelled = speed * tau - 0.5 * decel[j] * tau * tau
            out[j, s, 0] = positions[j, 0] + hx * travelled
            out[j, s, 1] = positions[j, 1] + hy * travelled
    return out


@compiled
def horizon_predictions(planned: np.ndarray, columns: np.ndarray, positions: np.ndarray, velocities: np.ndarray,
                        decel: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The three predictions of every other robot over the MPC horizon, ``(3 n, K, 2)``.

    ``planned`` ``(1 + K, n_plan, 2)`` is the robot's joint plan now and at ``times``; other
    robot ``j``, observed at ``positions[j]`` moving at ``velocities[j]``, is column
    ``columns[j]`` of it (-1: not in the plan). Rows ``0..n-1``: the plan's motion displaced to
    start where the robot is now (held still if not in the plan); ``n..2n-1``: constant
    velocity; ``2n..3n-1``: :func:`braking_extrapolation`.
    """
    n, k = positions.shape[0], times.shape[0]
    out = np.empty((3 * n, k, 2))
    out[2 * n:] = braking_extrapolation(positions, velocities, decel, times)
    for j in range(n):
        m = columns[j]
        for s in range(k):
            for d in range(2):
                shift = planned[1 + s, m, d] - planned[0, m, d] if m >= 0 else 0.0
                out[j, s, d] = positions[j, d] + shift
                out[n + j, s, d] = positions[j, d] + velocities[j, d] * times[s]
    return out


@compiled
def gated_horizon(times, plan_positions, t0, clocks, offsets, sample_times, gates, dt, columns, positions, velocities,
                  others, decel, horizon_times):
    """One control step of a gated execution in one call: the plan read at ``offsets`` after each
    robot's clock, held at its gate (:meth:`~nodnav.sim.execution.PlanExecution.read`,
    ``(M, n, 2)``), the :func:`horizon_predictions` of the robots ``others`` (rows of every
    robot's observed ``positions`` and ``velocities`` ``(N, 2)``) from it, and then the clocks
    run on by ``dt`` up to their gates, in place (:meth:`~nodnav.sim.execution.PlanExecution.advance`)."""
    n = clocks.shape[0]
    limits = np.empty(n)
    for r in range(n):
        limits[r] = sample_times[gates[r]]
    planned = read_kernel(times, plan_positions, t0, clocks, offsets, limits)
    for r in range(n):
        clocks[r] = min(clocks[r] + dt, max(clocks[r], limits[r]))
    m = others.shape[0]
    seen_positions, seen_velocities = np.empty((m, 2)), np.empty((m, 2))
    for j in range(m):
        for d in range(2):
            seen_positions[j, d] = positions[others[j], d]
            seen_velocities[j, d] = velocities[others[j], d]
    return planned, horizon_predictions(planned, columns, seen_positions, seen_velocities, decel, horizon_times)


@compiled
def at_rest_and_clear(position, velocity, reference, predictions, radii, reach, clearance, tolerance):
    """Whether a robot at ``position`` moving at ``velocity`` is at rest (speed at most ``tolerance``),
    told to stay (every point of its ``reference`` ``(K, 2)`` within ``tolerance`` of where it is)
    and clear of everyone: every point of every prediction ``(m, K, 2)`` of radius ``radii[j]``
    more than ``reach + radii[j] + clearance`` away (``reach``: its radius plus the safety margin)."""
    if np.sqrt(velocity[0] * velocity[0] + velocity[1] * velocity[1]) > tolerance:
        return False
    for k in range(reference.shape[0]):
        if abs(reference[k, 0] - position[0]) > tolerance or abs(reference[k, 1] - position[1]) > tolerance:
            return False
    for j in range(predictions.shape[0]):
        keep = reach + radii[j] + clearance
        for k in range(predictions.shape[1]):
            dx, dy = predictions[j, k, 0] - position[0], predictions[j, k, 1] - position[1]
            if dx * dx + dy * dy <= keep * keep:
                return False
    return True


@compiled
def gated_step(positions, velocities, i, t, times, plan_positions, t0, clocks, samples, dependencies, progress, gates,
               sample_times, rows, tolerance, patience, reach, anchors, anchored, since, released_until, offsets, dt,
               columns, others, decel, horizon_times, seen_positions, seen_velocities, has_seen, accel, radii, safety,
               slack, threshold, mode, surprised, surprise_steps, conflicted, base):
    """Robot ``i``'s bookkeeping of one control step of a gated execution in one call, the steps
    of :meth:`~nodnav.sim.methods.PlannedMethod.act` before its controller in their order:
    :meth:`~nodnav.sim.execution.WaitRelease.observe` (the plan's progress and gates, the wait and
    its release, with the state of ``anchors`` ``(N_r, N, 2)``, ``anchored``, ``since`` and
    ``released_until`` ``(N_r,)`` updated in place), :func:`gated_horizon` and
    :func:`~nodnav.sim.execution.careful_radii` (``surprised``: robot ``i``'s row). Returns the
    reference ``(K, 2)``, the predictions ``(3 m, K, 2)`` and their radii ``(3 m,)``."""
    waiting = patience > 0.0
    if waiting and not anchored[i]:
        anchors[i] = positions
        anchored[i] = True
        since[i] = t
    n = rows.shape[0]
    stuck = np.zeros(n, dtype=np.bool_)
    held, moved = _observe_held_kernel(samples, positions, rows, tolerance, dependencies, progress, gates,
                                       anchors[i] if waiting else positions, reach, stuck)
    if waiting:
        release = True
        if t >= released_until[i] - 1e-9:
            release = False
            if moved or not held:  # not held, or somebody of the plan got somewhere
                anchors[i] = positions
                since[i] = t
            elif not t - since[i] < patience - 1e-9:
                released_until[i] = t + patience
                release = True
        if release and stuck.any():  # PlanExecution.release: its precedences on them dropped, its gates anew
            for c in range(n):
                if stuck[c]:
                    dependencies[:, 0, c] = -1
            seen = np.empty((n, 2))
            for c in range(n):
                seen[c, 0], seen[c, 1] = positions[rows[c], 0], positions[rows[c], 1]
            _observe_kernel(samples, seen, tolerance, dependencies, progress, gates)
    planned, predictions = gated_horizon(times, plan_positions, t0, clocks, offsets, sample_times, gates, dt, columns,
                                         positions, velocities, others, decel, horizon_times)
    widened = careful_radii(positions, velocities, seen_positions, seen_velocities, has_seen, i, others, accel, radii,
                            safety, slack, dt, threshold, mode, surprised, surprise_steps, conflicted, base)
    return planned[1:, 0], predictions, widened
