"""The README opens with the two commands, and CI runs exactly the second one; the documented bounds
(docs/reference-bounds.md, generated from the code, and docs/limits.md) name every bound of a scenario."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _commands() -> list[str]:
    lines = (ROOT / "README.md").read_text().splitlines()
    return [lines[k + 1] for k, line in enumerate(lines) if line.strip() == "```bash"][:2]


def test_readme_opens_with_main_job_and_tests():
    main_job, tests = _commands()
    assert "nodnav run" in main_job and "--out" in main_job
    assert "pytest" in tests


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert _commands()[1] in ci


def test_docs_state_every_bound_of_a_scenario():
    from nodnav.scenario.bounds import declared_ranges
    from nodnav.scenario.limits import MAX_STRATEGIES

    table = (ROOT / "docs" / "reference-bounds.md").read_text()
    for key in declared_ranges():
        assert f"`{key}`" in table, key
    text = (ROOT / "docs" / "limits.md").read_text()
    assert f"`MAX_STRATEGIES` = {MAX_STRATEGIES}" in text


def test_main_job_installs_only_what_a_trial_needs():
    main_job = _commands()[0]
    assert "pip install -e ." in main_job and "[all]" not in main_job and "[dev]" not in main_job
