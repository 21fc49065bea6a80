"""Steady-state strategy selection of two robots with two strategies: the paper's Fig. 2a/2b.

Two robots, strategies S1 = (1,2) and S2 = (2,1), ``A = 1``, ``b = 0``, equal ``u`` and ``d``.
Robot 1 starts with ``z_11(0) = z_values[a]``, robot 2 with ``z_21(0) = z_values[c]``, and
``z_12(0) = z_22(0) = 0``; eq. (1) is integrated to steady state for the whole grid of ``(a, c)``
at once, and ``x11[a, c]`` is the limit of ``x_11(t)`` by eq. (3).

What to expect (with ``y_i = z_i1 - z_i2``, eq. (1) reads ``dy_1/dt = -d (y_1 - u tanh(y_2 / 2))``
and symmetrically, since ``R(a) - R(-a) = tanh(a)``): for ``u < 2`` every start tends to
``y = 0`` and ``x11 = 1/2``; for ``u > 2`` the robots agree on ``y_1 = y_2 = +-y*`` with
``y* = u tanh(y*/2)``, decided by the sign of ``z_11(0) + z_21(0)``. The anti-diagonal
``z_11(0) + z_21(0) = 0`` is invariant and flows to the saddle ``y = 0``.

Why relative opinions are integrated
------------------------------------
The probabilities depend on the opinions only through the relative opinions ``zbar`` of eq. (2),
and ``zbar`` obeys a closed system: the centred eq. (1), ``dzbar/dt = P f(zbar)`` with ``P`` the
centring of eq. (2) and ``f`` the right-hand side of eq. (1). We integrate that. On the
anti-diagonal the relative opinions are fixed by swapping both robots and strategies at once,
and the right-hand side commutes with that swap *exactly in floating point* (the same
operations on swapped operands), so the computed solution stays on the saddle's stable
manifold and the limit there is exactly 1/2. Integrating the raw opinions instead, the robots'
differing means enter through rounding, which pushes the anti-diagonal off the saddle (it is
unstable at rate ``d (u/2 - 1)``) to an arbitrary side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from nodnav.decision.opinion import opinion_rate, relative_opinions, strategy_probabilities


@dataclass(frozen=True)
class HeatmapResult:
    """Limits of ``x_11(t)`` over a grid of initial opinions (Fig. 2a/2b)."""

    u: float
    """Attention ``u_i`` of both robots."""
    z_values: np.ndarray
    """``(N,)`` initial opinions ``z_11(0)`` (rows) and ``z_21(0)`` (columns)."""
    x11: np.ndarray
    """``(N, N)``: ``x11[a, c] = lim x_11(t)`` for ``z_11(0) = z_values[a]``, ``z_21(0) = z_values[c]``."""
    converged: bool
    """Whether ``residual <= tol`` was reached before ``max_time`` (the success flag)."""
    residual: float
    """Largest ``|dzbar/dt|`` over the grid at the end, the rate of the relative opinions (2) that
    alone determine ``x`` (the means of the raw opinions drift to ``u/2`` independently)."""
    t_end: float
    """Time integrated to (s)."""
    d: float = 1.0
    """Resistance ``d_i``."""
    eta: float = 1.0
    """Softmax temperature of eq. (3)."""
    reason: str = ""
    """Empty on convergence, else why not."""


def z_grid(n: int = 41) -> np.ndarray:
    """``n`` initial opinions from -10 to 10 as ``np.linspace``, made exactly antisymmetric
    (``z[i] == -z[n-1-i]`` bit for bit) so that the anti-diagonal of the grid is exactly
    ``z_11(0) + z_21(0) = 0``."""
    if n < 2:
        raise ValueError(f"n must be at least 2, got {n}")
    z = np.linspace(-10.0, 10.0, n)
    return 0.5 * (z - z[::-1])


def steady_state_selection(
    u: float,
    z_values: np.ndarray,
    d: float = 1.0,
    eta: float = 1.0,
    t_final: float | None = None,
    rtol: float = 1e-9,
    atol: float = 1e-11,
    tol: float = 1e-8,
    max_time: float | None = None,
) -> HeatmapResult:
    """Steady-state selection ``lim x_11(t)`` of eqs. (1) and (3) over a grid of initial opinions.

    The grid's ``4 N^2`` relative opinions are one system for ``scipy.integrate.solve_ivp``
    (RK45, ``rtol``/``atol``), integrated to ``t_final`` (default ``20 / d``) and then over
    doubling horizons until the largest ``|dzbar/dt|`` is at most ``tol`` or ``max_time``
    (default ``1000 / d``) is reached; near the pitchfork ``u = 2`` the approach is algebraic
    and may not converge, which ``converged`` and ``reason`` report.
    """
    if not (np.isfinite(u) and np.isfinite(d) and np.isfinite(eta)):  # NaN would never converge: a hang
        raise ValueError(f"u, d and eta must be finite, got u={u}, d={d}, eta={eta}")
    if d <= 0 or eta <= 0:
        raise ValueError(f"d and eta must be positive, got d={d}, eta={eta}")
    z_values = np.asarray(z_values, dtype=float)
    if z_values.ndim != 1 or z_values.size < 1:
        raise ValueError(f"z_values must be a non-empty 1-D array, got shape {z_values.shape}")
    n = z_values.size
    horizon = 20.0 / d if t_final is None else float(t_final)
    if horizon <= 0:
        raise ValueError(f"t_final must be positive, got {t_final}")
    limit = max(1000.0 / d if max_time is None else float(max_time), horizon)

    z0 = np.zeros((n, n, 2, 2))
    z0[:, :, 0, 0] = z_values[:, None]
    z0[:, :, 1, 0] = z_values[None, :]
    shape = z0.shape

    def rate(_t: float, flat: np.ndarray) -> np.ndarray:
        return relative_opinions(opinion_rate(flat.reshape(shape), u, d, 0.0)).ravel()

    state, t = relative_opinions(z0).ravel(), 0.0
    while True:
        sol = solve_ivp(rate, (t, horizon), state, method="RK45", rtol=rtol, atol=atol, t_eval=[horizon])
        if not sol.success:
            x11 = strategy_probabilities(state.reshape(shape), eta)[..., 0, 0]
            residual = float(np.max(np.abs(rate(t, state))))
            return HeatmapResult(float(u), z_values, x11, False, residual, t, d, eta,
                                 f"solve_ivp failed at t = {t:g}: {sol.message}")
        state, t = sol.y[:, -1], horizon
        residual = float(np.max(np.abs(rate(t, state))))
        if residual <= tol or t >= limit:
            break
        horizon = min(2.0 * horizon, limit)

    x11 = strategy_probabilities(state.reshape(shape), eta)[..., 0, 0]
    converged = residual <= tol
    reason = "" if converged else f"max |dzbar/dt| = {residual:.3g} > tol = {tol:g} at t = {t:g}"
    return HeatmapResult(float(u), z_values, x11, converged, residual, t, d, eta, reason)
