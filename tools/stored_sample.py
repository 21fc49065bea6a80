"""A seeded random sample of a results database's trials, and each one's scenario rebuilt from
its stored configuration: what tools/commit_ab.py, setting_ab.py and stage_sample.py share.

Nothing of nodnav is imported here at module level: commit_ab.py runs the sample under other
checkouts, each importing its own nodnav.
"""

import json
import sqlite3

import numpy as np


def sample(db: str, n: int, seed: int, extra: str = "") -> list[tuple]:
    """``n`` trials drawn without replacement by ``numpy.random.default_rng(seed)`` from all of
    ``db``'s trials in key order: rows ``(key, config, seed, method, *extra)``, ``extra`` being
    further SQL expressions over the trials ``t`` (and their first study ``s.study``)."""
    columns = "t.key, t.config, t.seed, t.method" + (f", {extra}" if extra else "")
    rows = sqlite3.connect(db).execute(
        f"select {columns} from trials t left join (select key, min(study) as study from study_trials "
        "group by key) s on s.key = t.key order by t.key").fetchall()
    picked = np.random.default_rng(seed).choice(len(rows), size=min(n, len(rows)), replace=False)
    return [rows[i] for i in picked]


def stored_trial(row: tuple, name: str = "sample", settings: dict | None = None):
    """The scenario, method and seed of a sampled row, ``settings`` (``{section: {key: value}}``)
    written over the stored configuration."""
    from nodnav.scenario.schema import scenario_from_dict

    _, config, seed, method = row[:4]
    cfg = json.loads(config)
    raw = cfg["scenario"]
    for section, values in (settings or {}).items():
        raw.setdefault(section, {}).update(values)
    return scenario_from_dict(raw, name), cfg.get("method", method), seed
