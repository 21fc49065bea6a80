"""The compiled call after the QP (:func:`nodnav.control.mpc_plan.plan_after_qp`) against the NumPy
expressions it replaces: control points, the stacked values, and the exact check's verdict."""

import numpy as np
import pytest

from nodnav.control.mpc import BSplineMPC
from nodnav.control.mpc_plan import plan_values
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import paper_world

WORLD = paper_world()
ROBOT = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))
TIMES = 0.1 * np.arange(1, 9)


def _numpy(prob, p0, v0, z):
    c = p0 + prob.setup.greville[:, None] * v0 + prob.free_map @ z.reshape(2, -1).T
    return c, prob.b_post @ c


@pytest.mark.parametrize("n_others", [0, 1, 3])
def test_plan_values_are_the_numpy_products(n_others):
    rng = np.random.default_rng(10 + n_others)
    prob = BSplineMPC(WORLD, ROBOT, MPCParams())._problem(n_others, TIMES)
    nz = prob.free_map.shape[1]
    cases = [(np.zeros(2), np.zeros(2), np.zeros(2 * nz)), (np.array([1e3, -1e3]), np.zeros(2), np.ones(2 * nz))]
    cases += [(rng.uniform(-50, 50, 2), rng.normal(0, 1, 2), rng.normal(0, 10.0 ** rng.uniform(-6, 2), 2 * nz))
              for _ in range(300)]
    for p0, v0, z in cases:
        c, post = plan_values(z, p0, v0, prob.setup.greville, prob.free_map, prob.b_post)
        c_ref, post_ref = _numpy(prob, p0, v0, z)
        # Relative to the size of the terms summed (the sums cancel where the plan returns to zero).
        c_scale = np.abs(p0).max() + np.abs(prob.setup.greville).max() * np.abs(v0).max() + (
            np.abs(prob.free_map).sum(axis=1).max() * np.abs(z).max())
        np.testing.assert_allclose(c, c_ref, rtol=1e-12, atol=1e-13 * (c_scale + 1e-300))
        scale = np.abs(prob.b_post).sum(axis=1).max() * np.abs(c).max()
        np.testing.assert_allclose(post, post_ref, rtol=1e-12, atol=1e-13 * (scale + 1e-300))


def _compare_checks(seed: int) -> set[str]:
    """Same plan, values and verdict as the separate NumPy path on a step's real data, with plans
    that pass and plans that break each kind of constraint; returns the kinds of verdict seen."""
    rng = np.random.default_rng(seed)
    ctl = BSplineMPC(WORLD, ROBOT, MPCParams())
    n = 2
    prob = ctl._problem(n, TIMES)
    p0, v0 = rng.uniform([-6.0, -0.5], [6.0, 0.5]), rng.normal(0.0, 0.3, 2)
    ref = p0 + np.outer(TIMES, rng.normal(0.0, 0.4, 2))
    others = p0 + rng.normal(0.0, 1.5, (n, 1, 2)) + np.zeros((n, len(TIMES), 2))
    data = ctl._step_data(prob, p0, v0, ref, others, np.full(n, 0.2))
    verdicts: set[str] = set()
    for scale in (0.0, 1e-3, 1e-2, 0.1, 1.0, 5.0):
        for _ in range(20):
            z = rng.normal(0.0, scale, 2 * prob.free_map.shape[1])
            c, post, why = prob.checked_plan(data, z, separation=True)
            c_ref = prob.control_points(data, z)
            np.testing.assert_allclose(c, c_ref, rtol=1e-12, atol=1e-12)
            for a, b in zip(post, prob.evaluate(c_ref)):
                np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)
            assert why.split(" (")[0].split(" comes")[0] == prob.violation(data, c_ref, True).split(" (")[0].split(
                " comes")[0]
            verdicts.add(why.split(" (")[0].split(" comes")[0])
    return verdicts


@pytest.mark.parametrize("seed", range(6))
def test_checked_plan_is_control_points_evaluate_and_violation(seed):
    _compare_checks(seed)


def test_the_checks_saw_passing_and_failing_plans():
    """Both outcomes of the check are among those compared (the cases above, again: each test
    stands alone, whatever order or worker runs it)."""
    kinds = set().union(*(_compare_checks(seed) for seed in range(6)))
    assert "" in kinds and len(kinds) > 2
