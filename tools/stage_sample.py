"""Where a study's processor time goes, estimated from a random sample of its trials.

Draws ``N`` trials of a results database (uniformly, with a seeded generator), runs each again
with every stage timed (:func:`nodnav.bench.stages.measure_stages`; the first once before,
uncounted, to load the compiled kernels) and scales the sums to all of
the database's trials: the estimate per stage, the DAQP time by kind of QP (tracking, evasive,
certificate LP; wall time) and the time per outcome (docs/performance-11.md).

    python tools/stage_sample.py results.sqlite 250 7
"""

import collections
import sqlite3
import sys
import time

import nodnav.control.qp as qp
from nodnav.bench.stages import STAGES, measure_stages
from nodnav.sim.simulator import run_trial
from stored_sample import sample, stored_trial


def _counting_daqp(times: collections.Counter[str], calls: collections.Counter[str]):
    """A stand-in for the ``daqp`` module whose ``solve`` counts time and calls by kind of QP."""
    solve = qp.daqp.solve

    class Counting:
        @staticmethod
        def solve(h, g, a, up, low, sense, **kw):
            start = time.perf_counter()
            out = solve(h, g, a, up, low, sense, **kw)
            kind = "certificate" if "eps_prox" in kw else ("tracking" if a.shape[1] == 18 else "evasive")
            kind += "" if out[2] == 1 else " (failed)"
            times[kind] += time.perf_counter() - start
            calls[kind] += 1
            return out

    return Counting


if __name__ == "__main__":
    if len(sys.argv) != 4:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    db, n, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    picked = sample(db, n, seed)
    n_trials = sqlite3.connect(db).execute("select count(*) from trials").fetchone()[0]
    kinds: collections.Counter[str] = collections.Counter()
    kind_calls: collections.Counter[str] = collections.Counter()
    qp.daqp = _counting_daqp(kinds, kind_calls)
    stages: dict[str, float] = dict.fromkeys(STAGES, 0.0)
    by_outcome: dict[str, float] = collections.defaultdict(float)
    total = 0.0
    # The first sampled trial once, not counted: the compiled kernels load at their first call.
    run_trial(*stored_trial(picked[0], "warm-up"))
    for row in picked:
        scenario, method, trial_seed = stored_trial(row)
        times = measure_stages(scenario, trial_seed, method)
        for stage, seconds in times.cpu_seconds.items():
            stages[stage] += seconds
        total += times.cpu_time
        by_outcome[times.outcome] += times.cpu_time
    scale = n_trials / len(picked)
    print(f"sample {len(picked)} of {n_trials}: {total:.1f} s of processor time; "
          f"estimate for all: {total * scale:.0f} s")
    for stage in STAGES:
        print(f"  {stage:20s} {stages[stage] * scale:7.0f} s  {100 * stages[stage] / total:5.1f} %")
    print("DAQP by kind (estimate s, calls in the sample):",
          {k: (round(v * scale), kind_calls[k]) for k, v in kinds.most_common()})
    print("by outcome (estimate s):", {k: round(v * scale) for k, v in by_outcome.items()})
