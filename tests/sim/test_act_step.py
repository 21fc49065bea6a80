"""``gated_step`` (one compiled call per robot and control step of a gated execution) against the
separate steps it replaces, in their order: ``WaitRelease.observe``, ``gated_horizon`` and
``ReactionMargins.radii``, bit for bit, through waits, releases and surprises."""

import numpy as np

from nodnav.planning.base import JointTrajectory
from nodnav.scenario.loading import load_scenario
from nodnav.sim.agent import RobotView
from nodnav.sim.execution import ExecutionSettings, PlanExecution, ReactionMargins, WaitRelease
from nodnav.sim.horizon import gated_horizon, gated_step


def _queue() -> JointTrajectory:
    """Robot 0 (the plan's first) 1 m behind robot 1, both along x at 1 m/s, robot 2 aside."""
    t = 0.1 * np.arange(60)
    zero = 0 * t
    return JointTrajectory.from_positions(t, np.stack([np.stack([t, zero], 1), np.stack([1.0 + t, zero], 1),
                                                       np.stack([t, 3.0 + zero], 1)], axis=1))


def _positions(traj: JointTrajectory, step: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Every robot's observed state, read-only slices of a window as the simulator's views give
    them: nobody moves for the first 25 steps (robot 0 is held, then released), then robots 1
    and 2 move along the plan with noise and robot 3 (not in the plan) comes and goes."""
    k = 0 if step < 25 else step - 25
    positions = np.vstack([traj.positions[min(k, 59)], [[5.0 - 0.1 * step, 0.5]]])
    positions[0] = traj.positions[0, 0]
    if step >= 25:
        positions[1:] += rng.normal(0.0, 0.03, (3, 2))
    velocities = rng.normal(0.0, 0.4, (4, 2)) if step >= 25 else np.zeros((4, 2))
    window = np.concatenate([positions, velocities], axis=1)[:, None, :]
    window.flags.writeable = False
    return window[:, -1, :2], window[:, -1, 2:]


def test_gated_step_equals_the_separate_steps():
    scenario = load_scenario("4r-case2").with_overrides(**{"execution.wait_patience": 0.5,
                                                           "execution.reaction_margin": "surprised",
                                                           "execution.surprise": 0.02})
    settings = ExecutionSettings(gated=True, dt=0.1, horizon=6.0, lag=0.3, margin=0.1, tolerance=0.02)
    i, rows = 0, np.array([0, 1, 2], dtype=np.int64)
    others, columns = np.array([1, 2, 3], dtype=np.int64), np.array([1, 2, -1], dtype=np.int64)
    offsets = np.concatenate([[0.0], 0.1 * np.arange(1, 9)])
    decel = np.array([1.0, 2.0, 1.5])
    base = np.tile([0.3, 0.35, 0.4], 3)
    traj = _queue()
    fused, plain = (PlanExecution(traj, tuple(rows), np.full(3, 0.3), settings) for _ in range(2))
    fused_waits, plain_waits = WaitRelease(scenario), WaitRelease(scenario)
    fused_margins, plain_margins = ReactionMargins(scenario), ReactionMargins(scenario)
    rng = np.random.default_rng(3)
    released = surprised = 0
    for step in range(70):
        t = 0.1 * step
        positions, velocities = _positions(traj, step, rng)
        conflicted = step % 9 == 4
        fused_margins.conflicted[i] = plain_margins.conflicted[i] = conflicted
        seen = fused_margins.seen(i, positions, velocities)
        w = fused_waits
        reference, predictions, radii = gated_step(
            positions, velocities, i, t, traj.times, traj.positions, fused.t0, fused.clocks, fused.samples,
            fused.dependencies, fused.progress, fused.gates, fused.sample_times, rows, settings.tolerance,
            w.patience, w.reach, w.anchors, w.anchored, w.since, w.released_until, offsets, settings.dt, columns,
            others, decel, offsets[1:], *seen, *fused_margins.constants[i], conflicted, base)

        plain_waits.observe(i, t, plain, rows, positions)
        planned, want_predictions = gated_horizon(traj.times, traj.positions, plain.t0, plain.clocks, offsets,
                                                  plain.sample_times, plain.gates, settings.dt, columns, positions,
                                                  velocities, others, decel, offsets[1:])
        view = RobotView(t=t, window_times=np.array([t]), entered=(),
                         window_states=np.concatenate([positions, velocities], axis=1)[:, None, :])
        want_radii = plain_margins.radii(i, view, base)

        assert reference.tobytes() == np.ascontiguousarray(planned[1:, 0]).tobytes()
        assert predictions.tobytes() == want_predictions.tobytes()
        assert radii.tobytes() == want_radii.tobytes()
        for a, b in [(fused.dependencies, plain.dependencies), (fused.progress, plain.progress),
                     (fused.gates, plain.gates), (fused.clocks, plain.clocks), (w.since, plain_waits.since),
                     (w.released_until, plain_waits.released_until), (w.anchors, plain_waits.anchors),
                     (fused_margins._surprised, plain_margins._surprised)]:
            assert a.tobytes() == b.tobytes()
        released += bool(np.isfinite(w.released_until[i]))
        surprised += bool(fused_margins._surprised[i].any())
    assert released > 0 and surprised > 0  # the comparison went through a release and surprises
    assert (fused.dependencies[:, 0, 1:] == -1).all()  # the release dropped robot 0's precedences


def test_without_patience_nothing_is_anchored_or_released():
    """Without patience (``wait_patience: 0``) nothing is anchored or released."""
    scenario = load_scenario("4r-case2").with_overrides(**{"execution.wait_patience": 0.0})
    settings = ExecutionSettings(gated=True, dt=0.1, horizon=6.0, lag=0.3, margin=0.1, tolerance=0.02)
    rows = np.array([0, 1, 2], dtype=np.int64)
    traj = _queue()
    ex = PlanExecution(traj, tuple(rows), np.full(3, 0.3), settings)
    deps = ex.dependencies.copy()
    w, margins = WaitRelease(scenario), ReactionMargins(scenario)
    offsets = np.concatenate([[0.0], 0.1 * np.arange(1, 9)])
    for step in range(30):
        positions, velocities = _positions(traj, step, np.random.default_rng(step))
        gated_step(positions, velocities, 0, 0.1 * step, traj.times, traj.positions, ex.t0, ex.clocks, ex.samples,
                   ex.dependencies, ex.progress, ex.gates, ex.sample_times, rows, settings.tolerance, w.patience,
                   w.reach, w.anchors, w.anchored, w.since, w.released_until, offsets, settings.dt,
                   np.array([1, 2, -1]), np.array([1, 2, 3]), np.ones(3), offsets[1:],
                   *margins.seen(0, positions, velocities), *margins.constants[0], False, np.full(9, 0.3))
    assert not w.anchored.any() and np.array_equal(ex.dependencies, deps) and not np.isfinite(w.released_until).any()



def test_a_gated_execution_holds_its_plan_resampled_and_its_precedences():
    """PlanExecution's compiled build against ``positions_at`` and ``plan_dependencies`` of the
    conflict distances, on crossing plans of 1 to 5 robots, strided and not."""
    from nodnav.planning.dependencies import plan_dependencies

    rng = np.random.default_rng(12)
    settings = ExecutionSettings(gated=True, dt=0.1, horizon=1.8, lag=0.3, margin=0.1, tolerance=0.05)
    for n in (1, 2, 3, 5):
        times = np.linspace(2.0, 10.0, 81)
        starts, ends = rng.uniform(-2, 2, (n, 2)), rng.uniform(-2, 2, (n, 2))
        frac = np.clip((times[:, None] - 2.0 - rng.uniform(0.0, 1.0, n)) / 3.0, 0.0, 1.0)
        full = starts[None] + frac[..., None] * (ends - starts)[None]
        for traj in (JointTrajectory.from_positions(times, full),
                     JointTrajectory.from_positions(times, full).subset(list(range(n))[::-1])):
            radii = rng.uniform(0.2, 0.4, n)
            ex = PlanExecution(traj, tuple(range(n)), radii, settings)
            sample_times = 0.1 * np.arange(int(np.ceil(1.8 / 0.1)) + 1)
            want = traj.positions_at(traj.times[0] + sample_times)
            assert ex.sample_times.tobytes() == sample_times.tobytes()
            assert ex.samples.tobytes() == want.tobytes()
            conflict = radii[:, None] + radii[None, :] + 0.1
            assert np.array_equal(ex.dependencies, plan_dependencies(want, conflict, 3))
            assert np.array_equal(ex.gates, np.full(n, len(sample_times) - 1))
