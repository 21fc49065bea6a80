"""The ``bench`` command: speed of the planners, the MPC, whole trials, scaling in N_r (one core), or the QP solvers.

Each target is one function that measures and prints; :data:`BENCHMARKS` maps the target's name
to it, and the command line's choices come from that mapping and ``scaling``
(:mod:`nodnav.cli.scaling`), which has options of its own.
"""

from __future__ import annotations

import argparse
import json
import sys

from nodnav.cli.scaling import add_scaling_options, check_scaling_only, cmd_bench_scaling
from nodnav.cli.settings import add_set_option, parse_settings
from nodnav.cli.terminal import plural, whole
from nodnav.errors import NodnavError, shown


def _bench_planners(args: argparse.Namespace) -> None:
    from nodnav.bench.planners import main_bench_planners
    from nodnav.scenario.catalogue import PAPER_SCENARIOS

    print(main_bench_planners(args.json, planners=tuple(args.planner or ("fast", "prm")),
                              scenarios=PAPER_SCENARIOS))  # every order of 5-8 robots would be too many


def _bench_mpc(args: argparse.Namespace) -> None:
    import dataclasses

    from nodnav.bench.mpc import benchmark_mpc

    result = benchmark_mpc()
    d = dataclasses.asdict(result)
    if args.json:
        print(json.dumps(d))
    else:
        print(f"MPC, 4 robots queueing through the corridor: {result.solves} calls, median "
              f"{1e3 * result.median:.2f} ms, p95 {1e3 * result.p95:.2f} ms, max {1e3 * result.max:.1f} ms "
              f"(QP median {1e3 * result.qp_median:.2f} ms, p95 {1e3 * result.qp_p95:.2f} ms); "
              f"{result.infeasible} infeasible; min gap {result.min_separation:.3f} m; "
              f"{plural(result.arrived, 'robot')} arrived")


def _bench_sim(args: argparse.Namespace) -> None:
    from nodnav.bench.closed_loop import benchmark_closed_loop

    overrides, _ = parse_settings(args.settings)
    results = [benchmark_closed_loop(args.scenario[0], planner, seeds=tuple(range(1, (args.trials or 3) + 1)),
                                     breakdown=not args.no_breakdown, players=args.sim_players or "all",
                                     overrides=overrides, settings=tuple(args.settings or ()))
               for planner in (args.planner or ("fast",))]
    if args.json:
        print(json.dumps([r.to_dict() for r in results]))
    else:
        for r in results:
            print(r.format())


def _bench_solvers(args: argparse.Namespace) -> None:
    from nodnav.bench.solvers import compare_solvers

    result = compare_solvers(tuple(args.scenario), seeds=tuple(range(1, args.seeds + 1)))
    print(json.dumps(result.to_dict()) if args.json else result.format())


#: What ``nodnav bench TARGET`` measures: the target's name -> the function that measures it and prints.
BENCHMARKS = {
    "planners": _bench_planners,
    "mpc": _bench_mpc,
    "sim": _bench_sim,
    "solvers": _bench_solvers,
}


def _cmd_bench(args: argparse.Namespace) -> int:
    from nodnav.errors import nearest_hint
    from nodnav.planning import PLANNERS
    from nodnav.scenario.loading import load_scenario

    if args.settings and args.target != "sim":
        raise NodnavError("--set: only 'nodnav bench sim' takes it")
    args.sim_players = None
    if args.target == "sim" and args.players is not None:  # one number of game players, or 'all'
        from nodnav.cli.scaling import parse_players

        text, args.players = args.players, None
        args.sim_players, *more = parse_players(text)
        if more:
            raise NodnavError(f"--players: 'bench sim' takes one number of game players or 'all', got {shown(text)}")
    check_scaling_only(args)
    if args.target == "scaling":
        return cmd_bench_scaling(args)
    for p in args.planner or ():
        if p not in PLANNERS:
            raise NodnavError(f"--planner: unknown planner {shown(p)}{nearest_hint(p, PLANNERS, 'planners')}")
    if args.seeds is not None and args.target != "solvers":
        raise NodnavError("--seeds: only 'nodnav bench solvers' takes it")
    overrides, labels = parse_settings(args.settings)
    for key, option in (("planner.name", "--planner"), ("game_players", "--players")):
        if key in overrides:  # the benchmark sets these itself, after the overrides
            raise NodnavError(f"{labels[key]}: 'bench sim' takes {key} from {option}; give it there")
    if args.target == "sim":
        if len(args.scenario or ()) > 1:
            raise NodnavError(f"--scenario: 'bench sim' takes one scenario, got {len(args.scenario)}")
        args.scenario = args.scenario or ["4r-case2"]
    if args.target == "solvers":
        from nodnav.bench.solvers import DEFAULT_SCENARIOS, DEFAULT_SEEDS, missing_solvers

        args.scenario = list(dict.fromkeys(args.scenario or DEFAULT_SCENARIOS))
        args.seeds = args.seeds or DEFAULT_SEEDS
        if missing := missing_solvers():
            raise NodnavError(f"'bench solvers' needs {' and '.join(missing)}: install the solvers extra, "
                              "pip install 'nodnav[solvers]'")
    for name in args.scenario or () if args.target in ("sim", "solvers") else ():
        load_scenario(name, overrides or None, labels)  # a bad --set fails here, naming the option
    if not args.execute:
        return 0
    if not args.json:
        print(f"measuring {args.target} (this takes from seconds to a few minutes; -v logs each step)...",
              file=sys.stderr)
    BENCHMARKS[args.target](args)
    return 0


def add_parsers(sub) -> None:
    """The subcommand of this module."""
    p = sub.add_parser("bench", help="measure speed: planners, the MPC, whole trials, scaling in N_r (one core), or "
                       "the QP solvers on the MPC's QPs")
    p.add_argument("target", choices=(*BENCHMARKS, "scaling"), help="what to measure")
    add_scaling_options(p)
    p.add_argument("--planner", action="append", help="planner(s) to measure (repeatable; default fast and prm, "
                   "fast for sim)")
    p.add_argument("--scenario", action="append", help="scenario of the 'sim' benchmark (default 4r-case2); "
                   "'solvers': scenarios whose MPC QPs are recorded (repeatable; default "
                   "3r-case1 and 4r-case1)")
    p.add_argument("--seeds", type=whole(1, 20), help="'solvers': trials per scenario, seeds 1..N (default 1)")
    p.add_argument("--trials", type=whole(1, 100), help="trials (seeds 1..N) of the 'sim' benchmark "
                   "(default 3) and per cell of 'scaling' (default 1)")
    p.add_argument("--no-breakdown", action="store_true", help="'sim': skip the second, measured run of each "
                   "trial that splits its time by stage (decision, planning, control set-up, QP solve, simulation, "
                   "bookkeeping)")
    add_set_option(p)
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_bench)
