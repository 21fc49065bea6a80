"""The garbage collector in a process that runs many trials: the long-lived heap set aside once.

Importing NumPy, SciPy, numba and the compiled kernels leaves about 140,000 objects tracked by
Python's cyclic garbage collector. Every full collection walks all of them: 60-280 ms each, one
every few trials of a sweep worker (about 0.9 ms per simulated second of 4r-case2, 9 % of its
time, measured in docs/performance-11.md). None of them ever becomes garbage. After the first
trial of a process, :func:`freeze_long_lived` collects once and moves every object alive into
the collector's permanent generation (:func:`gc.freeze`), which later collections skip.

Frozen objects are still freed by reference counting when their last reference goes; only a
cycle among objects alive at the freeze, broken later, is never collected. That is why it is
done once, where nodnav owns the process's trials: after the first trial a sweep runs in each
worker (:func:`~nodnav.experiments.sweep.execute_trial`) and after the benchmark's warm-up. It
changes no result: the collector only frees memory.
"""

from __future__ import annotations

import gc


def freeze_long_lived() -> bool:
    """Collect once and freeze every object alive now (:func:`gc.freeze`), if nothing in this
    process is frozen yet; returns whether it froze. Idempotent: later calls cost one lookup."""
    if gc.get_freeze_count():
        return False
    gc.collect()
    gc.freeze()
    return True
