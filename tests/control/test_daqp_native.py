"""DAQP's C solver called directly (nodnav.control.daqp_native) against ``daqp.solve``, bit for bit."""

import ctypes
import logging

import daqp
import numpy as np
import pytest

from nodnav.control import daqp_native, qp
from nodnav.control.daqp_native import Settings, layout_verified, quadprog, quadprog_address

native = pytest.mark.skipif(quadprog_address() is None, reason="the installed DAQP's layouts are not verified")


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _assert_same_answer(args, **settings):
    """``quadprog`` and ``daqp.solve`` on the same QP: the same bits of ``x``, the cost, the exit
    flag, the iterations and nodes, and the multipliers where the solve succeeded (on failure DAQP
    leaves them unwritten: ``daqp.solve`` itself returns whatever its fresh buffer held)."""
    x, fval, flag, info = daqp.solve(*args, **settings)
    x2, fval2, flag2, info2 = quadprog(*args, **settings)
    assert flag2 == flag and info2["iterations"] == info["iterations"] and info2["nodes"] == info["nodes"]
    assert _same(x2, x) and _same(np.float64(fval2), np.float64(fval))
    if flag == 1:
        assert _same(info2["lam"], info["lam"])
    return flag


def _random_qp(rng, n, k, bounds=True, infeasible=False, degenerate=False):
    """A strictly convex QP: ``k`` rows ``a x >= b`` (a few at ``-inf``) and optional simple bounds;
    ``infeasible`` adds a row and its negation pushed apart, ``degenerate`` repeats rows so that
    more are active than variables."""
    m = rng.normal(size=(n, n))
    h = m @ m.T + 0.1 * np.eye(n)
    f = rng.normal(size=n) * 5.0
    a = rng.normal(size=(k, n))
    b = rng.normal(size=k) - 0.5
    b[rng.random(k) < 0.1] = -np.inf
    if degenerate:
        a = np.vstack([a, a, 2.0 * a])
        b = np.concatenate([b, b, 2.0 * b])
    if infeasible:
        row = rng.normal(size=n)
        a, b = np.vstack([a, row, -row]), np.append(b, [1.0, 1.0])
    low = np.concatenate([-rng.random(n), b]) if bounds else b
    sense = np.zeros(len(low), dtype=np.intc)
    return h, f, np.ascontiguousarray(a), np.full(len(low), np.inf), low, sense


@native
@pytest.mark.parametrize("kind", ["feasible", "no bounds", "infeasible", "degenerate"])
def test_quadprog_matches_daqp_solve_bit_for_bit(kind):
    rng = np.random.default_rng({"feasible": 1, "no bounds": 2, "infeasible": 3, "degenerate": 4}[kind])
    flags = set()
    for _trial in range(40):
        n, k = int(rng.integers(1, 19)), int(rng.integers(1, 60))
        args = _random_qp(rng, n, k, bounds=kind != "no bounds", infeasible=kind == "infeasible",
                          degenerate=kind == "degenerate")
        flags.add(_assert_same_answer(args, primal_tol=1e-9))
    if kind == "infeasible":
        assert -1 in flags  # some were proven infeasible, not only the easy cases
    else:
        assert 1 in flags


@native
def test_quadprog_matches_daqp_solve_on_warm_flags_defaults_and_lps():
    """Flags of a start (3: active at the lower bound), no flags or lower bounds at all
    (``daqp.solve``'s defaults), and the certificate's LP (zero Hessian, proximal weight 1)."""
    rng = np.random.default_rng(5)
    for _trial in range(20):
        h, f, a, up, low, sense = _random_qp(rng, 6, 30)
        x, _, flag, info = daqp.solve(h, f, a, up, low, sense)
        warm = np.where(info["lam"] != 0.0, 3, 0).astype(np.intc)
        _assert_same_answer((h, f, a, up, low, warm))
        _assert_same_answer((h, f, a, -low))
        n = a.shape[1] + 1
        cost = np.zeros(n)
        cost[0] = 1.0
        rows = np.hstack([np.ones((len(low) - 6, 1)), a])
        _assert_same_answer((np.zeros((n, n)), cost, rows, np.full(len(low) - 5, np.inf),
                             np.concatenate([[0.0], low[6:]]), None), eps_prox=1.0)


