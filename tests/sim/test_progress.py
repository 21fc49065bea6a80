"""The deadlock rule's progress along the followed plan (issue 19 item 3), against hand-computed
arc lengths, and on a scenario whose robots must back out for longer than the deadlock time."""

from pathlib import Path

import numpy as np

from nodnav.scenario.loading import load_scenario
from nodnav.sim.progress import PlanProgress
from nodnav.sim.simulator import run_trial

REACH = np.array([0.26])


def out_and_back() -> np.ndarray:
    """A plan that backs out 2 m to the left, waits, and then drives 5 m to the right, sampled
    every 0.08 m (0.8 m/s at 0.1 s), with 10 waiting samples at the turn."""
    back = np.stack([-np.arange(0, 26) * 0.08, np.zeros(26)], axis=1)
    wait = np.repeat(back[-1:], 10, axis=0)
    on = np.stack([back[-1, 0] + np.arange(1, 64) * 0.08, np.zeros(63)], axis=1)
    return np.vstack([back, wait, on])


def test_backing_out_along_the_plan_is_progress():
    route = out_and_back()
    progress = PlanProgress(1, 0.2)
    progress.follow(0, route)
    credited = [bool(progress.advanced(p[None], REACH)[0]) for p in route[::1]]
    # 2 m back, then 5.04 m on: 7.04 m in all; the cursor lands on the 0.08 m samples, so a
    # credit comes every third sample (at 0.24 m, 0.48 m, ...): floor(7.04 / 0.24) = 29.
    assert sum(credited) == 29
    assert progress.cursor[0] == 25 + 63  # the last of the 89 distinct samples (waits removed)


def test_standing_or_leaving_the_plan_is_no_progress():
    route = out_and_back()
    progress = PlanProgress(2, 0.2)
    progress.follow(0, route)
    progress.follow(1, route)
    for _ in range(50):  # robot 0 stands where it started; robot 1 goes the other way (off the plan)
        moved = progress.advanced(np.array([[0.0, 0.0], [0.0, 0.0]]), np.array([0.26, 0.26]))
        assert not moved.any()
    for x in np.arange(0.1, 2.0, 0.08):
        assert not progress.advanced(np.array([[0.0, 0.0], [x, 0.0]]), np.array([0.26, 0.26]))[1]


def test_a_failed_plan_makes_no_progress():
    progress = PlanProgress(1, 0.2)
    progress.follow(0, None)
    assert not progress.advanced(np.array([[-1.0, 0.0]]), REACH)[0]


def test_teams_backing_out_are_not_a_deadlock():
    # Two teams of two inside a 6 m passage: one team backs out for more than 2 s, moving away
    # from its goals, while the other cannot yet come closer to its own. Judged by the straight
    # distance to go through the mouths, that is "no progress for 2 s"; along the plans, it is not.
    here = Path(__file__).parent / "regression" / "teams-head-on-inside.yaml"
    short = {"sim.deadlock_time": 2.0}
    plan = load_scenario(here).with_overrides(**short)
    straight = load_scenario(here).with_overrides(**short, **{"sim.progress": "straight"})
    assert [run_trial(straight, seed=s).outcome for s in (0, 1)] == ["deadlock", "deadlock"]
    assert [run_trial(plan, seed=s).outcome for s in (0, 1)] == ["success", "success"]


def test_sides_changed_equals_side_of_along_and_reports_changes():
    from nodnav.scenario.world import Passage
    from nodnav.sim.progress import sides_changed

    rng = np.random.default_rng(2)
    for passage in (Passage(start=(-1.0, 0.5), end=(1.5, 0.5), width=0.8),
                    Passage(start=(-1.0, -0.7), end=(1.2, 0.9), width=0.6)):  # the paper's axis, and a tilted one
        sides = np.full(6, 99, dtype=np.int64)
        for _ in range(20):
            positions = rng.uniform(-3.0, 3.0, (6, 2))
            positions[0] = passage.start  # on a mouth
            want = passage.side_of_along(passage.along(positions))
            before = sides.copy()
            changed = sides_changed(positions, passage.along_x, passage.axis[0], passage.axis[1], passage.s_start,
                                    passage.s_end, sides)
            assert np.array_equal(sides, want) and changed == (not np.array_equal(before, want))
            assert not sides_changed(positions, passage.along_x, passage.axis[0], passage.axis[1], passage.s_start,
                                     passage.s_end, sides)


def _judged_plain(positions, destinations, tol, t, arrival, to_go, best, eps, progress, reach):
    """The simulator's arrival and progress judgement in NumPy, as it was before judge_progress."""
    gap = positions - destinations
    arrived = np.linalg.norm(gap, axis=1) <= tol
    arrival = np.where(np.isnan(arrival) & arrived, t, arrival)
    if arrived.all():
        return True, False, arrival, best
    improved = to_go < best - eps
    best = np.where(improved, to_go, best)
    if progress is not None:
        improved |= progress.advanced_plain(positions, reach)
    return False, bool(improved.any()), arrival, best


def test_judge_progress_equals_the_numpy_judgement():
    from nodnav.sim.progress import judge_progress

    rng = np.random.default_rng(8)
    n, tol, eps = 4, 0.1, 0.05
    destinations = rng.uniform(-3, 3, (n, 2))
    routes = [np.linspace(destinations[k] + rng.uniform(-4, 4, 2), destinations[k], 40) for k in range(n)]
    reach = 2.0 * np.array([0.5, 0.6, 0.7, 0.8]) * 0.1 + 0.1
    for with_plans in (True, False):
        fused, plain = (PlanProgress(n, eps) if with_plans else None for _ in range(2))
        for p in (fused, plain):
            if p is not None:
                for k in range(n - 1):  # the last robot follows no plan
                    p.follow(k, routes[k])
        arrival, best = np.full(n, np.nan), np.full(n, 50.0)
        want_arrival, want_best = arrival.copy(), best.copy()
        seen = {"arrived": 0, "improved": 0, "finished": 0}
        for step in range(45):
            t = 0.1 * step
            noise = rng.normal(0, 0.02, (n, 2)) * (1 - min(step / 40.0, 1.0))
            positions = np.array([routes[k][min(step, 39)] for k in range(n)]) + noise
            if step >= 42:
                positions = destinations.copy()
            to_go = np.linalg.norm(positions - destinations, axis=1) + rng.uniform(0, 0.1, n)
            want = _judged_plain(positions, destinations, tol, t, want_arrival, to_go, want_best, eps, plain, reach)
            flat = fused.end_to_end() if fused is not None else (np.zeros((0, 2)), np.zeros(0),
                                                               np.full((n, 2), -1, dtype=np.int64))
            cursor, credited = (fused.cursor, fused.credited) if fused is not None else (np.zeros(n, dtype=int),
                                                                                         np.zeros(n))
            got = judge_progress(positions, destinations, tol, t, arrival, to_go, best, eps, fused is not None, *flat,
                                 reach, eps, cursor, credited)
            assert (bool(got[0]), bool(got[1])) == want[:2]
            want_arrival, want_best = want[2], want[3]
            assert arrival.tobytes() == want_arrival.tobytes() and best.tobytes() == want_best.tobytes()
            if fused is not None:
                assert np.array_equal(fused.cursor, plain.cursor)
                assert fused.credited.tobytes() == plain.credited.tobytes()
            seen["arrived"] += int(np.isfinite(arrival).any())
            seen["improved"] += bool(got[1])
            seen["finished"] += bool(got[0])
            if got[0]:
                break
        assert all(v > 0 for v in seen.values())
