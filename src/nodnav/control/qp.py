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
    x, _, flag, info = daqp.solve(h, g, a, _no_upper(len(low)), low, sense, primal_tol=tol)
    iterations = int(info["iterations"])
    if warm is not None and flag not in (1, -1):
        x, _, flag, info = daqp.solve(h, g, a, _no_upper(len(low)), low, cold_flags(start_active, len(lower)),
                                      primal_tol=tol)
        iterations += int(info["iterations"])
    if flag == 1:
        return QPSolution(True, "", x, iterations, info["lam"])
    return QPSolution(False, _DAQP_REASONS.get(flag, f"DAQP exit flag {flag}"), x, iterations, info["lam"])


#: How far beyond the radius (relative, absolute) a row must lie to be left out of a reduced solve
#: (:func:`solve_reduced`): covers the few ulps by which :func:`~nodnav.control.mpc_rows.row_reach`'s
#: distances and DAQP's own products differ.
REACH_MARGIN = (1e-9, 1e-9)


def solve_reduced(hessian: np.ndarray, gradient: np.ndarray, rows: np.ndarray, lower: np.ndarray, tol: float,
                  reach: np.ndarray, last: float, start_multipliers: np.ndarray | None = None
                  ) -> tuple[QPSolution | None, float]:
    """:func:`solve_qp` of an identity-Hessian QP (no bounds) on only the rows DAQP could pick, or
    None where that cannot be shown; and the radius it took.

    DAQP solves the least-distance problem ``min |u|`` over ``u = x + gradient`` (with ``H = I``
    its whitened coordinates are these), rows ``rows[i] @ u >= lower[i] + rows[i] @ gradient``,
    each scaled to a unit normal (``daqp_normalize_M``). It adds a row to its working set only in
    ``daqp_add_infeasible``: the row with the most negative scaled slack, ties to the lowest
    index, and only if that slack is below ``-tol``; and only at iterates whose multipliers are
    all non-negative. Such an iterate minimises ``|u|`` over its working set's rows alone, a
    relaxation of the QP: it is no longer than the optimum ``u*``. A row whose half-plane holds
    the whole ball ``|u| <= r`` (``reach[i] >= r``, :func:`~nodnav.control.mpc_rows.row_reach`)
    therefore never has a negative slack while ``|u*| <= r``, and is never picked. Every per-row
    quantity (``daqp_compute_Mu``, the scaling, ``daqp_update_ldp``'s slacks) depends on that row
    alone, so the same QP without such rows (the others in their order) takes DAQP through the
    same working sets: the same ``x``, multipliers (zero on the rows left out) and iterations.
    DAQP's shortcut for a cold start (``daqp_check_unconstrained``: ``x = -gradient`` checked
    against every row) gives the same verdict too: a row left out holds ``u = 0`` with a slack
    of at least its margin. Rows at ``-inf`` are never picked; the rows of the warm start's
    working set (:func:`warm_flags`) are always kept.

    The radius is guessed (``max(2 |gradient|, 2 last)``, ``last`` the norm of the previous
    optimum of the same problem) and checked after the solve: the reduced solution is returned
    only if DAQP succeeded (warm, else cold after a failed warm start, as :func:`solve_qp`) with
    ``|u*| <= r``. Otherwise None: the caller solves the full QP, whose failures and reasons are
    its own. Also returns ``|u*|`` (NaN when DAQP failed): the next solve's ``last``."""
    n = lower.shape[0]
    sense = np.empty(n, dtype=np.intc)
    found = start_multipliers is not None and warm_flags(lower, start_multipliers, sense)
    if not found:
        sense[:] = 0
    kept_rows, kept_lower, kept_sense, index = np.empty(rows.shape), np.empty(n), np.empty(n, dtype=np.intc), \
        np.empty(n, dtype=np.intp)
    m, radius = reduced_rows(rows, lower, reach, gradient, last, REACH_MARGIN[0], REACH_MARGIN[1], sense, kept_rows,
                             kept_lower, kept_sense, index)
    a, low = kept_rows[:m], kept_lower[:m]
    x, _, flag, info = daqp.solve(hessian, gradient, a, _no_upper(m), low, kept_sense[:m] if found else None,
                                  primal_tol=tol)
    iterations = int(info["iterations"])
    if found and flag not in (1, -1):
        x, _, flag, info = daqp.solve(hessian, gradient, a, _no_upper(m), low, None, primal_tol=tol)
        iterations += int(info["iterations"])
    if flag != 1:
        return None, np.nan
    norm = whitened_norm(x, gradient)
    if not norm <= radius:
        return None, norm
    multipliers = np.zeros(n)
    multipliers[index[:m]] = info["lam"]
    return QPSolution(True, "", x, iterations, multipliers), norm


