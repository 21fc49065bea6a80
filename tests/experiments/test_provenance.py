"""Provenance: every stored trial records the code version, old databases are migrated, and a
resumed sweep never silently mixes code versions."""

import platform
import shutil
import sqlite3
from contextlib import closing
from pathlib import Path

import pytest

import nodnav
import nodnav.experiments.store as store_module
import nodnav.experiments.sweep as sweep_module
from nodnav.experiments.batch import run_sweep
from nodnav.experiments.store import ResultStore
from nodnav.experiments.study import SweepSpec
from nodnav.provenance import UNKNOWN, code_version, numerics, result_files, source_hash


@pytest.fixture
def cheap_trial(trial_result):
    def trial(scenario, method, seed):
        return trial_result("success", {"seed": seed, "sim_time_s": 1.0, "wall_time_s": 0.01})

    return trial


def test_code_version_is_the_package_version_and_a_hash_of_the_installed_source():
    root = Path(nodnav.__file__).resolve().parent
    assert code_version() == f"{nodnav.__version__}+{source_hash(root)[:12]}"
    names = {p.relative_to(root).as_posix() for p in result_files(root)}
    assert {"sim/simulator.py", "control/mpc.py", "scenario/builtin/3r-case4.yaml"} <= names
    assert not names & {"cli/main.py", "cli/runs.py", "viz/trial.py", "reporting/report.py"}


def test_the_hash_follows_what_determines_a_result_and_nothing_else(tmp_path):
    root = Path(nodnav.__file__).resolve().parent
    copy = tmp_path / "nodnav"
    shutil.copytree(root, copy, ignore=shutil.ignore_patterns("__pycache__"))
    before = source_hash(copy)
    (copy / "cli" / "runs.py").write_text((copy / "cli" / "runs.py").read_text() + "\n# a comment\n")
    (copy / "viz" / "trial.py").write_text("")
    assert source_hash(copy) == before  # presentation only
    (copy / "sim" / "simulator.py").write_text((copy / "sim" / "simulator.py").read_text() + "\n")
    assert source_hash(copy) != before
    after_sim = source_hash(copy)
    builtin = copy / "scenario" / "builtin" / "2r-case1.yaml"
    builtin.write_text(builtin.read_text() + "# edited\n")
    assert source_hash(copy) != after_sim


def test_every_stored_trial_records_the_code_version(tmp_path, cheap_trial):
    db = tmp_path / "r.sqlite"
    run_sweep(SweepSpec("s", ("2r-case1",), trials=2), db, quiet=True, trial_fn=cheap_trial)
    with ResultStore(db) as store:
        assert {r.code_version for r in store.records()} == {code_version()}
        assert store.code_versions() == {code_version(): 2}


def test_every_stored_trial_records_the_numerics_of_the_machine_that_ran_it(tmp_path, cheap_trial):
    """The architecture and the numerical libraries' versions, read here independently."""
    import daqp  # noqa: F401  (installed: a dependency)
    import numpy as np
    import scipy

    assert numerics().startswith(f"{platform.machine()}; NumPy {np.__version__} SIMD ")
    assert f"; SciPy {scipy.__version__};" in numerics() and "; DAQP " in numerics()
    db = tmp_path / "r.sqlite"
    run_sweep(SweepSpec("s", ("2r-case1",), trials=2), db, quiet=True, trial_fn=cheap_trial)
    with ResultStore(db) as store:
        assert {r.summary["numerics"] for r in store.records()} == {numerics()}
        assert store.numerics() == {numerics(): 2}


def test_a_trial_that_ends_in_an_error_records_the_numerics_too(tmp_path):
    def failing(scenario, method, seed):
        raise RuntimeError("broken on purpose")

    db = tmp_path / "r.sqlite"
    run_sweep(SweepSpec("s", ("2r-case1",), trials=2), db, quiet=True, trial_fn=failing)
    with ResultStore(db) as store:
        assert [r.outcome for r in store.records()] == ["error", "error"]
        assert store.numerics() == {numerics(): 2}


SCHEMA_1 = store_module._SCHEMA.replace(",\n    code_version   TEXT NOT NULL DEFAULT 'unknown'\n", "\n")


