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
