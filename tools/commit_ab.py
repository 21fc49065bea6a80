"""Two checkouts of nodnav side by side on the same random trials of a results database: the
processor time each takes per study, and whether every trial's outcome, makespan and least
separation are the same (docs/performance-12.md).

Each checkout runs in a worker process of its own (``PYTHONPATH=<checkout>/src``, a kernel cache
of its own), both at the same time, one per core, so both see the same machine; halfway through
the sample they swap cores. A worker runs one throw-away trial first (kernels load at their first
call; the heap is frozen after it where the checkout has ``nodnav.heap``, as sweep workers do),
then times each trial with ``time.process_time``.

    python tools/commit_ab.py results.sqlite 200 7 /path/to/base /path/to/new

A checkout is a directory holding ``src/nodnav`` (``git archive COMMIT src | tar -x -C DIR``).
"""

import collections
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from stored_sample import sample, stored_trial


def _worker(db: str, n: int, seed: int, cores: str) -> None:
    """Run the sample in this process (the checkout is whatever ``nodnav`` imports) and print one
    JSON line per trial."""
    from nodnav.sim.simulator import run_trial

    first, second = (int(c) for c in cores.split(","))
    trials = sample(db, n, seed, "s.study")

    def run(row):
        return run_trial(*stored_trial(row))

    os.sched_setaffinity(0, {first})
    run(trials[0])
    try:
        from nodnav.heap import freeze_long_lived
    except ImportError:
        pass
    else:
        freeze_long_lived()
    for index, row in enumerate(trials):
        if index == len(trials) // 2:
            os.sched_setaffinity(0, {second})
        start = time.process_time()
        result = run(row)
        cpu = time.process_time() - start
        print(json.dumps({"key": row[0], "study": row[4], "cpu": cpu, "outcome": result.outcome,
                          "makespan": result.makespan, "min_separation": result.min_separation}), flush=True)


def _launch(checkout: str, db: str, n: int, seed: int, cores: str) -> subprocess.Popen:
    # A kernel cache per checkout, kept between runs (compiling takes minutes).
    digest = hashlib.sha256(str(Path(checkout).resolve()).encode()).hexdigest()[:12]
    cache = Path(tempfile.gettempdir()) / "nodnav-ab-kernels" / digest
    if not cache.exists():
        # Kernels used first by later trials would compile inside their timing (the throw-away
        # trial loads only its own): such a run's times are not comparable.
        print(f"{checkout}: empty kernel cache {cache}; its trials compile kernels inside the timing: "
              "run the comparison again for figures", file=sys.stderr)
    env = dict(os.environ, PYTHONPATH=str(Path(checkout) / "src"), NUMBA_CACHE_DIR=str(cache))
    return subprocess.Popen([sys.executable, __file__, "--worker", db, str(n), str(seed), cores],
                            env=env, stdout=subprocess.PIPE, text=True)


def main(argv: list[str]) -> int:
    if argv and argv[0] == "--worker":
        _worker(argv[1], int(argv[2]), int(argv[3]), argv[4])
        return 0
    if len(argv) != 5:
        print(__doc__, file=sys.stderr)
        return 2
    db, n, seed, base, new = argv[0], int(argv[1]), int(argv[2]), argv[3], argv[4]
    workers = {"base": _launch(base, db, n, seed, "0,1"), "new": _launch(new, db, n, seed, "1,0")}
    lines = {name: [json.loads(line) for line in proc.stdout] for name, proc in workers.items()}
    if any(proc.wait() for proc in workers.values()):
        print("a worker failed", file=sys.stderr)
        return 1
    cpu: dict[str, dict[str, float]] = collections.defaultdict(lambda: {"base": 0.0, "new": 0.0})
    differ = []
    for a, b in zip(lines["base"], lines["new"]):
        for name, rec in (("base", a), ("new", b)):
            cpu[rec["study"]][name] += rec["cpu"]
            cpu["all"][name] += rec["cpu"]
        if any(json.dumps(a[k]) != json.dumps(b[k]) for k in ("outcome", "makespan", "min_separation")):  # NaN too
            differ.append(a["key"][:12])
    print(f"{len(lines['base'])} trials (seed {seed}); processor time, base -> new:")
    for study, t in sorted(cpu.items(), key=lambda kv: kv[0] == "all"):
        print(f"  {study:26s} {t['base']:8.1f} s -> {t['new']:8.1f} s  ratio {t['new'] / t['base']:.3f}")
    print(f"outcome, makespan and least separation the same in {len(lines['base']) - len(differ)} of "
          f"{len(lines['base'])} trials" + (f"; differ: {', '.join(differ)}" if differ else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
