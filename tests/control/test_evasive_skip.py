"""The evasive fallback's elastic QPs decided by the certificate LP first (QPs certain to fail
skipped) against the full flow (every QP solved, the LP after a failure): the same closed loop."""

import numpy as np

import nodnav.control.evasive as evasive
from nodnav.control.qp import SolverEffort
from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import run_trial


def _full_flow(prob, data, lin, cold, soft, firm, effort, keep_arrangement, hard_consistent=False):
    """elastic_plan as it was before the LP came first: solve the QP; on failure, the certificate
    LP on the hard rows names the robots to soften next."""
    n = 2 * prob.nz
    soft = soft.copy()
    gradient = np.concatenate([prob.gradient(data.v0, data.ref_local), prob.slack_gradient])
    while True:
        robots = np.flatnonzero(soft[prob.n_walls:])
        lower = prob.write_separation(data, lin, cold, np.where(soft, data.full, data.need),
                                      soft if keep_arrangement else None)
        var, hessian, rows, bounds, start_active = evasive.evasive_structure(prob, robots)
        rows[:, :n] = prob.rows
        sol = effort.solve(hessian, gradient[var], rows, lower, prob.setup.settings.qp_tolerance, bounds=bounds,
                           start_active=start_active, kind=(prob, robots.tobytes(), keep_arrangement),
                           like=(prob, robots.tobytes(), not keep_arrangement))
        if sol.success:
            c, _, why = prob.checked_plan(data, sol.x[:n], separation=False)
            return (None if why else c), soft
        hard = np.where(prob.softened_rows(soft), -np.inf, lower)
        certified = prob.certified_conflict(prob.rows, hard, effort)
        if certified is None:
            return None, soft
        more = prob.n_walls + certified[~firm[certified]]
        if soft[more].all():
            return None, None
        soft[more] = True


def test_skipping_qps_certain_to_fail_leaves_a_deadlocking_trial_bitwise_unchanged(monkeypatch):
    """4r-case3 without game players deadlocks by design: the evasive fallback runs at most
    steps, and many of its elastic QPs are infeasible. The trial's history with QPs skipped on
    the LP's word is the full flow's, bit for bit, and QPs were skipped."""
    scenario = load_scenario("4r-case3", {"game_players": 0})
    skipped = []
    relaxation = SolverEffort.relaxation

    def counted(self, rows, lower):
        found = relaxation(self, rows, lower)
        skipped.append(found[1] > evasive.CERTAINLY_INFEASIBLE)
        return found

    monkeypatch.setattr(SolverEffort, "relaxation", counted)
    fast = run_trial(scenario, seed=1)
    monkeypatch.setattr(evasive, "elastic_plan", _full_flow)
    full = run_trial(scenario, seed=1)
    # How many are skipped depends on the trajectory, whose last bits differ between processors
    # (82 on one machine, over 100 on another); the claim is that skipping happened and changed nothing.
    assert sum(skipped) > 0
    assert fast.outcome == full.outcome == "deadlock"
    fast_arrays, full_arrays = fast.history.arrays(), full.history.arrays()
    for name in ("positions", "velocities"):
        a, b = fast_arrays[name], full_arrays[name]
        assert a.shape == b.shape and a.tobytes() == b.tobytes()
