"""What the command line accepts and shows: option types, one-line usage errors, the notice
while numba compiles, and trial summaries in plain words. Used by the commands of :mod:`nodnav.cli` only."""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import sys

import numpy as np

from nodnav.errors import NodnavError, shown

#: Whole numbers accepted for ``--seed``: what numpy's SeedSequence and an SQLite integer both take.
MAX_SEED = 2**63 - 1


class UsageError(NodnavError):
    """The command line itself is malformed (unknown option, missing argument, bad value)."""


class Parser(argparse.ArgumentParser):
    """argparse, with its errors as one :class:`UsageError` line instead of usage text and exit."""

    def error(self, message: str):
        raise UsageError(f"{message.removeprefix('argument ')} (see {self.prog} --help)")


def plural(n: int, word: str, many: str | None = None) -> str:
    """``1 trial``, ``2 trials`` (``many`` for irregular plurals)."""
    return f"{n} {word if n == 1 else many or word + 's'}"


# -- option types: each says what it expects, with the value as typed ------------------------------


def whole(low: int, high: int):
    """An argparse type: a whole number from ``low`` to ``high``."""
    def parse(text: str) -> int:
        if not re.fullmatch(r"[+-]?[0-9]{1,20}", text.strip()) or not low <= int(text) <= high:
            raise argparse.ArgumentTypeError(f"expected a whole number from {low} to {high}, got {shown(text)}")
        return int(text)
    return parse


def real(low: float, high: float):
    """An argparse type: a finite number from ``low`` to ``high``."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
        if not low <= value <= high:  # refuses nan and inf too
            raise argparse.ArgumentTypeError(f"expected a number from {low:g} to {high:g}, got {shown(text)}")
        return value
    return parse


def jobs_limit() -> int:
    """Most worker processes: the CPU cores (at least 2)."""
    return max(2, os.cpu_count() or 1)


def jobs(text: str) -> int:
    """An argparse type: a number of worker processes, at most :func:`jobs_limit`."""
    cores = os.cpu_count() or 1
    try:
        return whole(1, jobs_limit())(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected a whole number from 1 to {jobs_limit()} (this machine has "
                                         f"{plural(cores, 'CPU core')}; more processes than cores only use memory), "
                                         f"got {shown(text)}") from None


# -- compiling ------------------------------------------------------------------------


COMPILING = ("nodnav: compiling the numerical kernels for this machine (once after installing; "
             "later runs load them from the cache)...")


@contextlib.contextmanager
def compile_notice():
    """Say once, on stderr, when numba starts compiling (it does only on a cache miss)."""
    try:
        from numba.core import event
    except ImportError:  # pragma: no cover - numba is a dependency
        yield
        return

    class Notice(event.Listener):
        said = False

        def on_start(self, ev) -> None:
            if not self.said:
                self.said = True
                from tqdm import tqdm

                tqdm.write(COMPILING, file=sys.stderr)

        def on_end(self, ev) -> None:
            pass

    with event.install_listener("numba:compile", Notice()):
        yield


def warm_kernels() -> None:
    """Compile (or load) the kernels in this process before workers start, so that they load them
    from the cache and the progress bar's first trials are not slowed by compiling."""
    from nodnav.scenario.loading import load_scenario
    from nodnav.sim.simulator import run_trial

    run_trial(load_scenario("2r-case1").with_overrides(time_limit=0.5), "nod", 1)


def trial_summary_lines(result, scenario, method: str, seed: int) -> list[str]:
    """The plain-words summary ``nodnav run`` prints for a finished trial."""
    from nodnav.decision.games import strategy_order
    from nodnav.decision.strategies import order_label, strategy_label

    summary = result.to_dict()
    # Game players are a setting of nod only; methods without strategies have no consensus either.
    setting = f"{method}, {plural(scenario.n_players, 'game player')} per robot" if method == "nod" else method
    lines = [f"{scenario.name} seed {seed} ({setting}): {result.outcome.upper()} at t = {result.sim_time:.1f} s "
             f"(took {result.wall_time:.1f} s)"]
    entry = summary["corridor_entry_order"]
    chooses = bool(result.history.ranks) and bool((np.asarray(result.history.ranks) >= 0).any())
    order_text = f"corridor entry order ({','.join(map(str, entry))})" if entry else "no robot entered the corridor"
    if chooses and summary["strategy"] and scenario.n_robots > 1:
        j = summary["strategy"] - 1
        order_text += (f", which is strategy {strategy_label(j)} {order_label(strategy_order(j, scenario.n_robots))}; "
                       f"the robots {'agreed' if summary['consensus'] else 'did not agree'} on the order beforehand")
    lines.append("  " + order_text)
    if summary.get("passage_entry_orders"):  # several passages: the order each was crossed in
        lines.append("  crossed " + "; ".join(f"passage {k + 1} in the order ({','.join(map(str, o))})" if o else
                                              f"passage {k + 1} by no robot"
                                              for k, o in enumerate(summary["passage_entry_orders"])))
    braking = (f"emergency braking at {plural(result.mpc_infeasible, 'robot step')} (no safe plan for the controller)"
               if result.mpc_infeasible else "no emergency braking")
    closest = (f"closest approach {result.min_separation:.3f} m between robot centres, "
               if np.isfinite(result.min_separation) else "")
    lines.append(f"  {closest}{braking}")
    goals = ", ".join(f"robot {k + 1} {t:.1f} s" if t is not None else f"robot {k + 1} not reached"
                      for k, t in enumerate(summary["time_to_goal_s"]))
    lines.append(f"  time to goal: {goals}")
    return lines


def note(text: str) -> None:
    """Print ``note: text`` on stderr, above any progress bar."""
    from tqdm import tqdm

    tqdm.write(f"note: {text}", file=sys.stderr)
