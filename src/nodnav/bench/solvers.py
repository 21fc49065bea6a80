"""Which solver for the MPC's QPs: every QP of a few closed-loop trials, solved again by each candidate.

The evidence behind DAQP (:mod:`nodnav.control.qp`) as a command (``nodnav bench solvers``).
:func:`recording` wraps :meth:`~nodnav.control.qp.SolverEffort.solve` for the duration of the
trials only (nothing in the closed loop is edited, as :mod:`nodnav.bench.stages` does) and keeps a
copy of every QP the MPC hands it: the tracking QPs and the evasive ones (those with simple
bounds, on the slack variables). :func:`compare_solvers` then solves each recorded QP with

* ``DAQP``: :func:`~nodnav.control.qp.solve_qp` with the recorded tolerance and start, as the loop does;
* ``OSQP``: OSQP (operator splitting, Apache-2.0) at its default settings;
* ``OSQP tight``: OSQP with ``eps_abs = eps_rel = 1e-9``, polishing, and 20,000 iterations at
  most (five times its default);
* ``Clarabel``: Clarabel (an interior-point method with homogeneous embedding, Apache-2.0,
  wheels on the package index), the reference: a different algorithm from DAQP's active set, it
  ends with either a minimiser or a certificate of primal infeasibility, and it is run with its
  gap and feasibility tolerances at 1e-12 (:data:`CLARABEL_TOLERANCE`). At its default 1e-8 its
  minimiser differs from DAQP's by up to 1e-3 on these problems (the Hessian's smallest
  eigenvalue is about 1e-4, so the objective barely tells such points apart); at 1e-12 the two
  agree to about 1e-8.

A solver's answer on a problem the reference solves counts as *at the optimum* when the solver
reports a minimiser whose objective is within :data:`OBJECTIVE_TOL` (relative, with 1 as the
floor) of the reference's and whose variables are within :data:`X_TOL` (max norm, relative,
floor 1) of the reference's. On a problem the reference finds infeasible, only a verdict of
"infeasible" counts. Problems on which the reference reaches no verdict are counted and left out.
OSQP and Clarabel are the ``solvers`` extra (:func:`missing_solvers`).

Times are processor time of this process (``time.process_time``: on a shared machine the wall
clock also counts the time other programs held the processor) for the solver's own calls
(OSQP's and Clarabel's set-up, which factorises, and solve; DAQP's solve), not for building the
sparse matrices, measured one after another on one core. OSQP prints a line on standard output
when it finds nothing to polish, whatever its ``verbose``; :func:`judge` sends the process's
standard output to the null device while it solves.
"""

from __future__ import annotations

import ctypes
import functools
import importlib.util
import logging
import os
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from nodnav.control.qp import SolverEffort, solve_qp
from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import run_trial

logger = logging.getLogger(__name__)

#: What ``bench solvers`` runs without options: about a minute on one core.
DEFAULT_SCENARIOS = ("3r-case1", "4r-case1")
DEFAULT_SEEDS = 1
#: Agreement with the reference's objective: ``|f - f*| <= OBJECTIVE_TOL * max(1, |f*|)``.
OBJECTIVE_TOL = 1e-6
#: Agreement with the reference's minimiser: ``max |x - x*| <= X_TOL * max(1, max |x*|)``.
X_TOL = 1e-4
#: OSQP's settings at its best for these problems (``OSQP tight``).
OSQP_TIGHT = {"eps_abs": 1e-9, "eps_rel": 1e-9, "polishing": True, "max_iter": 20_000}
#: Clarabel's gap and feasibility tolerances (its defaults are 1e-8).
CLARABEL_TOLERANCE = 1e-12
#: The solvers compared, in the order reported; the last is the reference.
SOLVERS = ("DAQP", "OSQP", "OSQP tight", "Clarabel")
REFERENCE = SOLVERS[-1]
#: Verdicts of a solver on one QP.
OPTIMAL, INFEASIBLE, ITERATION_LIMIT, FAILED = "optimal", "infeasible", "iteration limit", "failed"


