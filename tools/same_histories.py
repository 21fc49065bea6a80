"""Record the histories of a fixed set of trials, or compare them with a recording, bit for bit.

A pure refactoring must not change any trajectory. Run ``record DIR`` before the change and
``compare DIR`` after it: every array of every history (positions, velocities, opinions,
probabilities, strategies, players, ...), its events, entry order and outcome must be equal
byte for byte.

    .venv/bin/python tools/same_histories.py record /tmp/histories-before
    .venv/bin/python tools/same_histories.py compare /tmp/histories-before
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

#: (scenario, seed, method, overrides): the paper's scenarios with every robot a game player and
#: with one, every method once, the PRM* planner on a small roadmap, a drawn scenario, a trial
#: that deadlocks (no game players: the evasive fallback at most steps) and eight robots.
TRIALS = (
    [(s, seed, "nod", {}) for s in ("2r-case1", "3r-case4", "4r-case2") for seed in (1, 2, 3)]
    + [(s, seed, "nod", {"game_players": 1}) for s in ("3r-case4", "4r-case2") for seed in (1, 2, 3)]
    + [("3r-case4", 1, m, {}) for m in ("no-coordination", "independent", "closest-first", "oracle", "orca")]
    + [(s, 1, "nod", {"planner.name": "prm", "planner.roadmap_vertices": v,
                       "planner.cache_dir": "/tmp/nodnav-same-histories-cache"})
       for s, v in (("2r-case1", 300), ("2r-case1", 600), ("3r-case4", 500))]
    + [("mixed:5", 5, "nod", {})]
    + [("4r-case3", 1, "nod", {"game_players": 0}), ("8r-head-on", 1, "nod", {"game_players": 2})]
)


def _key(scenario: str, seed: int, method: str, overrides: dict) -> str:
    extra = "".join(f"-{k}={v}" for k, v in sorted(overrides.items()) if k != "planner.cache_dir")
    return f"{scenario}-{method}-seed{seed}{extra}".replace(":", "_").replace("/", "_")


def _run(scenario: str, seed: int, method: str, overrides: dict) -> dict[str, np.ndarray]:
    import nodnav

    if hasattr(nodnav, "run_trial"):
        load_scenario, run_trial = nodnav.load_scenario, nodnav.run_trial
    else:  # before the public API existed
        try:
            from nodnav.scenario.loading import load_scenario
        except ImportError:
            from nodnav.scenario.schema import load_scenario
        from nodnav.sim.simulator import run_trial
    s = load_scenario(scenario)
    if overrides:
        s = s.with_overrides(**overrides)
    try:
        h = run_trial(s, method=method, seed=seed).history
    except Exception as exc:  # a trial that raises must go on raising the same error after a refactoring
        return {"meta": np.array(json.dumps({"error": f"{type(exc).__name__}: {exc}"}))}
    record = dict(h.arrays())
    record["meta"] = np.array(json.dumps({"events": h.events, "entry_order": h.entry_order,
                                          "outcome": h.outcome}, sort_keys=True))
    return record


def main(argv: list[str]) -> int:
    if len(argv) != 2 or argv[0] not in ("record", "compare"):
        print(__doc__, file=sys.stderr)
        return 2
    mode, folder = argv[0], Path(argv[1])
    folder.mkdir(parents=True, exist_ok=True)
    differ = 0
    for trial in TRIALS:
        key = _key(*trial)
        now = _run(*trial)
        path = folder / f"{key}.npz"
        if mode == "record":
            np.savez(path, **now)
            print(f"recorded {key}: {str(now['meta'])[-60:]}")
            continue
        with np.load(path) as before:
            names = sorted(set(before.files) | set(now))
            bad = [n for n in names if n not in before.files or n not in now
                   or before[n].dtype != now[n].dtype or before[n].shape != now[n].shape
                   or before[n].tobytes() != now[n].tobytes()]
        differ += bool(bad)
        print(f"{'DIFFERENT' if bad else 'same'} {key}{': ' + ', '.join(bad) if bad else ''}")
    if mode == "compare":
        print(f"{len(TRIALS) - differ} of {len(TRIALS)} histories bitwise the same")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
