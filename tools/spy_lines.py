"""Where a sampling profile's time goes, by source line: py-spy's raw output summed by the line each
sample was executing (docs/performance-17.md).

cProfile charges its own overhead to every Python call, so it inflates the glue between compiled
calls several times over. A sampling profiler does not: each sample is the stack at an instant.
Time spent inside a compiled kernel or DAQP shows on the Python line that called it.

    pip install py-spy
    py-spy record -r 500 -f raw -o spy.txt -- python -c "from nodnav.scenario.loading import \\
        load_scenario; from nodnav.sim.simulator import run_trial; s = load_scenario('4r-case1'); \\
        [run_trial(s, seed=k) for k in range(1, 4)]"
    python tools/spy_lines.py spy.txt --under run_trial --top 30

``--under`` keeps only the samples whose stack holds a frame naming that text (e.g. ``run_trial``,
to leave out imports and set-up). Prints each line's share of the kept samples, largest first.
"""

from __future__ import annotations

import argparse
import collections
import sys


def line_shares(lines, under: str = "") -> tuple[int, collections.Counter[str]]:
    """The samples kept and, for each innermost frame (function, file and line), how many of them
    it was executing, from py-spy's raw lines (``frame;frame;...;frame COUNT``)."""
    counts: collections.Counter[str] = collections.Counter()
    total = 0
    for line in lines:
        stack, _, count = line.rstrip("\n").rpartition(" ")
        if not stack or not count.isdigit():
            continue
        frames = stack.split(";")
        if under and not any(under in frame for frame in frames):
            continue
        total += int(count)
        counts[frames[-1]] += int(count)
    return total, counts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="spy_lines", description=__doc__.splitlines()[0])
    parser.add_argument("raw", help="py-spy's output of `record -f raw`")
    parser.add_argument("--under", default="", help="keep only samples with a frame naming this text")
    parser.add_argument("--top", type=int, default=30, help="lines to print (default 30)")
    args = parser.parse_args(argv)
    try:
        with open(args.raw) as raw:
            total, counts = line_shares(raw, args.under)
    except OSError as err:
        print(f"spy_lines: error: cannot read {args.raw!r}: {err.strerror}", file=sys.stderr)
        return 2
    if not total:
        print(f"spy_lines: error: no samples in {args.raw!r}" + (f" under {args.under!r}" if args.under else ""),
              file=sys.stderr)
        return 2
    print(f"{total} samples")
    for frame, count in counts.most_common(args.top):
        print(f"{100 * count / total:5.1f} %  {frame}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
