"""The ``nodnav`` command: parses arguments, checks them, calls the library, prints. No logic of its own.

Every command checks all of its input (options, scenario files, output paths) before it starts
any long work; a problem is one line ``nodnav: error: ...`` naming what the user typed, and exit
code 2. Exit code 1 means the work ran but did not succeed (a plan failed, trials raised), 130
an interrupt. :func:`main` with ``execute=False`` does every check and stops before the work
(the fuzz tests use it).
"""

from __future__ import annotations

import argparse
import json
import logging
import re
import sys
import traceback
from pathlib import Path

import numpy as np

from nodnav.errors import NodnavError, one_line, shown, shown_path
from nodnav.paths import output_dir, output_file, safe_filename
from nodnav.terminal import (
    MAX_SEED,
    Parser,
    compile_notice,
    jobs,
    note,
    plural,
    real,
    trial_summary_lines,
    warm_kernels,
    whole,
)

# -- commands --------------------------------------------------------------------------------------


def _cmd_scenarios(args: argparse.Namespace) -> int:
    from nodnav.scenario.files import builtin_names
    from nodnav.scenario.loading import load_scenario

    for name in builtin_names():
        s = load_scenario(name)
        print(f"{name:10s} {plural(s.n_robots, 'robot')}  {s.description}")
    return 0


def _cmd_show(args: argparse.Namespace) -> int:
    from nodnav.scenario.families import is_family
    from nodnav.scenario.files import builtin_names
    from nodnav.scenario.loading import load_scenario

    if is_family(args.scenario):
        return _show_family(args)
    if args.seed is not None or args.count is not None:
        raise NodnavError(f"--seed and --count draw from a family; {args.scenario!r} is a scenario "
                          "(list the families with 'nodnav families')")
    names = builtin_names() if args.scenario == "all" else [args.scenario]
    scenarios = [load_scenario(n) for n in names]
    out = output_file(args.out)
    if not args.execute:
        return 0
    from nodnav.viz.scenario import save_gallery, save_scenario_figure

    path = save_gallery(scenarios, out) if args.scenario == "all" else save_scenario_figure(scenarios[0], out)
    print(f"wrote {path}")
    return 0


def _first_seed(value: int | None) -> int:
    seed = 1 if value is None else value
    if seed < 0:
        raise NodnavError(f"--seed: expected a whole number >= 0, got {seed}")
    return seed


def _show_family(args: argparse.Namespace) -> int:
    from nodnav.scenario.draws import draw
    from nodnav.scenario.families import load_family
    from nodnav.viz.family import save_family_gallery

    family = load_family(args.scenario)
    if Path(args.out).suffix.lower() != ".png":
        raise NodnavError(f"--out: the gallery is a PNG image; give a file name ending in .png, got {args.out!r}")
    seed, count = _first_seed(args.seed), 6 if args.count is None else args.count
    if not 1 <= count <= 60:
        raise NodnavError(f"--count: expected a whole number in 1..60 for a gallery, got {count}")
    scenarios = [draw(family, s) for s in range(seed, seed + count)]
    if not args.execute:
        return 0
    title = (f"family {family.name}, draws {seed}..{seed + count - 1}: origins (discs, numbered) and destinations "
             "(crosses)")
    print(f"wrote {save_family_gallery(title, scenarios, args.out)}")
    return 0


def _cmd_families(args: argparse.Namespace) -> int:
    from nodnav.scenario.families import builtin_families, load_family

    for name in builtin_families():
        f = load_family(name)
        print(f"{name:11s} {f.count[0]}-{f.count[1]} robots  {f.description}")
    return 0


def _cmd_generate(args: argparse.Namespace) -> int:
    from nodnav.scenario.draws import write_draws
    from nodnav.scenario.families import load_family

    if not 1 <= args.count <= 100_000:
        raise NodnavError(f"--count: expected a whole number in 1..100000, got {args.count}")
    written = write_draws(load_family(args.family), _first_seed(args.seed), args.count, args.out)
    print(f"wrote {len(written)} scenario files to {args.out} ({written[0].name} .. {written[-1].name})")
    return 0


