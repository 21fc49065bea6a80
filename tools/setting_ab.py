"""A setting's cost and effect on a random sample of a results database's trials: each trial run
with ``SECTION.KEY`` false and true, alternately (which first alternates with the trial), its
processor time and outcome compared (docs/performance-11.md).

    python tools/setting_ab.py results.sqlite 200 11 execution skip_at_rest
"""

import collections
import json
import sqlite3
import sys
import time

import numpy as np

from nodnav.scenario.schema import scenario_from_dict
from nodnav.sim.simulator import run_trial

if __name__ == "__main__":
    if len(sys.argv) != 6:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    db, n, seed, section, key = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
    rows = sqlite3.connect(db).execute("select key, config, seed, method, n_robots from trials order by key").fetchall()
    picked = np.random.default_rng(seed).choice(len(rows), size=min(n, len(rows)), replace=False)
    cpu: dict[bool, float] = {False: 0.0, True: 0.0}
    outcomes: collections.Counter[tuple[str, str]] = collections.Counter()
    by_robots: dict[int, list[float]] = collections.defaultdict(lambda: [0.0, 0.0])
    # The first sampled trial once, not counted: the compiled kernels load at their first call.
    first = json.loads(rows[picked[0]][1])
    run_trial(scenario_from_dict(first["scenario"], "warm-up"), first.get("method", rows[picked[0]][3]),
              rows[picked[0]][2])
    for i in picked:
        _, config, trial_seed, method, n_robots = rows[i]
        cfg = json.loads(config)
        outcome = {}
        for on in (False, True) if i % 2 else (True, False):
            raw = json.loads(json.dumps(cfg["scenario"]))
            raw.setdefault(section, {})[key] = on
            start = time.process_time()
            result = run_trial(scenario_from_dict(raw, "sample"), cfg.get("method", method), trial_seed)
            elapsed = time.process_time() - start
            cpu[on] += elapsed
            by_robots[n_robots][on] += elapsed
            outcome[on] = result.outcome
        outcomes[(outcome[False], outcome[True])] += 1
    print(f"{len(picked)} trials: off {cpu[False]:.1f} s, on {cpu[True]:.1f} s, ratio {cpu[True] / cpu[False]:.3f}")
    print("by robots:", {k: f"{v[1] / v[0]:.3f} ({v[0]:.1f} s)" for k, v in sorted(by_robots.items())})
    print("outcomes (off, on):", dict(outcomes))
