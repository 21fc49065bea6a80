"""How a scenario's outcomes depend on the QP solver's warm starts, whose solutions agree to
about 1e-12 (docs/safety.md, "Parking where one can start again").

    python tools/warm_start_sensitivity.py 4r-case1 --players 1 --seeds 1-200 --mode default
    python tools/warm_start_sensitivity.py 4r-case1 --players 1 --seeds 1-200 --mode tracking-cold \
        --set execution.restart_gap=false

Modes: ``default`` (every step solved: ``controller.skip_unpassable`` off); ``skip`` (on);
``tracking-cold`` (every step solved, every tracking QP without a warm start);
``drop-evasive-after-hopeless`` (every step solved, then the evasive QPs' warm starts forgotten
after every step where no plan could pass: what the skip does to the warm starts, without
skipping). Prints the outcomes and the seeds that did not
succeed. Changes nothing in the package: the modes wrap its functions in this process only.
"""

from __future__ import annotations

import argparse
import collections
import sys

import numpy as np

from nodnav.control import mpc as mpc_module
from nodnav.control import qp
from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import run_trial

MODES = ("default", "skip", "tracking-cold", "drop-evasive-after-hopeless")


def _install(mode: str) -> None:
    """Wrap the solver or the controller for ``mode`` (this process only)."""
    if mode == "tracking-cold":
        solve = qp.SolverEffort.solve

        def cold_tracking(self, hessian, gradient, rows, lower, tol, bounds=None, start_active=None, kind=None,
                          like=None):
            if kind is not None and not isinstance(kind, tuple):  # the tracking QP's kind is its problem
                kind = like = None
            return solve(self, hessian, gradient, rows, lower, tol, bounds, start_active, kind, like)

        qp.SolverEffort.solve = cold_tracking
    elif mode == "drop-evasive-after-hopeless":
        control = mpc_module.BSplineMPC.control

        def forgetting(self, request):
            result = control(self, request)
            if request.braking is not None and mpc_module.no_plan_passes(
                    request.braking, self._walls, np.asarray(request.position, float).reshape(2),
                    np.asarray(request.velocity, float).reshape(2), self.dt):
                for kind in [k for k in self._starts if isinstance(k, tuple)]:  # the evasive QPs' kinds
                    del self._starts[kind]
            return result

        mpc_module.BSplineMPC.control = forgetting


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--players", type=int, default=None)
    parser.add_argument("--seeds", default="1-200", help="A-B, inclusive")
    parser.add_argument("--mode", choices=MODES, default="default")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args(argv)
    try:
        first, last = (int(s) for s in args.seeds.split("-"))
        overrides = dict(item.split("=", 1) for item in args.set)
    except ValueError:
        print(f"warm_start_sensitivity: --seeds A-B and --set KEY=VALUE, got {args.seeds!r}, {args.set}",
              file=sys.stderr)
        return 2
    overrides = {k: {"true": True, "false": False}.get(v, v) for k, v in overrides.items()}
    overrides.setdefault("controller.skip_unpassable", args.mode == "skip")
    scenario = load_scenario(args.scenario, overrides=overrides)
    if args.players is not None:
        scenario = scenario.with_overrides(game_players=args.players)
    _install(args.mode)
    outcomes, failed = collections.Counter(), []
    for seed in range(first, last + 1):
        outcome = run_trial(scenario, seed=seed).outcome
        outcomes[outcome] += 1
        if outcome != "success":
            failed.append(seed)
    print(f"{args.scenario} players {args.players} seeds {args.seeds} mode {args.mode} {overrides}: "
          f"{dict(outcomes)}; not succeeding: {failed}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