def _cmd_heatmap(args: argparse.Namespace) -> int:
    from nodnav.decision.heatmap import steady_state_selection, z_grid

    out = output_file(args.out) if args.out else None
    if not args.execute:
        return 0
    if not args.json and (args.grid > 41 or abs(args.u) > 200):
        print(f"integrating eq. (1) from {args.grid * args.grid} initial opinions (a minute or more for large "
              "|u| and grids)...", file=sys.stderr)
    result = steady_state_selection(args.u, z_grid(args.grid))
    if out:
        from nodnav.viz.heatmap import plot_heatmap

        plot_heatmap(result, out)
    if args.json:
        print(json.dumps({"u": args.u, "z_values": result.z_values.tolist(), "x11": result.x11.tolist()}))
    else:
        x = result.x11
        print(f"u = {args.u:g}: lim x11 ranges over [{x.min():.4f}, {x.max():.4f}] on a {args.grid}x{args.grid} grid"
              f"{'' if result.converged else ' (NOT converged: ' + result.reason + ')'}")
        if out:
            print(f"wrote {out}")
    return 0


def _parse_order(text: str, n: int) -> tuple[int, ...]:
    parts = text.split(",")
    if len(parts) != n or not all(re.fullmatch(r"\s*[0-9]{1,3}\s*", p) for p in parts):
        raise NodnavError(f"--order: expected the {n} robot numbers separated by commas, e.g. "
                          f"{','.join(str(k) for k in range(n, 0, -1))}; got {shown(text)}")
    order = tuple(int(k) - 1 for k in parts)
    if sorted(order) != list(range(n)):
        raise NodnavError(f"--order: expected a permutation of 1..{n} for this {n}-robot scenario, got {shown(text)}")
    return order


#: Scenario settings the options of ``run`` and ``plan`` override, and the option that names each in errors.
OPTION_KEYS = {"game_players": "--players", "opinion.init": "--init", "opinion.bias": "--bias", "opinion.u": "--u",
               "planner.name": "--planner", "sim.observation_noise": "--noise"}


def scenario_with_options(args: argparse.Namespace):
    """The scenario named on the command line with the options that override its settings;
    an error about an option names the option."""
    from nodnav.experiments.study import parse_bias, parse_players
    from nodnav.scenario.loading import load_scenario

    scenario = load_scenario(args.scenario)
    changes = {}
    if getattr(args, "players", None) is not None:
        changes["game_players"] = parse_players(args.players, "--players")
    if getattr(args, "init", None):
        changes["opinion.init"] = args.init
    if getattr(args, "bias", None) is not None:
        changes["opinion.bias"] = dict(parse_bias(args.bias, "--bias"))  # type: ignore[assignment]
    if getattr(args, "u", None) is not None:
        changes["opinion.u"] = args.u
    if getattr(args, "planner", None):
        changes["planner.name"] = args.planner
    if getattr(args, "noise", None) is not None:
        changes["sim.observation_noise"] = args.noise
    return scenario.with_options(changes, OPTION_KEYS) if changes else scenario


