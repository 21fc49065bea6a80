"""The study key ``roles``: some robots of every scenario run another method."""

import pytest

from nodnav.experiments.study import StudyError, study_from_dict
from nodnav.experiments.sweep import expand


def test_roles_set_robots_methods_per_scenario_and_make_distinct_trials():
    spec = study_from_dict({"scenarios": ["2r-case1", "3r-case4"], "roles": ["none", {1: "person"},
                                                                             {"last": "closest-first"}], "trials": 2})
    assert spec.roles == ((), (("1", "person"),), (("last", "closest-first"),))
    trials = expand(spec).trials
    assert len(trials) == 2 * 3 * 2
    methods = {(t.scenario.name, tuple(r.method for r in t.scenario.robots)) for t in trials}
    assert ("3r-case4", (None, None, "closest-first")) in methods and ("2r-case1", ("person", None)) in methods
    assert ("3r-case4", (None, None, None)) in methods
    assert study_from_dict(spec.to_dict()) == spec


def test_a_role_for_a_robot_a_scenario_lacks_is_left_out_with_a_note():
    spec = study_from_dict({"scenarios": ["2r-case1"], "roles": [{3: "person"}]})
    out = expand(spec)
    assert not out.trials and "roles {'3': 'person'} skipped (2 robots)" in out.notes[0]


@pytest.mark.parametrize("roles, message", [
    ({0: "person"}, "expected a robot number from 1 or 'last'"),
    ({1: "persn"}, "unknown method 'persn'"),
    ("everyone", "expected 'none' or a mapping"),
])
def test_bad_roles_are_one_line(roles, message):
    with pytest.raises(StudyError, match=message):
        study_from_dict({"scenarios": ["2r-case1"], "roles": [roles]})


def test_a_stored_mixed_team_is_tabled_by_roles(tmp_path):
    from nodnav.experiments.batch import run_sweep
    from nodnav.experiments.store import ResultStore
    from nodnav.experiments.teams import team_rows
    from nodnav.reporting.mixed_teams import team_table

    spec = study_from_dict({"name": "teams", "scenarios": ["2r-case1"], "roles": [{1: "person"}, {"last": "person"}],
                            "trials": 1})
    db = tmp_path / "r.sqlite"
    run_sweep(spec, db_path=db, jobs=1, quiet=True)
    rows = team_rows(ResultStore(db).records("teams"))
    assert [r.label for r in rows] == ["robot 1: person", "last robot: person"]
    assert all(r.trials == 1 and r.robots_ok_count in (0, 1) for r in rows)
    assert team_table(rows)[0].startswith("| roles | trials |")
