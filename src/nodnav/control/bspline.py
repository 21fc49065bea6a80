"""B-spline curves for the MPC of the paper's appendix (a third-order B-spline trajectory).

A B-spline of degree ``p`` with knots ``t_0 <= ... <= t_{n+p}`` and control points ``c_0..c_{n-1}``
is ``p(tau) = sum_k N_{k,p}(tau) c_k``. Everything here is linear algebra on the basis: the
MPC's position, velocity and acceleration are matrices applied to the control points, and the
cost integral is a quadratic form with an exact Gram matrix.

Facts used by the controller (standard; see Piegl and Tiller, *The NURBS Book*, ch. 2-3):

* Partition of unity and non-negativity: on the domain ``[t_p, t_n]`` the basis functions are
  non-negative and sum to one, so ``p(tau)`` lies in the convex hull of the ``p + 1`` control
  points of the span containing ``tau`` (convex-hull property).
* The derivative of a degree-``p`` B-spline is a degree-``p - 1`` B-spline on the knots
  ``t_1..t_{n+p-1}`` with control points ``d_k = p (c_{k+1} - c_k) / (t_{k+p+1} - t_{k+1})``,
  so bounding the derivative control points bounds the derivative everywhere.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def uniform_knots(duration: float, n_segments: int, degree: int = 3) -> np.ndarray:
    """Uniform (unclamped) knots ``t_k = (k - degree) h``, ``h = duration / n_segments``.

    The curve's domain ``[t_degree, t_{n_segments + degree}]`` is ``[0, duration]``; it has
    ``n_segments + degree`` control points and ``2 degree + n_segments + 1`` knots.
    """
    if n_segments < 1 or degree < 0 or duration <= 0:
        raise ValueError("need duration > 0, n_segments >= 1 and degree >= 0")
    h = duration / n_segments
    return (np.arange(n_segments + 2 * degree + 1) - degree) * h


def n_control_points(knots: np.ndarray, degree: int) -> int:
    """Number of control points ``n = len(knots) - degree - 1``."""
    return len(knots) - degree - 1


def domain(knots: np.ndarray, degree: int) -> tuple[float, float]:
    """The parameter interval ``[t_p, t_n]`` on which the basis is a partition of unity."""
    n = n_control_points(knots, degree)
    return float(knots[degree]), float(knots[n])


def basis(t: ArrayLike, knots: np.ndarray, degree: int) -> np.ndarray:
    """Basis functions ``N_{k,p}(t)`` as a ``(len(t), n)`` matrix (Cox-de Boor recursion).

    Evaluated span by span (The NURBS Book, algorithm A2.2), vectorised over ``t``. A parameter
    outside the domain uses the polynomial piece of the nearest span, so the curve extends
    smoothly; the right end of the domain belongs to the last span.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    knots = np.asarray(knots, dtype=float)
    n = n_control_points(knots, degree)
    span = np.clip(np.searchsorted(knots, t, side="right") - 1, degree, n - 1)
    left = np.empty((degree + 1, t.size))
    right = np.empty((degree + 1, t.size))
    values = np.zeros((degree + 1, t.size))
    values[0] = 1.0
    for j in range(1, degree + 1):
        left[j] = t - knots[span + 1 - j]
        right[j] = knots[span + j] - t
        saved = np.zeros(t.size)
        for r in range(j):
            temp = values[r] / (right[r + 1] + left[j - r])
            values[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        values[j] = saved
    out = np.zeros((t.size, n))
    rows = np.arange(t.size)
    for j in range(degree + 1):
        out[rows, span - degree + j] = values[j]
    return out


def greville_abscissae(knots: np.ndarray, degree: int) -> np.ndarray:
    """Greville abscissae ``xi_k = (t_{k+1} + ... + t_{k+p}) / p``, shape ``(n,)``.

    Linear precision: the curve with control points ``a + b xi_k`` is ``a + b tau`` exactly.
    """
    knots = np.asarray(knots, dtype=float)
    n = n_control_points(knots, degree)
    if degree == 0:
        return knots[:n].copy()
    window = np.lib.stride_tricks.sliding_window_view(knots[1:], degree)[:n]
    return window.mean(axis=1)


def derivative_operator(knots: np.ndarray, degree: int) -> np.ndarray:
    """Matrix ``D`` (``(n - 1, n)``) mapping control points to derivative control points.

    ``d_k = p (c_{k+1} - c_k) / (t_{k+p+1} - t_{k+1})``; the derivative curve has degree
    ``p - 1`` and knots ``knots[1:-1]``.
    """
    knots = np.asarray(knots, dtype=float)
    n = n_control_points(knots, degree)
    k = np.arange(n - 1)
    scale = degree / (knots[k + degree + 1] - knots[k + 1])
    d = np.zeros((n - 1, n))
    d[k, k] = -scale
    d[k, k + 1] = scale
    return d


def derivative_control_operator(knots: np.ndarray, degree: int, order: int) -> np.ndarray:
    """Matrix mapping control points to the control points of the ``order``-th derivative.

    Shape ``(n - order, n)``; the ``order``-th derivative has degree ``p - order`` and knots
    ``knots[order:len(knots) - order]``.
    """
    knots = np.asarray(knots, dtype=float)
    op = np.eye(n_control_points(knots, degree))
    for j in range(order):
        sub = knots[j:len(knots) - j]
        op = derivative_operator(sub, degree - j) @ op
    return op


def velocity_hull_operator(knots: np.ndarray) -> np.ndarray:
    """Matrix ``(S + 2, n)`` of points whose convex hull contains the velocity of a uniform cubic
    B-spline over its whole domain: ``v(t_3), d_1, ..., d_S, v(t_{S+3})``.

    The velocity is a uniform quadratic B-spline with control points ``d_k``; on span ``k`` its
    Bezier control points are ``(d_k + d_{k+1}) / 2, d_{k+1}, (d_{k+1} + d_{k+2}) / 2``, whose hull
    contains the span. The midpoints are the velocities at the knots, and every interior one is a
    convex combination of two ``d_k``; so these ``S + 2`` points suffice. They are tighter than all
    ``S + 2`` control points ``d_0..d_{S+1}``, of which ``d_0`` and ``d_{S+1}`` lie outside the domain.
    """
    knots = np.asarray(knots, dtype=float)
    if not np.allclose(np.diff(knots), knots[1] - knots[0]):
        raise ValueError("velocity_hull_operator needs uniform knots")
    lo, hi = domain(knots, 3)
    d1 = derivative_operator(knots, 3)
    return np.vstack([basis_derivative([lo], knots, 3, 1), d1[1:-1], basis_derivative([hi], knots, 3, 1)])


def basis_derivative(t: ArrayLike, knots: np.ndarray, degree: int, order: int = 0) -> np.ndarray:
    """Matrix ``M`` (``(len(t), n)``) with ``M @ c`` the ``order``-th derivative of the curve at ``t``."""
    if order > degree:
        return np.zeros((np.atleast_1d(t).size, n_control_points(knots, degree)))
    knots = np.asarray(knots, dtype=float)
    sub = knots[order:len(knots) - order]
    return basis(t, sub, degree - order) @ derivative_control_operator(knots, degree, order)


def evaluate(control_points: np.ndarray, t: ArrayLike, knots: np.ndarray, degree: int,
             order: int = 0) -> np.ndarray:
    """The curve (or its ``order``-th derivative) at ``t``, shape ``(len(t), dim)``."""
    return basis_derivative(t, knots, degree, order) @ np.asarray(control_points, dtype=float)


def gauss_legendre(breakpoints: np.ndarray, n_nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of ``n_nodes``-point Gauss-Legendre rules on every sub-interval.

    The composite rule integrates exactly every function that is a polynomial of degree at
    most ``2 n_nodes - 1`` between consecutive (distinct, sorted) breakpoints.
    """
    b = np.unique(np.asarray(breakpoints, dtype=float))
    x, w = np.polynomial.legendre.leggauss(n_nodes)
    half = 0.5 * np.diff(b)[:, None]
    mid = 0.5 * (b[1:] + b[:-1])[:, None]
    return (mid + half * x).ravel(), (half * w).ravel()


def gram_matrix(knots: np.ndarray, degree: int, order: int, start: float, end: float) -> np.ndarray:
    """Exact ``G_ij = integral_start^end N^(order)_i(tau) N^(order)_j(tau) dtau``, shape ``(n, n)``.

    The integrand is a polynomial of degree ``2 (p - order)`` on each knot span, so a
    ``p + 1``-point Gauss-Legendre rule per span (exact to degree ``2p + 1``) is exact.
    """
    knots = np.asarray(knots, dtype=float)
    inner = knots[(knots > start) & (knots < end)]
    nodes, weights = gauss_legendre(np.concatenate([[start], inner, [end]]), degree + 1)
    m = basis_derivative(nodes, knots, degree, order)
    return m.T @ (weights[:, None] * m)
