"""The speed comparison suite of docs/performance.md: 4r-case1..4 (all players) and 8r-head-on
(2 game players), seeds 1 and 2, in one process; prints each trial's outcome, simulated time and
processor time, then the totals. Run it on two commits (``PYTHONPATH=<checkout>/src python
tools/speed_suite.py``) alternately, pinned to one core, and compare the processor times pair by
pair. ``--set KEY=VALUE`` (repeatable; the value read as YAML, as ``nodnav sweep --set``) runs
every trial with that setting, e.g. ``--set execution.skip_at_rest=false``."""

import argparse
import time

import yaml

from nodnav import load_scenario, run_trial

CASES = [(f"4r-case{k}", "all") for k in range(1, 5)] + [("8r-head-on", 2)]

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--set", dest="settings", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    overrides = {}
    for item in args.settings:
        key, _, value = item.partition("=")
        overrides[key] = yaml.safe_load(value)
    total_cpu = total_sim = 0.0
    for name, players in CASES:
        scenario = load_scenario(name).with_overrides(game_players=players, **overrides)
        for seed in (1, 2):
            start = time.process_time()
            result = run_trial(scenario, seed=seed)
            spent = time.process_time() - start
            total_cpu, total_sim = total_cpu + spent, total_sim + result.sim_time
            print(name, seed, result.outcome, result.sim_time, round(spent, 4), flush=True)
    print("total", round(total_sim, 1), round(total_cpu, 4), flush=True)
