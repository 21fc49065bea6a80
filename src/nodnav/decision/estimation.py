"""Estimating the other robots' opinions from their observed motion, eq. (4) (Section II-B-3).

Robot ``i`` cannot read robot ``k``'s opinions. It compares what ``k`` actually did over the last
window ``[t - T, t]`` with what its planner predicted ``k`` would do under each strategy; the
smaller the deviation, the more ``k`` is taken to favour that strategy. The saturated relative
estimate ``r^l_ik = R(zbar'_kl)`` then stands in for ``R(zbar_kl)`` in eq. (5), through
:func:`nodnav.decision.opinion.social_sum`, which applies the weights ``A^{jl}_ik``.
"""

from __future__ import annotations

import numpy as np

from nodnav.compiled import compiled
from nodnav.decision.opinion import relative_opinions, saturation


def estimated_opinions(observed: np.ndarray, planned: np.ndarray, dt: float, K1: float = 5.0) -> np.ndarray:
    """Estimated opinions ``z'_kj = -K1 int_{t-T}^t ||X_k(tau) - X_k^{(i,j)}(tau)||^2 dtau``, eq. (4a).

    Parameters
    ----------
    observed : ``(N_k, M, D)`` states ``X_k = (p_x, p_y, v_x, v_y)`` (``D = 4``) of the observed
        robots, sampled every ``dt`` from ``t - T`` to ``t`` with both ends included
        (``T = (M - 1) dt``).
    planned : ``(N_s, N_k, M, D)`` the states the planner predicted for them under each strategy,
        at the same instants.
    dt : sampling interval (s).
    K1 : scaling factor (1 / (m^2 s)); paper: 5.

    Returns
    -------
    ``(N_k, N_s)`` array of ``z'_kj <= 0``; the integral uses the trapezoidal rule, exact for
    deviations that vary linearly between samples.
    """
    observed = np.asarray(observed, dtype=float)
    planned = np.asarray(planned, dtype=float)
    if observed.ndim != 3:
        raise ValueError(f"observed must have shape (N_k, M, D), got {observed.shape}")
    if planned.ndim != 4 or planned.shape[1:] != observed.shape:
        raise ValueError(f"planned must have shape (N_s,) + {observed.shape}, got {planned.shape}")
    if dt <= 0:
        raise ValueError(f"dt must be positive, got {dt}")
    if planned.shape[-1] >= 8 or planned.shape[2] - 1 > PAIRWISE_BLOCK:  # beyond the kernel's summation orders
        return estimated_opinions_plain(observed, planned, dt, K1)
    return _deviation_integrals(observed, planned, float(dt), float(K1)).T


def estimated_opinions_plain(observed: np.ndarray, planned: np.ndarray, dt: float, K1: float = 5.0) -> np.ndarray:
    """:func:`estimated_opinions` in NumPy, the reference its compiled loop is tested against."""
    squared = np.sum((planned - observed[None]) ** 2, axis=-1)  # (N_s, N_k, M)
    return -K1 * np.trapezoid(squared, dx=dt, axis=-1).T


#: The longest sum :func:`_pairwise_sum` adds as NumPy does (its pairwise block; NumPy splits
#: longer ones in halves, which the kernel does not).
PAIRWISE_BLOCK = 128


@compiled
def _pairwise_sum(a, n):
    """``np.add.reduce`` of ``a[:n]`` (``n <= PAIRWISE_BLOCK``) in NumPy's order: left to right
    below 8 terms, else eight running sums combined pairwise and the rest added after."""
    if n < 8:
        res = -0.0
        for i in range(n):
            res += a[i]
        return res
    r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    i = 8
    while i < n - n % 8:
        r0, r1, r2, r3 = r0 + a[i], r1 + a[i + 1], r2 + a[i + 2], r3 + a[i + 3]
        r4, r5, r6, r7 = r4 + a[i + 4], r5 + a[i + 5], r6 + a[i + 6], r7 + a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[i]
        i += 1
    return res