@dataclass(frozen=True)
class RecordedQP:
    """Minimise ``x^T H x / 2 + g^T x`` subject to ``rows @ x >= lower`` and ``x >= bounds``, as the
    MPC asked :func:`~nodnav.control.qp.solve_qp` (rows or bounds at ``-inf`` never bind)."""

    hessian: np.ndarray
    """``H`` (positive definite)."""
    gradient: np.ndarray
    """``g``."""
    rows: np.ndarray
    """The inequality rows."""
    lower: np.ndarray
    """Their lower bounds."""
    tol: float
    """DAQP's primal tolerance the loop used."""
    bounds: np.ndarray | None = None
    """Simple lower bounds per variable, or none."""
    start_active: np.ndarray | None = None
    """DAQP's initial working set over ``bounds``, as the loop gave it."""
    source: str = ""
    """Where it came from (``scenario/seed``)."""

    @property
    def kind(self) -> str:
        """``evasive`` (the fallback's QP, with bounds on its slacks) or ``tracking``."""
        return "tracking" if self.bounds is None else "evasive"

    def objective(self, x: np.ndarray) -> float:
        """The objective at ``x``."""
        return float(0.5 * x @ self.hessian @ x + self.gradient @ x)

    def standard_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """``(A, b)`` with ``A x >= b``: the finite rows, then an identity row per finite bound."""
        keep = np.isfinite(self.lower)
        a, b = [self.rows[keep]], [self.lower[keep]]
        if self.bounds is not None:
            finite = np.flatnonzero(np.isfinite(self.bounds))
            a.append(np.eye(len(self.gradient))[finite])
            b.append(self.bounds[finite])
        return np.vstack(a), np.concatenate(b)


@dataclass(frozen=True)
class Answer:
    """One solver's answer to one QP."""

    verdict: str
    """:data:`OPTIMAL`, :data:`INFEASIBLE`, :data:`ITERATION_LIMIT` or :data:`FAILED`."""
    x: np.ndarray | None
    """The minimiser reported (with :data:`OPTIMAL`)."""
    seconds: float
    """Time of the solver's calls (s)."""
    detail: str = ""
    """The solver's own status."""


@contextmanager
def recording(into: list[RecordedQP], source: Callable[[], str] = lambda: "") -> Iterator[list[RecordedQP]]:
    """Copy every QP :meth:`SolverEffort.solve` is given into ``into`` while inside (restored after).

    The arrays are copied: the MPC reuses its rows as scratch space from one QP to the next.
    """
    saved = SolverEffort.__dict__["solve"]

    def solve(self, hessian, gradient, rows, lower, tol, bounds=None, start_active=None, kind=None, like=None):
        # The QP is recorded without the controller's warm start (``kind``, ``like``): the
        # solvers compared are each given it cold.
        into.append(RecordedQP(
            np.array(hessian, dtype=float), np.array(gradient, dtype=float), np.array(rows, dtype=float),
            np.array(lower, dtype=float), float(tol), None if bounds is None else np.array(bounds, dtype=float),
            None if start_active is None else np.array(start_active, dtype=bool), source()))
        return saved(self, hessian, gradient, rows, lower, tol, bounds, start_active, kind=kind, like=like)

    functools.update_wrapper(solve, saved)
    name = "solve"  # set by name: the class's method is replaced for the recording only
    try:
        setattr(SolverEffort, name, solve)
        yield into
    finally:
        setattr(SolverEffort, name, saved)


