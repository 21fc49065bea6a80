"""The fast planner's pieces against hand computations and brute-force references, and its
behaviour on small situations whose answer is known."""

import itertools
import math

import numpy as np
import pytest

from nodnav.planning.base import PlanRequest, corridor_entry_order, crossing_directions
from nodnav.planning.occupancy import (
    SLACK,
    Motion,
    blocked_bits,
    conflict_intervals,
    corridor_passage,
    entry_cell,
    free_cells,
    join_motions,
    polyline_segments,
    relaxed_separation,
    separation_requirements,
)
from nodnav.planning.polylines import arc_length_grid
from nodnav.planning.prioritized import PrioritizedPlanner
from nodnav.planning.timing import earliest_arrival
from nodnav.scenario.params import FastPlannerParams
from nodnav.scenario.world import paper_world

DT = 0.1


@pytest.fixture(scope="module")
def world():
    return paper_world()


@pytest.fixture(scope="module")
def planner(world):
    return PrioritizedPlanner(world, FastPlannerParams(dt=DT, margin=0.05))


def request(world, pos, dest, order, entered=(), t0=0.0):
    pos, dest = np.asarray(pos, float), np.asarray(dest, float)
    n = len(pos)
    return PlanRequest(world, pos, np.zeros_like(pos), dest, np.full(n, 0.2), np.ones(n), tuple(order),
                       tuple(entered), t0)


def min_gap(res, radii, factor=5):
    """Least surface-to-surface gap over all pairs at a step ``factor`` times finer than the plan's."""
    tr = res.trajectory
    t = np.linspace(tr.times[0], tr.times[-1], factor * (len(tr.times) - 1) + 1)
    p = tr.positions_at(t)
    n = tr.n_robots
    return min(np.linalg.norm(p[:, a] - p[:, b], axis=1).min() - radii[a] - radii[b]
               for a in range(n) for b in range(a + 1, n))


# ---------------------------------------------------------------------------------------------
# separation_requirements


def test_separation_requirements_hand_values():
    dest = np.array([[0.0, 1.0], [3.0, 1.0], [3.42, 1.0], [6.0, 1.0]])
    req = separation_requirements(dest, np.full(4, 0.2), np.ones(4), DT, 0.05)
    # Far apart: r_a + r_b + margin = 0.45 (sqrt(0.4^2 + (2 * 1 * 0.1 / 2)^2) = 0.412 is smaller).
    assert req[0, 1] == pytest.approx(0.45) and req[1, 0] == pytest.approx(0.45)
    # Robots 1 and 2 park 0.42 apart: held to 0.42 so that both can.
    assert req[1, 2] == pytest.approx(0.42)
    assert np.all(np.diag(req) == 0.0)
    # No margin: the between-samples bound sqrt(0.16 + 0.01) takes over.
    req0 = separation_requirements(dest[[0, 3]], np.full(2, 0.2), np.ones(2), DT, 0.0)
    assert req0[0, 1] == pytest.approx(math.sqrt(0.17))


def test_separation_requirements_never_below_contact():
    # Destinations overlapping (a malformed request): still the contact distance.
    req = separation_requirements(np.array([[0.0, 0.0], [0.3, 0.0]]), np.full(2, 0.2), np.ones(2), DT, 0.05)
    assert req[0, 1] == pytest.approx(0.4)


def test_relaxed_separation():
    req = np.array([0.45, 0.45, 0.45])
    got = relaxed_separation(req, np.array([0.43, 0.6, 0.1]))
    # Closer than required: a hair below the present distance; otherwise unchanged.
    assert got == pytest.approx([0.43 - SLACK, 0.45, 0.1 - SLACK], abs=1e-12)


# ---------------------------------------------------------------------------------------------
# corridor bookkeeping


def test_corridor_passage():
    F, T = False, True
    assert corridor_passage([F, F, T, T, F]) == (2, 4)
    assert corridor_passage([T, T, F]) == (0, 2)
    assert corridor_passage([F, T, F, T, T]) == (3, 5)  # the last stay counts
    assert corridor_passage([F, F]) == (-1, -1)


def test_polyline_segments_skip_empty_ones():
    # A 3-4-5 segment, a repeated vertex, then 4 m straight down.
    start, unit, length, arc0 = polyline_segments([[0.0, 0.0], [3.0, 4.0], [3.0, 4.0], [3.0, 0.0]])
    assert start.tolist() == [[0.0, 0.0], [3.0, 4.0]]
    assert np.allclose(unit, [[0.6, 0.8], [0.0, -1.0]], rtol=0.0, atol=1e-15)
    assert length.tolist() == [5.0, 4.0] and arc0.tolist() == [0.0, 5.0]


