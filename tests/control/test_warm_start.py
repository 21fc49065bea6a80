"""DAQP's warm start (:func:`solve_qp`'s ``start``) changes the path, never the minimiser.

A strictly convex QP has one minimiser, so a solve started from any set of constraints, right,
wrong, linearly dependent or more than the variables, must end where the cold solve ends (to the
solver's tolerance), and report infeasibility where the cold solve does. The references are the
cold solve and the KKT conditions checked directly.
"""

from __future__ import annotations

import numpy as np
import pytest

import nodnav.control.qp as qp
from nodnav.control.qp import SolverEffort, solve_qp, start_from

TOL = 1e-9


def _random_qp(rng: np.random.Generator, n: int, m: int, bounds: bool):
    """A strictly convex QP (diagonal Hessian as the MPC's), feasible by construction: every row
    holds at a random point with slack, some rows at ``-inf``."""
    hessian = np.diag(rng.uniform(0.5, 2.0, n)) if bounds else np.eye(n)
    gradient = rng.normal(size=n) * 3
    rows = rng.normal(size=(m, n))
    inside = rng.normal(size=n)
    if bounds:
        inside[n // 2:] = np.abs(inside[n // 2:]) + 0.1
    lower = rows @ inside - rng.uniform(0.0, 1.0, m)
    lower[rng.random(m) < 0.2] = -np.inf
    b = np.concatenate([np.full(n - n // 2, -np.inf), np.zeros(n // 2)]) if bounds else None
    return hessian, gradient, rows, lower, b


def _kkt_ok(hessian, gradient, rows, lower, b, sol) -> bool:
    """Primal feasibility and stationarity with non-negative multipliers (DAQP's are negative)."""
    x = sol.x
    lam = -sol.multipliers
    nb = 0 if b is None else len(b)
    a = rows if b is None else np.vstack([np.eye(len(x)), rows])
    low = lower if b is None else np.concatenate([b, lower])
    fin = np.isfinite(low)
    feasible = np.all(a[fin] @ x >= low[fin] - 1e-6)
    stationary = np.allclose(hessian @ x + gradient, a.T @ lam, atol=1e-6)
    complementary = np.all(np.abs(lam[fin] * (a[fin] @ x - low[fin])) < 1e-6)
    return bool(feasible and stationary and complementary and np.all(lam >= -1e-9) and nb >= 0)


@pytest.mark.parametrize("bounds", [False, True])
def test_any_start_reaches_the_cold_minimiser(bounds):
    rng = np.random.default_rng(7)
    for trial in range(300):
        n = int(rng.integers(2, 20))
        m = int(rng.integers(1, 80))
        h, g, rows, lower, b = _random_qp(rng, n, m, bounds)
        total = m + (0 if b is None else n)
        cold = solve_qp(h, g, rows, lower, TOL, b, None if b is None else b == 0.0)
        assert cold.success and _kkt_ok(h, g, rows, lower, b, cold)
        right = start_from(cold)
        starts = {
            "right": right,
            "random": np.flatnonzero(rng.random(total) < 0.3),
            "all": np.arange(total),  # more than n, and including -inf rows
            "none": np.zeros(0, dtype=int),
            "duplicated row": None,
        }
        for name, start in starts.items():
            r, lw, st = rows, lower, start
            if start is None:  # a row twice, both in the start: linearly dependent
                r, lw = np.vstack([rows, rows[:1]]), np.append(lower, lower[0])
                st = np.array([total - m, total])
                ref = solve_qp(h, g, r, lw, TOL, b, None if b is None else b == 0.0)
            else:
                ref = cold
            warm = solve_qp(h, g, r, lw, TOL, b, None if b is None else b == 0.0, st)
            assert warm.success, (trial, name, warm.reason)
            assert np.allclose(warm.x, ref.x, rtol=0, atol=1e-7), (trial, name, np.abs(warm.x - ref.x).max())
        # The right start needs no more active-set changes than adding its constraints.
        warm = solve_qp(h, g, rows, lower, TOL, b, None, right)
        assert warm.iterations <= cold.iterations + 1


def test_a_start_on_an_infeasible_qp_reports_it_infeasible():
    rng = np.random.default_rng(3)
    for _ in range(100):
        n = int(rng.integers(2, 10))
        rows = rng.normal(size=(20, n))
        lower = rng.normal(size=20)
        # Two opposite rows that no point meets together.
        rows[5], lower[5] = -rows[4], -lower[4] + 1.0
        start = np.flatnonzero(rng.random(20) < 0.5)
        cold = solve_qp(np.eye(n), rng.normal(size=n), rows, lower, TOL)
        warm = solve_qp(np.eye(n), rng.normal(size=n), rows, lower, TOL, start=start)
        assert not cold.success and not warm.success
        assert start_from(warm) is None


def test_a_start_of_the_wrong_length_is_ignored():
    h, g = np.eye(2), np.array([1.0, 1.0])
    rows, lower = np.eye(2), np.zeros(2)
    sol = solve_qp(h, g, rows, lower, TOL, start=np.arange(5))
    assert sol.success and np.allclose(sol.x, 0.0)  # the minimiser of |x + 1|^2 over x >= 0


def _spied_effort(monkeypatch) -> tuple[SolverEffort, list]:
    """A :class:`SolverEffort` that remembers starts, and the list of the start each solve got."""
    seen: list = []

    def spy(*args):
        seen.append(args[8])  # the warm start: the last solution's multipliers
        return solve_qp(*args)

    monkeypatch.setattr(qp, "solve_qp", spy)
    return SolverEffort(starts={}), seen


def test_solver_effort_starts_each_kind_from_its_last_solution(monkeypatch):
    effort, seen = _spied_effort(monkeypatch)
    h, g = np.eye(2), np.array([1.0, -1.0])
    rows, lower = np.eye(2), np.zeros(2)
    first = effort.solve(h, g, rows, lower, TOL, kind="a")
    effort.solve(h, g, rows, lower, TOL, kind="a")
    effort.solve(h, g, rows, lower, TOL, kind="b")
    assert seen[0] is None and seen[2] is None
    # x_0 >= 0 binds at the minimiser (g pushes it below), x_1 >= 0 does not.
    assert list(np.flatnonzero(seen[1])) == [0] and np.allclose(first.x, [0.0, 1.0])


def test_solver_effort_falls_back_to_a_like_kind(monkeypatch):
    effort, seen = _spied_effort(monkeypatch)
    h, g = np.eye(2), np.array([1.0, -1.0])
    rows, lower = np.eye(2), np.zeros(2)
    effort.solve(h, g, rows, lower, TOL, kind="a")
    effort.solve(h, g, rows, lower, TOL, kind="b", like="a")  # none of its own yet: a's
    effort.solve(h, g, rows, lower, TOL, kind="c", like="d")  # neither: cold
    assert list(np.flatnonzero(seen[1])) == [0] and seen[2] is None
