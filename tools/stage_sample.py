"""Where a study's processor time goes, estimated from a random sample of its trials.

Draws ``N`` trials of a results database (uniformly, with a seeded generator), runs each again
with every stage timed (:func:`nodnav.bench.stages.measure_stages`; the first once before,
uncounted, to load the compiled kernels) and scales the sums to all of
the database's trials: the estimate per stage, the DAQP time by kind of QP (tracking, evasive,
certificate LP; wall time) and the time per outcome (docs/performance-11.md).

    python tools/stage_sample.py results.sqlite 250 7
"""

import collections
import json
import sqlite3
import sys
import time

import numpy as np

import nodnav.control.qp as qp
from nodnav.bench.stages import STAGES, measure_stages
from nodnav.scenario.schema import scenario_from_dict
from nodnav.sim.simulator import run_trial


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
    rows = sqlite3.connect(db).execute("select key, config, seed, method from trials order by key").fetchall()
    picked = np.random.default_rng(seed).choice(len(rows), size=min(n, len(rows)), replace=False)
    kinds: collections.Counter[str] = collections.Counter()
    kind_calls: collections.Counter[str] = collections.Counter()
    qp.daqp = _counting_daqp(kinds, kind_calls)
    stages: dict[str, float] = dict.fromkeys(STAGES, 0.0)
    by_outcome: dict[str, float] = collections.defaultdict(float)
    total = 0.0
    # The first sampled trial once, not counted: the compiled kernels load at their first call.
    first = json.loads(rows[picked[0]][1])
    run_trial(scenario_from_dict(first["scenario"], "warm-up"), first.get("method", rows[picked[0]][3]),
              rows[picked[0]][2])
    for i in picked:
        _, config, trial_seed, method = rows[i]
        cfg = json.loads(config)
        times = measure_stages(scenario_from_dict(cfg["scenario"], "sample"), trial_seed, cfg.get("method", method))
        for stage, seconds in times.cpu_seconds.items():
            stages[stage] += seconds
        total += times.cpu_time
        by_outcome[times.outcome] += times.cpu_time
    scale = len(rows) / len(picked)
    print(f"sample {len(picked)} of {len(rows)}: {total:.1f} s of processor time; "
          f"estimate for all: {total * scale:.0f} s")
    for stage in STAGES:
        print(f"  {stage:20s} {stages[stage] * scale:7.0f} s  {100 * stages[stage] / total:5.1f} %")
    print("DAQP by kind (estimate s, calls in the sample):",
          {k: (round(v * scale), kind_calls[k]) for k, v in kinds.most_common()})
    print("by outcome (estimate s):", {k: round(v * scale) for k, v in by_outcome.items()})
