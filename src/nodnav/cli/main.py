"""The entry point of the ``nodnav`` command: parse, run the command, and turn every failure into its exit code."""

from __future__ import annotations

import logging
import os
import sys
import traceback

from nodnav.cli.interrupts import quiet_resource_trackers
from nodnav.cli.parser import build_parser
from nodnav.cli.terminal import compile_notice
from nodnav.errors import NodnavError, one_line


def main(argv: list[str] | None = None, *, execute: bool = True) -> int:
    """Entry point of the ``nodnav`` console command; returns the exit code.

    With ``execute`` false every check runs and the command stops before its work.
    """
    quiet_resource_trackers()
    try:
        args = build_parser().parse_args(argv)
    except KeyboardInterrupt:  # while the command's modules load
        print("nodnav: interrupted", file=sys.stderr)
        return 130
    except NodnavError as exc:
        print(f"nodnav: error: {one_line(exc)}", file=sys.stderr)
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
        print(f"nodnav: error: {one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("nodnav: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (nodnav scenarios | head): stop quietly, as cat does
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # what is still buffered goes nowhere
        return 141
    except Exception as exc:  # a bug: still one line, the traceback only when asked for
        if args.verbose:
            traceback.print_exc()
        print(f"nodnav: internal error: {one_line(f'{type(exc).__name__}: {exc}', 300)} (a bug in nodnav; "
              "please report it with the command; -v shows the traceback)", file=sys.stderr)
        return 3
