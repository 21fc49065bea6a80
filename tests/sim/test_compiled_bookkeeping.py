"""The compiled loops of the per-step bookkeeping against the plain NumPy code they replace."""


import numpy as np
import pytest

from nodnav.planning.base import JointTrajectory
from nodnav.planning.dependencies import gate_sample, observed_progress, plan_dependencies
from nodnav.scenario.loading import load_scenario
from nodnav.sim.agent import RobotView
from nodnav.sim.execution import ExecutionSettings, PlanExecution, ReactionMargins


def _view(t, positions, velocities):
    states = np.concatenate([positions, velocities], axis=1)[:, None, :]
    return RobotView(t=t, window_times=np.array([t]), window_states=states, entered=())


@pytest.mark.parametrize("mode", ["always", "moving", "surprised", "conflict", "off"])
def test_careful_radii_equal_the_plain_computation_bit_for_bit(mode):
    base = load_scenario("4r-case2")
    scenario = base.with_overrides(**{"execution.reaction_margin": mode})
    compiled_margins, plain = ReactionMargins(scenario), ReactionMargins(scenario)
    rng = np.random.default_rng(7)
    n = scenario.n_robots
    positions = scenario.origins.copy()
    velocities = np.zeros_like(positions)
    widened = 0
    for step in range(60):
        # Random walks with sudden swerves, so that surprises, memory and gaps all occur.
        velocities = velocities + rng.normal(0.0, 0.3, size=velocities.shape) * (rng.random((n, 1)) < 0.5)
        positions = positions + 0.1 * velocities
        conflicted = rng.random(n) < 0.2
        compiled_margins.conflicted[:] = conflicted
        plain.conflicted[:] = conflicted
        for i in range(n):
            radii = np.tile(np.delete(scenario.radii, i), 3)
            view = _view(0.1 * step, positions, velocities)
            got = compiled_margins.radii(i, view, radii)
            want = plain.radii_plain(i, view, radii)
            assert got.tobytes() == want.tobytes()
            widened += not np.array_equal(got, radii)
    assert np.array_equal(compiled_margins._surprised, plain._surprised)
    if mode != "off":
        assert widened > 0


def test_observe_equals_observed_progress_and_gate_sample():
    rng = np.random.default_rng(3)
    times = np.linspace(0.0, 8.0, 41)
    # Three robots on crossing straight lines, the second one waiting at first.
    starts, ends = rng.uniform(-2, 2, (3, 2)), rng.uniform(-2, 2, (3, 2))
    frac = np.clip((times[:, None] - np.array([0.0, 2.0, 1.0])) / 5.0, 0.0, 1.0)
    positions = starts[None] + frac[..., None] * (ends - starts)[None]
    traj = JointTrajectory.from_positions(times, positions)
    settings = ExecutionSettings(gated=True, dt=0.1, horizon=6.0, lag=0.3, margin=0.1, tolerance=0.02)
    radii = np.full(3, 0.3)
    execution = PlanExecution(traj, (0, 1, 2), radii, settings)
    deps = plan_dependencies(execution.samples, radii[:, None] + radii[None, :] + settings.margin, 3)
    progress = np.zeros(3, dtype=np.int64)
    for k in range(0, 60, 3):
        seen = traj.positions_at(0.1 * k)[0] + rng.normal(0.0, 0.05, (3, 2))
        execution.observe(seen)
        for c in range(3):
            progress[c] = observed_progress(execution.samples[:, c], seen[c], progress[c], settings.tolerance)
        gates = [gate_sample(deps, c, progress) for c in range(3)]
        assert execution.progress.tolist() == progress.tolist()
        assert execution.gates.tolist() == gates



@pytest.mark.parametrize("gated", [True, False])
def test_read_equals_the_plain_computation_bit_for_bit(gated):
    rng = np.random.default_rng(5)
    times = 2.0 + np.linspace(0.0, 8.0, 41)  # a plan that starts at t = 2 s
    starts, ends = rng.uniform(-2, 2, (3, 2)), rng.uniform(-2, 2, (3, 2))
    frac = np.clip((times[:, None] - 2.0 - np.array([0.0, 2.0, 1.0])) / 5.0, 0.0, 1.0)
    traj = JointTrajectory.from_positions(times, starts[None] + frac[..., None] * (ends - starts)[None])
    settings = ExecutionSettings(gated=gated, dt=0.1, horizon=6.0, lag=0.3, margin=0.1, tolerance=0.02)
    execution = PlanExecution(traj, (0, 1, 2), np.full(3, 0.3), settings)
    offsets = 0.1 * np.arange(0, 25)
    for k in range(80):  # past the plan's end: positions held
        seen = traj.positions_at(2.0 + 0.1 * k)[0] + rng.normal(0.0, 0.05, (3, 2))
        execution.observe(seen)
        got = execution.read(offsets)
        assert got.shape == (len(offsets), 3, 2)
        assert got.tobytes() == execution.read_plain(offsets).tobytes()
        execution.advance()
    one = PlanExecution(JointTrajectory.from_positions(times[:1], starts[None]), (0, 1, 2), np.full(3, 0.3), settings)
    assert one.read(offsets).tobytes() == one.read_plain(offsets).tobytes()

