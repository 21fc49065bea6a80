"""Two results databases of the same trials, compared draw by draw: did a change (another commit,
a setting turned on) make any group of trials succeed less often than chance explains?

The closed loop is chaotic: a change in the last bits of a trajectory flips single draws either
way (docs/performance-11.md, ``skip_at_rest``), so a family's total moving by two or three is no
evidence. Each trial of ``A`` is matched with the trial of ``B`` that simulates the same thing:
the same scenario name, configuration and seed (nodnav's ``run_key``), the settings named by
``--ignore`` left out. Per group (the study, a trial in several studies counted in the first by
name; or the scenario's family, the name before ``:``) the matched pairs are counted as both
successful, only ``A``, only ``B`` and neither, and the discordant pairs get McNemar's exact test
(a two-sided binomial test of "only A" against "only B" with p = 1/2). A change lowers a rate
credibly only where "only A" exceeds "only B" with a small p.

    python tools/paired_outcomes.py before.sqlite after.sqlite            # two commits, by study
    python tools/paired_outcomes.py off.sqlite on.sqlite --by family --ignore execution.skip_at_rest

Trials found in one database only are counted and left out. Two trials of one database that
match alike (settings that differ only in an ignored field) cannot be paired: that stops the
comparison with exit code 2.
"""

import argparse
import collections
import json
import sqlite3
import sys
from pathlib import Path

from scipy.stats import binomtest

from nodnav.experiments.store import run_key


def mcnemar_exact(only_a: int, only_b: int) -> float:
    """Two-sided exact McNemar p-value of ``only_a`` against ``only_b`` discordant pairs (1 without any)."""
    n = only_a + only_b
    return 1.0 if n == 0 else float(binomtest(min(only_a, only_b), n, 0.5).pvalue)


def match_key(config: dict, seed: int, ignore: tuple[str, ...] = ()) -> str:
    """The trial's ``run_key`` with the scenario's fields ``ignore`` (``section.key``) left out."""
    scenario = dict(config["scenario"])  # the caller's sections stay as they are
    for field in ignore:
        section, _, name = field.partition(".")
        part = scenario.get(section)
        if isinstance(part, dict):
            scenario[section] = {k: v for k, v in part.items() if k != name}
    return run_key({**config, "scenario": scenario}, seed)


def outcomes(db: str, ignore: tuple[str, ...] = ()) -> dict[tuple, tuple[str, str, bool]]:
    """Each trial's (:func:`match_key`, scenario name) -> (study, scenario, success); ValueError on
    two trials of one key. (The name is part of the match: a study's variant may simulate what
    another trial does under its own name.)"""
    if not Path(db).is_file():
        raise ValueError(f"{db}: no such results database")
    rows = sqlite3.connect(f"file:{db}?mode=ro", uri=True).execute(
        "select t.config, t.seed, coalesce(s.study, t.study), t.scenario, t.success from trials t left join "
        "(select key, min(study) as study from study_trials group by key) s on s.key = t.key").fetchall()
    found: dict[tuple, tuple[str, str, bool]] = {}
    for config, seed, study, scenario, success in rows:
        key = (match_key(json.loads(config), seed, ignore), scenario)
        if key in found:
            raise ValueError(f"{db}: two trials of {scenario} seed {seed} match alike "
                             "(they differ only in an ignored setting)")
        found[key] = (study, scenario, bool(success))
    return found


def paired_counts(a: dict, b: dict, by: str) -> dict[str, collections.Counter]:
    """Per group: the matched pairs counted as ``both``, ``only_a``, ``only_b``, ``neither``."""
    groups: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for key in a.keys() & b.keys():
        study, scenario, won_a = a[key]
        won_b = b[key][2]
        group = study if by == "study" else scenario.split(":")[0]
        groups[group][("both" if won_b else "only_a") if won_a else ("only_b" if won_b else "neither")] += 1
    return dict(groups)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", help="results database before the change")
    parser.add_argument("b", help="results database after it")
    parser.add_argument("--by", choices=("study", "family"), default="study")
    parser.add_argument("--ignore", action="append", default=[], metavar="SECTION.KEY",
                        help="a setting that differs between the databases (repeatable)")
    args = parser.parse_args()
    try:
        a, b = outcomes(args.a, tuple(args.ignore)), outcomes(args.b, tuple(args.ignore))
    except (ValueError, sqlite3.Error) as error:
        print(f"paired_outcomes: {error}", file=sys.stderr)
        return 2
    groups = paired_counts(a, b, args.by)
    print(f"{'group':30} {'pairs':>6} {'A wins':>7} {'B wins':>7} {'only A':>7} {'only B':>7} {'McNemar p':>10}")
    total: collections.Counter = collections.Counter()
    for group in sorted(groups):
        c = groups[group]
        total.update(c)
        pairs = sum(c.values())
        print(f"{group:30} {pairs:6d} {c['both'] + c['only_a']:7d} {c['both'] + c['only_b']:7d} "
              f"{c['only_a']:7d} {c['only_b']:7d} {mcnemar_exact(c['only_a'], c['only_b']):10.3g}")
    pairs = sum(total.values())
    print(f"{'all':30} {pairs:6d} {total['both'] + total['only_a']:7d} {total['both'] + total['only_b']:7d} "
          f"{total['only_a']:7d} {total['only_b']:7d} {mcnemar_exact(total['only_a'], total['only_b']):10.3g}")
    unmatched = len(a.keys() - b.keys()), len(b.keys() - a.keys())
    if any(unmatched):
        print(f"left out: {unmatched[0]} trials only in A, {unmatched[1]} only in B")
    return 0


if __name__ == "__main__":
    sys.exit(main())
