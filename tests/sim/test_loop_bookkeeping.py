"""The fused bookkeeping of the closed loop (docs/performance-7-loop.md) against the separate steps
it replaces: the same numbers, bit for bit, and the same trial."""

import copy

import numpy as np

from nodnav.planning.base import JointTrajectory
from nodnav.planning.prioritized import PrioritizedPlanner
from nodnav.scenario.loading import load_scenario
from nodnav.sim.agent import RobotView
from nodnav.sim.agent_queries import joint_requests
from nodnav.sim.execution import ExecutionSettings, PlanExecution, WaitRelease, moved_beyond_plain
from nodnav.sim.methods import gated_horizon, horizon_predictions
from nodnav.sim.plan_cache import PlanCache, state_key
from nodnav.sim.simulator import Simulation


def _crossing_plan(rng: np.random.Generator, n: int) -> JointTrajectory:
    """``n`` robots on straight lines that cross, starting at different times."""
    times = np.linspace(0.0, 8.0, 41)
    starts, ends = rng.uniform(-2, 2, (n, 2)), rng.uniform(-2, 2, (n, 2))
    frac = np.clip((times[:, None] - rng.uniform(0.0, 2.0, n)) / 5.0, 0.0, 1.0)
    return JointTrajectory.from_positions(times, starts[None] + frac[..., None] * (ends - starts)[None])


def _queue() -> JointTrajectory:
    """A follower (the plan's first robot) 1 m behind a leader, both along x at 1 m/s, and a third
    robot far aside."""
    t = 0.1 * np.arange(60)
    zero = 0 * t
    return JointTrajectory.from_positions(t, np.stack([np.stack([t, zero], 1), np.stack([1.0 + t, zero], 1),
                                                       np.stack([t, 3.0 + zero], 1)], axis=1))


def _wandering(rng, plan_positions, n_all, rows, step, lagging=False):
    """Every robot of a trial: those of the plan (``rows``) near their plan's positions at ``step``
    (all but the first at their start when ``lagging``), the others anywhere; a read-only
    ``(N, 2)`` slice of a window, as the simulator's views give it."""
    positions = rng.uniform(-2, 2, (n_all, 2))
    positions[rows] = plan_positions[min(step, len(plan_positions) - 1)] + rng.normal(0.0, 0.05, (len(rows), 2))
    if lagging and step % 10 < 6:
        positions[rows[1:]] = plan_positions[0, 1:] + rng.normal(0.0, 0.02, (len(rows) - 1, 2))
    window = np.concatenate([positions, rng.normal(0.0, 0.5, (n_all, 2))], axis=1)[:, None, :]
    window.flags.writeable = False
    return window[:, -1, :2], window[:, -1, 2:]


def test_observe_held_equals_observe_blockers_and_moved_beyond():
    rng = np.random.default_rng(11)
    settings = ExecutionSettings(gated=True, dt=0.1, horizon=6.0, lag=0.3, margin=0.1, tolerance=0.02)
    rows = np.array([3, 0, 4], dtype=np.int64)  # the plan's robots as scenario indices, itself first
    traj = _queue()
    fused, plain = (PlanExecution(traj, tuple(rows), np.full(3, 0.3), settings) for _ in range(2))
    anchor = rng.uniform(-2, 2, (5, 2))
    held_seen, stuck_seen = 0, 0
    for step in range(60):
        positions, _ = _wandering(rng, traj.positions, 5, rows, step, lagging=True)
        held, moved, stuck = fused.observe_held(positions, rows, anchor, 0.05)
        plain.observe(np.ascontiguousarray(positions[rows]))
        blockers = plain.blockers()
        away = moved_beyond_plain(positions, anchor, rows, 0.05)
        assert np.array_equal(fused.progress, plain.progress) and np.array_equal(fused.gates, plain.gates)
        assert held == len(blockers) and moved == bool(away.any())
        assert np.array_equal(np.flatnonzero(stuck), blockers[~away[blockers]])
        held_seen += held > 0
        stuck_seen += bool(stuck.any())
        if step % 7 == 0:
            anchor = positions.copy()
    assert held_seen > 0 and stuck_seen > 0  # the comparison covered robots held and robots stuck