def record_trials(scenarios: tuple[str, ...], seeds: tuple[int, ...], method: str = "nod",
                  time_limit: float | None = None) -> tuple[list[RecordedQP], list[str]]:
    """Every QP the MPC solves in the trials ``scenarios x seeds``, and each trial's outcome
    (``time_limit``: end each trial after this many simulated seconds, for tests)."""
    qps: list[RecordedQP] = []
    outcomes = []
    current = [""]
    with recording(qps, lambda: current[0]):
        for name in scenarios:
            scenario = load_scenario(name)
            if time_limit is not None:
                scenario = scenario.with_overrides(time_limit=time_limit)
            for seed in seeds:
                current[0] = f"{name}/{seed}"
                outcomes.append(f"{name}/{seed}: {run_trial(scenario, method, seed).outcome}")
                logger.info("%s: %d QPs recorded so far", outcomes[-1], len(qps))
    return qps, outcomes


def missing_solvers() -> list[str]:
    """The Python packages of the ``solvers`` extra that are not installed."""
    return [m for m in ("osqp", "clarabel") if importlib.util.find_spec(m) is None]


def solve_daqp(qp: RecordedQP) -> Answer:
    """DAQP through :func:`~nodnav.control.qp.solve_qp`, as the MPC calls it."""
    t = time.process_time()
    sol = solve_qp(qp.hessian, qp.gradient, qp.rows, qp.lower, qp.tol, qp.bounds, qp.start_active)
    seconds = time.process_time() - t
    if sol.success:
        return Answer(OPTIMAL, sol.x, seconds)
    verdict = {"infeasible": INFEASIBLE, "iteration limit": ITERATION_LIMIT}.get(sol.reason, FAILED)
    return Answer(verdict, None, seconds, sol.reason)


def solve_osqp(qp: RecordedQP, settings: dict | None = None) -> Answer:
    """OSQP on ``l <= A x <= u`` with ``u = inf`` (``settings``: OSQP's, e.g. :data:`OSQP_TIGHT`)."""
    import osqp
    from scipy import sparse

    a, b = qp.standard_rows()
    p = sparse.triu(sparse.csc_matrix(qp.hessian), format="csc")
    a_csc = sparse.csc_matrix(a)
    upper = np.full(len(b), np.inf)
    t = time.process_time()
    solver = osqp.OSQP()
    solver.setup(p, qp.gradient, a_csc, b, upper, verbose=False, **(settings or {}))
    res = solver.solve(raise_error=False)
    seconds = time.process_time() - t
    status = osqp.SolverStatus(res.info.status_val)
    if status == osqp.SolverStatus.OSQP_SOLVED:
        return Answer(OPTIMAL, np.array(res.x), seconds, status.name)
    verdict = {osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE: INFEASIBLE,
               osqp.SolverStatus.OSQP_MAX_ITER_REACHED: ITERATION_LIMIT}.get(status, FAILED)
    return Answer(verdict, None, seconds, status.name)


def solve_clarabel(qp: RecordedQP) -> Answer:
    """Clarabel on ``-A x + s = -b``, ``s >= 0``, one thread, tolerances :data:`CLARABEL_TOLERANCE`."""
    import clarabel
    from scipy import sparse

    a, b = qp.standard_rows()
    p = sparse.triu(sparse.csc_matrix(qp.hessian), format="csc")
    a_csc = sparse.csc_matrix(-a)
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.max_threads = 1
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = CLARABEL_TOLERANCE
    t = time.process_time()
    res = clarabel.DefaultSolver(p, qp.gradient, a_csc, -b, [clarabel.NonnegativeConeT(len(b))], settings).solve()
    seconds = time.process_time() - t
    if res.status == clarabel.SolverStatus.Solved:
        return Answer(OPTIMAL, np.array(res.x), seconds, str(res.status))
    verdict = {clarabel.SolverStatus.PrimalInfeasible: INFEASIBLE,
               clarabel.SolverStatus.MaxIterations: ITERATION_LIMIT}.get(res.status, FAILED)
    return Answer(verdict, None, seconds, str(res.status))


#: Each solver's adapter.
ADAPTERS: dict[str, Callable[[RecordedQP], Answer]] = {
    "DAQP": solve_daqp,
    "OSQP": solve_osqp,
    "OSQP tight": lambda qp: solve_osqp(qp, OSQP_TIGHT),
    "Clarabel": solve_clarabel,
}


