"""B-spline basics against hand formulas, finite differences and numerical quadrature."""

import numpy as np
import pytest
from scipy import integrate
from scipy.optimize import linprog

from nodnav.control import bspline


def clamped_knots(interior, degree):
    """An open (clamped) knot vector on [0, 1] with the given interior knots."""
    return np.concatenate([np.zeros(degree + 1), interior, np.ones(degree + 1)])


KNOT_CASES = [
    (bspline.uniform_knots(0.8, 8, 3), 3),
    (bspline.uniform_knots(2.0, 5, 2), 2),
    (bspline.uniform_knots(1.0, 4, 1), 1),
    (clamped_knots([0.1, 0.35, 0.4, 0.8], 3), 3),
]


@pytest.mark.parametrize("knots, degree", KNOT_CASES)
def test_partition_of_unity_and_non_negativity(knots, degree):
    lo, hi = bspline.domain(knots, degree)
    t = np.concatenate([np.linspace(lo, hi, 97), knots[(knots >= lo) & (knots <= hi)]])
    b = bspline.basis(t, knots, degree)
    assert b.shape == (len(t), len(knots) - degree - 1)
    np.testing.assert_allclose(b.sum(axis=1), 1.0, atol=1e-12)
    assert b.min() >= -1e-15


def test_uniform_knots_layout():
    knots = bspline.uniform_knots(0.8, 8, 3)
    np.testing.assert_allclose(knots, 0.1 * (np.arange(15) - 3))
    assert bspline.domain(knots, 3) == pytest.approx((0.0, 0.8))
    assert bspline.n_control_points(knots, 3) == 11


@pytest.mark.parametrize("knots, degree, order",
                         [(k, d, o) for k, d in KNOT_CASES for o in (1, 2) if o <= d])
def test_derivative_matches_finite_difference(knots, degree, order):
    lo, hi = bspline.domain(knots, degree)
    # Stay away from the knots, where higher derivatives of low degrees jump.
    t = np.linspace(lo, hi, 41)[1:-1] + 1e-3 * (hi - lo)
    t = t[np.min(np.abs(t[:, None] - knots[None]), axis=1) > 1e-3]
    h = 1e-5 * (hi - lo)
    analytic = bspline.basis_derivative(t, knots, degree, order)
    lower = bspline.basis_derivative(t - h, knots, degree, order - 1)
    upper = bspline.basis_derivative(t + h, knots, degree, order - 1)
    np.testing.assert_allclose(analytic, (upper - lower) / (2 * h), atol=1e-5 * np.abs(analytic).max())


def test_uniform_cubic_segment_hand_formula():
    """The uniform cubic segment p(u) = [(1-u)^3 c0 + (3u^3-6u^2+4) c1 + (-3u^3+3u^2+3u+1) c2 + u^3 c3] / 6."""
    rng = np.random.default_rng(3)
    knots = bspline.uniform_knots(0.8, 8, 3)
    c = rng.normal(size=(11, 2))
    h = 0.1
    for span in range(8):
        u = np.linspace(0.0, 1.0, 9)
        t = span * h + u * h
        c0, c1, c2, c3 = c[span:span + 4]
        hand = ((1 - u) ** 3)[:, None] * c0 + (3 * u**3 - 6 * u**2 + 4)[:, None] * c1 \
            + (-3 * u**3 + 3 * u**2 + 3 * u + 1)[:, None] * c2 + (u**3)[:, None] * c3
        np.testing.assert_allclose(bspline.evaluate(c, t, knots, 3), hand / 6.0, atol=1e-12)


@pytest.mark.parametrize("knots, degree", KNOT_CASES)
def test_collinear_control_points_give_the_straight_line(knots, degree):
    """Control points a + b xi_k (Greville abscissae) trace exactly p(t) = a + b t."""
    a, b = np.array([1.5, -2.0]), np.array([0.3, 0.7])
    xi = bspline.greville_abscissae(knots, degree)
    c = a + xi[:, None] * b
    lo, hi = bspline.domain(knots, degree)
    t = np.linspace(lo, hi, 33)
    np.testing.assert_allclose(bspline.evaluate(c, t, knots, degree), a + t[:, None] * b, atol=1e-12)
    np.testing.assert_allclose(bspline.evaluate(c, t, knots, degree, order=1), np.tile(b, (len(t), 1)), atol=1e-9)


def test_uniform_cubic_greville_abscissae_by_hand():
    knots = bspline.uniform_knots(0.8, 8, 3)
    np.testing.assert_allclose(bspline.greville_abscissae(knots, 3), 0.1 * (np.arange(11) - 1))


def test_gauss_legendre_is_exact_to_degree_2n_minus_1():
    nodes, weights = bspline.gauss_legendre(np.array([0.0, 0.3, 0.45, 1.0]), 3)
    for k in range(6):
        assert weights @ nodes**k == pytest.approx(1.0 / (k + 1), abs=1e-13)
    assert weights @ nodes**6 != pytest.approx(1.0 / 7, abs=1e-9)


