"""The ``export`` command: a saved trial history as CSV, Parquet or a ROS 2 bag (:mod:`nodnav.export`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from nodnav.errors import NodnavError, shown_path
from nodnav.paths import output_dir, output_file


def _cmd_export(args: argparse.Namespace) -> int:
    from nodnav.export import check_format, export_history
    from nodnav.sim.history import History

    check_format(args.format)
    history = History.load(args.history)
    if args.format == "rosbag2":  # a bag is a directory the writer creates
        out = Path(args.out)
        try:
            exists = out.exists() or out.is_symlink()
        except (OSError, ValueError):
            raise NodnavError(f"--out: {shown_path(out)} is not a usable directory name") from None
        if exists:
            raise NodnavError(f"--out: {shown_path(out)} exists; a bag is written as a new directory "
                              "(remove it or give another name)")
        output_dir(out.parent if str(out.parent) else ".")
    else:
        out = output_file(args.out, formats=None, default_suffix=f".{args.format}")
    if not args.execute:
        return 0
    if not args.no_plans:
        print("replaying the trial for its plans (seconds to a minute; --no-plans skips them)...", file=sys.stderr)
    try:
        result = export_history(history, args.format, out, plans=not args.no_plans)
    except OSError as exc:
        raise NodnavError(f"--out: cannot write {shown_path(out)} ({exc.strerror or exc})") from None
    print(result.reason)
    return 0 if result.success else 1


def add_parsers(sub) -> None:
    """The subcommand of this module."""
    p = sub.add_parser("export", help="write a saved trial as CSV or Parquet (pandas) or a ROS 2 bag (RViz)")
    p.add_argument("history", help="a .npz history written by 'nodnav run SCENARIO --out DIR'")
    p.add_argument("--format", required=True, help="csv, parquet (one row per robot and step) or rosbag2 "
                   "(poses and plans per robot; a new directory)")
    p.add_argument("--out", required=True, help="file to write (a new directory for rosbag2)")
    p.add_argument("--no-plans", action="store_true", help="do not replay the trial for its plans (faster)")
    p.set_defaults(func=_cmd_export)