def at_optimum(qp: RecordedQP, answer: Answer, reference: Answer) -> bool:
    """Whether ``answer`` reports a minimiser agreeing with ``reference``'s (:data:`OBJECTIVE_TOL`, :data:`X_TOL`)."""
    if answer.verdict != OPTIMAL or answer.x is None or reference.x is None:
        return False
    f, f_ref = qp.objective(answer.x), qp.objective(reference.x)
    scale_x = max(1.0, float(np.max(np.abs(reference.x))))
    return bool(abs(f - f_ref) <= OBJECTIVE_TOL * max(1.0, abs(f_ref))
                and np.max(np.abs(answer.x - reference.x)) <= X_TOL * scale_x)


@dataclass
class SolverTally:
    """One solver's record over the recorded QPs, judged against the reference."""

    solver: str
    """Its name (:data:`SOLVERS`)."""
    optimal: int = 0
    """Problems the reference solves on which it reported a minimiser at the reference's optimum."""
    off_optimum: int = 0
    """... on which it reported a minimiser that is not (too far in objective or variables)."""
    infeasible_found: int = 0
    """Problems the reference finds infeasible that it declared infeasible."""
    wrong_verdict: int = 0
    """Feasible problems it declared infeasible, or infeasible ones it claimed to solve."""
    iteration_limit: int = 0
    """Problems (with a reference verdict) on which it stopped at its iteration limit."""
    failed: int = 0
    """Problems (with a reference verdict) on which it stopped for another reason."""
    seconds: list[float] = field(default_factory=list)
    """Time per solve over every recorded QP (s)."""
    failures: dict[str, int] = field(default_factory=dict)
    """The solver's own status on the problems it :data:`FAILED`, and whether the reference
    found them feasible or infeasible -> how many."""

    def to_dict(self) -> dict:
        """JSON-ready counts and time per solve in milliseconds."""
        t = np.array(self.seconds) if self.seconds else np.zeros(1)
        return {"solver": self.solver, "optimal": self.optimal, "off_optimum": self.off_optimum,
                "infeasible_found": self.infeasible_found, "wrong_verdict": self.wrong_verdict,
                "iteration_limit": self.iteration_limit, "failed": self.failed,
                "median_ms": 1e3 * float(np.median(t)), "p95_ms": 1e3 * float(np.percentile(t, 95)),
                "failures": dict(self.failures)}


@dataclass(frozen=True)
class SolverComparison:
    """The result of :func:`compare_solvers`."""

    scenarios: tuple[str, ...]
    """Scenarios of the trials."""
    seeds: tuple[int, ...]
    """Their seeds."""
    outcomes: tuple[str, ...]
    """Each trial's outcome."""
    qps: int
    """QPs recorded."""
    evasive: int
    """Of them, evasive QPs."""
    feasible: int
    """QPs the reference solved."""
    infeasible: int
    """QPs the reference found infeasible."""
    undecided: int
    """QPs on which the reference reached no verdict (left out of the counts)."""
    tallies: tuple[SolverTally, ...]
    """Per solver, in the order of :data:`SOLVERS`."""

    def to_dict(self) -> dict:
        """JSON-ready."""
        return {"scenarios": list(self.scenarios), "seeds": list(self.seeds), "outcomes": list(self.outcomes),
                "qps": self.qps, "evasive": self.evasive, "feasible": self.feasible, "infeasible": self.infeasible,
                "undecided": self.undecided, "reference": REFERENCE, "objective_tol": OBJECTIVE_TOL, "x_tol": X_TOL,
                "solvers": [t.to_dict() for t in self.tallies]}

    def format(self) -> str:
        """A table, one row per solver."""
        lines = [f"{self.qps} QPs ({self.evasive} evasive) from {len(self.outcomes)} trials "
                 f"({'; '.join(self.outcomes)}); reference {REFERENCE}: {self.feasible} solved, "
                 f"{self.infeasible} infeasible, {self.undecided} undecided (left out)",
                 f"at the optimum: objective within {OBJECTIVE_TOL:g} and x within {X_TOL:g} (relative, floor 1) "
                 "of the reference's",
                 f"{'solver':<12} {'at optimum':>12} {'off optimum':>11} {'infeasible':>12} {'wrong':>6} "
                 f"{'iter limit':>10} {'failed':>6} {'median ms':>9} {'p95 ms':>7}"]
        for t in self.tallies:
            d = t.to_dict()
            lines.append(f"{t.solver:<12} {f'{t.optimal}/{self.feasible}':>12} {t.off_optimum:>11} "
                         f"{f'{t.infeasible_found}/{self.infeasible}':>12} {t.wrong_verdict:>6} "
                         f"{t.iteration_limit:>10} {t.failed:>6} {d['median_ms']:>9.3f} {d['p95_ms']:>7.3f}")
        lines.append("failed, by the solver's status (and the reference's verdict): " + "; ".join(
            f"{t.solver}: " + ", ".join(f"{why} {n}" for why, n in sorted(t.failures.items()))
            for t in self.tallies if t.failures) if any(t.failures for t in self.tallies) else "no failures")
        lines.append("times: processor time per solve over every QP (OSQP and Clarabel: set-up and solve)")
        return "\n".join(lines)


