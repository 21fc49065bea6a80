"""A simple hand-written policy for one robot among NOD robots, through the Gymnasium environment.

    python examples/hand_policy_env.py [SCENARIO] [ROBOT]

The policy reads only its observation (nodnav.envs.corridor documents it): it heads for its
entrance, through the corridor, then to its goal, at full speed; it waits before its entrance
while another robot is inside the corridor, and stops when another robot is close ahead.
"""

import sys

import numpy as np

import nodnav.envs

K = 3  # neighbours in the observation (the environment's default)


def hand_policy(obs: np.ndarray, max_speed: float) -> np.ndarray:
    """A velocity command from one observation."""
    p, to_goal = obs[0:2], obs[4:6]
    others = obs[6:6 + 6 * K].reshape(K, 6)
    left, right, half_width, inside = obs[-6:-4], obs[-4:-2], obs[-2], obs[-1] > 0.5
    goal = p + to_goal
    ent_left, ent_right = p + left, p + right
    x_min, x_max = ent_left[0], ent_right[0]
    crossing = (p[0] < x_min) != (goal[0] < x_min) or (p[0] > x_max) != (goal[0] > x_max)
    if inside or not crossing:
        target = goal if not inside else (ent_right if goal[0] > x_max else ent_left if goal[0] < x_min else goal)
    else:
        target = ent_left if p[0] < x_min else ent_right
        present = others[:, 5] > 0.5
        seen = p + others[:, :2]
        someone_inside = present & (seen[:, 0] > x_min) & (seen[:, 0] < x_max) & \
            (np.abs(seen[:, 1] - ent_left[1]) < half_width)
        if someone_inside.any() and np.linalg.norm(target - p) < 1.5:
            return np.zeros(2)  # wait before the mouth
    heading = target - p
    dist = float(np.linalg.norm(heading))
    if dist < 0.05:
        heading, dist = goal - p, float(np.linalg.norm(goal - p))
    direction = heading / max(dist, 1e-9)
    ahead = others[:, 5] > 0.5
    close = ahead & (np.linalg.norm(others[:, :2], axis=1) < 0.7) & (others[:, :2] @ direction > 0)
    speed = 0.0 if close.any() else min(max_speed, float(np.linalg.norm(to_goal)) / 0.5)
    return (direction * speed).astype(np.float32)


scenario = sys.argv[1] if len(sys.argv) > 1 else "2r-case1"
robot = int(sys.argv[2]) if len(sys.argv) > 2 else 1
env = nodnav.envs.gym_env(scenario, controlled=robot, seed=1)
obs, info = env.reset()
max_speed = float(env.action_space.high[0])
total, done = 0.0, False
while not done:
    obs, reward, terminated, truncated, info = env.step(hand_policy(obs, max_speed))
    total += reward
    done = terminated or truncated
print(f"hand-written policy for robot {robot} in {scenario}: return {total:.2f}, "
      f"{'arrived' if terminated and not info['contact'] else 'stopped'} at t = {info['t']:.1f} s "
      f"(trial {info['outcome'] or 'still running'})")
