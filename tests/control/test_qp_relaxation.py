"""The certificate LP's value (the least uniform relaxation of a set of rows) against HiGHS, and
what it tells of an elastic QP's success (the evasive fallback skips QPs on it)."""

import numpy as np
import pytest
from scipy.optimize import linprog

from nodnav.control.evasive import CERTAINLY_INFEASIBLE
from nodnav.control.qp import infeasibility_certificate, least_relaxation, relaxed_rows, solve_qp


def _least_relaxation_highs(rows, lower):
    """min t over (t, x), t >= 0, rows @ x + t >= lower: HiGHS, an independent LP solver."""
    finite = np.isfinite(lower)
    a, b = rows[finite], lower[finite]
    cost = np.append(1.0, np.zeros(a.shape[1]))
    res = linprog(cost, A_ub=-np.hstack([np.ones((len(b), 1)), a]), b_ub=-b,
                  bounds=[(0.0, None)] + [(None, None)] * a.shape[1], method="highs")
    assert res.status == 0
    return res.fun


def _random_system(rng, planted):
    """Rows a_i . x >= b_i; consistent (x = 0 meets every row) unless a contradiction
    a . x >= planted and a . x <= -planted is planted (least relaxation ``planted`` or less)."""
    n, m = int(rng.integers(2, 8)), int(rng.integers(5, 40))
    rows = rng.normal(size=(m, n))
    lower = np.minimum(rng.normal(size=m) - 4.0, -0.5)
    lower[rng.random(m) < 0.2] = -np.inf  # rows that never bind
    if planted:
        a = rng.normal(size=n)
        rows, lower = np.vstack([rows, a, -a]), np.append(lower, [planted, planted])
    return rows, lower


def test_least_relaxation_is_the_lps_optimum_and_its_support_the_certificate():
    """On random systems, consistent or made inconsistent by a planted contradiction, the value
    agrees with HiGHS's optimum and the support is :func:`infeasibility_certificate`'s."""
    rng = np.random.default_rng(11)
    for trial in range(60):
        rows, lower = _random_system(rng, [0.0, 1e-3, 0.3, 2.0][trial % 4])
        support, value = least_relaxation(rows, lower)
        assert value == pytest.approx(_least_relaxation_highs(rows, lower), abs=1e-6)
        np.testing.assert_array_equal(support, infeasibility_certificate(rows, lower))
        assert (value > 0) == (support.size > 0)


def test_by_hand():
    """x >= 1 and x <= -1: the least relaxation is 1 (x = 0 misses both by 1); both rows certify."""
    support, value = least_relaxation(np.array([[1.0], [-1.0]]), np.array([1.0, 1.0]))
    np.testing.assert_array_equal(support, [0, 1])
    assert abs(value - 1.0) < 1e-6
    support, value = least_relaxation(np.array([[1.0], [-1.0]]), np.array([1.0, -2.0]))
    assert support.size == 0 and value == 0.0


def test_an_elastic_qp_fails_exactly_when_its_hard_rows_are_relaxed_beyond_the_threshold():
    """An elastic QP (hard rows, and soft rows each with its own slack s >= 0 under a linear and
    quadratic penalty) is feasible exactly when its hard rows are. Where the hard rows' least
    relaxation exceeds :data:`CERTAINLY_INFEASIBLE`, DAQP fails on the QP (what the evasive
    fallback skips); where it is 0, DAQP finds the minimiser."""
    rng = np.random.default_rng(5)
    skipped = solved = 0
    for trial in range(80):
        hard, hard_lower = _random_system(rng, [0.0, 0.01, 0.5, 3.0][trial % 4])
        n, k = hard.shape[1], int(rng.integers(1, 10))
        soft = rng.normal(size=(k, n))
        soft_lower = rng.normal(size=k) + 5.0  # far from x = 0: only the slacks make them hold
        rows = np.block([[hard, np.zeros((len(hard), k))], [soft, np.eye(k)]])
        lower = np.concatenate([hard_lower, soft_lower])
        hessian = np.diag(np.concatenate([np.ones(n), np.full(k, 1e-3)]))
        gradient = np.concatenate([rng.normal(size=n), np.full(k, 1e3)])
        bounds = np.concatenate([np.full(n, -np.inf), np.zeros(k)])
        sol = solve_qp(hessian, gradient, rows, lower, 1e-9, bounds=bounds, start_active=bounds == 0.0)
        _, value = least_relaxation(hard, hard_lower)
        if value > CERTAINLY_INFEASIBLE:
            assert not sol.success and sol.reason == "infeasible"
            skipped += 1
        elif value == 0.0:
            assert sol.success
            assert (rows @ sol.x >= lower - 1e-8).all() and (sol.x[n:] >= -1e-9).all()
            solved += 1
    assert skipped >= 30 and solved >= 15


def test_relaxed_rows_writes_numpys_gathered_and_stacked_lp_data():
    """The compiled pass writes what ``flatnonzero(isfinite)``, gathering and ``hstack`` give, bit
    for bit (rows at -inf, +inf or NaN left out; none, some or all of them finite)."""
    rng = np.random.default_rng(5)
    for share in (0.0, 0.3, 1.0):
        rows, lower = rng.normal(size=(40, 7)), rng.normal(size=40)
        lower[rng.random(40) < share] = -np.inf
        lower[3] = np.inf if share else lower[3]
        lower[5] = np.nan if share else lower[5]
        finite = np.flatnonzero(np.isfinite(lower))
        relaxed, low, found = np.empty((40, 8)), np.empty(41), np.empty(40, dtype=np.intp)
        m = relaxed_rows(rows, lower, relaxed, low, found)
        assert m == len(finite)
        np.testing.assert_array_equal(found[:m], finite)
        assert relaxed[:m].tobytes() == np.hstack([np.ones((m, 1)), rows[finite]]).tobytes()
        assert low[:m + 1].tobytes() == np.concatenate([[0.0], lower[finite]]).tobytes()


def test_least_relaxation_hands_daqp_the_plain_constructions_lp(monkeypatch):
    """DAQP gets the same LP, bit for bit, as the plain NumPy construction (zero Hessian, unit
    cost, ``hstack`` of ones and the finite rows, +inf upper bounds, 0 then the finite bounds):
    so the same solution, whatever DAQP does with it."""
    import nodnav.control.qp as qp

    seen = []
    solve = qp.daqp.solve

    class Recording:
        @staticmethod
        def solve(*args, **kw):
            seen.append((args, kw))
            return solve(*args, **kw)

    monkeypatch.setattr(qp, "daqp", Recording)
    monkeypatch.setattr(qp, "NATIVE_DAQP", False)  # through daqp.solve, to see what it is handed
    rng = np.random.default_rng(3)
    for trial in range(12):
        rows, lower = _random_system(rng, [0.0, 0.3][trial % 2])
        least_relaxation(rows, lower)
        (h, f, a, up, low, sense), kw = seen[-1]
        finite = np.isfinite(lower)
        m, n = int(finite.sum()), rows.shape[1]
        plain = (np.zeros((n + 1, n + 1)), np.append(1.0, np.zeros(n)), np.hstack([np.ones((m, 1)), rows[finite]]),
                 np.full(m + 1, np.inf), np.concatenate([[0.0], lower[finite]]))
        for got, want in zip((h, f, a, up, low), plain):
            assert got.shape == want.shape and got.dtype == want.dtype and got.tobytes() == want.tobytes()
            assert got.flags.c_contiguous
        assert sense is None and kw == {"eps_prox": 1.0}
