"""The MPC's evasive fallback: when no plan keeps clear of every prediction, the one that intrudes least.

When the tracking QP has no solution, the robot does not brake blindly: an evasive QP with the
same dynamics, limits and (hard) wall constraints softens the separation rows of the robots
involved in the conflict (those owning rows of a Farkas certificate of the infeasibility,
:func:`~nodnav.control.qp.infeasibility_certificate`) with non-negative slacks under a large
exact (L1) penalty, weighted towards the near future (:func:`elastic_plan`), and so returns the
plan that intrudes least into the others' predicted discs. Such a QP is feasible exactly when
its hard rows are, so each is first decided by the certificate's linear program on those rows
(:func:`~nodnav.control.qp.least_relaxation`), which also names the robots to soften next: a QP
certain to fail is never solved. Which side to pass a robot on is a
non-convex choice: the evasive QP is solved linearised about the previous plan and about the
current arrangement of the robots, and the plan whose true intrusion comes later is kept
(:func:`evasive_plan`). Only if no evasive plan keeps clear of the walls does the robot brake
along its current velocity (:class:`~nodnav.control.mpc.BSplineMPC`).
"""

from __future__ import annotations

import numpy as np

from nodnav.control.mpc_problem import MPCProblem, StepData
from nodnav.control.qp import SolverEffort


def evasive_plan(prob: MPCProblem, data: StepData, lin: np.ndarray, cold: bool, conflict: np.ndarray,
                 firm: np.ndarray, effort: SolverEffort) -> tuple[np.ndarray | None, float, np.ndarray]:
    """The plan that intrudes least into the other robots' predicted discs.

    Keeping out of a disc is not convex: which side to pass on is a choice. Two
    linearisations are tried (:func:`elastic_plan`): the half-planes of the previous plan (pass
    the others as planned), and half-planes that keep the current arrangement (at every end
    the normal points from the other robot's position now to the robot's: back away from a
    robot coming head-on, run ahead of one coming from behind). Both soften the same robots:
    the second starts from the robots the first had to soften. The plan kept is the one
    whose first true intrusion into a disc (at the check times, beyond ``check_tolerance``)
    comes later, the time the others have to react; on a tie, the one whose intrusion summed
    with the penalty's weights (``T_MPC / tau``) is smaller, then the first.

    Returns (control points or None, largest true intrusion (m), the robots whose discs it enters).
    """
    tol = prob.setup.settings.check_tolerance
    best: tuple[np.ndarray | None, float, np.ndarray] = (None, np.inf, np.zeros(0, dtype=int))
    best_score = (np.inf, np.inf)
    soft = np.zeros(prob.n_groups, dtype=bool)
    soft[prob.n_walls + np.asarray(conflict, dtype=int)] = True
    for keep_arrangement in (False, True):
        if not soft.any():
            break
        # The second starts with the hard rows of the first's last QP (or LP): known consistent.
        c, softened = elastic_plan(prob, data, lin, cold, soft, firm, effort, keep_arrangement, keep_arrangement)
        if softened is None:
            break  # walls, bounds, limits and firm predictions alone conflict
        soft = softened
        if c is None:
            continue
        gap = prob.b_check @ c - data.pred_check
        short = np.maximum(data.full[prob.n_walls:, None] - np.hypot(gap[..., 0], gap[..., 1]), 0.0)
        hit = (short > tol).any(axis=0)
        first = prob.check_times[np.argmax(hit)] if hit.any() else np.inf
        score = (-first, float((short * prob.check_weights).sum()))
        if score < best_score:
            best = (c, float(short.max(initial=0.0)), np.flatnonzero((short > tol).any(axis=1)))
            best_score = score
        if first == np.inf:
            break  # no intrusion at all: nothing can do better
    return best


