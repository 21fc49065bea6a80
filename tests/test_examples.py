"""Every script in examples/ runs as documented (README, "Use from Python")."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def run(script: str, *args: str) -> str:
    done = subprocess.run([sys.executable, str(EXAMPLES / script), *args], capture_output=True, text=True,
                          timeout=300, env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_every_example_is_run_here():
    tested = {"trial_with_figure.py", "run_cautious_planner.py", "cautious_planner.py", "sweep_and_report.py",
              "random_policy_env.py", "hand_policy_env.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_a_trial_with_its_figure(tmp_path):
    out = run("trial_with_figure.py", str(tmp_path))
    assert "2r-case1: success" in out
    figure = tmp_path / "2r-case1-snapshots.png"
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_planner_of_ones_own_is_named_in_a_scenario_file():
    out = run("run_cautious_planner.py")
    assert "planner 'cautious'" in out and "speed_factor=0.8" in out
    assert "2r-cautious: " in out


def test_the_cautious_planners_own_setting_is_checked_when_the_scenario_loads(tmp_path):
    sys.path.insert(0, str(EXAMPLES))
    try:
        import cautious_planner  # noqa: F401
        import nodnav

        text = (EXAMPLES / "cautious_scenario.yaml").read_text().replace("speed_factor: 0.8", "speed_factor: 2")
        (tmp_path / "bad.yaml").write_text(text)
        with pytest.raises(nodnav.ScenarioError, match=r"planner.speed_factor: must be from 0.1 to 1, got 2"):
            nodnav.load_scenario(tmp_path / "bad.yaml")
    finally:
        sys.path.remove(str(EXAMPLES))


def test_a_sweep_and_its_report(tmp_path):
    out = run("sweep_and_report.py", str(tmp_path))
    assert "4 trials, 4 run now" in out
    assert (tmp_path / "report" / "report.md").read_text().startswith("# nodnav")


needs_rl = pytest.mark.skipif(importlib.util.find_spec("pettingzoo") is None, reason="needs nodnav[rl]")


@needs_rl
def test_a_random_policy_among_nod_robots():
    out = run("random_policy_env.py", "3r-case4", "30")
    assert "agents ['robot_1'], observation size 30" in out and "random policy: return" in out


@needs_rl
def test_a_hand_written_policy_among_nod_robots_arrives():
    out = run("hand_policy_env.py", "2r-case1", "1")
    assert "hand-written policy for robot 1 in 2r-case1" in out and "arrived" in out
