"""Check in closed loop that the MPC skips solving only where the full solve would refuse every plan.

Runs trials with the decisions of the full solve (``controller.skip_unpassable`` off, not the
default) and, at every control step with mutual braking, evaluates ``no_plan_passes`` on the
same request: wherever it says no plan can pass, the full solve must have ended in a refused plan
(braking or the committed trajectory), never in an accepted or evasive one. Exit code 1 if one did.

    .venv/bin/python tools/check_passing_bound.py 8r-head-on/2/1,2,3 crowded:1/-/1 ...

Each argument is ``SCENARIO/GAME_PLAYERS/SEEDS`` (``-``: the scenario's own players).
"""

from __future__ import annotations

import collections
import sys


def main(argv: list[str]) -> int:
    if not argv or any(a.count("/") != 2 for a in argv):
        print(__doc__, file=sys.stderr)
        return 2
    from nodnav.control import mpc as mpc_module
    from nodnav.control import mpc_braking
    from nodnav.scenario.loading import load_scenario
    from nodnav.sim.simulator import run_trial

    counts: collections.Counter = collections.Counter()
    control = mpc_module.BSplineMPC.control

    def checked(self, request):
        hopeless = ""
        if request.braking is not None:
            hopeless = mpc_braking.no_plan_passes(request.braking, self._walls, request.position,
                                                  request.velocity, self.dt)
        result = control(self, request)
        if hopeless:
            counts["skippable"] += 1
            if result.success or result.info.get("fallback") == "evasive":
                counts["accepted although skippable"] += 1
                print(f"ACCEPTED: {result.reason or 'tracking plan'} / {hopeless}")
        else:
            counts["solved"] += 1
        return result

    mpc_module.BSplineMPC.control = checked
    try:
        for spec in argv:
            name, players, seeds = spec.split("/")
            scenario = load_scenario(name, overrides={"controller.skip_unpassable": False})
            if players != "-":
                scenario = scenario.with_overrides(game_players=int(players))
            for seed in seeds.split(","):
                outcome = run_trial(scenario, seed=int(seed)).outcome
                print(f"{name} players={players} seed={seed}: {outcome}; {dict(counts)}", flush=True)
    finally:  # leave the package as it was (the check also runs inside the test suite)
        mpc_module.BSplineMPC.control = control
    if not counts["skippable"]:
        print("no step where the bound says no plan can pass: nothing was checked")
    return 1 if counts["accepted although skippable"] else 0

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
