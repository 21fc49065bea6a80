"""The speed comparison suite of docs/performance.md: 4r-case1..4 (all players) and 8r-head-on
(2 game players), seeds 1 and 2, in one process; prints each trial's outcome, simulated time and
processor time. Run it on two commits (``PYTHONPATH=<checkout>/src python tools/speed_suite.py``)
alternately, pinned to one core, and compare the processor times pair by pair."""

import time

from nodnav import load_scenario, run_trial

CASES = [(f"4r-case{k}", "all") for k in range(1, 5)] + [("8r-head-on", 2)]

if __name__ == "__main__":
    for name, players in CASES:
        scenario = load_scenario(name).with_overrides(game_players=players)
        for seed in (1, 2):
            start = time.process_time()
            result = run_trial(scenario, seed=seed)
            print(name, seed, result.outcome, result.sim_time, round(time.process_time() - start, 4), flush=True)
