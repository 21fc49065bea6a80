"""Run a small study into a results database, then write its report, from Python.

    python examples/sweep_and_report.py [OUT_DIR]
"""

import sys
from pathlib import Path

import nodnav

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out")
out.mkdir(parents=True, exist_ok=True)

study = {"name": "example", "scenarios": ["2r-case1"], "players": [0, "all"], "trials": 2}
summary = nodnav.run_sweep(study, out / "results.sqlite")
print(f"{summary.total} trials, {summary.done} run now, {summary.skipped} stored before: {dict(summary.outcomes)}")

report = nodnav.build_report(out / "results.sqlite", out / "report", heatmap_grid=5, rerun_snapshots=False)
print(report.reason)
print((out / "report" / "report.md").read_text().splitlines()[0])
