"""The fused set-up of a control step (``controller.fused_step``, :mod:`nodnav.control.mpc_fused`)
against the plain path it replaces: the NumPy products and the separate compiled calls.

The fused loops sum each small product in index order, BLAS in its own (with fused multiply-adds),
so they agree to rounding only. A sum of ``k`` products computed either way is within
``gamma_k |a| |b|`` of the exact one (``gamma_k = k u / (1 - k u)``, ``u = 2^-53``), so the two
within ``2 gamma_k |a| |b|``: that is the products' tolerance below. What is derived from them
(distances, unit normals, square roots, minima, the rows) carries that error scaled by the
conditioning of those operations: a unit normal's error is the point's error over the distance,
and the random states here keep distances above a few centimetres, so ``1e-11`` (m, or relative)
bounds every derived value with room, where positions are ~10 m and the products' own error
~1e-14 m. Flags (contact, overlap, walls out of reach) are compared exactly (no draw sits on a
threshold).

The braking tail's rows are the exception: each is the half-plane at the wall's point nearest to
the linearisation's tail segment, whose direction is a difference quotient of the last two
linearisation points (their rounding over the last interval, ~1e-14 m/s); where the segment runs
nearly parallel to a face, the nearest point's place along it moves by that error over the angle,
so near a wall's corner the half-plane's normal turns measurably (up to ~5e-6 in 18,000 draws).
Either half-plane is tangent to the same inflated wall, so either keeps the tail clear; ``TAIL_TOL``
(1e-4, the exact check's tolerance ``check_tolerance``) bounds the rows' difference there."""

import numpy as np
import pytest

from nodnav.control.base import ControlRequest
from nodnav.control.mpc import BSplineMPC
from nodnav.control.mpc_fused import (
    product_into,
    scratch_arrays,
    scratch_shapes,
    scratch_space,
    sparse_product_into,
    sparse_rows,
)
from nodnav.control.mutual_braking import passing_bound
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import paper_world
from nodnav.sim.simulator import Simulation

WORLD = paper_world()
ROBOT = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))
TIMES = 0.1 * np.arange(1, 9)
U = np.finfo(float).eps / 2
TOL = 1e-11
"""Derived values' tolerance (m, or relative where larger): see the module's docstring."""
TAIL_TOL = 1e-4
"""The braking tail's rows' tolerance (the module's docstring)."""

FIELDS = ("ref_local", "pred_check", "x_now", "away", "dist_now", "contact", "full", "need", "delta_sq",
          "velocities", "gap_box", "need_box", "static_lower", "box_low", "box_high")
EXACT = ("far", "overlap", "n_walls")
SCALARS = ("tail_weight", "tail_reach", "need_clear", "clearance_now")


def product_tolerance(a, b):
    """``2 gamma_k |a| |b|``: how far two sums of the ``k`` products may be apart (module docstring)."""
    k = a.shape[-1]
    return 2.0 * k * U / (1.0 - k * U) * (np.abs(a) @ np.abs(b))


def test_product_into_is_the_matmul_to_rounding():
    """The loop's product is NumPy's within the bound of two sums' rounding (and exact on integers)."""
    rng = np.random.default_rng(1)
    for shape in [(50, 8), (9, 8), (280, 2), (17, 11), (1, 1), (0, 3)]:
        a, b = rng.normal(0.0, 3.0, shape), rng.normal(0.0, 5.0, (shape[1], 2))
        out = np.empty((shape[0], 2))
        product_into(a, b, out)
        assert np.all(np.abs(out - a @ b) <= product_tolerance(a, b))
        ai, bi = np.round(a), np.round(b)  # small integers: every sum exact both ways
        product_into(ai, bi, out)
        assert np.array_equal(out, ai @ bi)


def test_sparse_product_is_the_dense_loop_bit_for_bit():
    """Leaving out the zero entries changes no sum (the problem's interpolation and basis, and random
    sparse matrices with empty rows)."""
    rng = np.random.default_rng(2)
    ctl = BSplineMPC(WORLD, ROBOT, MPCParams())
    prob = ctl._problem(3, TIMES)
    mats = [prob.interp_all, prob.b_ends] + [rng.normal(size=(7, 6)) * (rng.random((7, 6)) < 0.3) for _ in range(20)]
    for a in mats:
        b = rng.normal(0.0, 4.0, (a.shape[1], 2))
        dense, sparse = np.empty((a.shape[0], 2)), np.empty((a.shape[0], 2))
        product_into(a, b, dense)
        sparse_product_into(*sparse_rows(a), b, sparse)
        assert np.array_equal(dense, sparse)


def _plain(ctl, prob, args, committed):
    """The plain path's step data, linearisation points, cold flag, gradient, bounds and rows (copies)."""
    data = ctl._step_data(prob, *args)
    warm = ctl._warm_start(committed)
    cold = warm is None
    lin = prob.interp_ends @ args[2] if cold else prob.b_ends @ warm
    gradient, lower = prob.tracking_rows(data, lin, cold)
    copied = {f: np.copy(getattr(data, f)) for f in FIELDS + EXACT + SCALARS}
    return copied, lin, cold, gradient, lower, prob.rows.copy()


def _close(a, b, what="", tol=TOL):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    with np.errstate(invalid="ignore"):  # -inf - -inf: equal, caught by a == b
        same = (a == b) | (np.abs(a - b) <= tol * np.maximum(1.0, np.abs(b)))
    assert np.all(same), (what, np.flatnonzero(~same), a[~same], b[~same])


