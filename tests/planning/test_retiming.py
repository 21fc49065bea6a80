"""Paths timed within the acceleration limit (issue 18, item 2): hand-computed trapezoids, and
properties of retimed plans (never faster or harsher than the limits, never ahead of the cells
the search reserved) on random reservations."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nodnav.planning.base import PlanRequest
from nodnav.planning.prioritized import PrioritizedPlanner
from nodnav.planning.prm import accelerated_trajectory
from nodnav.planning.retiming import feasible_profile, profile_clear, retimed
from nodnav.planning.timing import earliest_arrival
from nodnav.scenario.params import FastPlannerParams
from nodnav.scenario.world import paper_world

DT = 0.1


def speeds_of(arc: np.ndarray) -> np.ndarray:
    """Speed on every step, with the rest before and after."""
    return np.concatenate([[0.0], np.diff(arc) / DT, [0.0]])


def test_trapezoid_by_hand():
    # 1 m at 0.5 m/s, 0.5 m/s^2, steps of 0.1 s: the speed rises by 0.05 m/s a step.
    # Up: 0.05, 0.10, ..., 0.50 (10 steps, 0.1 * 0.05 * 55 = 0.275 m); down: 0.45, ..., 0.05
    # (9 steps, 0.1 * 0.05 * 45 = 0.225 m); the 0.5 m between at 0.5 m/s: 10 steps. 29 steps, 2.9 s
    # (the continuous trapezoid, l / v + v / a = 3.0 s, rounded to whole steps of constant speed).
    arc, ahead = feasible_profile(np.array([0.0, 1.0]), 1.0, 0.0, 0.5, 0.5, DT)
    v = speeds_of(arc)
    assert not ahead
    assert len(arc) - 1 == 29 and arc[-1] == pytest.approx(1.0, abs=1e-12)
    assert v.max() == pytest.approx(0.5)
    assert v[1:11] == pytest.approx(0.05 * np.arange(1, 11))
    assert v[11:21] == pytest.approx(np.full(10, 0.5))
    assert v[21:30] == pytest.approx(0.05 * np.arange(9, 0, -1))


def test_triangle_by_hand():
    # 0.25 m at 1 m/s^2 never reaches 1 m/s: 0.1, 0.2, ..., 0.5, ..., 0.1 m/s covers 0.1 * 2.5 m
    # in 9 steps; peak 0.5 m/s = sqrt(l a), as for the continuous triangle (2 sqrt(l / a) = 1.0 s).
    arc, ahead = feasible_profile(np.array([0.0, 0.25]), 0.25, 0.0, 1.0, 1.0, DT)
    v = speeds_of(arc)
    assert not ahead and len(arc) - 1 == 9
    assert v[1:10] == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5, 0.4, 0.3, 0.2, 0.1])


def test_waits_where_the_reservation_waits_and_starts_gently():
    # The search holds the robot 1 s, then dashes 1 m at 1 m/s; at 0.5 m/s^2 the robot stays
    # put for the first second, then accelerates.
    upper = np.concatenate([np.zeros(11), np.minimum(0.1 * np.arange(1, 20), 1.0)])
    arc, ahead = feasible_profile(upper, 1.0, 0.0, 1.0, 0.5, DT)
    assert not ahead
    assert np.all(arc[:11] == 0.0)
    assert np.all(arc[:len(upper)] <= upper + 1e-12)
    assert np.abs(np.diff(speeds_of(arc))).max() <= 0.05 + 1e-12


def test_lone_robot_in_the_planner_drives_a_trapezoid_by_hand():
    # 11 m straight along the corridor's axis at 1 m/s and 0.5 m/s^2: up 0.05, ..., 1.0 m/s in
    # 20 steps (0.1 * 0.05 * 210 = 1.05 m), down 0.95, ..., 0.05 in 19 steps (0.95 m), the 9 m
    # between at 1 m/s: 129 steps, 12.9 s (11.0 s by speed alone).
    world = paper_world()
    request = PlanRequest(world, np.array([[-5.5, 0.0]]), np.zeros((1, 2)), np.array([[5.5, 0.0]]),
                          np.array([0.2]), np.array([1.0]), (0,), max_accels=np.array([0.5]))
    res = PrioritizedPlanner(world, FastPlannerParams(dt=DT)).plan(request)
    assert res.success
    assert res.trajectory.duration == pytest.approx(12.9)
    speed = np.linalg.norm(np.diff(res.trajectory.positions[:, 0], axis=0), axis=1) / DT
    assert speed.max() == pytest.approx(1.0)
    old = PrioritizedPlanner(world, FastPlannerParams(dt=DT, timing="speed-only")).plan(request)
    assert old.trajectory.duration == pytest.approx(11.0)


def test_a_robot_moving_now_starts_from_its_speed():
    # Already at 1 m/s along its way: no ramp up; 10.95 m are 10 m at 1 m/s (100 steps) and the
    # 0.95 m of braking (19 steps): 11.9 s.
    world = paper_world()
    request = PlanRequest(world, np.array([[-5.5, 0.0]]), np.array([[1.0, 0.0]]), np.array([[5.45, 0.0]]),
                          np.array([0.2]), np.array([1.0]), (0,), max_accels=np.array([0.5]))
    res = PrioritizedPlanner(world, FastPlannerParams(dt=DT)).plan(request)
    assert res.trajectory.duration == pytest.approx(11.9)


def test_prm_segment_rest_to_rest_by_hand():
    # Two robots on one joint segment: robot 0 drives 1 m (0.5 m/s, 0.5 m/s^2) and limits it,
    # robot 1 drives 0.5 m alongside at half its progress: robot 0's trapezoid of 29 steps.
    path = np.array([[[0.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 1.5]]])
    tr = accelerated_trajectory(path, np.array([0.5, 1.0]), np.array([0.5, 1.0]), DT)
    assert len(tr.times) - 1 == 29
    d0 = np.linalg.norm(np.diff(tr.positions[:, 0], axis=0), axis=1) / DT
    d1 = np.linalg.norm(np.diff(tr.positions[:, 1], axis=0), axis=1) / DT
    assert d0.max() == pytest.approx(0.5) and d1 == pytest.approx(d0 / 2)
    assert tr.positions[-1] == pytest.approx(path[-1])


@st.composite
def reservations(draw):
    """A random line of cells with random obstacles in space-time, searched as the fast
    planner does, and a robot's limits (cells of ``v_max dt / 2``, as the planner cuts them)."""
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    n_rows, n = int(rng.integers(2, 60)), int(rng.integers(2, 150))
    free = rng.random((n_rows, n)) > rng.uniform(0.0, 0.3)
    free = free[np.sort(rng.integers(0, n_rows, n_rows))]  # runs of equal steps, as in practice
    free[-1] = True
    ok2 = rng.random(n) > 0.1
    vmax = draw(st.floats(0.2, 2.0))
    accel = draw(st.floats(0.1, 3.0))
    v0 = draw(st.sampled_from([0.0, 0.0, vmax * draw(st.floats(0.0, 1.0))]))
    return free, ok2, vmax, accel, v0


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(reservations())
def test_retimed_plans_keep_the_limits_and_their_reservation(case):
    free, ok2, vmax, accel, v0 = case
    timing = earliest_arrival(free, ok2)
    if not timing.success:
        return
    n = free.shape[1]
    cell_arc = vmax * DT / 2 * np.arange(n)
    upper = cell_arc[timing.cells]
    arc, ahead = feasible_profile(upper, cell_arc[-1], v0, vmax, accel, DT)
    v = np.concatenate([[v0], np.diff(arc) / DT, [0.0]])
    tol = 1e-9
    assert arc[-1] == pytest.approx(cell_arc[-1], abs=1e-9)  # it arrives ...
    assert np.all(v >= -tol) and np.all(v <= vmax + tol)  # ... forwards, within the speed limit ...
    if v0 == 0.0:
        assert not ahead  # from rest a robot can always stay behind its reservation
    if not ahead:  # (a robot moving too fast to stop where its path ends cannot keep the limits)
        assert np.abs(np.diff(v)).max() <= accel * DT + tol  # ... and the acceleration limit, at rest at the end
        k = min(len(arc), len(upper))
        assert np.all(arc[:k] <= upper[:k] + tol)
        assert np.all(arc[k:] <= upper[-1] + tol)
    # The planner's retiming: either its motion is clear of every closed cell, or the search's
    # own timing is kept.
    words = np.zeros((free.shape[0], 8 * ((n + 63) // 64)), dtype=np.uint8)
    packed = np.packbits(free, axis=1, bitorder="little")
    words[:, :packed.shape[1]] = packed
    bits = words.view("<u8").astype(np.uint64)
    result = retimed(timing, cell_arc, bits, v0, vmax, accel, DT)
    if result.arc is None:
        assert profile_clear(arc, cell_arc, bits) >= 0
    else:
        for t, s in enumerate(result.arc):
            row = free[min(t, len(free) - 1)]
            c = int(np.searchsorted(cell_arc, s + 1e-9, side="right") - 1)
            assert t == 0 or (row[c] and (s <= cell_arc[c] + 1e-9 or row[c + 1]))


@pytest.mark.parametrize("name", ["2r-case1", "3r-case4", "4r-case2"])
def test_plans_timed_within_slow_accelerations_stay_valid(name):
    # Checked independently of the planner, at a step five times finer than the plan's: no
    # robot leaves free space, no pair comes closer than its radii, no speed above the limit.
    import itertools

    from nodnav.scenario.loading import load_scenario

    scenario = load_scenario(name)
    planner = PrioritizedPlanner(scenario.world, FastPlannerParams(dt=DT))
    n = scenario.n_robots
    for order in list(itertools.permutations(range(n)))[::5]:
        request = PlanRequest(scenario.world, scenario.origins, np.zeros_like(scenario.origins),
                              scenario.destinations, scenario.radii, scenario.max_speeds, order,
                              max_accels=np.full(n, 0.15))
        tr = planner.plan(request).trajectory
        t = np.linspace(tr.times[0], tr.times[-1], 5 * (len(tr.times) - 1) + 1)
        p = tr.positions_at(t)
        assert np.all(scenario.world.is_free(p, scenario.radii))
        for a, b in itertools.combinations(range(n), 2):
            assert np.linalg.norm(p[:, a] - p[:, b], axis=1).min() >= scenario.radii[a] + scenario.radii[b] - 1e-9
        speed = np.linalg.norm(np.diff(tr.positions, axis=0), axis=2) / DT
        assert np.all(speed <= scenario.max_speeds + 1e-9)
        assert np.allclose(tr.positions[-1], scenario.destinations, atol=1e-6)


def test_retimed_is_the_profile_kept_only_where_it_is_clear():
    """:func:`retimed` (one compiled call) against its definition from the two public steps:
    the profile of :func:`feasible_profile` when :func:`profile_clear` finds no clash, else the
    search's own cells; random reservations, speeds and blocked cells."""
    from nodnav.planning.timing import Timing

    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(2, 40))
        cell_arc = np.concatenate([[0.0], np.cumsum(rng.uniform(0.01, 0.1, n - 1))])
        steps = np.sort(rng.integers(0, n, int(rng.integers(1, 30))))
        cells = np.concatenate([[0], steps, [n - 1]])
        free = rng.integers(0, 2**63, (int(rng.integers(1, 40)), (n + 63) // 64), dtype=np.uint64)
        if rng.random() < 0.5:
            free[:] = np.uint64(2**64 - 1)
        v0, vmax, accel, dt = rng.uniform(0, 1), rng.uniform(0.2, 1.5), rng.uniform(0.1, 3), 0.1
        timing = Timing(True, "", cells)
        got = retimed(timing, cell_arc, free, v0, vmax, accel, dt)
        arc, _ = feasible_profile(cell_arc[cells], float(cell_arc[-1]), v0, vmax, accel, dt)
        if profile_clear(arc, cell_arc, free) >= 0:
            assert got is timing
        else:
            assert got.arc is not None and np.array_equal(got.arc, arc) and got.cells is cells
