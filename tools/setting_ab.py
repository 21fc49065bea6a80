"""A setting's cost and effect on a random sample of a results database's trials: each trial run
with ``SECTION.KEY`` off and on, alternately (which first alternates with the trial), its
processor time and outcome compared (docs/performance-11.md). Off and on are false and true, or
the two values given (numbers, else strings); the planner calls and the plans kept from the
round before (``planner.reuse_tolerance``) are counted too.

    python tools/setting_ab.py results.sqlite 200 11 execution skip_at_rest
    python tools/setting_ab.py results.sqlite 60 11 planner reuse_tolerance 0 0.05
"""

import collections
import sys
import time

from nodnav.sim import plan_cache
from nodnav.sim.simulator import run_trial
from stored_sample import sample, stored_trial


def value(text: str):
    """A setting's value from the command line: a number if it reads as one, else the string."""
    try:
        return int(text)
    except ValueError:
        try:
            return float(text)
        except ValueError:
            return text


def counted_caches() -> list:
    """Every plan cache made from now on, in a list (to read their counters after a trial)."""
    made: list = []
    init = plan_cache.PlanCache.__init__

    def recording(self, *args, **kwargs):
        init(self, *args, **kwargs)
        made.append(self)

    plan_cache.PlanCache.__init__ = recording
    return made


if __name__ == "__main__":
    if len(sys.argv) not in (6, 8):
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    db, n, seed, section, key = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
    values = {False: False, True: True} if len(sys.argv) == 6 else {False: value(sys.argv[6]), True: value(sys.argv[7])}
    picked = sample(db, n, seed, "t.n_robots")
    cpu: dict[bool, float] = {False: 0.0, True: 0.0}
    calls: dict[bool, int] = {False: 0, True: 0}
    kept: dict[bool, int] = {False: 0, True: 0}
    simulated: dict[bool, float] = {False: 0.0, True: 0.0}
    outcomes: collections.Counter[tuple[str, str]] = collections.Counter()
    by_robots: dict[int, list[float]] = collections.defaultdict(lambda: [0.0, 0.0])
    # The first sampled trial once, not counted: the compiled kernels load at their first call.
    run_trial(*stored_trial(picked[0], "warm-up"))
    caches = counted_caches()
    for position, row in enumerate(picked):
        n_robots = row[4]
        outcome, line = {}, {}
        for on in (False, True) if position % 2 else (True, False):
            caches.clear()
            start = time.process_time()
            result = run_trial(*stored_trial(row, settings={section: {key: values[on]}}))
            elapsed = time.process_time() - start
            cpu[on] += elapsed
            by_robots[n_robots][on] += elapsed
            outcome[on] = result.outcome
            simulated[on] += result.sim_time
            line[on] = f"{result.outcome} {result.sim_time:.1f} s in {elapsed:.2f} s"
            calls[on] += sum(c.misses for c in caches)
            kept[on] += sum(getattr(c, "reused", 0) for c in caches)
        outcomes[(outcome[False], outcome[True])] += 1
        print(f"{row[0]} ({n_robots} robots): off {line[False]}, on {line[True]}", file=sys.stderr)
    print(f"{len(picked)} trials ({key} {values[False]} vs {values[True]}): off {cpu[False]:.1f} s, "
          f"on {cpu[True]:.1f} s, ratio {cpu[True] / cpu[False]:.3f}")
    print(f"simulated: off {simulated[False]:.0f} s, on {simulated[True]:.0f} s; processor time per simulated "
          f"second, on / off: {cpu[True] / simulated[True] / (cpu[False] / simulated[False]):.3f}")
    print(f"planner calls: off {calls[False]}, on {calls[True]} ({kept[True]} plans kept from the round before)")
    print("by robots:", {k: f"{v[1] / v[0]:.3f} ({v[0]:.1f} s)" for k, v in sorted(by_robots.items())})
    print("outcomes (off, on):", dict(outcomes))