def _cmd_plan(args: argparse.Namespace) -> int:
    scenario = scenario_with_options(args)
    order = _parse_order(args.order, scenario.n_robots)
    out = output_file(args.out) if args.out else None
    if not args.execute:
        return 0
    from nodnav.geometry import min_pair_distance
    from nodnav.planning import PlanRequest, make_planner
    from nodnav.planning.base import corridor_entry_order

    planner = make_planner(scenario.planner, scenario.world)
    request = PlanRequest(world=scenario.world, positions=scenario.origins,
                          velocities=np.zeros_like(scenario.origins), destinations=scenario.destinations,
                          radii=scenario.radii, max_speeds=scenario.max_speeds, order=order)
    result = planner.plan(request)
    fine_times = np.arange(result.trajectory.times[0], result.trajectory.times[-1] + 1e-9, 0.02)
    summary = {
        "success": result.success,
        "reason": result.reason,
        "cost": result.cost if np.isfinite(result.cost) else None,
        "min_separation_m": min_pair_distance(result.trajectory.positions_at(fine_times)),
        "corridor_entry_order": [k + 1 for k in corridor_entry_order(scenario.world, result.trajectory)],
        "duration_s": result.trajectory.duration,
        "compute_time_ms": 1e3 * result.compute_time,
        "planner": scenario.planner.name,
    }
    if out:
        from nodnav.viz.plan import save_plan_figure

        save_plan_figure(scenario, result, out)
    if args.json:
        print(json.dumps(summary))
    else:
        status = "ok" if result.success else f"FAILED: {result.reason}"
        print(f"{scenario.name} order {args.order} with {summary['planner']}: {status}")
        if result.success:
            print(f"  cost {result.cost:.2f}, duration {result.trajectory.duration:.1f} s, "
                  f"closest approach {summary['min_separation_m']:.3f} m between centres, "
                  f"corridor entry order {','.join(map(str, summary['corridor_entry_order']))}, "
                  f"planned in {summary['compute_time_ms']:.1f} ms")
        if out:
            print(f"wrote {out}")
    return 0 if result.success else 1


def write_trial_outputs(result, out: Path) -> list[Path]:
    """History, snapshot figure and animation of a finished trial, into ``out``; the file names
    come from the scenario's name made safe (:func:`~nodnav.paths.safe_filename`)."""
    from nodnav.viz.trial import save_animation, save_snapshots

    out.mkdir(parents=True, exist_ok=True)
    h = result.history
    stem = f"{safe_filename(h.scenario.name)}-{safe_filename(h.method)}-seed{h.seed}"
    written = [h.save(out / f"{stem}.npz"), save_snapshots(h, out / f"{stem}-snapshots.png")]
    written += save_animation(h, out / f"{stem}.gif")
    return written


def _cmd_run(args: argparse.Namespace) -> int:
    from nodnav.errors import nearest_hint
    from nodnav.experiments.study import known_methods

    scenario = scenario_with_options(args)
    if args.method not in known_methods():
        raise NodnavError(f"--method: unknown method {shown(args.method)}"
                          f"{nearest_hint(args.method, known_methods(), 'methods')}")
    out = output_dir(args.out) if args.out else None
    if not args.execute:
        return 0
    from tqdm import tqdm

    from nodnav.sim.simulator import run_trial

    bar = None

    def progress(t: float, limit: float) -> None:
        nonlocal bar
        if bar is None:  # started after the first step, so compiling does not count towards the rate
            bar = tqdm(total=round(limit, 1), initial=round(t, 1), unit="sim s", delay=2.0, leave=False,
                       file=sys.stderr, bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} simulated s "
                       "[{elapsed}, at most {remaining} more]")
        elif t - bar.n >= 1.0 - 1e-9:  # redraw once per simulated second
            bar.update(t - bar.n)

    result = run_trial(scenario, args.method, args.seed, progress=None if args.json else progress)
    if bar is not None:
        bar.close()
    written = write_trial_outputs(result, out) if out else []
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print("\n".join(trial_summary_lines(result, scenario, args.method, args.seed)))
        for path in written:
            print(f"wrote {path}")
    return 0


def _cmd_replay(args: argparse.Namespace) -> int:
    from nodnav.sim.history import History

    history = History.load(args.history)
    out = output_dir(args.out)
    if not args.execute:
        return 0
    from nodnav.viz.trial import save_animation, save_snapshots

    stem = safe_filename(Path(args.history).stem)
    written = [save_snapshots(history, out / f"{stem}-snapshots.png")]
    if not args.no_animation:
        written += save_animation(history, out / f"{stem}.gif")
    for path in written:
        print(f"wrote {path}")
    return 0