@compiled
def reduced_rows(rows, lower, reach, gradient, last, relative, absolute, sense, kept_rows, kept_lower, kept_sense,
                 index):
    """:func:`solve_reduced`'s rows: the radius ``r = max(2 |gradient|, 2 last)``, then, in order,
    the rows with ``reach < r (1 + relative) + absolute`` or a nonzero ``sense`` (the warm
    start's), copied with their bounds and flags into the first ``m`` entries of ``kept_*`` and
    their indices into ``index``. Returns ``m`` and ``r``."""
    sq = 0.0
    for j in range(gradient.shape[0]):
        sq += gradient[j] * gradient[j]
    radius = max(2.0 * np.sqrt(sq), 2.0 * last)
    cut = radius * (1.0 + relative) + absolute
    m = 0
    for i in range(lower.shape[0]):
        if reach[i] < cut or sense[i] != 0:
            index[m] = i
            kept_lower[m] = lower[i]
            kept_sense[m] = sense[i]
            for j in range(rows.shape[1]):
                kept_rows[m, j] = rows[i, j]
            m += 1
    return m, radius


@compiled
def whitened_norm(x, gradient):
    """``|x + gradient|``: the length of DAQP's ``u`` at ``x`` when the Hessian is the identity."""
    sq = 0.0
    for j in range(x.shape[0]):
        u = x[j] + gradient[j]
        sq += u * u
    return np.sqrt(sq)


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
    tx, _, flag, info = daqp.solve(hessian, cost, relaxed, _no_upper(m + 1), low, None, eps_prox=1.0)
    if flag == 1:
        if tx[0] <= 0.0:
            return np.zeros(0, dtype=int), 0.0
        # DAQP's multipliers of active lower bounds are negative.
        return finite[-np.asarray(info["lam"])[1:] > 1e-12], float(tx[0])
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
    reduced: dict | None = None
    """What a reduced solve (:func:`solve_reduced`) of each kind reads of the last solve of that
    kind (the controller's, kept between steps): NaN if it failed, else its optimum's whitened
    norm. None: every solve is of the full QP."""

    def solve(self, hessian: np.ndarray, gradient: np.ndarray, rows: np.ndarray, lower: np.ndarray, tol: float,
              bounds: np.ndarray | None = None, start_active: np.ndarray | None = None,
              kind: object = None, like: object = None, reach: np.ndarray | None = None) -> QPSolution:
        """:func:`solve_qp`, counted, and warm-started from the last solution of the same
        ``kind`` (a key naming the same rows and variables in the same order, e.g. the problem
        object), else from that of the kind ``like`` (the same rows and variables, other data).
        With ``reach`` (an identity Hessian and no bounds: :func:`solve_reduced`) and a
        :attr:`reduced` memory, first on the rows DAQP could pick, unless the last solve of the
        same kind failed (a deadlocked robot's fails step after step, and a failure means a full
        solve besides); the same result either way."""
        starts = self.starts if kind is not None else None  # where this kind's start is kept, if anywhere
        warm = None
        if starts is not None:
            warm = starts.get(kind)
            if warm is None and like is not None:
                warm = starts.get(like)
        t = time.perf_counter()
        memory = self.reduced if reach is not None and kind is not None else None
        sol = None
        if memory is not None and reach is not None:  # (memory implies reach; said again for mypy)
            last = memory.get(kind, 0.0)
            if last == last:  # not NaN: the last solve of this kind succeeded (or there was none)
                sol, norm = solve_reduced(hessian, gradient, rows, lower, tol, reach, last, warm)
        if sol is None:
            sol = solve_qp(hessian, gradient, rows, lower, tol, bounds, start_active, None, warm)
            if memory is not None:
                norm = whitened_norm(sol.x, gradient) if sol.success else np.nan
        if memory is not None:
            if len(memory) >= MAX_STARTS and kind not in memory:
                memory.pop(next(iter(memory)))
            memory[kind] = norm
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
