"""Precedences of a joint plan, progress along it and the gate they give: hand-computed cases."""

import numpy as np

from nodnav.planning.dependencies import gate_sample, observed_progress, plan_dependencies


def _line(start: float, speed: float, steps: int, dt: float = 0.1, y: float = 0.0) -> np.ndarray:
    x = start + speed * dt * np.arange(steps)
    return np.stack([x, np.full(steps, y)], axis=1)


def test_a_follower_depends_on_the_leader_having_moved_on_and_not_the_other_way():
    # Leader 1 m ahead, both at 1 m/s along x, conflict distance 0.45 m. The follower at sample k
    # is at 0.1 k, the leader was at 1 + 0.1 k': closer than 0.45 m exactly when k' <= k - 6 (0.4 m; k - 5 gives
    # 0.5 m), and closer than the follower itself was then (1 m away): the latest is k' = k - 6.
    steps = 30
    positions = np.stack([_line(1.0, 1.0, steps), _line(0.0, 1.0, steps)], axis=1)
    deps = plan_dependencies(positions, np.full((2, 2), 0.45), lag=1)
    k = np.arange(steps)
    assert np.array_equal(deps[:, 1, 0], np.where(k >= 6, k - 6, -1))
    assert np.all(deps[:, 0, 1] == -1)  # the leader moves away from where the follower was


def test_robots_that_start_too_close_and_move_apart_do_not_wait_for_each_other():
    steps = 20
    positions = np.stack([_line(0.0, -1.0, steps), _line(0.3, 1.0, steps)], axis=1)
    deps = plan_dependencies(positions, np.full((2, 2), 0.5), lag=1)
    assert np.all(deps == -1)


def test_a_robot_waiting_in_place_creates_no_precedence_on_itself_until_someone_comes_close():
    # Robot 0 waits at the origin for 10 samples, then leaves upwards at 1 m/s; robot 1 comes
    # along x from -2 at 1 m/s and reaches the origin at sample 20.
    steps = 30
    wait = np.zeros((steps, 2))
    wait[10:, 1] = 0.1 * np.arange(1, steps - 9)
    positions = np.stack([wait, _line(-2.0, 1.0, steps)], axis=1)
    lag = 3
    deps = plan_dependencies(positions, np.full((2, 2), 0.5), lag=lag)
    # The definition, brute force: the latest earlier sample (lag back at least) at which robot
    # 0 stood within 0.5 m of robot 1's place at k, robot 1 having been farther from it then (the
    # first sample always admissible);
    # robot 1 comes within 0.5 m of the origin at k = 16 (0.4 m), while robot 0 still waited.
    hand = np.full(steps, -1)
    for k in range(steps):
        best = -1
        for kk in range(0, (max(k - lag, 0) if k >= 1 else -1) + 1):
            d = np.hypot(*(positions[k, 1] - positions[kk, 0]))
            before = np.hypot(*(positions[kk, 1] - positions[kk, 0]))
            if d < 0.5 and d < before - 1e-6:
                best = kk
        hand[k] = max(best, hand[k - 1] if k else -1)
    assert np.array_equal(deps[:, 1, 0], hand)
    assert deps[15, 1, 0] == -1 and deps[16, 1, 0] >= 9


def test_progress_is_the_earliest_of_the_nearest_samples_and_never_goes_back():
    path = np.zeros((10, 2))
    path[5:, 0] = 0.1 * np.arange(1, 6)  # waits for 5 samples, then moves along x
    assert observed_progress(path, np.array([0.0, 0.01]), 0, 0.05) == 0  # still waiting
    assert observed_progress(path, np.array([0.2, 0.0]), 0, 0.05) == 6
    assert observed_progress(path, np.array([0.0, 0.0]), 6, 0.05) == 6  # seen back: no regress


def test_the_gate_is_the_last_sample_whose_precedences_are_met():
    deps = np.full((8, 2, 2), -1)
    deps[3:, 1, 0] = [0, 0, 2, 2, 4]  # robot 1 needs robot 0 past 0 from sample 3, past 2 from 5
    assert gate_sample(deps, 1, np.array([0, 0])) == 2
    assert gate_sample(deps, 1, np.array([1, 0])) == 4
    assert gate_sample(deps, 1, np.array([3, 0])) == 6
    assert gate_sample(deps, 1, np.array([5, 0])) == 7
    assert gate_sample(deps, 0, np.array([0, 0])) == 7


def test_nobody_moves_into_the_room_of_a_robot_that_has_not_moved_yet_however_soon():
    # Robot 1 stands 0.42 m behind and beside robot 0 and, in the plan, closes in at once while
    # robot 0 drives off: from its very first step it depends on robot 0 having left its start,
    # although that is less than the lag back.
    steps = 10
    lead = _line(0.0, 1.0, steps, y=-0.15)
    follow = _line(-0.26, 1.0, steps, y=0.18)
    follow[:, 1] = np.linspace(0.18, 0.0, steps)
    deps = plan_dependencies(np.stack([lead, follow], axis=1), np.full((2, 2), 0.45), lag=3)
    assert deps[1, 1, 0] == 0
