"""The commands of studies of many trials: ``sweep``, ``reproduce`` (the paper's whole evaluation), ``report``."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from nodnav.cli.interrupts import workers_ignore_interrupts
from nodnav.cli.settings import add_set_option, parse_settings
from nodnav.cli.terminal import jobs, note, plural, real, warm_kernels, whole
from nodnav.errors import NodnavError, shown_path
from nodnav.paths import output_dir, output_file


def _cmd_sweep(args: argparse.Namespace) -> int:
    from nodnav.experiments.batch import run_sweep
    from nodnav.experiments.study import OPTION_NAMES, load_study, study_from_dict
    from nodnav.scenario.loading import load_scenario

    name = args.name
    if name is None and args.families and not args.scenarios and not args.study:  # group results by family
        name = "+".join(Path(f).stem for f in args.families)
    settings, labels = parse_settings(args.settings)
    options = {k: v for k, v in {"name": name, "scenarios": args.scenarios, "players": args.players,
                                 "init": args.init, "bias": args.bias, "planners": args.planners,
                                 "methods": args.methods, "trials": args.trials,
                                 "families": args.families, "set": settings or None}.items() if v is not None}
    spec = (load_study(args.study, overrides=options) if args.study
            else study_from_dict(options, "command line", OPTION_NAMES))
    for name in spec.scenarios:  # every scenario loads, with the study's settings, before any trial runs
        load_scenario(name, spec.overrides, labels)
    db = output_file(args.db, "--db", formats=None)
    if not args.execute:
        return 0
    if args.jobs > 1 and args.scheduler is None:
        warm_kernels()
    said = []

    def notify(text: str) -> None:
        said.append(text)
        note(text)

    # Ctrl-C stops the command alone, not its local workers (nodnav.cli.interrupts); a Dask cluster's are remote.
    with workers_ignore_interrupts() if args.scheduler is None else contextlib.nullcontext():
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
    with workers_ignore_interrupts():  # Ctrl-C stops the command alone, not its workers
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


def add_parsers(sub) -> None:
    """The subcommands of this module."""
    from nodnav.experiments.study import MAX_TRIALS
    from nodnav.planning import PLANNERS
    from nodnav.sim import METHODS

    p = sub.add_parser("sweep", help="run many trials, resumably, into a results database")
    p.add_argument("--study", help="YAML study file (the options below override its keys)")
    p.add_argument("--name", help="study name (default: the study file's stem, else 'sweep')")
    p.add_argument("--scenario", action="append", dest="scenarios",
                   help="built-in name, YAML path, FAMILY:SEED, or a group of built-ins: 'all', 'paper' (the "
                   "paper's ten), 'crowds' (5-8 robots) (repeatable)")
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
    add_set_option(p)
    p.add_argument("--trials", help=f"seeds 1..N for every combination (default 1, at most {MAX_TRIALS})")
    p.add_argument("--db", default="nodnav-results.sqlite", help="results database (default nodnav-results.sqlite)")
    p.add_argument("--jobs", type=jobs, default=1, help="local worker processes (default 1)")
    p.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://host:8786 (needs nodnav[cluster])")
    p.add_argument("--retry-errors", action="store_true", help="run trials stored as errors again")
    p.add_argument("--allow-mixed", action="store_true",
                   help="keep trials stored by another code version as results instead of running them again")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_sweep)

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
                   "fig2c, methods, reduction, planners, scaling, mixed-teams)")
    p.add_argument("--scenarios", help="scenarios of the success rates and comparisons, e.g. 3r-case1,4r-case4 "
                   "(default the paper's ten)")
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
