"""Use a planner defined outside nodnav, named in a scenario file.

    python examples/run_cautious_planner.py
"""

from pathlib import Path

import cautious_planner  # noqa: F401  (registers the planner "cautious")
import nodnav

here = Path(__file__).parent
scenario = nodnav.load_scenario(here / "cautious_scenario.yaml")
print(f"planner {scenario.planner.name!r} with {scenario.planner}")
result = nodnav.run_trial(scenario, seed=1)
print(f"{scenario.name}: {result.outcome} after {result.sim_time:.1f} s simulated")