def _advanced_plain(progress, positions, reach):
    """PlanProgress.advanced as it was written in NumPy before it was compiled."""
    from nodnav.sim.progress import OFF_ROUTE

    out = np.zeros(len(positions), dtype=bool)
    for k, points in enumerate(progress.routes):
        if points is None:
            continue
        arc, c = progress.arcs[k], int(progress.cursor[k])
        end = int(np.searchsorted(arc, arc[c] + reach[k], side="right"))
        window = points[c:max(end, c + 1)]
        gap = np.linalg.norm(window - positions[k], axis=1)
        best = int(np.argmin(gap))
        if gap[best] <= OFF_ROUTE:
            progress.cursor[k] = c + best
        if arc[progress.cursor[k]] >= progress.credited[k] + progress.epsilon:
            progress.credited[k] = arc[progress.cursor[k]]
            out[k] = True
    return out


def test_plan_progress_equals_the_plain_computation():
    from nodnav.sim.progress import PlanProgress

    rng = np.random.default_rng(5)
    compiled_progress, plain = PlanProgress(3, 0.05), PlanProgress(3, 0.05)
    # A route out and back the same way, a zigzag, and a robot without a plan.
    out_back = np.concatenate([np.linspace([0, 0], [2, 0], 21), np.linspace([2, 0], [0, 0], 21)[1:]])
    zigzag = np.cumsum(rng.normal(0.0, 0.1, (40, 2)), axis=0)
    for p in (compiled_progress, plain):
        p.follow(0, out_back)
        p.follow(1, zigzag)
        p.follow(2, None)
    credited = 0
    for step in range(80):
        t = step / 80
        positions = np.array([out_back[int(t * (len(out_back) - 1))], zigzag[int(t * 39)], [0.0, 0.0]])
        positions = positions + rng.normal(0.0, 0.02, positions.shape)
        reach = np.full(3, 0.3)
        got = compiled_progress.advanced(positions, reach)
        want = _advanced_plain(plain, positions, reach)
        assert got.tolist() == want.tolist()
        assert compiled_progress.cursor.tolist() == plain.cursor.tolist()
        credited += got.sum()
    assert compiled_progress.credited.tobytes() == plain.credited.tobytes()
    assert credited > 10


def test_moved_beyond_equals_the_plain_computation_and_a_hand_count():
    from nodnav.sim.execution import moved_beyond, moved_beyond_plain

    # By hand: (3, 4) from the anchor is 5 m away, beyond 4.9 m but not beyond 5 m; robot 2 has not moved.
    anchor = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, -2.0]])
    positions = np.array([[3.0, 4.0], [1.0, 1.0 + 4.95], [2.0, -2.0]])
    rows = np.array([0, 1, 2], dtype=np.int64)
    assert moved_beyond(positions, anchor, rows, 4.9).tolist() == [True, True, False]
    assert moved_beyond(positions, anchor, rows, 5.0).tolist() == [False, False, False]
    # Random walks, a subset of rows in any order, thresholds right at the distances: the same
    # verdict as norm's, bit for bit (the same square root of the same sum).
    rng = np.random.default_rng(3)
    for _ in range(200):
        anchor = rng.normal(0.0, 5.0, size=(8, 2))
        positions = anchor + rng.normal(0.0, 0.05, size=(8, 2)) * (rng.random((8, 1)) < 0.7)
        rows = rng.permutation(8)[:rng.integers(1, 9)].astype(np.int64)
        distances = np.linalg.norm(positions[rows] - anchor[rows], axis=1)
        for reach in (0.02, float(distances[0]), float(np.nextafter(distances[0], 0.0))):
            assert np.array_equal(moved_beyond(positions, anchor, rows, reach),
                                  moved_beyond_plain(positions, anchor, rows, reach))
