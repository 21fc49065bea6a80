"""tools/paired_outcomes.py: McNemar's exact test by hand, and trials paired across two results
databases by configuration and seed, an ignored setting left out."""

import json
import sqlite3

import pytest


@pytest.fixture(scope="module")
def tool(tool_script):
    return tool_script("paired_outcomes")


def test_mcnemar_exact_by_hand(tool):
    # 4 discordant pairs one way, 1 the other: P(X <= 1) for X ~ Bin(5, 1/2) is 6/32; two-sided 12/32.
    assert tool.mcnemar_exact(4, 1) == pytest.approx(12 / 32)
    assert tool.mcnemar_exact(1, 4) == pytest.approx(12 / 32)
    assert tool.mcnemar_exact(0, 6) == pytest.approx(2 / 64)
    assert tool.mcnemar_exact(0, 0) == 1.0


def _database(path, trials):
    """A results database with the columns the tool reads: (scenario, seed, skip, success) each."""
    db = sqlite3.connect(path)
    db.execute("create table trials (key text primary key, study text, scenario text, seed integer, "
               "config text, success integer)")
    db.execute("create table study_trials (study text, key text)")
    for i, (scenario, seed, skip, success) in enumerate(trials):
        config = {"method": "nod", "scenario": {"name": scenario, "execution": {"skip_at_rest": skip}, "robots": []}}
        db.execute("insert into trials values (?, 'fam', ?, ?, ?, ?)", (f"k{i}", scenario, seed, json.dumps(config),
                                                                       success))
        db.execute("insert into study_trials values ('fam', ?)", (f"k{i}",))
    db.commit()
    db.close()


def test_trials_pair_by_configuration_and_seed_with_the_setting_ignored(tool, tmp_path):
    draws = [("mixed:1", 1), ("mixed:2", 2), ("mixed:3", 3), ("crowded:1", 1)]
    off, on = tmp_path / "off.sqlite", tmp_path / "on.sqlite"
    _database(off, [(s, seed, False, ok) for (s, seed), ok in zip(draws, [1, 1, 0, 1])])
    _database(on, [(s, seed, True, ok) for (s, seed), ok in zip(draws, [1, 0, 1, 1])] + [("mixed:9", 9, True, 1)])
    a, b = tool.outcomes(str(off), ("execution.skip_at_rest",)), tool.outcomes(str(on), ("execution.skip_at_rest",))
    groups = tool.paired_counts(a, b, "family")
    assert groups["mixed"] == {"both": 1, "only_a": 1, "only_b": 1}
    assert groups["crowded"] == {"both": 1}
    # Without ignoring the setting nothing pairs: the configurations differ.
    assert not tool.outcomes(str(off)).keys() & tool.outcomes(str(on)).keys()
