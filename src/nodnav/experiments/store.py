"""The results database: one SQLite file, one row per trial, enough to write a report from.

Tables
------
``trials``
    One row per trial, keyed by :func:`trial_key` (a hash of the full configuration and the
    seed). It holds the configuration as JSON, the factors of the sweep as plain columns
    (scenario, robots, method, planner, players, init, bias, seed), the outcome, the headline
    numbers as columns (success, makespan, min_separation, strategy, consensus, sim_time,
    wall_time), the whole summary and the metrics as JSON, the nodnav version, the code version
    that ran it (:func:`nodnav.provenance.code_version`; ``unknown`` for rows stored before code
    versions were recorded) and a timestamp.
``stale_trials``
    Rows of ``trials`` that a later sweep replaced by re-running the same trial under another
    code version (same columns; keyed by trial and code version). Kept for the record; no
    report reads them as results.
``study_trials``
    Which trials belong to which study. A trial is run once and shared by every study whose
    cross product contains it, so a study's results are the rows linked to it here.
``studies``
    Each study's specification as JSON, as it was last run.

Schema 1 (before code versions) is migrated when opened: the column is added and its old rows
are marked ``unknown``.

Durability: the file is in WAL mode with ``synchronous=FULL``, and each trial (its row and its
link to the study) is written in one transaction, so a process killed at any instant leaves every
committed trial whole and no partial row.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import sqlite3
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from nodnav.errors import NodnavError
from nodnav.provenance import UNKNOWN
from nodnav.provenance import code_version as current_code_version
from nodnav.sim.failure import OUTCOMES as TRIAL_OUTCOMES

DEFAULT_DB = "nodnav-results.sqlite"

OUTCOMES = (*TRIAL_OUTCOMES, "error")

SCHEMA_VERSION = 2

_SCHEMA = """
CREATE TABLE IF NOT EXISTS trials (
    key            TEXT PRIMARY KEY,
    study          TEXT NOT NULL,
    scenario       TEXT NOT NULL,
    n_robots       INTEGER NOT NULL,
    method         TEXT NOT NULL,
    planner        TEXT NOT NULL,
    players        INTEGER NOT NULL,
    init           TEXT NOT NULL,
    bias           TEXT NOT NULL,
    seed           INTEGER NOT NULL,
    config         TEXT NOT NULL,
    outcome        TEXT NOT NULL,
    error          TEXT,
    success        INTEGER NOT NULL,
    makespan       REAL,
    min_separation REAL,
    strategy       INTEGER,
    consensus      INTEGER,
    sim_time       REAL,
    wall_time      REAL,
    summary        TEXT NOT NULL,
    metrics        TEXT NOT NULL,
    version        TEXT NOT NULL,
    created        TEXT NOT NULL,
    code_version   TEXT NOT NULL DEFAULT 'unknown'
);
CREATE INDEX IF NOT EXISTS trials_factors ON trials (scenario, players, init, bias, planner, method);
CREATE TABLE IF NOT EXISTS study_trials (
    study TEXT NOT NULL,
    key   TEXT NOT NULL REFERENCES trials (key),
    PRIMARY KEY (study, key)
);
CREATE TABLE IF NOT EXISTS studies (
    name    TEXT PRIMARY KEY,
    spec    TEXT NOT NULL,
    updated TEXT NOT NULL
);
"""

#: Columns of ``trials`` (and of ``stale_trials``), in table order.
TRIAL_COLUMNS = ("key", "study", "scenario", "n_robots", "method", "planner", "players", "init", "bias", "seed",
                 "config", "outcome", "error", "success", "makespan", "min_separation", "strategy", "consensus",
                 "sim_time", "wall_time", "summary", "metrics", "version", "created", "code_version")

_STALE = """
CREATE TABLE IF NOT EXISTS stale_trials AS SELECT * FROM trials WHERE 0;
CREATE UNIQUE INDEX IF NOT EXISTS stale_trials_key ON stale_trials (key, code_version);
"""

#: Columns that :meth:`ResultStore.records` and :meth:`ResultStore.outcome_counts` filter and group on.
FACTOR_COLUMNS = ("scenario", "n_robots", "method", "planner", "players", "init", "bias", "seed", "outcome",
                  "version", "success", "strategy", "consensus", "code_version")


class StoreError(NodnavError):
    """The results database cannot be used; the message says why in one line."""


def canonical_json(value) -> str:
    """``value`` as compact JSON with sorted keys: equal configurations give equal text."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)


