"""The PettingZoo and Gymnasium environments pass their libraries' API checks and do what the docs say."""

import importlib.util

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(importlib.util.find_spec("pettingzoo") is None
                                or importlib.util.find_spec("gymnasium") is None,
                                reason="needs the rl extra: pip install 'nodnav[rl]'")


def test_parallel_env_passes_pettingzoos_api_test():
    from pettingzoo.test import parallel_api_test

    import nodnav.envs

    env = nodnav.envs.parallel_env("3r-case4", controlled=[1, 3], seed=2)
    assert env.possible_agents == ["robot_1", "robot_3"]
    parallel_api_test(env, num_cycles=100)


def test_gym_env_passes_gymnasiums_env_checker():
    from gymnasium.utils.env_checker import check_env

    import nodnav.envs

    check_env(nodnav.envs.gym_env("2r-case1", controlled=2, seed=1), skip_render_check=True)


def test_observation_layout_and_limits_of_a_command():
    import nodnav.envs
    from nodnav.envs.corridor import command_step

    env = nodnav.envs.gym_env("2r-case1", controlled=1, seed=1, render_mode="rgb_array")
    obs, _ = env.reset()
    s = env.core.scenario
    assert obs.shape == (6 + 6 * 3 + 6,)
    assert np.allclose(obs[0:2], s.origins[0]) and np.allclose(obs[4:6], s.destinations[0] - s.origins[0])
    assert np.allclose(obs[6:8], s.origins[1] - s.origins[0], atol=1e-5) and obs[11] == 1.0 and obs[17] == 0.0
    assert np.allclose(obs[-6:-4], np.asarray(s.world.entrances[0]) - s.origins[0], atol=1e-5)
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
    # From rest, a command of 5 m/s along x gives max_accel * dt = 0.2 m/s after one step, 0.02 m moved.
    p, v = command_step(np.zeros(2), np.zeros(2), np.array([5.0, 0.0]), 1.0, 2.0, 0.1)
    assert np.allclose(v, [0.2, 0.0]) and np.allclose(p, [0.02, 0.0])
    # Moving at 1 m/s, the speed limit holds whatever the command.
    p, v = command_step(np.zeros(2), np.array([1.0, 0.0]), np.array([5.0, 5.0]), 1.0, 2.0, 0.1)
    assert np.isclose(np.linalg.norm(v), 1.0)


def test_progress_is_rewarded_and_the_same_seed_gives_the_same_episode():
    import nodnav.envs

    def episode():
        env = nodnav.envs.gym_env("2r-case1", controlled=1, seed=7)
        obs, _ = env.reset()
        out = []
        for _ in range(20):
            obs, reward, *_ = env.step(np.clip(obs[4:6], -1, 1))
            out.append(reward)
        return np.array(out)

    a, b = episode(), episode()
    assert np.array_equal(a, b)
    assert a[-1] > 0.0  # heading for its goal makes progress
