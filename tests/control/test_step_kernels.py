"""The MPC step's fused compiled calls (:mod:`nodnav.control.mpc_rows`: ``all_finite``,
``step_state``, ``step_rows``, ``plan_check``) against the separate calls and the NumPy
expressions they replace: equal bit for bit (the same operations in the same order)."""

import math

import numpy as np
import pytest

from nodnav.control import bspline
from nodnav.control.braking import tail_clearance, tail_rows
from nodnav.control.mpc import BSplineMPC
from nodnav.control.mpc_rows import all_finite, group_state, plan_check, plan_extremes, separation_rows, step_state
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import paper_world

WORLD = paper_world()
ROBOT = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0))
PARAMS = MPCParams()
TIMES = 0.1 * np.arange(1, 9)


def test_all_finite_finds_any_non_finite_entry():
    arrays = [np.zeros(2), np.ones(2), np.zeros((8, 2)), np.zeros((2, 8, 2)), np.full(2, 0.2)]
    assert all_finite(*arrays)
    for i, bad in [(0, np.nan), (2, np.inf), (3, -np.inf), (4, np.nan)]:
        broken = [a.copy() for a in arrays]
        broken[i].reshape(-1)[-1] = bad
        assert not all_finite(*broken)
    assert all_finite(arrays[0], arrays[1], arrays[2], np.zeros((0, 8, 2)), np.zeros(0))


@pytest.mark.parametrize("seed", range(4))
def test_step_state_is_group_state_with_numpy_clearances_and_box(seed):
    rng = np.random.default_rng(seed)
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    prob = ctl._problem(3, TIMES)
    p0 = rng.uniform([-6.0, -1.0], [6.0, 1.0])
    v0 = rng.normal(0.0, 0.5, 2)
    radii = rng.uniform(0.1, 0.3, 3)
    others = p0 + rng.normal(0.0, 1.0, (3, 1, 2)) + np.outer(TIMES, rng.normal(0.0, 0.5, 2))[None]
    pred = prob.interp_all @ others
    n_end, r, margin, eps0, reach, tol = len(prob.ends), ROBOT.radius, PARAMS.safety_margin, prob.eps[0], 3.0, 1e-3
    bounds = np.asarray(WORLD.bounds, dtype=float)
    static = np.full(prob.n_static, np.nan)
    # Into buffers full of garbage (NaN), as a problem's scratch state is between steps: every entry is written.
    state = [np.full_like(a, np.nan) if a.dtype == float else np.ones_like(a) for a in prob.state]
    ref_in, ref_local = rng.normal(0.0, 3.0, (len(TIMES), 2)), np.full((len(TIMES), 2), np.nan)
    scalars = step_state(pred, p0, math.hypot(*v0), radii, np.full(3, margin), ref_in, ref_local,
                         prob.static_alpha @ v0, static, n_end, prob.ends, prob.intervals, WORLD.obstacle_array,
                         WORLD.piece_array, bounds, r, ROBOT.max_speed, ROBOT.max_accel, eps0, reach, tol,
                         prob.eps_end, prob.static_base, prob.static_line, False, 1.0, 1.0, 1.0, 1.0, 1.0, *state)
    assert scalars[3:] == (0.0, 0.0)  # no braking tail: its weight and reach are 0
    out = (*state, *scalars[:3])
    m_w = prob.n_walls
    full = np.concatenate([np.full(m_w, r), r + radii + margin])
    contact = np.concatenate([np.full(m_w, 1e-12), r + radii])
    speed = np.minimum(ROBOT.max_speed, math.hypot(*v0) + ROBOT.max_accel * prob.ends)
    ref = group_state(pred, n_end, p0, speed, prob.intervals, WORLD.obstacle_array, WORLD.piece_array, full, eps0,
                      reach)
    for a, b in zip(out[:6], ref):
        assert np.array_equal(a, b)
    assert np.array_equal(out[6], full) and np.array_equal(out[7], contact)
    gap = np.concatenate([p0 - bounds[:2], bounds[2:] - p0])
    need_box = np.minimum(r, gap - eps0)
    assert np.array_equal(out[8], gap) and np.array_equal(out[9], need_box)
    assert np.array_equal(out[10], bounds[:2] + need_box[:2]) and np.array_equal(out[11], bounds[2:] - need_box[2:])
    assert out[12] == min(ref[3][:m_w].min(), need_box.min())
    assert out[13] == min(ref[2][:m_w].min(), gap.min())
    assert out[14] == bool((ref[2][m_w:] < contact[m_w:] - tol).any())
    assert np.array_equal(static, prob.static_lower(p0, v0, out[10], out[11]))
    assert np.array_equal(ref_local, ref_in - p0)


