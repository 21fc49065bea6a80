"""Steps per second of the PettingZoo environment (docs/mixed-teams.md).

    .venv/bin/python tools/env_step_rate.py [SCENARIO] [CONTROLLED] [STEPS]

CONTROLLED: robot numbers separated by commas (default 1). Each step, every controlled robot
heads for its goal at full speed (a fixed, cheap policy, so that the rate is the environment's).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import nodnav.envs


def main(argv: list[str]) -> int:
    scenario = argv[0] if argv else "4r-case2"
    controlled = [int(k) for k in (argv[1] if len(argv) > 1 else "1").split(",")]
    steps = int(argv[2]) if len(argv) > 2 else 300
    env = nodnav.envs.parallel_env(scenario, controlled=controlled, seed=1)
    observations, _ = env.reset()
    done, start = 0, time.perf_counter()
    while done < steps:
        actions = {a: np.clip(o[4:6], -1.0, 1.0) for a, o in observations.items()}
        observations, *_ = env.step(actions)
        done += 1
        if not env.agents:
            observations, _ = env.reset()
    elapsed = time.perf_counter() - start
    print(f"{scenario}, controlled {controlled}: {steps} steps in {elapsed:.1f} s = {steps / elapsed:.1f} steps/s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
