"""A random policy for robot 1 among NOD robots, through the PettingZoo environment (``nodnav[rl]``).

    python examples/random_policy_env.py [SCENARIO] [STEPS]

Robot 1 takes uniformly random velocity commands; the others run NOD. It prints what the robot
observed, what it was rewarded, and how the episode ended (usually in a contact).
"""

import sys

import numpy as np

import nodnav.envs

scenario = sys.argv[1] if len(sys.argv) > 1 else "3r-case4"
steps = int(sys.argv[2]) if len(sys.argv) > 2 else 100

env = nodnav.envs.parallel_env(scenario, controlled=[1], seed=1)
observations, infos = env.reset()
print(f"{scenario}: agents {env.agents}, observation size {env.observation_space('robot_1').shape[0]}")
rng = np.random.default_rng(0)
total, info = 0.0, {}
for _ in range(steps):
    actions = {agent: env.action_space(agent).sample() for agent in env.agents}
    observations, rewards, terminations, truncations, infos = env.step(actions)
    total += sum(rewards.values())
    info = infos.get("robot_1", info)
    if not env.agents:
        break
outcome = info.get("outcome") or "running"
print(f"random policy: return {total:.2f} after {info.get('t', 0):.1f} s, trial outcome {outcome}")
