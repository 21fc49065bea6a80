"""Reduced tracking solves (:func:`nodnav.control.qp.solve_reduced`): DAQP on only the rows it
could ever pick takes the full QP's path bit for bit; the rows' reach
(:func:`nodnav.control.mpc_rows.row_reach`) against plain NumPy; the fallback to the full QP."""

import numpy as np
import pytest

from nodnav.control.mpc import BSplineMPC
from nodnav.control.mpc_rows import row_reach
from nodnav.control.qp import SolverEffort, solve_qp, solve_reduced
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.transform import transform_scenario
from nodnav.scenario.world import paper_world
from nodnav.sim.simulator import Simulation

NZ = 6


def _reach_plain(rows, lower, gradient):
    """-(lower + rows @ g) / |rows| per row, inf at -inf (NumPy)."""
    with np.errstate(invalid="ignore"):
        out = -(lower + rows @ gradient) / np.linalg.norm(rows, axis=1)
    return np.where(np.isneginf(lower), np.inf, out)


def _far_rows_qp(rng, m=120, n=2 * NZ):
    """A strictly convex QP (identity Hessian) with a few rows near the unconstrained minimiser
    and many far from it, some at -inf, in random order."""
    g = rng.normal(size=n)
    normals = rng.normal(size=(m, n))
    distance = np.where(rng.random(m) < 0.2, rng.uniform(-0.5, 1.0, m), rng.uniform(3.0, 50.0, m)) * np.linalg.norm(g)
    # Row a @ u >= d with u = x + g: d = -distance |a|, so lower = d - a @ g.
    lower = -distance * np.linalg.norm(normals, axis=1) - normals @ g
    lower[rng.random(m) < 0.1] = -np.inf
    return g, normals, lower


def _shapes_rows(rng, n_shapes=7, m=90):
    """Rows [n_x s_k, n_y s_k] of unit normals times shapes, and a few free rows (shape -1)."""
    shapes = rng.normal(size=(n_shapes, NZ))
    row_shape = rng.integers(-1, n_shapes, m).astype(np.intp)
    rows = np.empty((m, 2 * NZ))
    for i, k in enumerate(row_shape):
        if k < 0:
            rows[i] = rng.normal(size=2 * NZ)
        else:
            a = rng.uniform(0.0, 2.0 * np.pi)
            rows[i] = np.concatenate([np.cos(a) * shapes[k], np.sin(a) * shapes[k]])
    return shapes, row_shape, rows


def test_row_reach_is_the_plain_distance():
    rng = np.random.default_rng(1)
    for _ in range(20):
        shapes, row_shape, rows = _shapes_rows(rng)
        g = rng.normal(size=2 * NZ)
        lower = rng.normal(size=len(rows))
        lower[rng.random(len(rows)) < 0.1] = -np.inf
        reach = np.empty(len(rows))
        row_reach(rows, lower, g, row_shape, shapes, np.linalg.norm(shapes, axis=1),
                  np.argmax(np.abs(shapes), axis=1).astype(np.intp), reach)
        plain = _reach_plain(rows, lower, g)
        assert np.array_equal(np.isinf(reach), np.isinf(plain))
        finite = np.isfinite(plain)
        assert np.allclose(reach[finite], plain[finite], rtol=1e-12, atol=1e-12)