def _cmd_sweep(args: argparse.Namespace) -> int:
    from nodnav.experiments.study import OPTION_NAMES, load_study, study_from_dict
    from nodnav.experiments.sweep import run_sweep
    from nodnav.scenario.loading import load_scenario

    name = args.name
    if name is None and args.families and not args.scenarios and not args.study:  # group results by family
        name = "+".join(Path(f).stem for f in args.families)
    options = {k: v for k, v in {"name": name, "scenarios": args.scenarios, "players": args.players,
                                 "init": args.init, "bias": args.bias, "planners": args.planners,
                                 "methods": args.methods, "trials": args.trials,
                                 "families": args.families}.items() if v is not None}
    spec = (load_study(args.study, overrides=options) if args.study
            else study_from_dict(options, "command line", OPTION_NAMES))
    for name in spec.scenarios:  # every scenario loads before any trial runs
        load_scenario(name)
    db = output_file(args.db, "--db", formats=None)
    if not args.execute:
        return 0
    if args.jobs > 1 and args.scheduler is None:
        warm_kernels()
    said = []

    def notify(text: str) -> None:
        said.append(text)
        note(text)

    summary = run_sweep(spec, db, jobs=args.jobs, scheduler=args.scheduler, quiet=args.quiet,
                        retry_errors=args.retry_errors, allow_mixed=args.allow_mixed, notify=notify)
    for line in summary.notes:
        if line not in said:
            print(f"note: {line}", file=sys.stderr)
    outcomes = ", ".join(f"{k} {v}" for k, v in sorted(summary.outcomes.items()))
    print(f"{spec.name}: {plural(summary.total, 'trial')}, {summary.done} run, {summary.skipped} already stored, "
          f"{plural(summary.errors, 'error')} in {summary.wall_time:.1f} s"
          f"{f' ({outcomes})' if outcomes else ''} -> {db}")
    if not summary.success:
        print(f"nodnav: {summary.reason}", file=sys.stderr)
    return 0 if summary.success else 1


# -- reproduce and report: the paper's whole evaluation -------------------------------------------


def _names(text: str | None) -> tuple[str, ...]:
    return tuple(n.strip() for n in text.split(",") if n.strip()) if text else ()


def _reproduce_command(args: argparse.Namespace) -> str:
    """The command line as the report quotes it: every option that was given or matters."""
    words = ["nodnav reproduce", f"--trials {args.trials}", f"--jobs {args.jobs}", f"--out {args.out}",
             f"--method-trials {args.method_trials}"]
    for flag, value in (("--methods", args.methods), ("--planners", args.planners), ("--budget", args.budget),
                        ("--fig2c-grid", args.fig2c_grid), ("--fig2c-trials", args.fig2c_trials),
                        ("--db", args.db), ("--scenarios", args.scenarios),
                        ("--parts", args.parts)):
        if value is not None:
            words.append(f"{flag} {value:g}" if isinstance(value, float) else f"{flag} {value}")
    if args.allow_mixed:
        words.append("--allow-mixed")
    return " ".join(words)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from nodnav.reporting.reproduce import PARTS, ReproduceOptions, check_options, reproduce

    out = output_dir(args.out)
    db = output_file(args.db, "--db", formats=None) if args.db else None
    options = ReproduceOptions(
        out=out, trials=args.trials, jobs=args.jobs, methods=_names(args.methods),
        planners=_names(args.planners) or ("fast",), budget_minutes=args.budget, fig2c_grid=args.fig2c_grid,
        fig2c_trials=args.fig2c_trials, method_trials=args.method_trials, scenarios=_names(args.scenarios),
        parts=_names(args.parts) or PARTS, heatmap_grid=args.heatmap_grid, db=db,
        command=_reproduce_command(args), quiet=args.quiet, allow_mixed=args.allow_mixed)
    check_options(options)
    if not args.execute:
        return 0
    if args.jobs > 1:
        warm_kernels()
    result = reproduce(options, notify=note)
    for cut in result.cuts:
        print(f"cut: {cut}", file=sys.stderr)
    print(result.reason)
    return 0 if result.success else 1