def test_motion_sweep_finds_the_steps_that_cut_a_corner():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    # The move from arc 0.6 to 1.2 (step 1) passes the corner at arc 1; its chord joins the samples.
    arc = np.array([0.0, 0.6, 1.2, 2.0])
    samples = np.array([[0.0, 0.0], [0.6, 0.0], [1.0, 0.2], [1.0, 1.0]])
    basis, offset, s0, length, step, chord_a, chord_b = Motion(path, samples, arc).sweep
    assert step.tolist() == [1] and chord_a.tolist() == [[0.6, 0.0]] and chord_b.tolist() == [[1.0, 0.2]]
    # A point's coordinates along and across each segment: (x, y) on the first, (y, -(x - 1)) on the second.
    frame = np.array([[0.5, 0.3]]) @ basis - offset
    assert np.allclose(frame, [[0.5, 0.3, 0.3, 0.5]], rtol=0.0, atol=1e-15)
    assert s0.tolist() == [0.0, 1.0] and length.tolist() == [1.0, 1.0]
    # A sample exactly on the corner: no move cuts it.
    on = Motion(path, np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]), np.array([0.0, 1.0, 2.0]))
    assert on.sweep[4].tolist() == []


def test_entry_cell():
    F, T = False, True
    assert entry_cell([F, F, T, T, F]) == 2
    assert entry_cell([T, T, F, F, T]) == 4  # starts inside: only a re-entry counts
    assert entry_cell([T, T]) == -1
    assert entry_cell([F, F]) == -1


# ---------------------------------------------------------------------------------------------
# conflict_intervals and free_cells


def test_conflict_intervals_straight_line_by_hand():
    # The other robot runs along y = 0 from x = 0 to x = 10, 0.1 m per step (samples t = 0..100).
    path = np.array([[0.0, 0.0], [10.0, 0.0]])
    arc = np.arange(101) * 0.1
    samples = np.stack([arc, np.zeros_like(arc)], axis=1)
    cells = np.array([[5.03, 0.3], [9.97, 0.3], [5.0, 2.0]])
    cols, first, last = conflict_intervals(cells, [Motion(path, samples, arc)], [0.5])
    got = {(int(c), int(f), int(min(e, 10**6))) for c, f, e in zip(cols, first, last)}
    # Cell 0 is within 0.5 of x in (5.03 - 0.4, 5.03 + 0.4) = (4.63, 5.43): the steps whose
    # stretch [0.1 t, 0.1 t + 0.1] meets it are t = 46..54. Cell 1 is within 0.5 of x in
    # (9.57, 10]: steps 95..99 while moving, then 0.30 from the parking spot (10, 0) from step
    # 100 for good. Cell 2 is never within 0.5.
    assert (0, 46, 54) in got
    assert (1, 95, 99) in got and (1, 100, 10**6) in got
    assert all(c != 2 for c, _, _ in got)
    free = free_cells(3, 120, [(cols, first, last)])
    assert np.nonzero(~free[:, 0])[0].tolist() == list(range(46, 55))
    assert np.nonzero(~free[:, 1])[0].tolist() == list(range(95, 120))


def test_conflict_intervals_match_dense_sampling():
    # A corner path walked with a random mix of waits, half and full steps; cells scattered around.
    rng = np.random.default_rng(3)
    path = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.5], [0.5, 2.5]])
    grid = arc_length_grid(path, 0.05)
    idx = np.minimum(np.cumsum(np.concatenate([[0], rng.choice([0, 1, 2], 120, p=[0.2, 0.3, 0.5])])),
                     len(grid.points) - 1)
    samples, arc = grid.points[idx], grid.arc_length[idx]
    cells = rng.uniform([-0.5, -0.7], [2.8, 3.0], (150, 2))
    required = 0.45
    n_rows = len(samples) + 5
    free = free_cells(len(cells), n_rows, [conflict_intervals(cells, [Motion(path, samples, arc)], [required])])

    # Brute force: where the other robot can be during [t, t+1] -- the polyline stretch and the
    # chord between the samples, densely sampled -- and the least distance to each cell.
    u = np.linspace(0.0, 1.0, 200)
    near = np.zeros((n_rows, len(cells)))
    for t in range(n_rows):
        if t + 1 < len(samples):
            s = arc[t] + u * (arc[t + 1] - arc[t])
            stretch = np.stack([np.interp(s, grid.arc_length, grid.points[:, 0]),
                                np.interp(s, grid.arc_length, grid.points[:, 1])], axis=1)
            chord = samples[t] + u[:, None] * (samples[t + 1] - samples[t])
            where = np.vstack([stretch, chord])
        else:
            where = samples[-1:]
        near[t] = np.linalg.norm(where[:, None] - cells[None], axis=2).min(axis=0)
    # Every truly conflicting (step, cell) is blocked; nothing clearly clear is blocked.
    assert not np.any(free & (near < required - 1e-3))
    assert not np.any(~free & (near > required + 1e-3))


def test_free_cells_by_hand():
    cols, first, last = np.array([1, 0, 1]), np.array([2, 0, 3]), np.array([3, 0, 10**9])
    free = free_cells(3, 5, [(cols, first, last)], gates=[(2, 2)])
    expected = np.array([[0, 1, 0],
                         [1, 1, 0],
                         [1, 0, 1],
                         [1, 0, 1],
                         [1, 0, 1]], dtype=bool)
    assert (free == expected).all()


# ---------------------------------------------------------------------------------------------
# earliest_arrival