def bias_label(bias: dict[str, float]) -> str:
    """A bias mapping as text, e.g. ``S3=150,S5=150`` in strategy order; empty for no bias."""
    items = sorted((int(k[1:]), float(v)) for k, v in bias.items() if float(v) != 0.0)
    return ",".join(f"S{j}={v:g}" for j, v in items)


def trial_config(scenario_mapping: dict, method: str) -> dict:
    """The configuration that determines a trial, apart from its seed.

    ``scenario_mapping`` comes from :func:`nodnav.scenario.schema.scenario_to_dict`.
    """
    return {"scenario": scenario_mapping, "method": method}


def trial_key(config: dict, seed: int) -> str:
    """Hash (SHA-256, hex) of everything that determines a trial's result: configuration and seed.

    The scenario's description does not change the trial and is left out; game players ``all``
    and ``N_r - 1`` are the same trial and hash alike.
    """
    scenario = dict(config["scenario"])
    scenario.pop("description", None)
    if scenario.get("game_players") == "all":
        scenario["game_players"] = len(scenario["robots"]) - 1
    return hashlib.sha256(canonical_json({**config, "scenario": scenario, "seed": int(seed)}).encode()).hexdigest()


def run_key(config: dict, seed: int) -> str:
    """:func:`trial_key` of the configuration less the scenario's name (and ``set``, which only
    records how the scenario was made): trials with equal run keys simulate the same thing.

    The name labels a trial in a study (``4r-case2 [entered]`` is 4r-case2 run as the game reduction's
    ``entered`` variant, its own setting) and is read by no part of the simulation, only written into the summary.
    """
    scenario = {k: v for k, v in config["scenario"].items() if k != "name"}
    rest = {k: v for k, v in config.items() if k not in ("scenario", "set")}
    return trial_key({**rest, "scenario": scenario}, seed)


@dataclass(frozen=True)
class TrialRecord:
    """One stored trial, as a report reads it."""

    key: str
    """Trial key, :func:`trial_key`."""
    study: str
    """Study that first ran the trial."""
    scenario: str
    """Scenario name."""
    n_robots: int
    """Number of robots N_r."""
    method: str
    """Navigation method."""
    planner: str
    """Planner name."""
    players: int
    """Effective number of game players per robot (N_r - 1 for 'all')."""
    init: str
    """Initial-opinion mode."""
    bias: str
    """Bias as text, :func:`bias_label` (empty for none)."""
    seed: int
    """Trial seed."""
    config: dict
    """The full configuration, :func:`trial_config`."""
    outcome: str
    """``success``, ``collision``, ``deadlock``, ``timeout`` or ``error``."""
    error: str | None
    """One-line error message when the outcome is ``error``."""
    summary: dict
    """The trial's JSON summary (``TrialResult.to_dict()``; for an error, the traceback)."""
    metrics: dict
    """The trial's metrics (see ``docs/metrics.md``)."""
    version: str
    """nodnav version that ran the trial."""
    created: str
    """When the trial was stored (ISO 8601, UTC)."""
    code_version: str = UNKNOWN
    """:func:`nodnav.provenance.code_version` of the code that ran the trial (``unknown`` for
    trials stored before code versions were recorded)."""

    @property
    def success(self) -> bool:
        """Whether every robot arrived without collision."""
        return self.outcome == "success"


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _where(study: str | None, filters: dict) -> tuple[str, list]:
    clauses, params = [], []
    if study is not None:
        clauses.append("key IN (SELECT key FROM study_trials WHERE study = ?)")
        params.append(study)
    for column, value in filters.items():
        if column not in FACTOR_COLUMNS:
            raise StoreError(f"cannot filter on '{column}'; use one of {', '.join(FACTOR_COLUMNS)}")
        values = list(value) if isinstance(value, (list, tuple, set, frozenset)) else [value]
        clauses.append(f"{column} IN ({', '.join('?' * len(values))})")
        params.extend(values)
    return (" WHERE " + " AND ".join(clauses)) if clauses else "", params


