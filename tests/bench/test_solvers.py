"""``bench solvers``: each solver's adapter on hand-solved QPs, the recording of a trial's QPs, the command's checks."""

import importlib.util
import json

import numpy as np
import pytest

from nodnav.bench import solvers as bs
from nodnav.bench.solvers import (
    ADAPTERS,
    INFEASIBLE,
    OPTIMAL,
    Answer,
    RecordedQP,
    at_optimum,
    compare_solvers,
    judge,
    record_trials,
)
from nodnav.cli import main
from nodnav.control.qp import SolverEffort
from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import run_trial

HAVE_EXTRA = all(importlib.util.find_spec(m) is not None for m in ("osqp", "clarabel"))
needs_extra = pytest.mark.skipif(not HAVE_EXTRA, reason="the solvers extra (osqp, clarabel) is not installed")

#: Each solver and how close to the hand-computed minimiser it must come: OSQP at its default
#: settings stops at residuals of 1e-3, the others are exact to their tight tolerances.
CLOSENESS = {"DAQP": 1e-7, "OSQP": 2e-2, "OSQP tight": 1e-6, "Clarabel": 1e-6}
SOLVERS = [pytest.param(s, marks=() if s == "DAQP" else needs_extra) for s in CLOSENESS]


def on_a_row() -> tuple[RecordedQP, np.ndarray]:
    """min |x - (2, 1)|^2 / 2 subject to x1 + x2 <= 2 (and an inactive row, and one at -inf).

    The unconstrained minimiser (2, 1) has x1 + x2 = 3, so the row binds and the minimiser is the
    projection of (2, 1) onto x1 + x2 = 2: (2, 1) - (1/2)(1, 1) = (1.5, 0.5).
    """
    rows = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    lower = np.array([-2.0, -5.0, -np.inf])
    return RecordedQP(np.eye(2), np.array([-2.0, -1.0]), rows, lower, 1e-9), np.array([1.5, 0.5])


def on_a_bound() -> tuple[RecordedQP, np.ndarray]:
    """min (2 x1^2 + x2^2) / 2 + x1 - x2 subject to x1 >= 0 (a simple bound) and x1 + x2 >= 0.5.

    Separable: x1's unconstrained minimiser -1/2 is below its bound, so x1 = 0; x2 = 1 (from
    x2 - 1 = 0), and then x1 + x2 = 1 >= 0.5 leaves the row inactive.
    """
    qp = RecordedQP(np.diag([2.0, 1.0]), np.array([1.0, -1.0]), np.array([[1.0, 1.0]]), np.array([0.5]), 1e-9,
                    bounds=np.array([0.0, -np.inf]), start_active=np.array([True, False]))
    return qp, np.array([0.0, 1.0])


def infeasible() -> RecordedQP:
    """x1 >= 1 and x1 <= 0 together: no point satisfies both."""
    return RecordedQP(np.eye(2), np.zeros(2), np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 0.0]), 1e-9)


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("problem", [on_a_row, on_a_bound])
def test_each_solver_finds_the_hand_computed_minimiser(solver, problem):
    qp, x_star = problem()
    answer = ADAPTERS[solver](qp)
    assert answer.verdict == OPTIMAL, answer.detail
    assert np.max(np.abs(answer.x - x_star)) <= CLOSENESS[solver]
    assert answer.seconds >= 0


def test_the_hand_computed_optima():
    """The minimisers above satisfy the KKT conditions: H x + g = A^T y with y >= 0 on the active rows only."""
    qp, x = on_a_row()
    # Gradient (1.5 - 2, 0.5 - 1) = (-0.5, -0.5) = y (-1, -1) with y = 0.5 on the row x1 + x2 <= 2.
    assert np.allclose(qp.hessian @ x + qp.gradient, 0.5 * qp.rows[0])
    assert qp.objective(x) == pytest.approx(0.5 * (1.5**2 + 0.5**2) - (2 * 1.5 + 0.5))
    qp, x = on_a_bound()
    assert np.allclose(qp.hessian @ x + qp.gradient, [1.0, 0.0])  # the bound's multiplier 1 on x1


@pytest.mark.parametrize("solver", SOLVERS)
def test_each_solver_declares_the_contradiction_infeasible(solver):
    answer = ADAPTERS[solver](infeasible())
    assert answer.verdict == INFEASIBLE, answer.detail


