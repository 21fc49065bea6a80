"""A setting's cost and effect on a random sample of a results database's trials: each trial run
with ``SECTION.KEY`` false and true, alternately (which first alternates with the trial), its
processor time and outcome compared (docs/performance-11.md).

    python tools/setting_ab.py results.sqlite 200 11 execution skip_at_rest
"""

import collections
import sys
import time

from nodnav.sim.simulator import run_trial
from stored_sample import sample, stored_trial

if __name__ == "__main__":
    if len(sys.argv) != 6:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    db, n, seed, section, key = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
    picked = sample(db, n, seed, "t.n_robots")
    cpu: dict[bool, float] = {False: 0.0, True: 0.0}
    outcomes: collections.Counter[tuple[str, str]] = collections.Counter()
    by_robots: dict[int, list[float]] = collections.defaultdict(lambda: [0.0, 0.0])
    # The first sampled trial once, not counted: the compiled kernels load at their first call.
    run_trial(*stored_trial(picked[0], "warm-up"))
    for position, row in enumerate(picked):
        n_robots = row[4]
        outcome = {}
        for on in (False, True) if position % 2 else (True, False):
            start = time.process_time()
            result = run_trial(*stored_trial(row, settings={section: {key: on}}))
            elapsed = time.process_time() - start
            cpu[on] += elapsed
            by_robots[n_robots][on] += elapsed
            outcome[on] = result.outcome
        outcomes[(outcome[False], outcome[True])] += 1
    print(f"{len(picked)} trials: off {cpu[False]:.1f} s, on {cpu[True]:.1f} s, ratio {cpu[True] / cpu[False]:.3f}")
    print("by robots:", {k: f"{v[1] / v[0]:.3f} ({v[0]:.1f} s)" for k, v in sorted(by_robots.items())})
    print("outcomes (off, on):", dict(outcomes))