@compiled
def _deviation_integrals(observed, planned, dt, K1):
    """Eq. (4a)'s ``-K1 int ||X_k - X_k^(l)||^2`` ``(N_s, N_k)``, element by element with
    :func:`estimated_opinions_plain`'s operations: the squared deviation summed over the state's
    components, then the trapezoidal rule's terms ``dt (y_{m+1} + y_m) / 2`` summed over the window."""
    g, n, m, d = planned.shape
    out = np.empty((g, n))
    squares = np.empty(d)
    squared = np.empty(m)
    terms = np.empty(max(m - 1, 0))
    for s in range(g):
        for k in range(n):
            for t in range(m):
                for c in range(d):
                    e = planned[s, k, t, c] - observed[k, t, c]
                    squares[c] = e * e
                squared[t] = _pairwise_sum(squares, d)
            for t in range(m - 1):
                terms[t] = dt * (squared[t + 1] + squared[t]) / 2.0
            out[s, k] = -K1 * (_pairwise_sum(terms, m - 1) if m > 1 else 0.0)
    return out


def reachable_predictions(observed: np.ndarray, planned: np.ndarray, accel: np.ndarray, dt: float) -> np.ndarray:
    """The planned motion as each observed robot can carry it out, for eq. (4) (not in the paper).

    A plan is made from the robots' observed positions, but the planner may have a robot move at
    once in a direction it is not moving in (back out while it still drives forward). A robot
    that starts carrying out such a plan first brakes, and over the window it then looks like the
    plans in which it keeps going: eq. (4) reads a robot that yields as one that presses on, and
    two robots that both yield each read the other as pressing on. So each prediction is
    replaced by the motion of a robot that starts from its observed state at the start of the
    window and follows the planned velocity, its velocity changing by at most ``accel * dt`` a
    sample (positions by the trapezoidal rule). A plan the robot can follow from where it was
    is unchanged.

    Parameters
    ----------
    observed : ``(N_k, M, 4)`` observed states (px, py, vx, vy), as :func:`estimated_opinions`.
    planned : ``(N_s, N_k, M, 4)`` planned states at the same instants.
    accel : ``(N_k,)`` each observed robot's acceleration limit (m/s^2).
    dt : sampling interval (s).

    Returns
    -------
    ``(N_s, N_k, M, 4)`` the reachable predictions.
    """
    observed = np.asarray(observed, dtype=float)
    planned = np.asarray(planned, dtype=float)
    out = np.empty_like(planned)
    p = np.broadcast_to(observed[:, 0, :2], planned.shape[:2] + (2,)).copy()
    v = np.broadcast_to(observed[:, 0, 2:], planned.shape[:2] + (2,)).copy()
    out[:, :, 0, :2], out[:, :, 0, 2:] = p, v
    step = (np.asarray(accel, dtype=float) * dt)[None, :]
    for m in range(1, planned.shape[2]):
        dv = planned[:, :, m, 2:] - v
        norm = np.linalg.norm(dv, axis=-1)
        scale = np.where(norm > step, step / np.maximum(norm, 1e-12), 1.0)
        v_next = v + dv * scale[..., None]
        p = p + 0.5 * dt * (v + v_next)
        v = v_next
        out[:, :, m, :2], out[:, :, m, 2:] = p, v
    return out


def mismatch_predictions(observed: np.ndarray, planned: np.ndarray, accel: np.ndarray, dt: float) -> np.ndarray:
    """The planned motion plus what the observed robot's initial mismatch with it costs (not in the paper).

    :func:`reachable_predictions` has the robot chase the planned *velocity* at its acceleration
    limit. A plan timed within that limit (``planner.timing: feasible``) already accelerates at
    it, and its sample ``m`` carries the velocity of step ``m``, one ``accel * dt`` ahead of a
    robot at rest: the chase then lags one step for good while the plan accelerates (at 2 m/s^2,
    0.1 m after a 1 s window), so the limit is counted twice and a robot that goes as planned
    looks like one that hesitates. Here only the mismatch is carried: the velocity error
    ``e = v_observed - v_planned`` at the start of the window shrinks by at most ``accel * dt`` a
    sample and its integral shifts the planned positions (the positions start at the observed
    ones). For a plan at constant velocity this is :func:`reachable_predictions`; a plan the
    robot follows is unchanged but for that first step.

    Shapes as :func:`reachable_predictions`.
    """
    observed = np.asarray(observed, dtype=float)
    planned = np.asarray(planned, dtype=float)
    # One compiled loop, the same float operations as mismatch_predictions_plain.
    return _mismatch_kernel(np.ascontiguousarray(observed), np.ascontiguousarray(planned),
                            np.asarray(accel, dtype=float) * dt, 0.5 * dt)


