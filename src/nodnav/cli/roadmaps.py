"""The ``roadmaps`` command: build (or load) every PRM* roadmap ahead of time."""

from __future__ import annotations

import argparse
import re
import sys

from nodnav.cli.interrupts import workers_ignore_interrupts
from nodnav.cli.terminal import jobs, plural, whole
from nodnav.errors import NodnavError, shown
from nodnav.paths import output_dir


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
    from nodnav.scenario.params import PRMParams

    scenario = load_scenario(args.scenario)
    prm = scenario.with_overrides(**{"planner.name": "prm"}).planner  # the scenario's PRM* settings
    assert isinstance(prm, PRMParams)  # the planner named prm reads its settings into PRMParams
    counts = _robot_counts(args.robots)
    cache = output_dir(resolve_cache_dir(args.cache_dir or prm.cache_dir), "--cache-dir")
    if not args.execute:
        return 0
    from tqdm import tqdm

    start = time.perf_counter()
    # Ctrl-C stops the command alone: its build processes do not see it (nodnav.cli.interrupts).
    with workers_ignore_interrupts(), tqdm(total=1, unit="vertex", file=sys.stderr, dynamic_ncols=True, desc="roadmaps",
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
                                     vertices_per_robot=args.vertices or prm.roadmap_vertices,
                                     cache_dir=str(cache), n_jobs=args.jobs, progress=progress)
    print(format_build_reports(reports))
    print(f"{plural(len(reports), 'roadmap')} ready in {time.perf_counter() - start:.1f} s (cache {cache})")
    return 0


def add_parsers(sub) -> None:
    """The subcommand of this module."""
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