def _cmd_report(args: argparse.Namespace) -> int:
    from nodnav.experiments.store import ResultStore
    from nodnav.reporting.report import build_report

    db = Path(args.db)
    try:
        found = "file" if db.is_file() else "directory" if db.is_dir() else None
        if found == "file" and db.stat().st_size == 0:
            raise NodnavError(f"{shown_path(args.db)}: an empty file, not a results database")
    except (OSError, ValueError):
        found = None
    if found != "file":
        what = "a directory" if found else "no such file"
        raise NodnavError(f"{shown_path(args.db)}: no such results database ({what}"
                          "); write one with nodnav sweep or nodnav reproduce")
    with ResultStore(db):  # opens, checks and migrates it before any work
        pass
    out = output_dir(args.out)
    if not args.execute:
        return 0
    result = build_report(db, out, command=f"nodnav report {args.db} --out {args.out}",
                          heatmap_grid=args.heatmap_grid, rerun_snapshots=not args.no_rerun)
    if not result.success:
        print(f"nodnav: {result.reason}", file=sys.stderr)
        return 1
    print(result.reason)
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from nodnav.errors import nearest_hint
    from nodnav.planning import PLANNERS
    from nodnav.scenario.loading import load_scenario

    for p in args.planner or ():
        if p not in PLANNERS:
            raise NodnavError(f"--planner: unknown planner {shown(p)}{nearest_hint(p, PLANNERS, 'planners')}")
    if args.target == "sim":
        load_scenario(args.scenario)
    if not args.execute:
        return 0
    if not args.json:
        print(f"measuring {args.target} (this takes from seconds to a few minutes; -v logs each step)...",
              file=sys.stderr)
    if args.target == "planners":
        from nodnav.planning.bench import main_bench_planners

        print(main_bench_planners(args.json, planners=tuple(args.planner or ("fast", "prm"))))
    elif args.target == "mpc":
        import dataclasses

        from nodnav.control.bench import benchmark_mpc

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
    else:
        from nodnav.sim.bench import benchmark_closed_loop

        results = [benchmark_closed_loop(args.scenario, planner, seeds=tuple(range(1, args.trials + 1)))
                   for planner in (args.planner or ("fast",))]
        if args.json:
            print(json.dumps([r.to_dict() for r in results]))
        else:
            for r in results:
                print(r.format())
    return 0


def _robot_counts(text: str) -> tuple[int, ...]:
    from nodnav.scenario.limits import MAX_ROBOTS

    parts = [p.strip() for p in text.split(",")]
    if not all(re.fullmatch(r"[0-9]{1,2}", p) and 1 <= int(p) <= MAX_ROBOTS for p in parts):
        raise NodnavError(f"--robots: expected robot counts from 1 to {MAX_ROBOTS} separated by commas, e.g. 2,3,4; "
                          f"got {shown(text)}")
    return tuple(sorted({int(p) for p in parts}))


def _cmd_roadmaps(args: argparse.Namespace) -> int:
    import time

    from nodnav.planning.roadmap_cache import build_all_roadmaps, format_build_reports, resolve_cache_dir
    from nodnav.scenario.loading import load_scenario

    scenario = load_scenario(args.scenario)
    prm = scenario.with_overrides(**{"planner.name": "prm"}).planner  # the scenario's PRM* settings
    counts = _robot_counts(args.robots)
    cache = output_dir(resolve_cache_dir(args.cache_dir or prm.cache_dir), "--cache-dir")  # type: ignore[attr-defined]
    if not args.execute:
        return 0
    from tqdm import tqdm

    start = time.perf_counter()
    with tqdm(total=1, unit="vertex", file=sys.stderr, dynamic_ncols=True, desc="roadmaps",
              bar_format="{desc}: {percentage:3.0f}% of the vertices |{bar}| [{elapsed}<{remaining}]{postfix}") as bar:
        ready = 0

        def progress(report, vertices: int, total: int) -> None:
            nonlocal ready
            ready += 1
            bar.total = total
            bar.set_postfix_str(f"{ready} ready, last {plural(report.n_robots, 'robot')} {report.pattern} "
                                f"{'(cached)' if report.from_cache else f'built in {report.build_seconds:.0f} s'}",
                                refresh=False)
            bar.update(vertices)

        reports = build_all_roadmaps(scenario.world, radius=float(scenario.radii[0]), robot_counts=counts,
                                     vertices_per_robot=args.vertices or prm.roadmap_vertices,  # type: ignore[attr-defined]
                                     cache_dir=str(cache), n_jobs=args.jobs, progress=progress)
    print(format_build_reports(reports))
    print(f"{plural(len(reports), 'roadmap')} ready in {time.perf_counter() - start:.1f} s (cache {cache})")
    return 0