def brute_force_arrival(free, ok2):
    """Reachable sets as Python sets and the earliest step at which the goal is reachable and
    stays free (rows past the end repeat the last one)."""
    n_rows, n = free.shape
    def row(t):
        return free[min(t, n_rows - 1)]

    reach = [{0}]
    for t in range(1, n_rows + 2 * n + 2):
        nxt = {c + m for c in reach[-1] for m in (0, 1, 2)
               if c + m < n and (m < 2 or ok2[c]) and row(t)[c + m]}
        reach.append(nxt)
    for t, r in enumerate(reach):
        if n - 1 in r and all(row(s)[n - 1] for s in range(max(t, 1), n_rows + 1)):
            return t, reach
    return None, reach


def check_timing(timing, free, ok2):
    cells = timing.cells
    n_rows, n = free.shape
    assert cells[0] == 0 and cells[-1] == n - 1
    moves = np.diff(cells)
    assert np.all((moves >= 0) & (moves <= 2))
    assert all(ok2[cells[t]] for t in np.nonzero(moves == 2)[0])
    assert all(free[min(t, n_rows - 1), c] for t, c in enumerate(cells) if t > 0)


def test_earliest_arrival_all_free():
    free = np.ones((1, 11), dtype=bool)
    t = earliest_arrival(free, np.ones(11, dtype=bool))
    assert t.success and t.arrival == 5 and t.cells.tolist() == [0, 2, 4, 6, 8, 10]
    # Without full-speed moves: one cell per step.
    t = earliest_arrival(free, np.zeros(11, dtype=bool))
    assert t.arrival == 10


def test_earliest_arrival_waits_for_a_passing_robot():
    # Cells 3 and 4 are occupied during steps 0..9; the robot cannot jump both at once, so it
    # reaches cell 4 at step 10 at the earliest and its destination at step 11.
    free = np.ones((12, 6), dtype=bool)
    free[:10, 3:5] = False
    # Waiting late: it drives up to cell 2 at once and waits there.
    t = earliest_arrival(free, np.ones(6, dtype=bool), wait_early=False)
    assert t.success and t.cells.tolist() == [0] + [2] * 9 + [4, 5]
    # Waiting early: it holds back in cell 0 and leaves just in time (cell 1 at step 9, cell 3
    # as soon as it frees at step 10).
    t = earliest_arrival(free, np.ones(6, dtype=bool), wait_early=True)
    assert t.success and t.cells.tolist() == [0] * 9 + [1, 3, 5]


def test_earliest_arrival_waits_until_the_goal_stays_free():
    free = np.ones((9, 5), dtype=bool)
    free[7, 4] = False  # someone passes the destination at step 7
    t = earliest_arrival(free, np.ones(5, dtype=bool))
    assert t.arrival == 8


def test_earliest_arrival_cornered_and_blocked():
    free = np.ones((4, 4), dtype=bool)
    free[1, :3] = False
    t = earliest_arrival(free, np.ones(4, dtype=bool))
    assert not t.success and t.trapped_at == 1 and "cornered" in t.reason
    free = np.ones((4, 4), dtype=bool)
    free[3, 3] = False  # the destination stays taken for good
    t = earliest_arrival(free, np.ones(4, dtype=bool))
    assert not t.success and t.trapped_at == -1
    free = np.ones((4, 6), dtype=bool)
    free[1:, 3:5] = False  # a parked robot blocks the way for good
    t = earliest_arrival(free, np.ones(6, dtype=bool))
    assert not t.success and t.trapped_at == -1 and "blocked" in t.reason


@pytest.mark.parametrize("wait_early", [True, False])
@pytest.mark.parametrize("seed", range(60))
def test_earliest_arrival_matches_brute_force(seed, wait_early):
    rng = np.random.default_rng(seed)
    check_against_brute_force(rng, int(rng.integers(2, 25)), int(rng.integers(2, 70)), rng.uniform(0.05, 0.4), 0.1,
                              wait_early)


@pytest.mark.parametrize("wait_early", [True, False])
@pytest.mark.parametrize("seed", range(10))
def test_earliest_arrival_across_words_matches_brute_force(seed, wait_early):
    # Lines of 65..200 cells span two to four 64-bit words: moves carry bits across words.
    rng = np.random.default_rng(100 + seed)
    check_against_brute_force(rng, int(rng.integers(30, 120)), int(rng.integers(65, 200)), rng.uniform(0.0, 0.1), 0.0,
                              wait_early)


def check_against_brute_force(rng, n_rows, n, density, final_density, wait_early):
    """:func:`earliest_arrival` against :func:`brute_force_arrival` on random free cells
    (``density`` of them closed, ``final_density`` in the last row)."""
    free = rng.random((n_rows, n)) > density
    free = free[np.sort(rng.integers(0, n_rows, n_rows))]  # runs of equal steps, as in practice
    free[-1] = rng.random(n) >= final_density
    ok2 = rng.random(n) > 0.2
    expected, reach = brute_force_arrival(free, ok2)
    t = earliest_arrival(free, ok2, wait_early)
    if expected is None:
        assert not t.success
        return
    assert t.success and t.arrival == expected
    check_timing(t, free, ok2)
    if np.all(np.diff(t.cells) > 0):
        return  # no waiting at all: where the one slower step goes is immaterial
    # Backwards from the arrival, the nearest (waiting early) or farthest (waiting late) cell
    # from which the rest of the chosen timing can still be driven.
    back = {len(free[0]) - 1}
    for s in range(expected, -1, -1):
        options = reach[s] & back
        assert t.cells[s] == (min(options) if wait_early else max(options))
        options = {t.cells[s]}
        if s:
            back = {c - m for c in options for m in (0, 1, 2) if c - m >= 0 and (m < 2 or ok2[c - m])}


