"""Dense convex QPs for the MPC: DAQP, a dual active-set method, and certificates of infeasibility.

The MPC's QPs have about 18 variables and a few hundred inequality rows, many of them
degenerate (more rows active than variables). DAQP (Arnstroem et al., MIT licence,
:func:`solve_qp`) solves them exactly and detects infeasibility. The evidence for it over OSQP
is a command, ``nodnav bench solvers`` (:mod:`nodnav.bench.solvers`; figures and the commit in
docs/method.md, "The MPC's QP solver"): it records every QP of a few closed-loop trials and
solves each again with DAQP, OSQP (default and tight settings) and Clarabel at tight
tolerances as the reference. DAQP found every optimum the reference found and all but one of
its infeasible problems (that one it reported as cycling; the controller treats every failure
alike and lets the certificate below decide), at a fraction of a millisecond; OSQP stopped at
its iteration limit on about a third of the problems even at its tight settings. A row may be
violated by up to DAQP's primal tolerance, so callers tighten every row by it.

DAQP's QP solve returns no Farkas certificate of infeasibility, which the evasive fallback
(:mod:`nodnav.control.evasive`) uses to choose which robots' rows to soften: a small linear
program finds one (:func:`infeasibility_certificate`). :class:`SolverEffort` counts what a
control step spent in both.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import daqp
import numpy as np
from scipy.optimize import linprog

from nodnav.compiled import compiled
from nodnav.control import daqp_native

_DAQP_REASONS = {-1: "infeasible", -2: "cycling", -3: "unbounded", -4: "iteration limit", -5: "not convex",
                 -6: "overdetermined start", -7: "time limit", -8: "unsupported"}


@dataclass(slots=True)
class QPSolution:
    """Result of :func:`solve_qp` (read only; not frozen, whose ``__init__`` costs 1.2 instead of
    0.3 us, on every one of the tracking QPs)."""

    success: bool
    """Whether ``x`` is the minimiser."""
    reason: str
    """Empty on success, else why not (``infeasible``: no point satisfies every row)."""
    x: np.ndarray
    """The minimiser (unspecified on failure)."""
    iterations: int
    """Active-set changes the solver made."""
    multipliers: np.ndarray | None = None
    """DAQP's multipliers of the constraints (the bounds, then the rows): nonzero (negative) on
    those active at the minimiser, which :func:`start_from` makes a later solve's start."""


def solve_qp(hessian: np.ndarray, gradient: np.ndarray, rows: np.ndarray, lower: np.ndarray, tol: float,
             bounds: np.ndarray | None = None, start_active: np.ndarray | None = None,
             start: np.ndarray | None = None, start_multipliers: np.ndarray | None = None) -> QPSolution:
    """Minimise ``x^T H x / 2 + g^T x`` subject to ``rows @ x >= lower`` and ``x >= bounds`` (DAQP).

    ``H`` must be positive definite. ``bounds`` (one per variable, optional) are handled by DAQP
    as simple bounds, cheaper than rows. Rows or bounds at ``-inf`` never bind. A row may be
    violated by up to ``tol`` (DAQP's primal tolerance), so callers tighten their rows by it.
    ``start_active`` (a mask over ``bounds``) makes those bounds DAQP's initial working set: a
    guess of the constraints active at the minimiser saves the iterations that would add them.
    ``start`` (indices of constraints, the bounds then the rows, :func:`start_from`) makes
    those constraints DAQP's initial working set instead (those at ``-inf`` left out: DAQP would
    activate them and return NaN), e.g. the constraints active at the minimiser of the previous
    control step's QP (a warm start). The QP is strictly convex, so a start changes only
    DAQP's path to its unique minimiser: DAQP drops constraints of the start whose multipliers
    have the wrong sign and stops adding them at the first linearly dependent one. A
    warm-started solve that fails for any reason but infeasibility (which DAQP proves from a
    dual ray, whatever the start) is solved again cold. ``start_multipliers`` (an earlier
    solution's :attr:`QPSolution.multipliers`, instead of ``start``) is the same start as
    ``start_from`` of that solution, its flags found in one pass (:func:`warm_flags`).
    """
    if bounds is None:
        low = lower if _plain(lower) else np.ascontiguousarray(lower, dtype=float)
    else:
        low = np.concatenate([np.asarray(bounds, dtype=float), np.asarray(lower, dtype=float)])
    warm = None  # DAQP's constraint flags of the start (1 active, 2 at the lower bound), if any
    if start is not None and len(start) and start[-1] < len(low):
        warm = start_flags(low, start)
    elif start_multipliers is not None:
        flags = np.empty(len(low), dtype=np.intc)  # DAQP copies the flags into its own workspace
        if warm_flags(low, start_multipliers, flags):  # else cold, as with start_from's indices
            warm = flags
    h = hessian if _plain(hessian) else np.ascontiguousarray(hessian, dtype=float)
    g = gradient if _plain(gradient) else np.ascontiguousarray(gradient, dtype=float)
    a = rows if _plain(rows) else np.ascontiguousarray(rows, dtype=float)
    # The cold flags only when they are used: without a start, or again after a failed warm one.
    sense = warm if warm is not None else cold_flags(start_active, len(lower))
    x, flag, iterations, lam = _daqp(h, g, a, low, sense, primal_tol=tol)
    if warm is not None and flag not in (1, -1):
        x, flag, more, lam = _daqp(h, g, a, low, cold_flags(start_active, len(lower)), primal_tol=tol)
        iterations += more
    if flag == 1:
        return QPSolution(True, "", x, iterations, lam)
    return QPSolution(False, _DAQP_REASONS.get(flag, f"DAQP exit flag {flag}"), x, iterations, lam)


