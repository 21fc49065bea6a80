"""The compiled kernels of a control step against the plain NumPy they replace (independent references)."""

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
