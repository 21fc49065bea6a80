"""``nodnav bench scaling``: its options, their checks, and what it prints.

:mod:`nodnav.cli.bench` adds :func:`add_scaling_options` to the ``bench`` parser and hands the
``scaling`` target to :func:`cmd_bench_scaling`.
"""

from __future__ import annotations

import argparse
import json
import re
import sys

from nodnav.cli.terminal import real
from nodnav.errors import NodnavError, shown
from nodnav.paths import output_file

#: What ``bench scaling`` runs without options: a minute or two on one core (docs: Performance).
DEFAULT_ROBOTS = "2..8"
DEFAULT_PLAYERS = "1,2,3,all"
DEFAULT_TRIALS = 1


def add_scaling_options(p: argparse.ArgumentParser) -> None:
    """The ``bench`` options only ``scaling`` takes."""
    p.add_argument("--robots", help=f"scaling: robot counts, e.g. 2..8 or 4,6,8 (default {DEFAULT_ROBOTS})")
    p.add_argument("--players", help=f"scaling: game players per robot, e.g. 1,2,3,all (default {DEFAULT_PLAYERS})")
    p.add_argument("--out", help="scaling: picture of the four figures against N_r (.png, .pdf, .svg, ...)")
    p.add_argument("--time-limit", type=real(0.1, 3600), help="scaling: end each trial after this many simulated "
                   "seconds (default: the scenario's own limit, trials run to their end)")


def parse_robots(text: str) -> tuple[int, ...]:
    """``2..8``, ``4,6,8`` or a mix (``2..4,8``) as sorted robot counts from 2 to MAX_ROBOTS."""
    from nodnav.scenario.limits import MAX_ROBOTS

    counts: set[int] = set()
    for item in (p.strip() for p in text.split(",")):
        m = re.fullmatch(r"([0-9]{1,2})(?:\s*\.\.\s*([0-9]{1,2}))?", item)
        low, high = (int(m.group(1)), int(m.group(2) or m.group(1))) if m else (0, 0)
        if not m or not 2 <= low <= high <= MAX_ROBOTS:
            raise NodnavError(f"--robots: expected robot counts from 2 to {MAX_ROBOTS} as a range or a list, e.g. "
                              f"2..8 or 4,6,8; got {shown(text)}")
        counts.update(range(low, high + 1))
    return tuple(sorted(counts))


def parse_players(text: str) -> tuple[str, ...]:
    """``1,2,3,all``: whole numbers of game players (0 to MAX_ROBOTS - 1) or ``all``, in the order given."""
    from nodnav.scenario.limits import MAX_ROBOTS

    items = [p.strip() for p in text.split(",")]
    if not all(p == "all" or (re.fullmatch(r"[0-9]{1,2}", p) and int(p) < MAX_ROBOTS) for p in items):
        raise NodnavError(f"--players: expected numbers of game players from 0 to {MAX_ROBOTS - 1} or 'all', "
                          f"separated by commas, e.g. 1,2,3,all; got {shown(text)}")
    return tuple(dict.fromkeys("all" if p == "all" else str(int(p)) for p in items))


def check_scaling_only(args: argparse.Namespace) -> None:
    """Refuse the scaling options for another ``bench`` target."""
    for option in ("robots", "players", "out", "time_limit"):
        if args.target != "scaling" and getattr(args, option, None) is not None:
            raise NodnavError(f"--{option.replace('_', '-')}: only 'nodnav bench scaling' takes it")


def cmd_bench_scaling(args: argparse.Namespace) -> int:
    """Run ``nodnav bench scaling`` and print its table (or JSON); 1 if a cell's worker failed."""
    from nodnav.bench.scaling import benchmark_scaling

    if args.planner:
        raise NodnavError("--planner: 'bench scaling' measures the fast planner only")
    robots = parse_robots(args.robots or DEFAULT_ROBOTS)
    players = parse_players(args.players or DEFAULT_PLAYERS)
    out = output_file(args.out) if args.out else None
    if not args.execute:
        return 0
    if not args.json:
        print(f"measuring scaling: N_r {', '.join(map(str, robots))} x players {', '.join(players)}, "
             f"{args.trials or DEFAULT_TRIALS} trial(s) per cell, one worker process per cell on one core "
             "(a minute or two with the defaults)...", file=sys.stderr)

    def progress(done: int, total: int, label: str) -> None:
        if not args.json:
            print(f"  cell {done + 1}/{total}: {label}", file=sys.stderr)

    result = benchmark_scaling(robots, players, trials=args.trials or DEFAULT_TRIALS, time_limit=args.time_limit,
                               progress=progress)
    print(json.dumps(result.to_dict()) if args.json else result.format())
    if out is not None:
        from nodnav.viz.scaling import plot_scaling_benchmark

        path = plot_scaling_benchmark(result.to_dict(), out)
        if not args.json:
            print(f"wrote {path}")
    return 1 if result.errors else 0