class ResultStore:
    """An open results database; use as a context manager or call :meth:`close`.

    Only one process should write (the sweep's parent); any number may read at the same time.
    """

    def __init__(self, path: str | Path = DEFAULT_DB):
        self.path = Path(path)
        try:
            self._db = _Guarded(sqlite3.connect(self.path, isolation_level=None, timeout=30.0), self.path)
        except sqlite3.Error as exc:
            raise StoreError(f"{self.path}: cannot open the results database ({exc})") from None
        try:
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")
            problems = [row[0] for row in self._db.execute("PRAGMA quick_check").fetchall()]
            if problems != ["ok"]:
                raise StoreError(f"{self.path}: the results database is damaged ({problems[0]}); "
                                 "use another --db file")
            version = self._db.execute("PRAGMA user_version").fetchone()[0]
            if version not in (0, 1, SCHEMA_VERSION):
                raise StoreError(f"{self.path}: results database of schema {version}, this nodnav reads "
                                 f"{SCHEMA_VERSION}; use another --db file")
            self._db.executescript(_SCHEMA)
            columns = {row[1] for row in self._db.execute("PRAGMA table_info(trials)").fetchall()}
            if version == 1 and "code_version" not in columns:  # schema 1: no code versions yet
                self._db.execute(f"ALTER TABLE trials ADD COLUMN code_version TEXT NOT NULL DEFAULT '{UNKNOWN}'")
                columns.add("code_version")
            if set(TRIAL_COLUMNS) - columns:
                raise StoreError(f"{self.path}: has a 'trials' table that nodnav did not write; use another --db file")
            self._db.executescript(_STALE)
            self._db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
        except BaseException:
            self._db.close()
            raise

    def __enter__(self) -> "ResultStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection (every trial is already committed)."""
        self._db.close()

    # -- writing -----------------------------------------------------------------------------

    def add_trial(self, *, key: str, study: str, config: dict, seed: int, outcome: str, summary: dict,
                  metrics: dict, version: str, error: str | None = None, code_version: str | None = None,
                  also: tuple[str, ...] = ()) -> None:
        """Store one finished trial and link it to ``study`` (and the studies ``also``), in one transaction.

        ``summary`` is ``TrialResult.to_dict()`` (JSON-ready), from which the headline columns
        are taken; ``config`` is :func:`trial_config`; ``code_version`` is the code that ran it
        (default: this process's :func:`~nodnav.provenance.code_version`). A trial already
        stored under ``key`` is replaced (the study that first ran it is kept); if it was run
        by another code version, the old row is first moved to ``stale_trials``.
        """
        if outcome not in OUTCOMES:
            raise StoreError(f"unknown outcome '{outcome}'; expected one of {', '.join(OUTCOMES)}")
        sc = config["scenario"]
        n = len(sc["robots"])
        players = n - 1 if sc["game_players"] == "all" else int(sc["game_players"])

        def flag(v):
            return None if v is None else int(bool(v))

        strategy = summary.get("strategy")
        row = {
            "key": key, "study": study, "scenario": sc["name"], "n_robots": n, "method": config["method"],
            "planner": sc["planner"]["name"], "players": players, "init": sc["opinion"]["init"],
            "bias": bias_label(sc["opinion"]["bias"]), "seed": int(seed), "config": canonical_json(config),
            "outcome": outcome, "error": error, "success": int(outcome == "success"),
            "makespan": summary.get("makespan_s"), "min_separation": summary.get("min_separation_m"),
            "strategy": None if strategy is None else int(strategy), "consensus": flag(summary.get("consensus")),
            "sim_time": summary.get("sim_time_s"), "wall_time": summary.get("wall_time_s"),
            "summary": canonical_json(summary), "metrics": canonical_json(metrics), "version": version,
            "created": _now(), "code_version": code_version or current_code_version(),
        }
        columns = ", ".join(row)
        with self._transaction():
            first = self._db.execute("SELECT study FROM trials WHERE key = ?", (key,)).fetchone()
            if first is not None:
                row["study"] = first[0]
                cols = ", ".join(TRIAL_COLUMNS)
                self._db.execute(f"INSERT OR REPLACE INTO stale_trials ({cols}) SELECT {cols} FROM trials "
                                 "WHERE key = ? AND code_version != ?", (key, row["code_version"]))
            self._db.execute(f"INSERT OR REPLACE INTO trials ({columns}) VALUES ({', '.join('?' * len(row))})",
                             list(row.values()))
            self._db.executemany("INSERT OR IGNORE INTO study_trials (study, key) VALUES (?, ?)",
                                 [(name, key) for name in dict.fromkeys((study, *also))])

    def link(self, study: str, keys) -> None:
        """Record that the already stored trials ``keys`` belong to ``study`` (one transaction)."""
        with self._transaction():
            self._db.executemany("INSERT OR IGNORE INTO study_trials (study, key) VALUES (?, ?)",
                                 [(study, k) for k in keys])

    def save_study(self, name: str, spec: dict) -> None:
        """Store (or replace) a study's specification."""
        with self._transaction():
            self._db.execute("INSERT OR REPLACE INTO studies (name, spec, updated) VALUES (?, ?, ?)",
                             (name, canonical_json(spec), _now()))

    @contextmanager
    def _transaction(self):
        self._db.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self._db.execute("ROLLBACK")
            raise
        self._db.execute("COMMIT")

    # -- reading -----------------------------------------------------------------------------

    def stored(self, keys, code_version: str | None = None) -> dict[str, str]:
        """The outcome of each of ``keys`` that is stored (run by ``code_version`` only, if given)."""
        return {k: outcome for k, (outcome, v) in self.stored_versions(keys).items()
                if code_version is None or v == code_version}

    def stored_versions(self, keys) -> dict[str, tuple[str, str]]:
        """``(outcome, code_version)`` of each of ``keys`` that is stored."""
        keys = list(keys)
        out: dict[str, tuple[str, str]] = {}
        for start in range(0, len(keys), 500):  # keep below SQLite's limit on parameters
            chunk = keys[start:start + 500]
            rows = self._db.execute(f"SELECT key, outcome, code_version FROM trials WHERE key IN "
                                    f"({', '.join('?' * len(chunk))})", chunk).fetchall()
            out.update((k, (o, v)) for k, o, v in rows)
        return out

    def record(self, key: str) -> TrialRecord | None:
        """The stored trial ``key``, or ``None``."""
        names = [f.name for f in dataclasses.fields(TrialRecord)]
        row = self._db.execute(f"SELECT {', '.join(names)} FROM trials WHERE key = ?", (key,)).fetchone()
        if row is None:
            return None
        d = dict(zip(names, row))
        for k in ("config", "summary", "metrics"):
            d[k] = self._json(d[k])
        return TrialRecord(**d)

    def wall_times(self) -> list[tuple[str, int, str, str, float]]:
        """``(config JSON, robots, method, planner, wall time in s)`` of every stored trial with a
        wall time: what a cost estimate needs, without parsing every summary."""
        return [tuple(row) for row in self._db.execute(
            "SELECT config, n_robots, method, planner, wall_time FROM trials WHERE wall_time IS NOT NULL")]

    def code_versions(self) -> dict[str, int]:
        """Number of stored trials per code version."""
        return dict(self._db.execute("SELECT code_version, COUNT(*) FROM trials GROUP BY code_version "
                                     "ORDER BY code_version").fetchall())

    def numerics(self) -> dict[str, int]:
        """Number of stored trials per machine numerics (:func:`nodnav.provenance.numerics`; trials
        stored before it was recorded count under ``unknown``)."""
        return dict(self._db.execute("SELECT COALESCE(json_extract(summary, '$.numerics'), 'unknown'), COUNT(*) "
                                     "FROM trials GROUP BY 1 ORDER BY 1").fetchall())

    def stale_count(self) -> int:
        """Number of rows kept in ``stale_trials`` (trials re-run under another code version)."""
        return self._db.execute("SELECT COUNT(*) FROM stale_trials").fetchone()[0]

    def records(self, study: str | None = None, **filters) -> list[TrialRecord]:
        """Stored trials of ``study`` (all studies if ``None``) matching ``filters``, in factor then seed order.

        A filter is a column of :data:`FACTOR_COLUMNS` and a value or a list of accepted values,
        e.g. ``records("paper", scenario="3r-case2", players=[1, 2])``.
        """
        where, params = _where(study, filters)
        names = [f.name for f in dataclasses.fields(TrialRecord)]
        rows = self._db.execute(f"SELECT {', '.join(names)} FROM trials{where} "
                                "ORDER BY scenario, players, init, bias, planner, method, seed", params).fetchall()
        out = []
        for row in rows:
            d = dict(zip(names, row))
            for k in ("config", "summary", "metrics"):
                d[k] = self._json(d[k])
            out.append(TrialRecord(**d))
        return out

    def _json(self, text: str):
        try:
            return json.loads(text)
        except (TypeError, ValueError):
            raise StoreError(f"{self.path}: not a usable results database (a stored row does not parse); "
                             "if it is damaged, use another --db file") from None

    def outcome_counts(self, by=("scenario", "players"), study: str | None = None, **filters) -> dict[tuple, dict[str,
                                                                                                                  int]]:
        """Number of trials of each outcome per group of the columns ``by``.

        ``{("3r-case2", 2): {"success": 38, "deadlock": 2}, ...}``; outcomes with no trial are left out.
        """
        by = tuple(by)
        for column in by:
            if column not in FACTOR_COLUMNS:
                raise StoreError(f"cannot group by '{column}'; use some of {', '.join(FACTOR_COLUMNS)}")
        where, params = _where(study, filters)
        group = ", ".join(by)
        select = f"{group}, " if by else ""
        rows = self._db.execute(f"SELECT {select}outcome, COUNT(*) FROM trials{where} "
                                f"GROUP BY {select}outcome ORDER BY {select}outcome", params).fetchall()
        out: dict[tuple, dict[str, int]] = {}
        for row in rows:
            out.setdefault(tuple(row[:len(by)]), {})[row[len(by)]] = row[len(by) + 1]
        return out

    def studies(self) -> dict[str, dict]:
        """Every stored study's specification, by name."""
        return {name: self._json(spec) for name,
                spec in self._db.execute("SELECT name, spec FROM studies ORDER BY name")}

    def count(self, study: str | None = None, **filters) -> int:
        """Number of stored trials of ``study`` matching ``filters``."""
        where, params = _where(study, filters)
        return self._db.execute(f"SELECT COUNT(*) FROM trials{where}", params).fetchone()[0]