# -- the parser ------------------------------------------------------------------------------------


def _add_report_parsers(sub) -> None:
    """The ``reproduce`` and ``report`` subcommands."""
    from nodnav.experiments.study import MAX_TRIALS

    p = sub.add_parser("reproduce", help="run the paper's whole evaluation into DIR and write DIR/report.md")
    p.add_argument("--trials", type=whole(1, MAX_TRIALS), default=40, help="trials per cell (default 40)")
    p.add_argument("--jobs", type=jobs, default=1, help="local worker processes (default 1)")
    p.add_argument("--out", default="nodnav-reproduce", help="output directory (default nodnav-reproduce)")
    p.add_argument("--methods", help="methods to compare, e.g. nod,orca (default: every registered method)")
    p.add_argument("--planners", help="planners to compare, e.g. fast,prm (default fast: no comparison)")
    p.add_argument("--budget", type=real(0, 1e5), default=18.0,
                   help="minutes for the whole command; trials are cut evenly to fit (default 18; 0: no limit)")
    p.add_argument("--fig2c-grid", type=whole(2, 41), default=5, help="Fig. 2c grid points per axis (default 5)")
    p.add_argument("--fig2c-trials", type=whole(1, MAX_TRIALS), default=2, help="Fig. 2c trials per cell (default 2)")
    p.add_argument("--method-trials", type=whole(1, MAX_TRIALS), default=20,
                   help="trials per cell of the methods comparison, at most --trials (default 20)")
    p.add_argument("--db", help="results database (default DIR/results.sqlite, DIR the --out directory)")
    p.add_argument("--parts", help="parts to run, e.g. success,table1 (default all: success, table1, table2, "
                   "fig2c, methods, planners)")
    p.add_argument("--scenarios", help="scenarios of the success rates and comparisons, e.g. 3r-case1,4r-case4 "
                   "(default every built-in scenario)")
    p.add_argument("--allow-mixed", action="store_true",
                   help="keep trials stored by another code version as results instead of running them again")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--heatmap-grid", type=whole(2, 101), default=41,
                   help="Fig. 2a/2b grid points per axis (default 41)")
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser("report", help="write report.md and its figures from a results database")
    p.add_argument("db", help="results database written by 'nodnav reproduce' or 'nodnav sweep'")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--no-rerun", action="store_true", help="do not re-run the snapshot trials")
    p.add_argument("--heatmap-grid", type=whole(2, 101), default=41,
                   help="Fig. 2a/2b grid points per axis (default 41)")
    p.set_defaults(func=_cmd_report)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``nodnav`` command."""
    from nodnav.experiments.study import MAX_TRIALS
    from nodnav.planning import PLANNERS
    from nodnav.sim import METHODS

    # Choices and their help come from the registries (plugins included).
    planners, methods = PLANNERS.help_text(), METHODS.help_text()
    parser = Parser(prog="nodnav", description="nodnav: opinion-driven multi-robot navigation through a "
                     "narrow corridor")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("scenarios", help="list the built-in scenarios")
    p.set_defaults(func=_cmd_scenarios)

    p = sub.add_parser("show", help="draw a scenario (or 'all' for the gallery, or a family's draws)")
    p.add_argument("scenario", help="built-in name, YAML path, FAMILY:SEED, 'all', or a family (a gallery of draws)")
    p.add_argument("--out", required=True, help="picture to write (.png, .pdf, .svg, ...; a family's gallery: .png)")
    p.add_argument("--seed", type=int, help="family only: first draw (default 1)")
    p.add_argument("--count", type=int, help="family only: number of draws (default 6)")
    p.set_defaults(func=_cmd_show)

    p = sub.add_parser("families", help="list the built-in scenario families")
    p.set_defaults(func=_cmd_families)

    p = sub.add_parser("generate", help="write scenario files drawn from a family")
    p.add_argument("family", help="built-in family name or family YAML path")
    p.add_argument("--seed", type=int, default=1, help="first draw (default 1)")
    p.add_argument("--count", type=int, default=1, help="number of draws: seeds N..N+K-1 (default 1)")
    p.add_argument("--out", required=True, help="directory for the scenario files (FAMILY-SEED.yaml)")
    p.set_defaults(func=_cmd_generate)

    p = sub.add_parser("heatmap", help="steady-state strategy selection of the pure NOD (Fig. 2a/2b)")
    p.add_argument("--u", type=real(-1000, 1000), required=True, help="attention parameter u (from -1000 to 1000)")
    p.add_argument("--grid", type=whole(2, 101), default=41, help="grid points per axis over [-10, 10] (default 41)")
    p.add_argument("--out", help="picture to write (.png, .pdf, .svg, ...)")
    p.add_argument("--json", action="store_true", help="print the grid as JSON")
    p.set_defaults(func=_cmd_heatmap)

    p = sub.add_parser("plan", help="plan a joint path for one passing order from the scenario's origins")
    p.add_argument("scenario", help="built-in name, YAML path, or FAMILY:SEED (e.g. mixed:17)")
    p.add_argument("--order", required=True, help="passing order as robot numbers, e.g. 2,1,3")
    p.add_argument("--planner", help=f"planner ({planners}; default: the scenario's)")
    p.add_argument("--out", help="picture to write (.png, .pdf, .svg, ...)")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=_cmd_plan)

    p = sub.add_parser("run", help="simulate one trial of a scenario")
    p.add_argument("scenario", help="built-in name, YAML path, or FAMILY:SEED (e.g. mixed:17)")
    p.add_argument("--seed", type=whole(0, MAX_SEED), default=1, help="trial seed (default 1)")
    p.add_argument("--players", help="game players per robot: a number or 'all' (default: the scenario's)")
    p.add_argument("--init", choices=("zero", "distance"), help="initial opinions (default: the scenario's)")
    p.add_argument("--bias", help="bias per strategy, e.g. S3=150,S5=150 (default: the scenario's)")
    p.add_argument("--u", type=float, help="attention parameter u (default: the scenario's)")
    p.add_argument("--planner", help=f"planner ({planners}; default: the scenario's)")
    p.add_argument("--method", default="nod", help=f"navigation method, nod by default ({methods})")
    p.add_argument("--noise", type=float, help="observation noise standard deviation in m (default: the scenario's)")
    p.add_argument("--out", help="directory for the history, snapshot figure and animation")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("sweep", help="run many trials, resumably, into a results database")
    p.add_argument("--study", help="YAML study file (the options below override its keys)")
    p.add_argument("--name", help="study name (default: the study file's stem, else 'sweep')")
    p.add_argument("--scenario", action="append", dest="scenarios",
                   help="built-in name, YAML path, FAMILY:SEED, or 'all' for every built-in scenario (repeatable)")
    p.add_argument("--family", action="append", dest="families",
                   help="generated family (built-in name or YAML path): trial seed s runs draw s (repeatable)")
    p.add_argument("--players", action="append",
                   help="game players K or 'all' (repeatable; default: each scenario's own)")
    p.add_argument("--init", action="append", choices=("zero", "distance"),
                   help="initial opinions (repeatable; default: each scenario's own)")
    p.add_argument("--bias", action="append",
                   help="e.g. S3=150,S5=150 or 'none' (repeatable; default: each scenario's own)")
    p.add_argument("--planner", action="append", dest="planners",
                   help=f"planner, one of {', '.join(PLANNERS)} (repeatable; default: each scenario's own)")
    p.add_argument("--method", action="append", dest="methods",
                   help=f"navigation method, one of {', '.join(METHODS)} (repeatable; default nod)")
    p.add_argument("--trials", help=f"seeds 1..N for every combination (default 1, at most {MAX_TRIALS})")
    p.add_argument("--db", default="nodnav-results.sqlite", help="results database (default nodnav-results.sqlite)")
    p.add_argument("--jobs", type=jobs, default=1, help="local worker processes (default 1)")
    p.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://host:8786 (needs nodnav[cluster])")
    p.add_argument("--retry-errors", action="store_true", help="run trials stored as errors again")
    p.add_argument("--allow-mixed", action="store_true",
                   help="keep trials stored by another code version as results instead of running them again")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("bench", help="measure speed: planners, the MPC, or whole trials (one core)")
    p.add_argument("target", choices=("planners", "mpc", "sim"), help="what to measure")
    p.add_argument("--planner", action="append", help="planner(s) to measure (repeatable; default fast and prm, "
                   "fast for sim)")
    p.add_argument("--scenario", default="4r-case2", help="scenario of the 'sim' benchmark (default 4r-case2)")
    p.add_argument("--trials", type=whole(1, 100), default=3, help="trials (seeds 1..N) of the 'sim' benchmark "
                   "(default 3)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser("roadmaps", help="build (or load) every PRM* roadmap ahead of time")
    p.add_argument("action", choices=("build",), help="what to do")
    p.add_argument("--scenario", default="3r-case1", help="scenario whose world and robot radius to use "
                   "(default 3r-case1)")
    p.add_argument("--robots", default="1,2,3,4", help="robot counts, e.g. 2,3,4 (default 1,2,3,4)")
    p.add_argument("--vertices", type=whole(10, 10_000),
                   help="vertices per robot (default: the scenario's planner setting, 2000)")
    p.add_argument("--cache-dir", help="roadmap cache directory (default $NODNAV_CACHE or ~/.cache/nodnav)")
    p.add_argument("--jobs", type=jobs, default=2, help="parallel build processes (default 2)")
    p.set_defaults(func=_cmd_roadmaps)

    p = sub.add_parser("replay", help="redraw the pictures of a saved trial history")
    p.add_argument("history", help="a .npz history written by 'nodnav run --out'")
    p.add_argument("--out", required=True, help="directory for the pictures")
    p.add_argument("--no-animation", action="store_true", help="only the snapshot figure")
    p.set_defaults(func=_cmd_replay)
    _add_report_parsers(sub)
    return parser


def main(argv: list[str] | None = None, *, execute: bool = True) -> int:
    """Entry point of the ``nodnav`` console command; returns the exit code.

    With ``execute`` false every check runs and the command stops before its work.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except NodnavError as exc:
        print(f"nodnav: error: {one_line(exc)}", file=sys.stderr)  # type: ignore[arg-type]
        return 2
    except SystemExit as exc:  # --help, printed by argparse
        return exc.code if isinstance(exc.code, int) else 0
    args.execute = execute
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        with compile_notice():
            return args.func(args)
    except NodnavError as exc:
        print(f"nodnav: error: {one_line(exc)}", file=sys.stderr)  # type: ignore[arg-type]
        return 2
    except KeyboardInterrupt:
        print("nodnav: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug: still one line, the traceback only when asked for
        if args.verbose:
            traceback.print_exc()
        print(f"nodnav: internal error: {one_line(f'{type(exc).__name__}: {exc}', 300)} (a bug in nodnav; "
              "please report it with the command; -v shows the traceback)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