def test_gated_horizon_equals_read_predictions_and_advance():
    rng = np.random.default_rng(5)
    settings = ExecutionSettings(gated=True, dt=0.1, horizon=6.0, lag=0.3, margin=0.1, tolerance=0.02)
    rows = np.array([1, 2, 0], dtype=np.int64)
    others = np.array([0, 2, 3], dtype=np.int64)  # robot 1's others; robot 3 is not in its plan
    columns = np.array([2, 1, -1], dtype=np.int64)
    offsets = np.concatenate([[0.0], 0.2 * np.arange(1, 16)])
    horizon_times = offsets[1:]
    decel = np.array([1.0, 2.0, 1.5])
    traj = _crossing_plan(rng, 3)
    fused, plain = (PlanExecution(traj, tuple(rows), np.full(3, 0.3), settings) for _ in range(2))
    for step in range(50):
        positions, velocities = _wandering(rng, traj.positions, 4, rows, step, lagging=step > 25)
        for ex in (fused, plain):
            ex.observe(np.ascontiguousarray(positions[rows]))
        planned, predictions = gated_horizon(traj.times, traj.positions, fused.t0, fused.clocks, offsets,
                                             fused.sample_times, fused.gates, settings.dt, columns, positions,
                                             velocities, others, decel, horizon_times)
        want = plain.read_plain(offsets)
        want_predictions = horizon_predictions(want, columns, positions[others], velocities[others], decel,
                                               horizon_times)
        plain.advance()
        assert planned.tobytes() == want.tobytes()
        assert predictions.tobytes() == want_predictions.tobytes()
        assert fused.clocks.tobytes() == plain.clocks.tobytes()


def test_wait_release_observe_equals_observe_then_check():
    """The fused wait check releases the same robots at the same steps as the separate one."""
    scenario = load_scenario("4r-case2").with_overrides(**{"execution.wait_patience": 0.5})
    settings = ExecutionSettings(gated=True, dt=0.1, horizon=6.0, lag=0.3, margin=0.1, tolerance=0.02)
    rows = np.array([0, 1, 2], dtype=np.int64)
    traj = _queue()
    fused, plain = (PlanExecution(traj, tuple(rows), np.full(3, 0.3), settings) for _ in range(2))
    fused_waits, plain_waits = WaitRelease(scenario), WaitRelease(scenario)
    still = traj.positions[0]  # nobody moves: the robot is held, then released
    released = 0
    for step in range(40):
        t = 0.1 * step
        positions = np.vstack([still, [[5.0, 5.0]]])
        view = RobotView(t=t, window_times=np.array([t]), entered=(),
                         window_states=np.concatenate([positions, np.zeros((4, 2))], axis=1)[:, None, :])
        fused_waits.observe(0, t, fused, rows, view.positions)
        plain.observe(view.positions[rows])
        plain_waits.check(0, t, plain, rows, view)
        assert np.array_equal(fused.dependencies, plain.dependencies)
        assert np.array_equal(fused.gates, plain.gates)
        assert fused_waits.released_until[0] == plain_waits.released_until[0]
        released += np.isfinite(plain_waits.released_until[0])
    assert released > 0


def test_plan_order_builds_only_the_requests_not_yet_answered():
    scenario = load_scenario("3r-case4")
    cache = PlanCache(PrioritizedPlanner(scenario.world))
    states = np.concatenate([scenario.origins, np.zeros((3, 2))], axis=1)[:, None, :]
    view = RobotView(t=0.0, window_times=np.zeros(1), window_states=states, entered=())
    orders = [(0, 1, 2), (2, 1, 0), (1, 0, 2)]
    requests = joint_requests(scenario, view, (0, 1, 2), orders)
    alone = PlanCache(PrioritizedPlanner(scenario.world))
    want = [alone.plan(r) for r in requests]
    template = requests[0]
    got = [cache.plan_order(template, order, state_key(template)) for order in orders]
    assert [g.order for g in got] == [w.order for w in want]
    assert all(np.array_equal(g.trajectory.positions, w.trajectory.positions) for g, w in zip(got, want))
    assert (cache.misses, cache.hits) == (3, 0)
    again = cache.plan_order(template, orders[1], state_key(template))
    assert again is got[1] and (cache.misses, cache.hits) == (3, 1)