@contextmanager
def _quiet_stdout() -> Iterator[None]:
    """The process's standard output (file descriptor 1, which C libraries write to) sent to the null device."""
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    libc.fflush(None)
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


def judge(qps: list[RecordedQP], solvers: tuple[str, ...] = SOLVERS) -> tuple[list[SolverTally], dict[str, int]]:
    """Solve every QP with every solver and tally each against the reference (the last of ``solvers``).

    Returns the tallies and the reference's verdict counts (``feasible``, ``infeasible``, ``undecided``).
    """
    tallies = [SolverTally(s) for s in solvers]
    counts = {"feasible": 0, "infeasible": 0, "undecided": 0}
    for done, qp in enumerate(qps):
        if done % 250 == 0:
            logger.info("solving QP %d of %d", done + 1, len(qps))
        with _quiet_stdout():
            answers = [ADAPTERS[s](qp) for s in solvers]
        ref = answers[-1]
        key = {OPTIMAL: "feasible", INFEASIBLE: "infeasible"}.get(ref.verdict, "undecided")
        counts[key] += 1
        for tally, answer in zip(tallies, answers):
            tally.seconds.append(answer.seconds)
            if key == "undecided":
                continue
            if answer.verdict == ITERATION_LIMIT:
                tally.iteration_limit += 1
            elif answer.verdict == FAILED:
                tally.failed += 1
                why = f"{answer.detail} ({key})"
                tally.failures[why] = tally.failures.get(why, 0) + 1
            elif key == "infeasible":
                tally.infeasible_found += answer.verdict == INFEASIBLE
                tally.wrong_verdict += answer.verdict != INFEASIBLE
            elif answer.verdict == INFEASIBLE:
                tally.wrong_verdict += 1
            elif at_optimum(qp, answer, ref):
                tally.optimal += 1
            else:
                tally.off_optimum += 1
    return tallies, counts


def compare_solvers(scenarios: tuple[str, ...] = DEFAULT_SCENARIOS, seeds: tuple[int, ...] = (1,),
                    time_limit: float | None = None) -> SolverComparison:
    """Record the MPC's QPs in the trials ``scenarios x seeds`` (fast planner, the NOD method) and
    judge every solver on them. Needs the ``solvers`` extra (:func:`missing_solvers`)."""
    qps, outcomes = record_trials(scenarios, seeds, time_limit=time_limit)
    tallies, counts = judge(qps)
    return SolverComparison(scenarios=tuple(scenarios), seeds=tuple(seeds), outcomes=tuple(outcomes), qps=len(qps),
                            evasive=sum(q.kind == "evasive" for q in qps), tallies=tuple(tallies), **counts)