def test_the_problems_reach_is_row_reach_of_its_rows():
    ctl = BSplineMPC(paper_world(), RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0)), MPCParams())
    times = 0.1 * np.arange(1, 9)
    prob = ctl._problem(1, times)
    p0, v0 = np.array([-1.0, 0.2]), np.array([0.5, 0.1])
    ref = p0 + np.outer(times, [0.8, 0.0])
    others = (np.array([1.5, 0.0]) + np.outer(times, [-0.4, 0.0]))[None]
    data = ctl._step_data(prob, p0, v0, ref, others, np.array([0.2]))
    gradient, lower = prob.tracking_rows(data, prob.interp_ends @ ref, True)
    plain = _reach_plain(prob.rows, lower, gradient)
    finite = np.isfinite(plain)
    assert np.array_equal(np.isinf(prob.reach), ~finite)
    assert np.allclose(prob.reach[finite], plain[finite], rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("turn", [0.0, 30.0])
def test_every_closed_loop_reach_is_the_plain_distance(turn, monkeypatch):
    """row_reach reads each row's normal back from its shape: every tracking QP of a closed loop,
    in the paper's corridor and turned by 30 degrees (polygon walls), has the reach of its rows
    (a wrong reach would leave out rows DAQP needs)."""
    checked = []
    solve = SolverEffort.solve

    def checking(self, hessian, gradient, rows, lower, tol, *args, reach=None, **kwargs):
        if reach is not None:
            plain = _reach_plain(rows, lower, gradient)
            finite = np.isfinite(plain)
            assert np.array_equal(np.isinf(reach), ~finite)
            assert np.allclose(reach[finite], plain[finite], rtol=1e-10, atol=1e-12)
            checked.append(len(rows))
        return solve(self, hessian, gradient, rows, lower, tol, *args, reach=reach, **kwargs)

    monkeypatch.setattr(SolverEffort, "solve", checking)
    scenario = load_scenario("4r-case4")
    sim = Simulation(transform_scenario(scenario, turn) if turn else scenario, "nod", 1)
    for _ in range(120):
        if sim.step():
            break
    assert len(checked) > 300


def _same(a, b):
    assert a.success == b.success and a.reason == b.reason and a.iterations == b.iterations
    assert a.x.tobytes() == b.x.tobytes()
    assert np.asarray(a.multipliers).tobytes() == np.asarray(b.multipliers).tobytes()


@pytest.mark.parametrize("warm", [False, True])
def test_reduced_solve_is_the_full_solve_bit_for_bit(warm):
    rng = np.random.default_rng(5 + warm)
    h = np.eye(2 * NZ)
    accepted = 0
    for _ in range(60):
        g, rows, lower = _far_rows_qp(rng)
        start = None
        if warm:  # the active set of a neighbouring QP's solution
            g2, _, _ = g + rng.normal(0.0, 0.1, g.shape), None, None
            prior = solve_qp(h, g2, rows, lower, 1e-9)
            start = prior.multipliers if prior.success else None
        full = solve_qp(h, g, rows, lower, 1e-9, start_multipliers=start)
        reduced, norm = solve_reduced(h, g, rows, lower, 1e-9, _reach_plain(rows, lower, g), 0.0, start)
        if reduced is None:
            continue
        accepted += 1
        _same(reduced, full)
        assert norm == np.linalg.norm(full.x + g) or np.isclose(norm, np.linalg.norm(full.x + g), rtol=1e-14)
    assert accepted >= 30


def test_too_small_a_radius_falls_back_to_the_full_solve():
    """Every row far but one that moves the optimum beyond the radius: the reduced solve declines
    (None, its optimum's norm); SolverEffort then solves the full QP, the same result."""
    n = 2 * NZ
    g = np.zeros(n)
    g[0] = 1.0
    rows = np.zeros((3, n))
    rows[0, 0] = 1.0  # x0 >= 5: u0 = x0 + 1 >= 6, far beyond 2 |g| = 2
    rows[1, 1] = 1.0  # x1 >= -100: far
    rows[2, 2] = -1.0  # -x2 >= -100
    lower = np.array([5.0, -100.0, -100.0])
    reach = _reach_plain(rows, lower, g)
    sol, norm = solve_reduced(np.eye(n), g, rows, lower, 1e-9, reach, 0.0)
    assert sol is None and norm == pytest.approx(6.0)
    memory = {}
    effort = SolverEffort(starts={}, reduced=memory)
    got = effort.solve(np.eye(n), g, rows, lower, 1e-9, kind="k", reach=reach)
    _same(got, solve_qp(np.eye(n), g, rows, lower, 1e-9))
    assert memory["k"] == pytest.approx(6.0)
    # The next solve of this kind takes the radius 2 x 6 = 12: accepted, the same again.
    sol2, _ = solve_reduced(np.eye(n), g, rows, lower, 1e-9, reach, memory["k"], effort.starts["k"])
    assert sol2 is not None
    _same(sol2, solve_qp(np.eye(n), g, rows, lower, 1e-9, start_multipliers=effort.starts["k"]))


def test_a_failed_solve_makes_the_next_of_its_kind_full():
    n = 2 * NZ
    g = np.ones(n)
    rows = np.zeros((2, n))
    rows[0, 0], rows[1, 0] = 1.0, -1.0  # x0 >= 1 and -x0 >= 0: infeasible
    lower = np.array([1.0, 0.0])
    memory = {}
    effort = SolverEffort(starts={}, reduced=memory)
    sol = effort.solve(np.eye(n), g, rows, lower, 1e-9, kind="k", reach=_reach_plain(rows, lower, g))
    assert not sol.success and np.isnan(memory["k"])


def test_warm_start_rows_are_kept_and_the_multipliers_mapped_back():
    """A warm start naming a far row keeps it (DAQP starts from it and drops it); the reduced
    multipliers land on the full rows' indices, zero on those left out."""
    rng = np.random.default_rng(11)
    h = np.eye(2 * NZ)
    for _ in range(30):
        g, rows, lower = _far_rows_qp(rng)
        reach = _reach_plain(rows, lower, g)
        far = np.flatnonzero(np.isfinite(reach) & (reach > 10.0 * np.linalg.norm(g)))
        start = np.zeros(len(lower))
        start[far[:2]] = -1.0
        full = solve_qp(h, g, rows, lower, 1e-9, start_multipliers=start)
        reduced, _ = solve_reduced(h, g, rows, lower, 1e-9, reach, 0.0, start)
        if reduced is not None:
            _same(reduced, full)
            assert reduced.multipliers.shape == (len(lower),)