@native
def test_solve_qp_and_least_relaxation_are_the_same_natively_and_through_daqp_solve(monkeypatch):
    rng = np.random.default_rng(6)
    for trial in range(20):
        h, f, a, _, low, _ = _random_qp(rng, 5, 25, infeasible=trial % 3 == 0)
        answers = []
        for use_native in (True, False):
            monkeypatch.setattr(qp, "NATIVE_DAQP", use_native)
            sol = qp.solve_qp(h, f, a, low[5:], 1e-9, bounds=low[:5])
            # A start from the multipliers of a success only (a failure's are unwritten memory).
            start = sol.multipliers if sol.success else None
            again = qp.solve_qp(h, f, a, low[5:], 1e-9, bounds=low[:5], start_multipliers=start)
            support, t = qp.least_relaxation(a, low[5:])
            answers.append((sol, again, support, t))
        (s1, w1, c1, t1), (s2, w2, c2, t2) = answers
        for one, two in ((s1, s2), (w1, w2)):
            assert (one.success, one.reason, one.iterations) == (two.success, two.reason, two.iterations)
            assert _same(one.x, two.x)
            if one.success:
                assert _same(one.multipliers, two.multipliers)
        assert _same(c1, c2) and _same(np.float64(t1), np.float64(t2))


def test_the_settings_struct_has_daqp_0_11_0s_layout():
    """Offsets of DAQPSettings in the 0.11.0 wheel's debug information (gdb ``ptype /o``)."""
    assert ctypes.sizeof(Settings) == 136
    offsets = {name: getattr(Settings, name).offset for name, _ in Settings._fields_}
    assert offsets["cycle_tol"] == 40 and offsets["iter_limit"] == 44 and offsets["fval_bound"] == 48
    assert offsets["eps_prox"] == 56 and offsets["time_limit"] == 112 and offsets["w_soft"] == 120
    assert offsets["eq_reduction"] == 128 and offsets["presolve"] == 132
    block = daqp_native.settings_block(1e-9, 1.0)
    assert np.frombuffer(block[:8].tobytes())[0] == 1e-9 and np.frombuffer(block[56:64].tobytes())[0] == 1.0


def test_only_the_verified_version_is_read():
    assert layout_verified("0.11.0")
    for other in ("0.11.1", "0.12.0", "0.10.0", "0.9.1", "unknown"):
        assert not layout_verified(other)


def test_another_daqp_version_falls_back_to_daqp_solve_logged_once(monkeypatch, caplog):
    monkeypatch.setattr(daqp_native.importlib.metadata, "version", lambda name: "0.12.0")
    calls = []
    solve = daqp.solve

    def recording(*args, **kw):
        calls.append(kw)
        return solve(*args, **kw)

    monkeypatch.setattr(daqp_native.daqp, "solve", recording)
    quadprog_address.cache_clear()
    try:
        with caplog.at_level(logging.WARNING, logger=daqp_native.__name__):
            assert quadprog_address() is None
            h, f, a, up, low, sense = _random_qp(np.random.default_rng(7), 4, 10)
            got = quadprog(h, f, a, up, low, sense, primal_tol=1e-9)
            quadprog(h, f, a, up, low, sense)
        want = solve(h, f, a, up, low, sense, primal_tol=1e-9)
        assert len(calls) == 2 and calls[0]["primal_tol"] == 1e-9
        assert _same(got[0], want[0]) and got[2] == want[2]
        assert sum("0.12.0" in r.getMessage() for r in caplog.records) == 1
    finally:
        quadprog_address.cache_clear()


@native
def test_a_compiled_caller_gets_the_same_bits():
    """What a control step compiled as a whole needs: DAQP called from nopython code."""
    import numba

    @numba.njit
    def caller(address, h, f, a, up, low, sense, settings):
        x, lam, _, flag, iterations, _, _, _ = daqp_native.quadprog_kernel(address, h, f, a, up, low, sense,
                                                                           settings)
        return x, lam, flag, iterations

    rng = np.random.default_rng(8)
    for trial in range(10):
        h, f, a, up, low, sense = _random_qp(rng, 8, 40, infeasible=trial % 4 == 0)
        x, lam, flag, iterations = caller(quadprog_address(), h, f, a, up, low, sense,
                                          daqp_native.settings_for(1e-9, None))
        x1, _, flag1, info = daqp.solve(h, f, a, up, low, sense, primal_tol=1e-9)
        assert (flag, iterations) == (flag1, info["iterations"]) and _same(x, x1)
        if flag == 1:
            assert _same(lam, info["lam"])
