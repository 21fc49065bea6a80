"""Statistics of rates: Wilson score intervals, Newcombe's interval of a difference, and how they are read.

A rate ``k / n`` is reported with its 95 % Wilson score interval (:func:`wilson_interval`); a
difference of two rates with Newcombe's hybrid score interval (:func:`newcombe_difference`),
which is built from the two Wilson intervals. Two rates are called different only when their
intervals do not overlap, a conservative rule that the report states wherever it uses it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodnav.experiments.paper import PLANNER_EQUIVALENCE

#: Two-sided 95 % quantile of the standard normal distribution.
Z95 = 1.959963984540054


@dataclass(frozen=True)
class Interval:
    """A rate (or a difference of rates) and its confidence interval, all as fractions in [0, 1]
    (in [-1, 1] for a difference); arrays when the inputs were arrays, NaN where ``n = 0``."""

    rate: np.ndarray | float
    """Point estimate ``k / n``."""
    low: np.ndarray | float
    """Lower end of the interval."""
    high: np.ndarray | float
    """Upper end of the interval."""


def wilson_interval(successes, trials, z: float = Z95) -> Interval:
    """Wilson score interval of a binomial proportion ``k / n`` (Wilson 1927).

    ``centre = (k + z^2/2) / (n + z^2)``, ``half-width = z sqrt(k (n - k) / n + z^2 / 4) / (n + z^2)``:
    the set of ``p`` that a two-sided score test at level ``z`` does not reject. Vectorised over
    ``successes`` and ``trials``; NaN where ``trials == 0``. Unlike the normal approximation it
    stays inside [0, 1] and is not degenerate at ``k = 0`` or ``k = n``.
    """
    k = np.asarray(successes, dtype=float)
    n = np.asarray(trials, dtype=float)
    if np.any(k < 0) or np.any(k > n):
        raise ValueError(f"need 0 <= successes <= trials, got {successes!r} of {trials!r}")
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(n > 0, k / n, np.nan)
        denom = n + z * z
        centre = (k + z * z / 2.0) / denom
        half = z * np.sqrt(np.where(n > 0, k * (n - k) / n, np.nan) + z * z / 4.0) / denom
    # At k = 0 and k = n the ends are exactly 0 and 1; rounding would put them a hair inside.
    low = np.where(k == 0, 0.0, np.clip(centre - half, 0.0, 1.0))
    high = np.where(k == n, 1.0, np.clip(centre + half, 0.0, 1.0))
    low, high = np.where(n > 0, low, np.nan), np.where(n > 0, high, np.nan)
    if rate.ndim == 0:
        return Interval(float(rate), float(low), float(high))
    return Interval(rate, low, high)


def newcombe_difference(k1, n1, k2, n2, z: float = Z95) -> Interval:
    """Difference ``p1 - p2`` of two independent proportions with Newcombe's hybrid score interval.

    With Wilson intervals ``[l_i, u_i]`` of each proportion (Newcombe 1998, method 10):
    ``low = d - sqrt((p1 - l1)^2 + (u2 - p2)^2)``, ``high = d + sqrt((u1 - p1)^2 + (p2 - l2)^2)``.
    """
    a, b = wilson_interval(k1, n1, z), wilson_interval(k2, n2, z)
    d = np.asarray(a.rate) - np.asarray(b.rate)
    low = d - np.sqrt((np.asarray(a.rate) - a.low) ** 2 + (b.high - np.asarray(b.rate)) ** 2)
    high = d + np.sqrt((a.high - np.asarray(a.rate)) ** 2 + (np.asarray(b.rate) - b.low) ** 2)
    if d.ndim == 0:
        return Interval(float(d), float(low), float(high))
    return Interval(d, low, high)


def intervals_separate(a: Interval, b: Interval) -> int:
    """+1 when ``a``'s interval lies wholly above ``b``'s, -1 wholly below, 0 when they overlap or either is empty."""
    if any(math.isnan(float(x)) for x in (a.low, a.high, b.low, b.high)):
        return 0
    if a.low > b.high:
        return 1
    if a.high < b.low:
        return -1
    return 0


def fmt_rate(iv: Interval, n: int | None = None) -> str:
    """``92.5 [81.8, 97.4]`` in percent, with `` (n)`` when ``n`` is given; ``-`` when undefined."""
    if math.isnan(float(iv.rate)):
        return "-"
    text = f"{100 * iv.rate:.1f} [{100 * iv.low:.1f}, {100 * iv.high:.1f}]"
    return f"{text} ({n})" if n is not None else text


def mean_sd(values) -> tuple[float, float, int]:
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return math.nan, math.nan, 0
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else 0.0, int(v.size)


def fmt_mean_sd(mean: float, sd: float, n: int, digits: int = 1) -> str:
    if n == 0:
        return "-"
    return f"{mean:.{digits}f} ± {sd:.{digits}f}" if n > 1 else f"{mean:.{digits}f}"


def planner_verdict(d: Interval, margin: float = PLANNER_EQUIVALENCE) -> str:
    """What a difference of success rates between two planners says about "the planner barely matters".

    The claim holds when the whole interval of the difference lies within ``+-margin`` percentage
    points, is contradicted when it lies wholly beyond them, and is left open otherwise.
    """
    eq = margin / 100
    if d.low >= -eq and d.high <= eq:
        return (f"the whole interval lies within ±{margin:.0f} points, so at this sample size the paper's claim "
                "that the planner barely matters holds")
    if d.low > eq or d.high < -eq:
        return (f"the whole interval lies beyond ±{margin:.0f} points, so the planner does matter here, against "
                "the paper")
    return (f"the interval reaches beyond ±{margin:.0f} points, so these trials can neither confirm nor refute the "
            "claim")
