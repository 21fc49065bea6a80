"""Piecewise-linear interpolation of sampled values (a request's reference and predictions) as
weight matrices, so that one product interpolates every sampled series at once."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def interpolation_matrix(times: ArrayLike, query: ArrayLike) -> np.ndarray:
    """Weights ``W`` (``(len(query), K)``) with ``W @ values`` the piecewise-linear interpolant.

    Linear through ``(times, values)``; before the first sample it continues the first segment
    (the request gives no value at ``tau = 0``), after the last it holds the last value (a plan
    that has ended stands still, as :class:`~nodnav.planning.base.JointTrajectory` does).
    """
    times = np.asarray(times, dtype=float)
    q = np.atleast_1d(np.asarray(query, dtype=float))
    k = len(times)
    w = np.zeros((q.size, k))
    if k == 1:
        w[:, 0] = 1.0
        return w
    qq = np.minimum(q, times[-1])
    idx = np.clip(np.searchsorted(times, qq, side="right") - 1, 0, k - 2)
    frac = (qq - times[idx]) / (times[idx + 1] - times[idx])
    rows = np.arange(q.size)
    w[rows, idx] = 1.0 - frac
    w[rows, idx + 1] += frac
    return w


def slope_matrix(times: ArrayLike, t: float) -> np.ndarray:
    """Weights ``(K,)`` giving the left derivative at ``t`` of the interpolant of :func:`interpolation_matrix`."""
    times = np.asarray(times, dtype=float)
    w = np.zeros(len(times))
    if len(times) == 1 or t > times[-1]:
        return w
    i = int(np.clip(np.searchsorted(times, t, side="left") - 1, 0, len(times) - 2))
    w[i], w[i + 1] = -1.0, 1.0
    return w / (times[i + 1] - times[i])