@pytest.mark.parametrize("order", [0, 1, 2])
def test_gram_matrix_against_numerical_quadrature(order):
    knots = bspline.uniform_knots(0.8, 8, 3)
    rng = np.random.default_rng(7)
    c = rng.normal(size=11)
    g = bspline.gram_matrix(knots, 3, order, 0.0, 0.8)
    f = lambda t: bspline.evaluate(c[:, None], [t], knots, 3, order)[0, 0] ** 2  # noqa: E731
    reference = integrate.quad(f, 0.0, 0.8, points=knots[3:12], limit=200, epsabs=1e-13)[0]
    assert c @ g @ c == pytest.approx(reference, rel=1e-10)


def test_exact_quadratic_cost_against_quadrature():
    """integral ||p - r||^2 + w ||p'||^2 with r(t) = (t^2, 1 - t): expanded with the Gram matrices."""
    knots = bspline.uniform_knots(0.8, 8, 3)
    rng = np.random.default_rng(11)
    c = rng.normal(size=(11, 2))
    w = 0.37
    ref = lambda t: np.array([t**2, 1.0 - t])  # noqa: E731

    def integrand(t):
        p = bspline.evaluate(c, [t], knots, 3)[0]
        v = bspline.evaluate(c, [t], knots, 3, 1)[0]
        return np.sum((p - ref(t)) ** 2) + w * np.sum(v**2)

    reference = integrate.quad(integrand, 0.0, 0.8, points=knots[3:12], limit=200, epsabs=1e-13)[0]
    g = bspline.gram_matrix(knots, 3, 0, 0.0, 0.8) + w * bspline.gram_matrix(knots, 3, 1, 0.0, 0.8)
    nodes, weights = bspline.gauss_legendre(knots[3:12], 4)
    cross = bspline.basis(nodes, knots, 3).T @ (weights[:, None] * np.stack([ref(t) for t in nodes]))
    const = integrate.quad(lambda t: np.sum(ref(t) ** 2), 0.0, 0.8)[0]
    exact = np.sum(c * (g @ c)) - 2.0 * np.sum(c * cross) + const
    assert exact == pytest.approx(reference, rel=1e-10)


def in_hull(point, vertices):
    """Whether ``point`` is a convex combination of ``vertices`` (a feasibility LP)."""
    k = len(vertices)
    res = linprog(np.zeros(k), A_eq=np.vstack([vertices.T, np.ones(k)]), b_eq=np.append(point, 1.0),
                  bounds=[(0, None)] * k, method="highs")
    return res.status == 0


def test_convex_hull_property():
    knots = bspline.uniform_knots(0.8, 8, 3)
    rng = np.random.default_rng(5)
    c = rng.normal(size=(11, 2))
    for span in range(8):
        t = np.linspace(0.1 * span, 0.1 * (span + 1), 7)
        for p in bspline.evaluate(c, t, knots, 3):
            assert in_hull(p, c[span:span + 4])


def test_velocity_hull_points_bound_the_velocity():
    """Every velocity on the domain lies in the hull of v(0), d_1..d_S, v(T) (support functions)."""
    knots = bspline.uniform_knots(0.8, 8, 3)
    rng = np.random.default_rng(9)
    c = rng.normal(size=(11, 2))
    hull = bspline.velocity_hull_operator(knots) @ c
    vel = bspline.evaluate(c, np.linspace(0.0, 0.8, 401), knots, 3, 1)
    ang = np.linspace(0.0, 2.0 * np.pi, 73)
    dirs = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    assert np.all((vel @ dirs.T).max(axis=0) <= (hull @ dirs.T).max(axis=0) + 1e-12)
    np.testing.assert_allclose(hull[0], bspline.evaluate(c, [0.0], knots, 3, 1)[0])
    np.testing.assert_allclose(hull[-1], bspline.evaluate(c, [0.8], knots, 3, 1)[0])
    # The hull points are inside the hull of all derivative control points (never looser).
    d = bspline.derivative_operator(knots, 3) @ c
    for p in hull:
        assert in_hull(p, d)


def test_derivative_control_points_bound_the_acceleration():
    knots = bspline.uniform_knots(0.8, 8, 3)
    rng = np.random.default_rng(13)
    c = rng.normal(size=(11, 2))
    e = bspline.derivative_control_operator(knots, 3, 2) @ c
    acc = bspline.evaluate(c, np.linspace(0.0, 0.8, 401), knots, 3, 2)
    # A uniform linear B-spline interpolates its control points at the knots.
    np.testing.assert_allclose(bspline.evaluate(c, 0.1 * np.arange(9), knots, 3, 2), e, atol=1e-9)
    assert np.linalg.norm(acc, axis=1).max() <= np.linalg.norm(e, axis=1).max() + 1e-9