class _Guarded:
    """An sqlite3 connection whose every database error becomes one :class:`StoreError` line
    naming the file (a damaged file can fail on any page, at any query)."""

    def __init__(self, connection: sqlite3.Connection, path: Path):
        self._c, self._path = connection, path

    def _call(self, target, name: str, *args):
        try:
            out = getattr(target, name)(*args)
        except (sqlite3.Error, UnicodeDecodeError) as exc:  # damaged text decodes badly
            what = "stored text that does not decode" if isinstance(exc, UnicodeDecodeError) else exc
            raise StoreError(f"{self._path}: not a usable results database ({what}); if it is damaged, "
                             "use another --db file") from None
        return _GuardedCursor(self, out) if isinstance(out, sqlite3.Cursor) else out

    def execute(self, *args):
        return self._call(self._c, "execute", *args)

    def executemany(self, *args):
        return self._call(self._c, "executemany", *args)

    def executescript(self, *args):
        return self._call(self._c, "executescript", *args)

    def close(self) -> None:
        self._c.close()


class _GuardedCursor:
    """A cursor of :class:`_Guarded`: rows are read lazily, so reading can fail too."""

    def __init__(self, guard: _Guarded, cursor: sqlite3.Cursor):
        self._g, self._cursor = guard, cursor

    def fetchone(self):
        return self._g._call(self._cursor, "fetchone")

    def fetchall(self):
        return self._g._call(self._cursor, "fetchall")

    def __iter__(self):
        return iter(self.fetchall())