# ---------------------------------------------------------------------------------------------
# The planner on small situations


def test_single_robot_goes_straight_at_full_speed(world, planner):
    res = planner.plan(request(world, [[-5.5, 0.0]], [[5.5, 0.0]], (0,)))
    # 11 m in cells of 0.05 m, two cells per 0.1 s step: 110 steps, exactly 11 s at 1 m/s.
    assert res.success and res.reason == ""
    assert res.trajectory.duration == pytest.approx(11.0)
    assert res.cost == pytest.approx(11.0)
    assert res.info["path_lengths"] == pytest.approx([11.0])
    speeds = np.linalg.norm(res.trajectory.velocities[:-1, 0], axis=1)
    assert speeds == pytest.approx(np.ones(len(speeds)))


def test_head_on_pair_second_enters_after_first_leaves(world, planner):
    res = planner.plan(request(world, [[-5.5, 0.0], [5.5, 0.0]], [[5.5, 0.0], [-5.5, 0.0]], (1, 0)))
    assert res.success
    inside = world.in_corridor(res.trajectory.positions)
    last_1 = np.nonzero(inside[:, 1])[0][-1]
    first_0 = np.nonzero(inside[:, 0])[0][0]
    assert first_0 > last_1 + 1
    assert corridor_entry_order(world, res.trajectory) == (1, 0)
    assert min_gap(res, [0.2, 0.2]) >= 0.0
    # Robot 1 goes straight through at full speed: 11 s.
    assert res.info["arrival_times"][1] == pytest.approx(11.0)
    assert res.cost == pytest.approx(res.info["arrival_times"].sum())


def test_same_direction_follows_closely(world, planner):
    res = planner.plan(request(world, [[-5.5, 0.0], [-6.2, 0.0]], [[5.5, 0.0], [6.0, 0.5]], (0, 1)))
    assert res.success
    p = res.trajectory.positions
    both_inside = world.in_corridor(p).all(axis=1)
    assert both_inside.any()  # following inside the corridor is allowed
    assert np.linalg.norm(p[:, 0] - p[:, 1], axis=1).min() >= 0.45 - 1e-9


def test_plans_are_deterministic_and_memo_is_transparent(world):
    req = request(world, [[-5.0, 1.5], [5.0, 1.5], [-5.0, -1.5]], [[5.0, -1.5], [-5.0, -1.5], [5.5, 1.5]], (1, 2, 0))
    a = PrioritizedPlanner(world, FastPlannerParams()).plan(req)
    p = PrioritizedPlanner(world, FastPlannerParams())
    p.plan(request(world, [[-5.0, 1.5], [5.0, 1.5], [-5.0, -1.5]], [[5.0, -1.5], [-5.0, -1.5], [5.5, 1.5]], (2, 1, 0)))
    b = p.plan(req)
    assert a.success and np.array_equal(a.trajectory.positions, b.trajectory.positions)


def test_orders_repaired_alike_share_one_read_only_plan(world):
    # Robots 0 and 2 stand in the corridor: every order is repaired to start with them, so the
    # orders (1, 0, 2) and (0, 1, 2) are both planned as (0, 2, 1) and differ only in the note.
    p = PrioritizedPlanner(world, FastPlannerParams())
    pos, dest = [[-1.0, 0.0], [5.0, 1.5], [-2.0, 0.0]], [[5.5, 0.0], [-5.0, -1.5], [5.0, -1.5]]
    a = p.plan(request(world, pos, dest, (1, 0, 2), entered=(0, 2)))
    b = p.plan(request(world, pos, dest, (0, 1, 2), entered=(0, 2)))
    fresh = PrioritizedPlanner(world, FastPlannerParams()).plan(request(world, pos, dest, (0, 1, 2), entered=(0, 2)))
    assert a.success and a.order_planned == b.order_planned == (0, 2, 1)
    assert a.order == (1, 0, 2) and b.order == (0, 1, 2) and "repaired" in a.reason and "repaired" in b.reason
    assert np.array_equal(b.trajectory.positions, fresh.trajectory.positions) and b.cost == fresh.cost
    assert not a.trajectory.positions.flags.writeable and not a.info["arrival_times"].flags.writeable


def test_robot_already_home_stays(world, planner):
    res = planner.plan(request(world, [[-5.0, 0.0], [5.0, 2.0]], [[5.0, 0.0], [5.0, 2.0]], (0, 1)))
    assert res.success and res.info["arrival_times"][1] == 0.0
    assert np.all(res.trajectory.positions[:, 1] == [5.0, 2.0])