@compiled
def _mismatch_kernel(observed, planned, step, half_dt):
    """:func:`mismatch_predictions_plain` element by element (``step`` is ``accel * dt``)."""
    out = planned.copy()
    n_g, n_k, n_m = planned.shape[0], planned.shape[1], planned.shape[2]
    for g in range(n_g):
        for j in range(n_k):
            px = observed[j, 0, 0] - planned[g, j, 0, 0]
            py = observed[j, 0, 1] - planned[g, j, 0, 1]
            vx = observed[j, 0, 2] - planned[g, j, 0, 2]
            vy = observed[j, 0, 3] - planned[g, j, 0, 3]
            out[g, j, 0, 0] += px
            out[g, j, 0, 1] += py
            out[g, j, 0, 2] += vx
            out[g, j, 0, 3] += vy
            for m in range(1, n_m):
                norm = np.sqrt(vx * vx + vy * vy)
                scale = 1.0 - step[j] / max(norm, 1e-12) if norm > step[j] else 0.0
                nx, ny = vx * scale, vy * scale
                px = px + half_dt * (vx + nx)
                py = py + half_dt * (vy + ny)
                vx, vy = nx, ny
                out[g, j, m, 0] += px
                out[g, j, m, 1] += py
                out[g, j, m, 2] += vx
                out[g, j, m, 3] += vy
    return out


def mismatch_predictions_plain(observed: np.ndarray, planned: np.ndarray, accel: np.ndarray,
                               dt: float) -> np.ndarray:
    """:func:`mismatch_predictions` in NumPy, the reference its compiled loop is tested against."""
    observed = np.asarray(observed, dtype=float)
    planned = np.asarray(planned, dtype=float)
    out = planned.copy()
    err_p = observed[None, :, 0, :2] - planned[:, :, 0, :2]
    err_v = observed[None, :, 0, 2:] - planned[:, :, 0, 2:]
    out[:, :, 0, :2] += err_p
    out[:, :, 0, 2:] += err_v
    step = (np.asarray(accel, dtype=float) * dt)[None, :]
    for m in range(1, planned.shape[2]):
        norm = np.linalg.norm(err_v, axis=-1)
        scale = np.where(norm > step, 1.0 - step / np.maximum(norm, 1e-12), 0.0)
        next_v = err_v * scale[..., None]
        err_p = err_p + 0.5 * dt * (err_v + next_v)
        err_v = next_v
        out[:, :, m, :2] += err_p
        out[:, :, m, 2:] += err_v
    return out


def estimate_social_term(z_prime: np.ndarray, planned: np.ndarray | None = None) -> np.ndarray:
    """Estimated social scores ``r_kl = R(zbar'_kl)``, with ``zbar'`` from eq. (4b) and ``R`` from (9).

    ``z_prime`` is ``(N_k, N_s)`` from :func:`estimated_opinions`; the result has the same shape,
    values in ``[0, 1]``, largest for the strategy whose prediction matched best.

    ``planned`` ``(N_s,)`` (optional) says which strategies the planner found a joint path for.
    A strategy without one predicts nothing, so observed motion is no evidence for it: its score
    is 0 (``R(-inf)``), and eq. (4b) centres the others on their own mean. Without any planned
    strategy there is no evidence at all and every score is ``R(0) = 1/2``.
    """
    z_prime = np.asarray(z_prime, dtype=float)
    if planned is None:
        return saturation(relative_opinions(z_prime))
    planned = np.asarray(planned, dtype=bool)
    if planned.all():
        return saturation(relative_opinions(z_prime))
    if not planned.any():
        return np.full(z_prime.shape, 0.5)
    r = np.zeros(z_prime.shape)
    r[..., planned] = saturation(relative_opinions(z_prime[..., planned]))
    return r
