"""The argument parser of the ``nodnav`` command: the global options and every group's subcommands."""

from __future__ import annotations

import argparse

from nodnav.cli import bench, exports, passages, roadmaps, runs, scenarios, studies
from nodnav.cli.terminal import Parser


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``nodnav`` command."""
    parser = Parser(prog="nodnav", description="nodnav: opinion-driven multi-robot navigation through a "
                    "narrow corridor")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for group in (scenarios, passages, runs, exports, studies, bench, roadmaps):
        group.add_parsers(sub)
    return parser