def test_shared_answers_are_computed_once_per_round_and_read_only():
    cache = PlanCache(PrioritizedPlanner(load_scenario("2r-case1").world))
    calls = []

    def compute():
        calls.append(1)
        return np.arange(3.0)

    first = cache.shared(("k", 1), compute)
    assert cache.shared(("k", 1), compute) is first and len(calls) == 1
    assert not first.flags.writeable
    cache.clear()
    cache.shared(("k", 1), compute)
    assert len(calls) == 2


def _history(sim: Simulation, steps: int) -> list[np.ndarray]:
    for _ in range(steps):
        if sim.step():
            break
    h = sim.history
    return [np.array(h.positions), np.array(h.velocities), np.array(h.opinions), np.array(h.ranks),
            np.array([len(sim.entered_true)]), np.array([len(s) for s in sim.entered_seen])]


def test_exact_sensing_shared_by_every_robot_gives_the_same_trial():
    """One observation and one window for all (exact sensing) against each robot observing alone."""
    scenario = load_scenario("3r-case4")
    shared = Simulation(scenario, seed=4)
    assert shared._exact and all(w is shared._windows[0] for w in shared._windows)
    assert all(r is shared.observed[0] for r in shared.observed)  # one record, shared
    alone = Simulation(scenario, seed=4)
    alone._exact = False  # the general path: every robot observes, keeps its window, every record updated
    alone._windows = [copy.deepcopy(w) for w in alone._windows]
    alone.observed = [list(r) for r in alone.observed]  # each robot its own record
    for a, b in zip(_history(shared, 120), _history(alone, 120)):
        assert a.tobytes() == b.tobytes()


def test_trajectory_states_equal_positions_and_velocities_at():
    from nodnav.sim.plan_cache import trajectory_states, trajectory_states_plain

    rng = np.random.default_rng(9)
    for n in (1, 3):
        traj = _crossing_plan(rng, n)
        # Inside, on the samples, before the first and from the last sample on.
        query = np.concatenate([rng.uniform(-1.0, 9.0, 30), traj.times[[0, 5, -2, -1]], [-0.5, 8.0, 12.0]])
        got = trajectory_states(traj.times, traj.positions, traj.velocities, query)
        assert got.tobytes() == np.ascontiguousarray(trajectory_states_plain(traj, query)).tobytes()
        assert np.all(got[:, query >= traj.times[-1], 2:] == 0.0)
    single = JointTrajectory.from_positions(np.array([0.0]), np.zeros((1, 2, 2)))
    got = trajectory_states(single.times, single.positions, single.velocities, np.array([-1.0, 0.0, 3.0]))
    assert got.tobytes() == np.ascontiguousarray(trajectory_states_plain(single, np.array([-1.0, 0.0, 3.0]))).tobytes()


def test_a_request_in_another_order_is_the_template_with_that_order():
    from dataclasses import fields, replace

    from nodnav.sim.plan_cache import _in_order

    scenario = load_scenario("3r-case4")
    states = np.concatenate([scenario.origins, np.zeros((3, 2))], axis=1)[:, None, :]
    view = RobotView(t=1.5, window_times=np.zeros(1), window_states=states, entered=(2,))
    template = joint_requests(scenario, view, (0, 1, 2), [(2, 0, 1)])[0]
    got, want = _in_order(template, (2, 1, 0)), replace(template, order=(2, 1, 0))
    assert type(got) is type(want) and got.order == (2, 1, 0) and template.order == (2, 0, 1)
    assert all(getattr(got, f.name) is getattr(want, f.name) for f in fields(want) if f.name != "order")