def test_a_schema_1_database_is_migrated_and_its_rows_marked_unknown(tmp_path):
    assert "code_version" not in SCHEMA_1
    db = tmp_path / "old.sqlite"
    with closing(sqlite3.connect(db)) as c:
        c.executescript(SCHEMA_1)
        c.execute("INSERT INTO trials (key, study, scenario, n_robots, method, planner, players, init, bias, seed, "
                  "config, outcome, success, summary, metrics, version, created) VALUES ('k', 's', '2r-case1', 2, "
                  "'nod', 'fast', 1, 'zero', '', 1, '{}', 'success', 1, '{}', '{}', '0.1.0', 'then')")
        c.execute("PRAGMA user_version=1")
        c.commit()
    with ResultStore(db) as store:
        [record] = store.records()
        assert record.code_version == UNKNOWN and record.outcome == "success"
    with closing(sqlite3.connect(db)) as c:
        assert c.execute("PRAGMA user_version").fetchone()[0] == store_module.SCHEMA_VERSION


def _pretend_code_changed(monkeypatch, version: str) -> None:
    monkeypatch.setattr(sweep_module, "code_version", lambda: version)
    monkeypatch.setattr(store_module, "current_code_version", lambda: version)


def test_a_resumed_sweep_reruns_trials_of_another_code_version_and_keeps_the_old_rows(tmp_path, monkeypatch,
                                                                                      cheap_trial):
    db = tmp_path / "r.sqlite"
    spec = SweepSpec("s", ("2r-case1",), trials=3)
    first = run_sweep(spec, db, quiet=True, trial_fn=cheap_trial)
    assert first.done == 3 and first.stale == 0
    _pretend_code_changed(monkeypatch, "9.9.9+new")
    said = []
    second = run_sweep(spec, db, quiet=True, trial_fn=cheap_trial, notify=said.append)
    assert second.done == 3 and second.skipped == 0 and second.stale == 3
    assert len(said) == 1 and "3 stored trials of this study came from another code version" in said[0]
    assert "run again under 9.9.9+new" in said[0] and said[0] in second.notes
    with ResultStore(db) as store:
        assert store.code_versions() == {"9.9.9+new": 3}  # the results hold one version only
        assert store.stale_count() == 3  # the old rows are kept apart
    third = run_sweep(spec, db, quiet=True, trial_fn=cheap_trial, notify=said.append)
    assert third.done == 0 and third.skipped == 3 and third.stale == 0 and len(said) == 1


def test_allow_mixed_keeps_trials_of_another_code_version(tmp_path, monkeypatch, cheap_trial):
    db = tmp_path / "r.sqlite"
    run_sweep(SweepSpec("s", ("2r-case1",), trials=2), db, quiet=True, trial_fn=cheap_trial)
    _pretend_code_changed(monkeypatch, "9.9.9+new")
    said = []
    out = run_sweep(SweepSpec("s", ("2r-case1",), trials=3), db, quiet=True, trial_fn=cheap_trial,
                    allow_mixed=True, notify=said.append)
    assert out.done == 1 and out.skipped == 2 and out.stale == 2
    assert "--allow-mixed keeps them" in said[0]
    with ResultStore(db) as store:
        assert store.code_versions() == {code_version(): 2, "9.9.9+new": 1}
        assert store.stale_count() == 0


@pytest.mark.parametrize("allow", [False, True])
def test_the_policy_is_said_on_the_command_line(tmp_path, monkeypatch, capsys, allow, cheap_trial):
    from nodnav.cli import main

    db = tmp_path / "r.sqlite"
    run_sweep(SweepSpec("sweep", ("2r-case1",), trials=1), db, quiet=True, trial_fn=cheap_trial)
    _pretend_code_changed(monkeypatch, "9.9.9+new")
    monkeypatch.setattr(sweep_module, "_default_trial_fn", lambda: cheap_trial)
    argv = ["sweep", "--scenario", "2r-case1", "--db", str(db), "--quiet"] + (["--allow-mixed"] if allow else [])
    assert main(argv) == 0
    captured = capsys.readouterr()
    notes = [line for line in captured.err.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and "another code version" in notes[0]
    assert ("0 run, 1 already stored" if allow else "1 run, 0 already stored") in captured.out