def _two_others_step():
    """A controller's step data with two others metres ahead and behind, and what it was built from."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    prob = ctl._problem(2, TIMES)
    p0, v0 = np.array([-1.0, 0.2]), np.array([0.5, 0.1])
    ref = p0 + np.outer(TIMES, [0.8, 0.0])
    others = np.array([[1.5, 0.0], [-2.5, -0.3]])[:, None] + np.outer(TIMES, [-0.4, 0.0])[None]
    return ctl, prob, p0, v0, ref, others, ctl._step_data(prob, p0, v0, ref, others, np.array([0.2, 0.25]))


@pytest.mark.parametrize("cold", [False, True])
def test_step_rows_are_the_separate_row_writers(cold):
    rng = np.random.default_rng(7)
    ctl, prob, p0, v0, ref, others, data = _two_others_step()
    assert data.tail_weight > 0.0
    lin = prob.interp_ends @ ref + rng.normal(0.0, 0.05, (len(prob.ends), 2))
    lower = prob.write_separation(data, lin, cold, data.need)
    rows = prob.rows.copy()
    # The separate writers, as before they were fused.
    ref_rows, ref_lower = np.zeros_like(rows), np.empty_like(lower)
    ref_lower[:prob.n_static] = data.static_lower
    ref_rows[:prob.n_static] = rows[:prob.n_static]
    separation_rows(lin, data.x_now, prob.setup.obstacles, prob.setup.pieces, prob.n_walls, p0, v0, data.contact,
                    data.need, cold, np.zeros(prob.n_groups, dtype=bool), prob.eps_end, data.delta_sq,
                    prob.group_point, prob.group_wv, prob.term_offset, data.velocities, data.far, data.away,
                    prob.dyn_phi, prob.dyn_line, ref_rows, ref_lower, prob.n_static)
    lin_v = (lin[-1] - lin[-2]) / prob.intervals[-1]
    m_w = prob.n_walls
    tail_rows(lin[-1], lin_v, data.tail_weight, p0, v0, data.x_now[:m_w, -1], data.away[:m_w], data.dist_now[:m_w],
              data.need[:m_w], data.tail_reach, prob.setup.obstacles, prob.setup.pieces, data.box_low, data.box_high,
              prob.tail_phi, prob.tail_line, prob.tol, cold, ref_rows, ref_lower, prob.n_separation)
    assert np.array_equal(rows, ref_rows)
    assert np.array_equal(lower, ref_lower)


def test_plan_check_is_plan_extremes_with_the_shortfall_and_the_tail():
    rng = np.random.default_rng(5)
    points = np.column_stack([rng.uniform(-7.5, 7.5, 40), rng.uniform(-3.0, 3.0, 40)])
    values = np.vstack([points, rng.normal(size=(12, 2))])
    preds = rng.normal(size=(3, 40, 2))
    need = np.array([0.5, 3.0, 2.9])
    bounds = np.asarray(WORLD.bounds, dtype=float)
    end = np.array([[-1.0, 0.1], [0.8, 0.2]])
    clear, short, worst, fastest, hardest, tail = plan_check(values, 40, 5, WORLD.obstacle_array, WORLD.piece_array,
                                                             bounds, preds, need, end, 1.5)
    ref = plan_extremes(values, 40, 5, WORLD.obstacle_array, WORLD.piece_array, bounds, preds)
    assert (clear, fastest, hardest) == (ref[0], ref[2], ref[3])
    shortfall = need - ref[1]
    assert worst == int(np.argmax(shortfall)) and short == shortfall[worst]
    assert tail == tail_clearance(end[0], end[1], 1.5, WORLD.obstacle_array, WORLD.piece_array, bounds)
    none = plan_check(values, 40, 5, WORLD.obstacle_array, WORLD.piece_array, bounds, np.zeros((0, 40, 2)),
                      np.zeros(0), end, 0.0)
    assert none[1] == -np.inf and none[2] == -1 and none[5] == np.inf


def test_step_data_static_bounds_are_static_lower():
    """The static rows' bounds ``step_state`` completes are :meth:`MPCProblem.static_lower`'s, bit for bit."""
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    prob = ctl._problem(1, TIMES)
    for p0, v0 in [((-1.0, 0.2), (0.5, 0.1)), ((6.9, -1.1), (-0.3, 0.7)), ((0.0, 0.0), (0.0, 0.0))]:
        p0, v0 = np.array(p0), np.array(v0)
        ref = p0 + np.outer(TIMES, [0.8, 0.0])
        others = np.array([[1.5, 0.0]])[:, None] + np.outer(TIMES, [-0.4, 0.0])[None]
        data = ctl._step_data(prob, p0, v0, ref, others, np.array([0.2]))
        assert np.array_equal(data.static_lower, prob.static_lower(p0, v0, data.box_low, data.box_high))


@pytest.mark.parametrize("n_others", [0, 1, 3])
def test_evaluate_is_the_separate_products_bit_for_bit(n_others):
    """One stacked product of a plan gives each row block exactly as its own product did."""
    rng = np.random.default_rng(n_others)
    ctl = BSplineMPC(WORLD, ROBOT, PARAMS)
    prob, setup = ctl._problem(n_others, TIMES), ctl.setup
    for scale in (1e-3, 1.0, 1e3):
        c = rng.normal(0.0, scale, (setup.greville.size, 2))
        check_rates, tail, out, sub = prob.evaluate(c)
        assert np.array_equal(check_rates, np.vstack([prob.b_check, setup.rates]) @ c)
        assert np.array_equal(tail, np.vstack([bspline.basis_derivative([setup.horizon], setup.knots, 3, 0),
                                               bspline.basis_derivative([setup.horizon], setup.knots, 3, 1)]) @ c)
        assert np.array_equal(out, np.vstack([setup.b_step, setup.bv_step, prob.b_samples]) @ c)
        assert np.array_equal(sub, setup.b_substeps @ c)


def test_step_data_fields_hold_what_they_name():
    """``_step_data`` builds its :class:`StepData` positionally: each field is the value it names."""
    ctl, prob, p0, v0, ref, others, data = _two_others_step()
    x_now, away, dist_now, need, delta_sq, far, full, contact, gap, need_box, box_low, box_high = prob.state
    n_end, pred = len(prob.ends), prob.interp_all @ others
    assert data.p0 is p0 and data.v0 is v0 and np.array_equal(data.ref_local, ref - p0)
    assert np.array_equal(data.pred_check, pred[:, n_end + 1:-1]) and np.array_equal(data.velocities, pred[:, -1])
    named = dict(x_now=x_now, away=away, dist_now=dist_now, need=need, delta_sq=delta_sq, far=far, full=full,
                 contact=contact, gap_box=gap, need_box=need_box, box_low=box_low, box_high=box_high)
    assert all(getattr(data, name) is value for name, value in named.items())
    assert data.n_walls == prob.n_walls
    assert np.array_equal(data.static_lower, prob.static_lower(p0, v0, box_low, box_high))
    speed = np.hypot(*v0)
    top = min(ROBOT.max_speed, speed + ROBOT.max_accel * ctl.horizon)
    assert data.tail_weight == top / (2.0 * prob.tail_decel) and data.tail_reach > data.tail_weight * top
    assert data.need_clear == min(need[:prob.n_walls].min(), need_box.min())
    assert data.clearance_now == min(dist_now[:prob.n_walls].min(), gap.min())
    assert not data.overlap  # the others are metres away