def test_robot_inside_counts_as_entered(world, planner):
    # Robot 1 is in the corridor although the request does not say so: it goes first.
    res = planner.plan(request(world, [[-5.0, 0.0], [1.0, 0.0]], [[5.0, 0.0], [5.5, 1.0]], (0, 1)))
    assert res.success and res.order_planned == (1, 0) and res.repaired
    assert "repaired" in res.reason and res.info["entered"] == (1,)
    assert corridor_entry_order(world, res.trajectory) == (1, 0)


def test_cornered_robot_backs_out(world, planner):
    # Both robots are in the corridor heading for each other; robot 0 entered first, so robot 1
    # must back out to its room, wait beside the entrance and come through afterwards.
    res = planner.plan(request(world, [[-1.0, 0.0], [2.0, 0.0]], [[5.5, 0.0], [-5.5, 0.0]], (0, 1), entered=(0, 1)))
    assert res.success and res.info["retreats"] == (1,) and "back out" in res.reason
    tr = res.trajectory
    assert min_gap(res, [0.2, 0.2]) >= 0.0
    assert np.all(world.is_free(tr.positions_at(np.linspace(tr.times[0], tr.times[-1], 2000)), 0.2))
    assert np.allclose(tr.positions[-1], [[5.5, 0.0], [-5.5, 0.0]])
    assert tr.positions[:, 1, 0].max() > 3.0  # it left the corridor on its own side


def test_destinations_overlapping_fail_cleanly(world, planner):
    res = planner.plan(request(world, [[-5.0, 1.0], [-5.0, -1.0]], [[5.0, 0.0], [5.1, 0.0]], (0, 1)))
    assert not res.success and "overlap" in res.reason and res.cost == float("inf")
    assert res.trajectory.positions[0].tolist() == [[-5.0, 1.0], [-5.0, -1.0]]


def test_parking_in_the_corridor_blocks_the_opposite_robot(world, planner):
    res = planner.plan(request(world, [[-5.0, 0.0], [5.0, 0.0]], [[0.0, 0.0], [-5.0, 0.0]], (0, 1)))
    assert not res.success and "parks inside the corridor" in res.reason


def test_robot_in_the_way_of_the_first_is_avoided(world, planner):
    # Robot 1 (second) stands on robot 0's straight line; robot 0 goes around it, and robot 1
    # can wait where it is.
    res = planner.plan(request(world, [[-6.0, 0.0], [-4.5, 0.0]], [[-3.5, 0.0], [-4.5, 2.0]], (0, 1)))
    assert res.success
    d = np.linalg.norm(res.trajectory.positions[:, 0] - [-4.5, 0.0], axis=1)
    assert d.min() >= 0.45 - 1e-9
    assert res.info["path_lengths"][0] > 2.5


def test_compute_time_and_order_fields(world, planner):
    res = planner.plan(request(world, [[-5.0, 0.0], [5.0, 0.0]], [[5.0, 0.0], [-5.0, 0.0]], (0, 1), t0=3.0))
    assert res.compute_time > 0 and res.order == (0, 1) == res.order_planned and not res.repaired
    assert res.trajectory.times[0] == 3.0
    assert np.diff(res.trajectory.times) == pytest.approx(np.full(len(res.trajectory.times) - 1, DT))


def test_malformed_order_is_rejected(world, planner):
    with pytest.raises(ValueError):
        planner.plan(request(world, [[-5.0, 0.0], [5.0, 0.0]], [[5.0, 0.0], [-5.0, 0.0]], (0, 0)))


# ---------------------------------------------------------------------------------------------
# Pieces added for the closed loop: windows, gates, rows, joined motions


def test_conflict_intervals_windows_clip_the_steps():
    path = np.array([[0.0, 0.0], [10.0, 0.0]])
    arc = np.arange(101) * 0.1
    motion = Motion(path, np.stack([arc, np.zeros_like(arc)], axis=1), arc)
    cells = np.array([[5.03, 0.3]])
    # Unclipped: steps 46..54 (see the straight-line test above); the window keeps 50..60.
    cols, first, last = conflict_intervals(cells, [motion], [0.5], ([50], [60]))
    assert (cols.tolist(), first.tolist(), last.tolist()) == ([0], [50], [54])
    cols, first, last = conflict_intervals(cells, [motion], [0.5], ([0], [45]))
    assert len(cols) == 0


def test_blocked_bits_several_gates_and_rows():
    # Gate at cell 1 until step 2, gate at cell 3 until step 4; an interval closes cell 0 at step 3.
    bits = blocked_bits(5, 6, [(np.array([0]), np.array([3]), np.array([3]))], [(1, 2), (3, 4)])
    assert bits.shape == (6, 1) and bits.dtype == np.uint64
    assert bits[:, 0].tolist() == [0b11110, 0b11110, 0b11000, 0b11001, 0, 0]


def test_blocked_bits_span_several_words():
    # Cell 130 lives in the third 64-bit word, bit 2; a gate at cell 70 closes bits 6..63 of the
    # second word and bits 0..21 of the third (cells 128..149), none of the first. Steps before 0
    # and past the last row are ignored.
    bits = blocked_bits(150, 3, [(np.array([130, 1]), np.array([1, -5]), np.array([10**9, 0]))], [(70, 1)])
    assert bits.shape == (3, 3)
    assert bits[0].tolist() == [0b10, (2**64 - 1) ^ (2**6 - 1), 2**22 - 1]
    assert bits[1].tolist() == [0, 0, 1 << 2] and bits[2].tolist() == [0, 0, 1 << 2]


