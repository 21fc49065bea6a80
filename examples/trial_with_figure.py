"""Run one trial of a built-in scenario from Python and draw its snapshot figure.

    python examples/trial_with_figure.py [OUT_DIR]
"""

import sys
from pathlib import Path

import nodnav

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out")
out.mkdir(parents=True, exist_ok=True)

scenario = nodnav.load_scenario("2r-case1")
result = nodnav.run_trial(scenario, seed=1)
print(f"{scenario.name}: {result.outcome} after {result.sim_time:.1f} s simulated, "
      f"robots entered the corridor in the order {[k + 1 for k in result.history.entry_order]}")
print("wrote", nodnav.save_snapshots(result.history, out / "2r-case1-snapshots.png"))