def test_a_minimiser_off_the_reference_is_not_at_the_optimum():
    qp, x_star = on_a_row()
    reference = Answer(OPTIMAL, x_star, 0.0)
    assert at_optimum(qp, Answer(OPTIMAL, x_star + 1e-6, 0.0), reference)
    assert not at_optimum(qp, Answer(OPTIMAL, x_star + [1e-3, -1e-3], 0.0), reference)
    assert not at_optimum(qp, Answer(INFEASIBLE, None, 0.0), reference)


@needs_extra
def test_judge_tallies_verdicts_against_the_reference():
    qps = [on_a_row()[0], on_a_bound()[0], infeasible()]
    tallies, counts = judge(qps)
    assert counts == {"feasible": 2, "infeasible": 1, "undecided": 0}
    for t in tallies:
        if t.solver != "OSQP":  # at its default tolerance OSQP's minimiser may miss by 1e-3
            assert (t.optimal, t.infeasible_found, t.wrong_verdict, t.failed) == (2, 1, 0, 0), t
        assert len(t.seconds) == 3


def test_recording_captures_every_qp_of_a_short_trial_and_changes_nothing():
    scenario = load_scenario("4r-case1").with_overrides(time_limit=2.0)
    counted = []
    saved = SolverEffort.__dict__["solve"]

    def count(self, *args, **kwargs):
        counted.append(1)
        return saved(self, *args, **kwargs)

    # An independent count of the solver's calls, under the recording wrapper.
    SolverEffort.solve = count
    try:
        qps, outcomes = record_trials(("4r-case1",), (1,), time_limit=2.0)
        assert SolverEffort.__dict__["solve"] is count  # the recording unwrapped again
    finally:
        SolverEffort.solve = saved
    alone = run_trial(scenario, seed=1)
    assert outcomes == [f"4r-case1/1: {alone.outcome}"]
    assert len(qps) == len(counted) > 0
    # Copies, not the MPC's scratch rows: no two recorded problems share memory.
    assert not np.shares_memory(qps[0].rows, qps[1].rows)
    for qp in qps:
        n = len(qp.gradient)
        assert qp.hessian.shape == (n, n) and qp.rows.shape == (len(qp.lower), n)
        assert np.linalg.eigvalsh(qp.hessian)[0] > 0
        assert qp.source == "4r-case1/1"
        answer = ADAPTERS["DAQP"](qp)
        if answer.verdict == OPTIMAL:  # the minimiser meets every row to DAQP's tolerance
            a, b = qp.standard_rows()
            assert (a @ answer.x >= b - 10 * qp.tol * np.maximum(1.0, np.abs(b))).all()


@needs_extra
def test_a_short_comparison_reports_every_solver():
    # Two seconds: in the first, robots at rest whose plans hold them still skip their MPC (execution.skip_at_rest).
    result = compare_solvers(("2r-case2",), (1,), time_limit=2.0)
    assert result.qps == result.feasible + result.infeasible + result.undecided > 0
    assert [t.solver for t in result.tallies] == list(bs.SOLVERS)
    d = json.loads(json.dumps(result.to_dict()))
    assert d["solvers"][0]["median_ms"] > 0
    text = result.format()
    assert all(s in text for s in bs.SOLVERS)


def test_command_checks(capsys, monkeypatch):
    assert main(["bench", "solvers", "--seeds", "0"]) == 2
    assert main(["bench", "sim", "--seeds", "1"]) == 2
    assert "only 'nodnav bench solvers'" in capsys.readouterr().err
    assert main(["bench", "sim", "--scenario", "2r-case1", "--scenario", "2r-case2"]) == 2
    assert main(["bench", "solvers", "--scenario", "no-such-scenario"]) == 2
    capsys.readouterr()
    monkeypatch.setattr(bs, "missing_solvers", lambda: ["osqp"])
    assert main(["bench", "solvers"], execute=False) == 2
    err = capsys.readouterr().err
    assert "nodnav[solvers]" in err and len(err.strip().splitlines()) == 1
    monkeypatch.setattr(bs, "missing_solvers", lambda: [])
    assert main(["bench", "solvers", "--scenario", "2r-case1", "--seeds", "2"], execute=False) == 0