def test_join_motions():
    head = Motion(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]),
                  np.array([0.0, 0.5, 1.0]))
    tail = Motion(np.array([[1.0, 0.0], [1.0, 1.0]]), np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 1.0]]),
                  np.array([0.0, 0.0, 1.0]))
    m = join_motions(head, tail)
    assert m.samples.tolist() == [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
    assert m.arc.tolist() == [0.0, 0.5, 1.0, 1.0, 2.0] and m.last_step == 4
    assert m.path.tolist() == [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]


# ---------------------------------------------------------------------------------------------
# Door zones, getting out of the way, and pairs that start too close


def check_plan(world, req, res, door_clearance=1.0):
    """Independent checks of a successful plan: start and end, speed, free space, contact at a
    step five times finer, never closer than a pair started, entry order, single file, doors."""
    tr = res.trajectory
    assert res.success, res.reason
    n = len(req.positions)
    assert np.allclose(tr.positions[0], req.positions) and np.allclose(tr.positions[-1], req.destinations)
    speed = np.linalg.norm(np.diff(tr.positions, axis=0), axis=2) / DT
    assert np.all(speed <= req.max_speeds + 1e-9)
    t = np.linspace(tr.times[0], tr.times[-1], 5 * (len(tr.times) - 1) + 1)
    p = tr.positions_at(t)
    assert np.all(world.is_free(p, 0.2))
    start_gap = np.linalg.norm(req.positions[:, None] - req.positions[None], axis=2)
    for a in range(n):
        for b in range(a + 1, n):
            assert np.linalg.norm(p[:, a] - p[:, b], axis=1).min() >= 0.4 - 1e-9
            at_samples = np.linalg.norm(tr.positions[:, a] - tr.positions[:, b], axis=1)
            assert at_samples.min() >= min(0.45, start_gap[a, b]) - 1e-5
    dirs = crossing_directions(world, req.positions, req.destinations)
    crossing = [k for k in res.order_planned if dirs[k] != 0]
    assert [k for k in corridor_entry_order(world, tr) if dirs[k] != 0] == crossing
    inside = world.in_corridor(tr.positions)
    entrances = np.asarray(world.entrances)
    for i, a in enumerate(crossing):
        for b in crossing[i + 1:]:
            if dirs[a] == dirs[b]:
                continue
            assert np.nonzero(inside[:, b])[0][0] > np.nonzero(inside[:, a])[0][-1]
            # Door rule: once b is (or gets) clear of its door zone, it comes back only after a
            # has left that zone for good.
            door = entrances[0 if dirs[b] > 0 else 1]
            in_b = np.linalg.norm(tr.positions[:, b] - door, axis=1) < door_clearance
            in_a = np.linalg.norm(tr.positions[:, a] - door, axis=1) < door_clearance
            a_left = np.nonzero(in_a)[0][-1] if in_a.any() else -1
            first_out = np.argmax(~in_b)
            later_in = np.nonzero(in_b[first_out:])[0]
            if len(later_in):
                assert first_out + later_in[0] > a_left, f"robot {b} is in its door zone while robot {a} is"
    return tr


def test_waiting_robot_stays_clear_of_the_door(world, planner):
    # Head-on from the rooms: robot 1 goes second and waits outside the right door zone until
    # robot 0 has come out of it (farther than the old rule, which let it wait at the entrance).
    req = request(world, [[-5.5, 0.0], [5.5, 0.0]], [[5.5, 1.2], [-5.5, -1.2]], (0, 1))
    tr = check_plan(world, req, planner.plan(req))
    gap = np.linalg.norm(tr.positions[:, 1] - [3.0, 0.0], axis=1)
    out = np.linalg.norm(tr.positions[:, 0] - [3.0, 0.0], axis=1)
    left = np.nonzero(out < 1.0)[0][-1]
    assert gap[:left + 1].min() >= 1.0 - 1e-9
    assert gap.min() < 1.0  # and it does go through afterwards


def test_door_rule_can_be_narrowed(world):
    narrow = PrioritizedPlanner(world, FastPlannerParams(dt=DT, door_clearance=0.3))
    req = request(world, [[-5.5, 0.0], [5.5, 0.0]], [[5.5, 1.2], [-5.5, -1.2]], (0, 1))
    wide = PrioritizedPlanner(world, FastPlannerParams(dt=DT)).plan(req)
    tight = check_plan(world, req, narrow.plan(req), 0.3)
    # Waiting nearer the door, robot 1 is through sooner.
    assert narrow.plan(req).info["arrival_times"][1] < wide.info["arrival_times"][1]
    assert tight.positions.shape[0] <= wide.trajectory.positions.shape[0]


@pytest.mark.parametrize("mirror", [1.0, -1.0])
def test_robot_in_front_of_the_exit_gets_out_of_the_way(world, planner, mirror):
    # Recorded in the closed loop (2r-case2, seed 2, t = 10 s), and its mirror image at the right
    # exit: robot 1 is leaving the corridor at its exit, robot 0, which goes second, stands right
    # in front of it, 0.42 m away (less than the 0.45 m required).
    flip = np.array([mirror, 1.0])
    pos = np.array([[-3.098, 0.169], [-2.816, -0.146]]) * flip
    dest = np.array([[5.0, -1.5], [-5.0, -1.5]]) * flip
    for order, entered in [((0, 1), (1,)), ((1, 0), (1,)), ((1, 0), ())]:
        req = request(world, pos, dest, order, entered)
        res = planner.plan(req)
        assert res.order_planned == (1, 0) and res.info["retreats"] == (0,)
        tr = check_plan(world, req, res)
        # Robot 0 moves first; robot 1 holds until robot 0 has made room.
        moved_0 = np.argmax(np.linalg.norm(tr.positions[:, 0] - pos[0], axis=1) > 0.05)
        moved_1 = np.argmax(np.linalg.norm(tr.positions[:, 1] - pos[1], axis=1) > 0.05)
        assert moved_0 < moved_1


def test_robot_parked_in_the_door_zone_leaves_it_first(world, planner):
    # Robot 1 waits 0.85 m from the right entrance, not in robot 0's way; robot 0, which has
    # entered, comes out there. Robot 1 first leaves the door zone, then comes back after robot 0.
    req = request(world, [[0.0, 0.0], [3.6, 0.6]], [[5.5, -1.0], [-5.5, 0.0]], (0, 1), entered=(0,))
    res = planner.plan(req)
    assert res.info["retreats"] == (1,)
    tr = check_plan(world, req, res)
    gap = np.linalg.norm(tr.positions[:, 1] - [3.0, 0.0], axis=1)
    assert gap[0] < 1.0 and (gap >= 1.0 - 1e-9).any()


def test_three_robots_jammed_at_the_door(world, planner):
    # Recorded in the closed loop (3r-case1, seed 1, t = 5 s): three robots bound the same way
    # crowd the left entrance, robot 2 right in front of it, 0.42 m from each of the others.
    pos = [[-3.202, 0.527], [-3.235, -0.295], [-3.137, 0.112]]
    dest = [[5.5, 1.5], [5.5, -1.5], [5.5, 0.0]]
    for order in itertools.permutations(range(3)):
        req = request(world, pos, dest, order)
        check_plan(world, req, planner.plan(req))


def test_robot_pinned_in_the_entrance_gets_room(world, planner):
    # Recorded in the closed loop (3r-case4, seed 2): robot 2 stands in the right entrance,
    # pinned between the wall's corner and robot 1 (0.43 m away); both go left, robot 1 first.
    # Robot 2 can only get out of the way once robot 1 has backed off.
    pos = [[-5.0, -0.8], [3.179, -0.259], [3.057, 0.154]]
    dest = [[5.8, 1.8], [-5.8, 1.5], [-5.8, -1.8]]
    for order in itertools.permutations(range(3)):
        req = request(world, pos, dest, order)
        res = planner.plan(req)
        check_plan(world, req, res)
        if order.index(1) < order.index(2):
            assert 2 in res.info["retreats"]


def test_pair_starting_too_close_may_separate(world, planner):
    # 0.41 m apart (0.45 required), both going away from each other: allowed, and they never
    # come closer than they started.
    req = request(world, [[-5.0, 0.0], [-5.0, 0.41]], [[-5.0, -2.0], [-5.0, 2.0]], (0, 1))
    res = planner.plan(req)
    tr = check_plan(world, req, res)
    gap = np.linalg.norm(tr.positions[:, 0] - tr.positions[:, 1], axis=1)
    assert gap.min() >= 0.41 - 1e-5 and res.info["arrival_times"] == pytest.approx([2.0, 1.6])


def test_four_robots_jammed_at_the_door(world, planner):
    # Recorded in the closed loop (4r-case1, seed 5, old planner): four robots bound the same way
    # box each other in at the left entrance; robot 0 stands in it, pinned between the wall's
    # corner and robot 2 (0.43 m away), which is itself hemmed in by robots 1 and 3. In some
    # orders robots must get out of the way of robots that are getting out of the way.
    pos = [[-3.139, 0.194], [-3.594, 0.354], [-3.452, -0.095], [-3.307, -0.519]]
    dest = [[4.5, 1.0], [6.0, 1.5], [6.0, -1.5], [4.5, -1.0]]
    for order in itertools.permutations(range(4)):
        req = request(world, pos, dest, order)
        check_plan(world, req, planner.plan(req))


def test_relaxed_pair_keeps_full_separation_once_apart(world, planner):
    # Robot 1 starts 0.41 m right behind robot 0 (0.45 m required) and follows it through the
    # corridor. The relaxation lasts only until robot 0's motion keeps 0.45 m from where robot 1
    # started; from then on the pair keeps the full separation.
    req = request(world, [[-5.0, 0.0], [-5.41, 0.0]], [[5.5, 0.0], [5.0, 0.8]], (0, 1))
    tr = check_plan(world, req, planner.plan(req))
    p0 = tr.positions_at(np.linspace(tr.times[0], tr.times[-1], 20 * (len(tr.times) - 1) + 1))[:, 0]
    near = np.linalg.norm(p0 - [-5.41, 0.0], axis=1) < 0.45
    t_sep = (np.nonzero(near)[0][-1] + 1) / 20 * DT  # last moment robot 0 is within 0.45 of that start
    gap = np.linalg.norm(tr.positions[:, 0] - tr.positions[:, 1], axis=1)
    after = tr.times - tr.times[0] >= t_sep + DT
    assert gap.min() >= 0.41 - 1e-5 and after.any()
    assert gap[after].min() >= 0.45 - 1e-9


def test_a_robot_that_would_park_in_the_way_waits_aside_until_the_robots_after_it_have_passed(world, planner):
    """Robot 0 goes first and parks right outside the right mouth, on the axis; robot 1 follows it
    through to the far side. Parked at once, robot 0 would shut the mouth for good; instead it
    waits aside in the right room and parks once robot 1 is through."""
    dest0 = np.array([3.25, 0.0])
    res = planner.plan(request(world, [[-4.0, 0.0], [-5.5, 0.0]], [dest0, [6.0, 0.0]], (0, 1)))
    assert res.success and res.info["deferred"] == (0,)
    assert corridor_entry_order(world, res.trajectory) == (0, 1)
    p = res.trajectory.positions
    np.testing.assert_allclose(p[-1], [dest0, [6.0, 0.0]], atol=1e-9)
    # Robot 1 leaves the corridor before robot 0 reaches its destination: at robot 1's exit robot 0
    # stands aside, at least the required distance from the mouth's axis point.
    exit_1 = np.flatnonzero(p[:, 1, 0] > 3.0)[0]
    assert np.linalg.norm(p[exit_1, 0] - dest0) > 0.45
    assert min_gap(res, [0.2, 0.2]) >= 0.05 - 1e-6  # the planner's margin


def _paper_or_turned_world(turned: bool):
    """The paper's corridor, or a passage of the same length turned by 40 degrees."""
    from nodnav.scenario.world import Passage, World, paper_world

    if not turned:
        return paper_world()
    c, s = math.cos(0.7), math.sin(0.7)
    return World(bounds=(-10.0, -10.0, 10.0, 10.0), obstacles=(),
                 passages=(Passage(start=(-3 * c, -3 * s), end=(3 * c, 3 * s), width=1.2),))


@pytest.mark.parametrize("turned", [False, True])
def test_plan_stays_compiled_match_the_world_functions(turned):
    """RobotPlan's corridor and door stays (one compiled pass) against World.on_line and
    in_door_zone with corridor_passage (the plain twin), on random walks through the paper's
    corridor and through a passage turned by 40 degrees; samples exactly on the mouths and on
    the door-zone circles included."""
    from nodnav.planning.fast_state import RobotPlan, plain_stays
    from nodnav.planning.occupancy import Motion

    world = _paper_or_turned_world(turned)
    rng = np.random.default_rng(11)
    ent = np.asarray(world.entrances, dtype=float)
    for _ in range(300):
        n = int(rng.integers(1, 60))
        a, b = rng.uniform(-5, 5, 2), rng.uniform(-5, 5, 2)
        samples = a + np.linspace(0, 1, n)[:, None] * (b - a) + rng.normal(0, 0.3, (n, 2))
        if n > 3:
            samples[1] = ent[0]
            samples[2] = ent[1] + [1.0, 0.0]  # on the right door zone's circle
        plan = RobotPlan(Motion(samples.copy(), samples, np.zeros(n)), world, 1.0)
        want = plain_stays(world, samples, 1.0)
        assert (plan.passage, plan.doors) == ((want[0], want[1]), ((want[2], want[3]), (want[4], want[5])))


@pytest.mark.parametrize("turned", [False, True])
def test_cell_zones_compiled_match_the_world_functions(turned):
    """The cut's zones of its cells (zones_of, one compiled pass) against World.on_line and
    in_door_zone point by point, on random points about the paper's corridor and a passage
    turned by 40 degrees; points on the mouths, on the centreline's edges and on the door-zone
    circles included."""
    from nodnav.planning.fast_state import zones_of
    from nodnav.planning.fused_timing import stay_geometry
    from nodnav.planning.waiting_spots import in_door_zone

    world = _paper_or_turned_world(turned)
    rng = np.random.default_rng(12)
    ent = np.asarray(world.entrances, dtype=float)
    p = world.passage
    for door in (0.5, 1.0):
        g = stay_geometry(world, door)
        for _ in range(100):
            pts = rng.uniform(-5, 5, (int(rng.integers(1, 80)), 2))
            if len(pts) > 4:
                pts[0], pts[1] = ent[0], ent[1] + [door, 0.0]
                pts[2] = p.to_world(np.array(p.s_start), np.array(p.t_centre + 0.5 * p.width))
                pts[3] = p.to_world(np.array(0.5 * (p.s_start + p.s_end)), np.array(p.t_centre))
            line, left, right = zones_of(np.ascontiguousarray(pts), g)
            assert np.array_equal(line, world.on_line(pts))
            assert np.array_equal(left, in_door_zone(world, pts, 0, door))
            assert np.array_equal(right, in_door_zone(world, pts, 1, door))