#: Whether :func:`solve_qp` and :func:`least_relaxation` call DAQP's C solver directly
#: (:mod:`nodnav.control.daqp_native`, where the installed DAQP's struct layouts are verified)
#: rather than through ``daqp.solve``: the same solver, settings and data, so the same bits
#: (tests/control/test_daqp_native.py), without the wrapper's Python around each call.
NATIVE_DAQP = True


def _daqp(h: np.ndarray, g: np.ndarray, a: np.ndarray, low: np.ndarray, sense: np.ndarray | None,
          primal_tol: float | None = None, eps_prox: float | None = None) -> tuple[np.ndarray, int, int, np.ndarray]:
    """DAQP on ``h, g, a`` (C-contiguous float64) with lower bounds ``low`` (simple bounds first),
    no upper ones, the constraint flags ``sense`` (None: all 0) and the settings ``primal_tol`` and
    ``eps_prox`` (None: DAQP's default): ``x``, the exit flag, the iterations and the multipliers,
    as ``daqp.solve`` returns them (the multipliers unspecified unless the flag is 1: DAQP leaves
    them unwritten)."""
    address = daqp_native.quadprog_address() if NATIVE_DAQP else None
    if address is None:
        settings = {k: v for k, v in (("primal_tol", primal_tol), ("eps_prox", eps_prox)) if v is not None}
        x, _, flag, info = daqp.solve(h, g, a, _no_upper(len(low)), low, sense, **settings)
        return x, flag, int(info["iterations"]), info["lam"]
    if sense is None:
        sense = _zero_flags(len(low))
    x, lam, _, flag, iterations, _, _, _ = daqp_native.quadprog_kernel(
        address, h, g, a, _no_upper(len(low)), low, sense, daqp_native.settings_for(primal_tol, eps_prox))
    return x, flag, iterations, lam


def cold_flags(start_active: np.ndarray | None, n_rows: int) -> np.ndarray | None:
    """DAQP's constraint flags of a cold start: 3 (active, at the lower bound) on the bounds
    ``start_active`` marks, 0 on the rest and on the ``n_rows`` rows; None (all 0) without a mask."""
    if start_active is None:
        return None
    return np.concatenate([np.where(start_active, 3, 0), np.zeros(n_rows)]).astype(np.intc)


def start_from(solution: QPSolution) -> np.ndarray | None:
    """The constraints active at ``solution`` (indices, the bounds then the rows, increasing),
    a later solve's ``start`` (:func:`solve_qp`), or None if it failed."""
    if not solution.success or solution.multipliers is None:
        return None
    return solution.multipliers.nonzero()[0]  # np.flatnonzero of the (one-dimensional) multipliers


@compiled
def start_flags(low, start):
    """DAQP's constraint flags ``(len(low),)`` for the start: 3 (active, at the lower bound) on
    the constraints ``start`` whose lower bound is finite, 0 elsewhere (one compiled call for
    NumPy's ``zeros``, ``isfinite`` and two fancy indexings, the same flags)."""
    sense = np.zeros(low.shape[0], dtype=np.intc)
    for i in start:
        if np.isfinite(low[i]):
            sense[i] = 3
    return sense