def _compare(ctl, prob, args, committed, partners=None):
    """The fused set-up against the plain one on the same controller state (and the passing bound
    towards ``partners``, the same kernel: bit for bit)."""
    plain, lin, cold, gradient, lower, rows = _plain(ctl, prob, args, committed)
    data, f_lin, f_cold, (f_gradient, f_lower), bound = ctl._fused_setup(prob, *args, committed, partners)
    assert bound == (np.inf if partners is None else passing_bound(args[0], args[1], partners)[0])
    assert f_cold == cold
    for f in FIELDS + SCALARS:
        _close(getattr(data, f), plain[f], f)
    for f in EXACT:
        assert np.array_equal(getattr(data, f), plain[f])
    _close(f_lin, lin)
    _close(f_gradient, gradient)
    tail = prob.n_separation  # the braking tail's rows from here on
    _close(f_lower[:tail], lower[:tail], "lower")  # -inf where the plain path has it
    _close(prob.rows[:tail], rows[:tail], "rows")
    _close(f_lower[tail:], lower[tail:], "tail lower", TAIL_TOL)
    _close(prob.rows[tail:], rows[tail:], "tail rows", TAIL_TOL)


@pytest.mark.parametrize("n_others", [0, 1, 3, 9])
@pytest.mark.parametrize("warm", [False, True])
def test_fused_setup_is_the_plain_one_on_random_states(n_others, warm):
    """Random states, references and predictions, cold (no plan) and warm (a previous plan)."""
    rng = np.random.default_rng(10 + n_others + 100 * warm)
    ctl = BSplineMPC(WORLD, ROBOT, MPCParams(fused_step=True))
    prob = ctl._problem(n_others, TIMES)
    for _ in range(30):
        p0, v0 = rng.uniform([-6.0, -0.6], [6.0, 0.6]), rng.normal(0.0, 0.5, 2)
        ref = p0 + np.outer(TIMES, rng.normal(0.0, 0.4, 2))
        others = p0 + rng.normal(0.0, 1.5, (n_others, 1, 2)) + np.outer(TIMES, rng.normal(0.0, 0.3, 2))[None]
        ctl._previous = p0 + rng.normal(0.0, 0.2, (len(ctl.setup.greville), 2)) if warm else None
        _compare(ctl, prob, (p0, v0, ref, others, np.full(n_others, 0.2), np.full(n_others, 0.05)), None)


def test_fused_setup_is_the_plain_one_on_recorded_steps():
    """Every step of a trial of the paper's 3r-case4 (the plain path's trial, warm starts from
    previous plans and committed trajectories): the fused set-up from the same state and request."""
    seen = {"steps": 0, "modes": set(), "partners": 0}
    plain_control = BSplineMPC.control

    def control(self, request: ControlRequest):
        p0, v0, ref, times, others, radii, firm, margins = self._validated(request)
        prob = self._problem(len(others), times)
        committed = self._committed
        if committed is not None:  # as _advance_committed will have it, without moving it on
            committed.elapsed += self.dt
        args = (p0, v0, ref, others, radii, margins)
        _compare(self, prob, args, committed if self._following else None, request.braking)
        seen["partners"] += request.braking is not None
        if committed is not None:
            committed.elapsed -= self.dt
        seen["steps"] += 1
        seen["modes"].add((self._previous is None, self._following))
        self._step_data(prob, *args)  # the plain path's scratch state back, for the trial itself
        return plain_control(self, request)

    # The plain path drives the trial, and every step solves its MPC (no skip at rest).
    scenario = load_scenario("3r-case4", {"controller.fused_step": False, "execution.skip_at_rest": False})
    sim = Simulation(scenario, "nod", 1)
    try:
        BSplineMPC.control = control
        for _ in range(60):
            if sim.step():
                break
    finally:
        BSplineMPC.control = plain_control
    assert seen["steps"] > 100 and seen["partners"] > 100
    assert (True, False) in seen["modes"] and (False, False) in seen["modes"]  # cold, and warm from a plan


@pytest.mark.parametrize("n_others", [0, 3])
def test_scratch_arrays_read_back_the_layout_of_scratch_space(n_others):
    """The compiled read-back of a step's scratch space gives the arrays laid out in Python: each
    the next ``prod(shape)`` numbers of the buffer, in C order (a hand-made layout: consecutive
    ranges of ``arange``), views of the buffer itself."""
    n_end, n_pred, n_samples = 7, 11, 4
    shapes = scratch_shapes(5 + n_others, n_end, n_others, n_pred, 13, n_samples, 6, 17)
    buffer, starts, views = scratch_space(shapes)
    buffer[:] = np.arange(buffer.size)
    read = scratch_arrays(buffer, starts, n_others, n_pred, n_samples, n_end)
    first = 0
    for shape, view, got in zip(shapes, views, read, strict=True):
        expected = np.arange(first, first + int(np.prod(shape)), dtype=float).reshape(shape)
        first += expected.size
        assert got.shape == view.shape == shape
        assert np.array_equal(got, expected) and np.array_equal(view, expected)
        assert got.flags.c_contiguous and (got.size == 0 or np.shares_memory(got, buffer))
    assert first == buffer.size


def test_a_problems_scratch_space_holds_its_state_and_outputs_apart():
    """The per-group state and the fused set-up's outputs of a problem are views of its one buffer,
    none overlapping another (writing one leaves the others as they were)."""
    prob = BSplineMPC(WORLD, ROBOT, MPCParams(fused_step=True))._problem(3, TIMES)
    arrays = [a for a in (*prob.state, *prob.fused_outputs) if a.dtype == float]
    assert len(arrays) == 17 and prob.state[5].dtype == bool  # far, apart
    assert sum(a.size for a in arrays) == prob.scratch.size
    prob.scratch[:] = 0.0
    for k, a in enumerate(arrays):
        a[...] = k + 1.0
    for k, a in enumerate(arrays):
        assert np.all(a == k + 1.0)
