"""solve_qp's cold start flags, built only when used, against DAQP called by hand."""

import daqp
import numpy as np

from nodnav.control.qp import QPSolution, cold_flags, solve_qp


def test_cold_flags_mark_the_masked_bounds_active_at_their_lower_bound():
    flags = cold_flags(np.array([True, False, True]), 2)
    assert flags.dtype == np.intc
    assert flags.tolist() == [3, 0, 3, 0, 0]
    assert cold_flags(None, 4) is None


def test_a_cold_start_with_active_bounds_is_daqps_own_solve_with_those_flags():
    """Minimise |x - c|^2 / 2 subject to x >= 0 (bounds, the first two active at the start) and
    one row x0 + x1 + x2 >= 1: solve_qp's minimiser and multipliers are DAQP's, bit for bit."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        c = rng.normal(size=3)
        h, g = np.eye(3), -c
        rows, lower, bounds = np.ones((1, 3)), np.array([1.0]), np.zeros(3)
        active = np.array([True, True, False])
        sol = solve_qp(h, g, rows, lower, 1e-9, bounds, active)
        x, _, flag, info = daqp.solve(h, g, rows, np.full(4, np.inf), np.concatenate([bounds, lower]),
                                      np.array([3, 3, 0, 0], dtype=np.intc), primal_tol=1e-9)
        assert isinstance(sol, QPSolution) and sol.success == (flag == 1)
        assert x.tobytes() == sol.x.tobytes() and info["lam"].tobytes() == sol.multipliers.tobytes()
        assert sol.iterations == info["iterations"]
