"""The fused compiled calls of a control step added for speed (gradient, the mutual braking check of a plan's next
state) against the plain versions they replace (independent references)."""

from __future__ import annotations

import math

import numpy as np

from nodnav.control.braking import tail_clearance
from nodnav.control.mpc_braking import _straight_slack_kernel
from nodnav.control.mpc_rows import gradient_into
from nodnav.control.mutual_braking import MAX_SAMPLES, SAMPLE_STEP, BrakingPartners, braking_slack
from nodnav.scenario.loading import load_scenario


def test_gradient_kernel_is_the_numpy_expression_bit_for_bit():
    rng = np.random.default_rng(3)
    for n in (1, 5, 9):
        q, w, v0, ref = rng.normal(size=n), rng.normal(size=(n, 8)), rng.normal(size=2), rng.normal(size=(8, 2))
        out = np.empty(2 * n)
        gradient_into(q, v0, w @ ref, out)
        assert np.array_equal(out, (2.0 * (q[:, None] * v0 - w @ ref)).T.ravel())


def test_straight_slack_kernel_is_tail_clearance_then_braking_slack():
    rng = np.random.default_rng(4)
    world = load_scenario("4r-case1").world
    boxes, pieces, bounds = world.obstacle_array, world.piece_array, world.bounds_array
    lo, hi = bounds[:2], bounds[2:]
    branches = set()
    for _ in range(200):
        n = int(rng.integers(2, 6))
        partners = BrakingPartners(robot=0, positions=rng.uniform(lo, hi, (n, 2)), velocities=rng.normal(size=(n, 2)),
                                   decels=rng.uniform(1.0, 3.0, n), radii=rng.uniform(0.2, 0.4, n),
                                   keeps_rule=rng.random(n) < 0.8, seen=rng.random(n) < 0.9, turn=int(rng.integers(2)),
                                   convention=0, dt=0.1)
        p, v = partners.positions[0] + rng.normal(size=2) * 0.1, partners.velocities[0].copy()
        limit = 0.3
        out = np.empty(n)
        straight, j = _straight_slack_kernel(p, v, 2.0, boxes, pieces, bounds, limit, 0, partners.positions,
                                             partners.velocities, partners.decels, partners.radii,
                                             partners.keeps_rule, partners.seen, partners.turn, partners.convention,
                                             partners.dt, SAMPLE_STEP, MAX_SAMPLES, out)
        clear = tail_clearance(p, v, 2.0, boxes, pieces, bounds)
        assert straight == (clear >= limit)
        branches.add(straight)
        if straight:
            slack, worst = braking_slack(p, v, partners)
            assert j == worst
            assert np.array_equal(out, slack)
        else:
            assert j == -1 and math.isfinite(clear)
    assert branches == {True, False}  # both ways taken


def test_checked_plan_braking_is_checked_plan_then_fallback_conflict():
    """The plan, values and verdict of :meth:`checked_plan`, and the mutual braking check's verdict
    of :func:`fallback_conflict` computed on its own (every branch: straight braking passing,
    failing), from one compiled call."""
    from nodnav.control.mpc import BSplineMPC
    from nodnav.control.mpc_braking import fallback_conflict
    from nodnav.scenario.params import MPCParams, RobotSpec
    from nodnav.scenario.world import paper_world

    rng = np.random.default_rng(7)
    times = 0.1 * np.arange(1, 9)
    ctl = BSplineMPC(paper_world(), RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0)), MPCParams())
    prob = ctl._problem(2, times)
    outcomes = set()
    for _ in range(300):
        p0, v0 = rng.uniform([-6.0, -0.6], [6.0, 0.6]), rng.normal(0.0, 0.5, 2)
        ref = p0 + np.outer(times, rng.normal(0.0, 0.4, 2))
        others = p0 + rng.normal(0.0, 1.5, (2, 1, 2)) + np.zeros((2, len(times), 2))
        data = ctl._step_data(prob, p0, v0, ref, others, np.full(2, 0.2))
        n = 3
        partners = BrakingPartners(robot=0, positions=np.vstack([p0, others[:, 0]]),
                                   velocities=np.vstack([v0, rng.normal(0.0, 0.5, (2, 2))]), decels=np.full(n, 2.0),
                                   radii=np.full(n, 0.2), keeps_rule=np.ones(n, dtype=bool),
                                   seen=np.ones(n, dtype=bool), turn=0, convention=0, dt=0.1)
        z = rng.normal(0.0, 0.05, 2 * prob.free_map.shape[1])
        c, post, why, checked = prob.checked_plan_braking(data, z, partners, ctl._walls)
        c_ref, post_ref, why_ref = prob.checked_plan(data, z, separation=True)
        assert np.array_equal(c, c_ref) and why == why_ref
        assert all(np.array_equal(a, b) for a, b in zip(post, post_ref))

        def committed(c=c, post=post):
            from nodnav.control.braking import Committed
            return Committed(points=c, knots=ctl.setup.knots, horizon=ctl.horizon, end_position=post[1][0],
                             end_velocity=post[1][1], decel=prob.tail_decel, elapsed=ctl.dt)

        fused = fallback_conflict(partners, ctl._walls, post[2][:2], committed, 1.0, checked)
        alone = fallback_conflict(partners, ctl._walls, post[2][:2], committed, 1.0)
        assert fused == alone
        outcomes.add((bool(checked[0]), fused == ""))  # (straight, worst, slack)
    assert (True, True) in outcomes and (True, False) in outcomes
