"""execution.skip_at_rest: a robot at rest, told to stay and clear of everyone, stays put without its MPC."""

import numpy as np

from nodnav.scenario.loading import load_scenario
from nodnav.sim.methods import at_rest_and_clear
from nodnav.sim.simulator import run_trial


def test_at_rest_and_clear_by_hand():
    p = np.array([1.0, 2.0])
    still = np.tile(p, (5, 1))
    far = np.tile([[4.0, 2.0]], (1, 5, 1))  # 3 m away: 3 > 0.25 + 0.2 + 0.5
    radii = np.array([0.2])
    assert at_rest_and_clear(p, np.zeros(2), still, far, radii, 0.25, 0.5, 1e-3)
    # Moving, told to move, or someone predicted near: the MPC runs.
    assert not at_rest_and_clear(p, np.array([2e-3, 0.0]), still, far, radii, 0.25, 0.5, 1e-3)
    assert not at_rest_and_clear(p, np.zeros(2), still + [0.0, 2e-3], far, radii, 0.25, 0.5, 1e-3)
    near = far.copy()
    near[0, 3] = [1.9, 2.0]  # 0.9 m away at one sample: not more than 0.95
    assert not at_rest_and_clear(p, np.zeros(2), still, near, radii, 0.25, 0.5, 1e-3)
    assert at_rest_and_clear(p, np.zeros(2), still, near, radii, 0.25, 0.4, 1e-3)
    assert at_rest_and_clear(p, np.zeros(2), still, np.zeros((0, 5, 2)), np.zeros(0), 0.25, 0.5, 1e-3)


def test_robots_at_rest_stay_exactly_put_and_the_trial_succeeds():
    scenario = load_scenario("4r-case2").with_overrides(**{"execution.skip_at_rest": True})
    result = run_trial(scenario, seed=1)
    assert result.outcome == "success"
    h = result.history
    pos, vel = np.asarray(h.positions), np.asarray(h.velocities)
    # Skipped steps start and end at zero velocity exactly, where the robot stood. (An MPC step at
    # rest can also end at zero velocity exactly, its position rounded by an ulp: hence the
    # tolerance; a braking step ends at zero velocity too, but starts moving.)
    stopped = (vel[1:] == 0.0).all(axis=2) & (vel[:-1] == 0.0).all(axis=2)
    assert stopped.sum() > 50
    assert (pos[1:][stopped] == pos[:-1][stopped]).all(axis=1).sum() > 50
    assert np.abs(pos[1:][stopped] - pos[:-1][stopped]).max() <= 1e-12
