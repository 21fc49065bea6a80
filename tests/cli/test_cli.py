"""The command line: one clear line and a non-zero exit for bad input, never a traceback."""

import json

import pytest

from nodnav.cli import main


@pytest.mark.parametrize("text, message", [
    ("name: t\nrobots: [\n", "invalid YAML"),
    ("robots:\n  - {origin: [-5, 0], destination: [5, 0]}\ntime_limt: 3\n", "did you mean 'time_limit'"),
    ("robots:\n  - {origin: [0, 0.3], destination: [5, 0]}\n", "inside a wall"),
    ("robots:\n  - {origin: [-5, 0], destination: [5, 0]}\n  - {origin: [-5, 0.1], destination: [5, 1]}\n",
     "origins overlap"),
])
def test_bad_scenario_is_one_line_and_exit_2(tmp_path, capsys, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    assert main(["show", str(path), "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nodnav: error: ") and message in err and "\n" not in err


def test_bad_order_is_one_line(capsys):
    assert main(["plan", "3r-case2", "--order", "1,1,3"]) == 2
    assert "permutation of 1..3" in capsys.readouterr().err


def test_heatmap_json_shape(capsys):
    assert main(["heatmap", "--u", "1", "--grid", "3", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["u"] == 1 and out["z_values"] == [-10.0, 0.0, 10.0]
    assert len(out["x11"]) == 3 and all(len(row) == 3 for row in out["x11"])
    # u = 1 < 2: no consensus equilibrium, so every initial condition ends undecided at 1/2.
    assert all(abs(x - 0.5) < 1e-6 for row in out["x11"] for x in row)


def test_plan_json(capsys):
    assert main(["plan", "3r-case2", "--order", "2,1,3", "--planner", "fast", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["success"] and out["corridor_entry_order"] == [2, 1, 3]
    assert out["min_separation_m"] >= 0.4