@compiled
def warm_flags(low, multipliers, sense):
    """:func:`start_flags` of ``start_from``'s indices (the nonzero ``multipliers``, NaN
    included) in one pass, written into ``sense`` (``(len(low),)``, every entry; a returned array
    would cost numba a Python call to box it). Returns False where :func:`solve_qp` would start
    cold instead: no nonzero multiplier, or one beyond ``low`` (a start of the wrong length)."""
    sense[:] = 0
    found = False
    for i in range(multipliers.shape[0]):
        if multipliers[i] != 0.0:
            if i >= low.shape[0]:
                return False
            found = True
            if np.isfinite(low[i]):
                sense[i] = 3
    return found


_F64 = np.dtype(np.float64)


def _plain(a: np.ndarray) -> bool:
    """Whether ``a`` is already what DAQP takes as it is (a C-contiguous float64 array)."""
    return type(a) is np.ndarray and a.dtype is _F64 and a.flags.c_contiguous


_UPPER: dict[int, np.ndarray] = {}

#: How many kinds of QP a :class:`SolverEffort`'s ``starts`` remembers (the oldest goes first).
MAX_STARTS = 16


_ZERO_FLAGS: dict[int, np.ndarray] = {}


def _zero_flags(n: int) -> np.ndarray:
    """DAQP's flags of ``n`` inactive inequalities (what ``daqp.solve`` passes for no flags; one
    array per size, never written: ``daqp_quadprog`` copies the flags into its workspace)."""
    flags = _ZERO_FLAGS.get(n)
    if flags is None:
        flags = _ZERO_FLAGS[n] = np.zeros(n, dtype=np.intc)
    return flags


def _no_upper(n: int) -> np.ndarray:
    """``+inf`` upper bounds for ``n`` constraints (one array per size, never written: DAQP
    copies its bounds into its own workspace)."""
    up = _UPPER.get(n)
    if up is None:
        up = _UPPER[n] = np.full(n, np.inf)
    return up


@compiled
def relaxed_rows(rows, lower, relaxed, low, finite):
    """:func:`least_relaxation`'s LP data, written in place: for the ``m`` rows with a finite
    ``lower`` (in order), their indices into ``finite[:m]``, the rows ``[1, rows[i]]`` into
    ``relaxed[:m]`` and the bounds ``[0, lower[i]...]`` into ``low[:m + 1]``; returns ``m``. The
    same values as NumPy's ``flatnonzero(isfinite(lower))``, gathering and ``hstack`` (copies)."""
    low[0] = 0.0
    m = 0
    for i in range(lower.shape[0]):
        if np.isfinite(lower[i]):
            finite[m] = i
            low[m + 1] = lower[i]
            relaxed[m, 0] = 1.0
            for j in range(rows.shape[1]):
                relaxed[m, j + 1] = rows[i, j]
            m += 1
    return m