def elastic_plan(prob: MPCProblem, data: StepData, lin: np.ndarray, cold: bool, soft: np.ndarray,
                 firm: np.ndarray, effort: SolverEffort,
                 keep_arrangement: bool, hard_consistent: bool = False) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The tracking QP with the separation rows of the ``soft`` groups softened.

    Each interval end (and the terminal rows together) of a softened robot gets a slack
    ``s >= 0`` in its rows, costing ``w s + c s^2 / 2`` with ``w``
    (``settings.evasive_penalty``, times ``T_MPC / tau``) far above what tracking could gain,
    so every intrusion that can be avoided is (the L1 penalty is exact), and the nearest ones
    first. Softened robots must keep ``r_i + r_j + margin``, not the relaxed requirement, so
    the plan steers out of their discs; with ``keep_arrangement`` their half-planes keep the
    current arrangement (see :meth:`~nodnav.control.mpc_problem.MPCProblem.write_separation`).
    Walls, the box, speed and acceleration stay hard; the slacks' ``s >= 0`` are simple bounds,
    active at the solver's start.

    If the softened problem is infeasible too, the robots in an infeasibility certificate
    are softened as well, except the request's ``firm`` predictions, which stay hard like
    walls. A row with its own slack can always be met, so it never takes part in a
    certificate: the certificate is computed on the rows kept hard alone (fewer variables),
    and they do not depend on the linearisation of the softened ones. For the same reason the
    QP is feasible exactly when its hard rows are, so the certificate's LP comes first (a
    fraction of a failing QP's time) and the QP is solved only if the LP's least relaxation of
    the hard rows is at most :data:`CERTAINLY_INFEASIBLE`: above it the QP could not succeed at
    its tolerance, and the certificate is the one the LP would have given after the QP's
    failure, so the plans are those of solving every QP. ``hard_consistent`` (the hard rows
    are known consistent, e.g. the last ones of the other linearisation) solves the QP first,
    as before, and so does a set of softened robots whose hard rows were consistent when last
    decided (:func:`known_consistent`): a deadlock meets the same sets step after step, and
    the LP would mostly have confirmed it (about half of the LPs of deadlocked trials saved);
    should the QP fail, the same LP on the same rows comes after it, so the plans are those of
    deciding first. The robots kept hard are kept clear whatever that costs in intrusion into the
    softened ones: softening every robot at once instead let the plan trade a late intrusion
    into an uninvolved robot for a smaller early one, and collided more often in closed loop.

    Returns (control points or None if the QP fails or its plan fails the exact check of
    walls, bounds and limits; the softened groups, or None if walls, bounds, limits and firm
    predictions alone conflict).
    """
    n = 2 * prob.nz
    soft = soft.copy()
    gradient = np.concatenate([prob.gradient(data.v0, data.ref_local), prob.slack_gradient])
    while True:
        robots = np.flatnonzero(soft[prob.n_walls:])
        lower = prob.write_separation(data, lin, cold, np.where(soft, data.full, data.need),
                                      soft if keep_arrangement else None)
        key = robots.tobytes()
        support = None
        if not (hard_consistent or known_consistent(prob, key)):
            # The QP is feasible exactly when its hard rows are: decide that first, with the LP
            # that names the robots to soften next, and skip a QP certain to fail.
            support, excess = effort.relaxation(prob.rows, hard_lower(prob, soft, lower))
            remember_consistent(prob, key, excess <= CERTAINLY_INFEASIBLE)
        if support is None or excess <= CERTAINLY_INFEASIBLE:
            var, hessian, rows, bounds, start_active, _ = evasive_structure(prob, robots)
            rows[:, :n] = prob.rows
            sol = effort.solve(hessian, gradient[var], rows, lower, prob.setup.settings.qp_tolerance, bounds=bounds,
                               start_active=start_active, kind=(prob, key, keep_arrangement),
                               like=(prob, key, not keep_arrangement))
            remember_consistent(prob, key, sol.success)
            if sol.success:
                c, _, why = prob.checked_plan(data, sol.x[:n], separation=False)
                return (None if why else c), soft
            if support is None:
                support = effort.certificate(prob.rows, hard_lower(prob, soft, lower))
        if not support.size:
            return None, soft  # the solver failed on a problem the certificate finds consistent
        certified = prob.conflicting_others(support)
        more = prob.n_walls + certified[~firm[certified]]
        if soft[more].all():  # also when the certificate names no robot at all
            return None, None
        soft[more] = True
        hard_consistent = False


#: Least uniform relaxation of the hard rows (m, :func:`~nodnav.control.qp.least_relaxation`) above
#: which the evasive QP is not solved: far above DAQP's tolerances (the QP's 1e-9 m, the LP's own
#: 1e-6), so the QP could not have succeeded and skipping it changes no plan.
CERTAINLY_INFEASIBLE = 1e-4


def hard_lower(prob: MPCProblem, soft: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """The lower bounds of the rows kept hard: ``-inf`` on the rows of the ``soft`` groups."""
    return np.where(prob.softened_rows(soft), -np.inf, lower)


def known_consistent(prob: MPCProblem, key: bytes) -> bool:
    """Whether the hard rows of the evasive QP with the robots ``key`` (their indices' bytes)
    softened were consistent when last decided on this problem (False if never, or forgotten)."""
    hit = prob.evasive_memo.get(key)
    return hit is not None and hit[5][0]


def remember_consistent(prob: MPCProblem, key: bytes, consistent: bool) -> None:
    """Note :func:`known_consistent`'s answer for the robots ``key`` (where their QP's structure
    is remembered: a set whose QP was never solved starts with the LP anyway)."""
    hit = prob.evasive_memo.get(key)
    if hit is not None:
        hit[5][0] = consistent


#: How many sets of softened robots :func:`evasive_structure` remembers per problem.
MEMO_SIZE = 8


def evasive_structure(prob: MPCProblem, robots: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                                    np.ndarray, list[bool]]:
    """What the evasive QP with the other robots ``robots`` softened keeps from step to step
    (memoised per set of robots on the problem): its variables (``z``, then those robots'
    slacks), its Hessian, its rows (the first ``2 nz`` columns to be written with the problem's
    rows at each solve, then the slack columns), its bounds, which bounds start active, and
    whether its hard rows were consistent when last decided (a one-element list,
    :func:`known_consistent` and :func:`remember_consistent`; False until decided)."""
    key = robots.tobytes()
    hit = prob.evasive_memo.get(key)
    if hit is None:
        n, spg = 2 * prob.nz, len(prob.slack_weights)
        slacks = (spg * robots[:, None] + np.arange(spg)).ravel()
        var = np.concatenate([np.arange(n), n + slacks])
        rows = np.zeros((prob.n_rows, len(var)))
        rows[:, n:] = prob.slack_columns[:, slacks]
        bounds = prob.slack_bounds[var]
        if len(prob.evasive_memo) >= MEMO_SIZE:
            prob.evasive_memo.pop(next(iter(prob.evasive_memo)))
        hit = prob.evasive_memo[key] = (var, prob.evasive_hessian[np.ix_(var, var)], rows, bounds, bounds == 0.0,
                                        [False])
    return hit
