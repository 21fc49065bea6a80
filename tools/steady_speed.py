"""Steady-state real-time factor of the checked-out commit on one scenario, the same script for
every commit (run it with ``PYTHONPATH=<checkout>/src`` to time another).

A throw-away trial (seed 0) is run to its end first, so every compiled kernel is loaded as in a
sweep worker's first trial; then, where the commit has :mod:`nodnav.heap`, the long-lived heap is
frozen as its sweep workers do; then seeds 1..N are timed (wall clock; pin it to one core with
``taskset -c 0``). Prints the real-time factor overall and per seed (docs/performance-11.md).

    python tools/steady_speed.py 4r-case1 3
    python tools/steady_speed.py 8r-head-on 2 2     # 2 game players per robot
"""

import sys
import time

from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import run_trial

if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    name, n = sys.argv[1], int(sys.argv[2])
    players = sys.argv[3] if len(sys.argv) > 3 else "all"
    scenario = load_scenario(name).with_overrides(game_players=players if players == "all" else int(players))
    run_trial(scenario, seed=0)
    try:
        from nodnav.heap import freeze_long_lived
    except ImportError:  # a commit before the heap module: its workers froze nothing
        froze = "no heap module"
    else:
        freeze_long_lived()
        froze = "heap frozen"
    sim = wall = 0.0
    per_seed = []
    for seed in range(1, n + 1):
        start = time.perf_counter()
        result = run_trial(scenario, seed=seed)
        elapsed = time.perf_counter() - start
        sim, wall = sim + result.sim_time, wall + elapsed
        per_seed.append(f"{result.sim_time / elapsed:.0f}x {result.outcome}")
    print(f"{name} k={players} seeds 1-{n}: {sim / wall:.1f}x real time ({', '.join(per_seed)}; {froze})")