_LP_OBJECTIVES: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _lp_objective(n: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`least_relaxation`'s zero Hessian ``(n, n)`` and cost ``(1, 0, ..., 0)`` over its ``n``
    variables ``(t, x)`` (one pair per size, never written: DAQP only reads its problem data)."""
    pair = _LP_OBJECTIVES.get(n)
    if pair is None:
        cost = np.zeros(n)
        cost[0] = 1.0
        pair = _LP_OBJECTIVES[n] = (np.zeros((n, n)), cost)
    return pair


def infeasibility_certificate(rows: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """Rows that together admit no ``x`` with ``rows @ x >= lower``: the support of a Farkas certificate.

    ``{x : A x >= b}`` is empty exactly when some ``y >= 0`` has ``A^T y = 0`` and ``b^T y > 0``
    (Farkas' lemma). Such a ``y`` (normalised to ``sum y = 1``) is the dual solution of the
    linear program "least uniform relaxation": minimise ``t >= 0`` subject to
    ``A x + t >= b``, positive exactly when the rows conflict. DAQP solves it with proximal
    regularisation (well under a millisecond for the MPC's few hundred rows) and, keeping its
    working set linearly independent, ends at a vertex, whose support is an irreducible
    infeasible subset: few rows. Should DAQP not converge, SciPy's HiGHS solves the dual LP
    (``max b^T y`` over ``A^T y = 0``, ``sum y = 1``, ``y >= 0``) instead, about 8 ms. Returns
    the indices of the rows with ``y > 0`` (empty if the rows are consistent). Rows at ``-inf``
    never take part.
    """
    return least_relaxation(rows, lower)[0]


def least_relaxation(rows: np.ndarray, lower: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`infeasibility_certificate`'s support, and the LP's optimal value: the least ``t >= 0``
    with some ``x`` meeting ``rows @ x + t >= lower`` (m for the MPC's rows; 0 when consistent).
    No ``x`` violates every row by at most ``t``, less the LP's own tolerance: a QP on these
    rows whose primal tolerance is far below ``t`` cannot succeed."""
    rows, lower = np.asarray(rows, dtype=float), np.asarray(lower, dtype=float)
    k, n = rows.shape
    # Variables (t, x); t >= 0 is DAQP's simple bound, the first entry of the bound vectors.
    # The rows [1, a] and bounds [0, b] of the finite rows written in one compiled pass (no
    # isfinite, gathering copy or hstack); the zero Hessian, unit cost and +inf upper bounds are
    # shared per size.
    relaxed, low, finite = np.empty((k, n + 1)), np.empty(k + 1), np.empty(k, dtype=np.intp)
    m = relaxed_rows(rows, lower, relaxed, low, finite)
    relaxed, low, finite = relaxed[:m], low[:m + 1], finite[:m]
    hessian, cost = _lp_objective(n + 1)
    tx, flag, _, lam = _daqp(hessian, cost, relaxed, low, None, eps_prox=1.0)
    if flag == 1:
        if tx[0] <= 0.0:
            return np.zeros(0, dtype=int), 0.0
        # DAQP's multipliers of active lower bounds are negative.
        return finite[-np.asarray(lam)[1:] > 1e-12], float(tx[0])
    a, b = rows[finite], lower[finite]
    res = linprog(-b, A_eq=np.vstack([a.T, np.ones(len(finite))]), b_eq=np.append(np.zeros(n), 1.0),
                  bounds=(0.0, None), method="highs")
    if res.status != 0 or -res.fun <= 0.0:
        return np.zeros(0, dtype=int), 0.0
    return finite[res.x > 1e-12], float(-res.fun)


@dataclass
class SolverEffort:
    """Solver effort spent on one control step (reported in ``ControlResult.info``), and the
    solver calls that count it."""

    qps: int = 0
    """QPs solved."""
    qp_steps: int = 0
    """Active-set changes over those QPs."""
    qp_time: float = 0.0
    """Time inside the QP and LP solvers (s)."""
    constraints: int = 0
    """Most constraints (rows and finite bounds) of one QP."""
    starts: dict | None = None
    """Warm starts by kind of QP (the controller's, kept between steps): the multipliers of the
    last solution of each kind (its start is :func:`start_from`'s, :func:`warm_flags`); None:
    every solve starts cold."""

    def solve(self, hessian: np.ndarray, gradient: np.ndarray, rows: np.ndarray, lower: np.ndarray, tol: float,
              bounds: np.ndarray | None = None, start_active: np.ndarray | None = None,
              kind: object = None, like: object = None) -> QPSolution:
        """:func:`solve_qp`, counted, and warm-started from the last solution of the same
        ``kind`` (a key naming the same rows and variables in the same order, e.g. the problem
        object), else from that of the kind ``like`` (the same rows and variables, other data)."""
        starts = self.starts if kind is not None else None  # where this kind's start is kept, if anywhere
        warm = None
        if starts is not None:
            warm = starts.get(kind)
            if warm is None and like is not None:
                warm = starts.get(like)
        t = time.perf_counter()
        sol = solve_qp(hessian, gradient, rows, lower, tol, bounds, start_active, None, warm)
        self.qp_time += time.perf_counter() - t
        self.qps += 1
        self.qp_steps += sol.iterations
        n = len(lower) if bounds is None else len(lower) + int(np.isfinite(bounds).sum())
        if n > self.constraints:
            self.constraints = n
        if starts is not None and sol.success:
            if len(starts) >= MAX_STARTS and kind not in starts:
                starts.pop(next(iter(starts)))
            # The multipliers, not their nonzero indices: the next solve's flags take one pass over them.
            starts[kind] = sol.multipliers
        return sol

    def certificate(self, rows: np.ndarray, lower: np.ndarray) -> np.ndarray:
        """:func:`infeasibility_certificate`, its time counted."""
        t = time.perf_counter()
        support = infeasibility_certificate(rows, lower)
        self.qp_time += time.perf_counter() - t
        return support

    def relaxation(self, rows: np.ndarray, lower: np.ndarray) -> tuple[np.ndarray, float]:
        """:func:`least_relaxation`, its time counted."""
        t = time.perf_counter()
        found = least_relaxation(rows, lower)
        self.qp_time += time.perf_counter() - t
        return found

    def as_info(self) -> dict:
        """The counts as ``ControlResult.info`` entries."""
        return {"qps": self.qps, "qp_steps": self.qp_steps, "qp_time": self.qp_time,
                "constraints": self.constraints}
