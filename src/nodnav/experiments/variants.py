"""Game reduction, side by side: variants of who a robot plays with and how it treats the others.

The paper selects ``k`` game players by the conflict likelihood (6)-(7) and has a robot treat
every other robot as a static obstacle: not planned, held still in the MPC. With ``k = 1`` that
fails head-on (the two robots on each side play with each other and both pairs enter). The
variants below change one thing at a time, each selectable by name in the scenario file
(``opinion.conflict``, ``opinion.nonplayers``); ``nodnav reproduce`` runs them all on the
built-in scenarios for every ``1 <= k < N_r - 1`` (part ``reduction``) and the report puts them
side by side (:mod:`nodnav.reporting.reduction`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import yaml

from nodnav.experiments.analysis import RateCell
from nodnav.experiments.statistics import fmt_rate, wilson_interval
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_to_dict


@dataclass(frozen=True)
class Variant:
    """One way of reducing the game."""

    name: str
    """Short name, used in scenario names (``4r-case2 [paper]``) and the report."""
    description: str
    """What it changes, in one line."""
    overrides: dict
    """Scenario overrides (``Scenario.with_overrides`` keys)."""


VARIANTS = (
    Variant("paper", "eqs. (6)-(7) over every robot; non-players not planned, held still in the MPC (the paper)",
            {"opinion.conflict": "paper", "opinion.nonplayers": "static"}),
    Variant("entered", "eqs. (6)-(7); non-players seen inside the corridor planned at the front of the order",
            {"opinion.conflict": "paper", "opinion.nonplayers": "entered"}),
    Variant("undecided", "eqs. (6)-(7) among robots not yet in the corridor first; non-players held still",
            {"opinion.conflict": "undecided", "opinion.nonplayers": "static"}),
    Variant("undecided-entered", "both of the above",
            {"opinion.conflict": "undecided", "opinion.nonplayers": "entered"}),
)
"""The variants, the paper's first."""

_LABEL = re.compile(r"^(?P<scenario>.+) \[(?P<variant>[a-z-]+)\]$")


def variant_name(scenario: str, variant: str) -> str:
    """The name of ``scenario`` run as ``variant``: ``4r-case2 [paper]``."""
    return f"{scenario} [{variant}]"


def split_name(name: str) -> tuple[str, str] | None:
    """``(scenario, variant)`` of a name made by :func:`variant_name`, else ``None``."""
    m = _LABEL.match(name)
    return (m.group("scenario"), m.group("variant")) if m else None


def variant_scenario_files(directory: Path, scenarios: tuple[str, ...]) -> list[Path]:
    """Every scenario of ``scenarios`` with at least three robots, for every number of game players
    ``1 <= k < N_r - 1`` (game reduction) and every variant, written as YAML files into
    ``directory`` (named as :func:`variant_name`; ``k`` is the file's ``game_players``)."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for spec in scenarios:
        base = load_scenario(spec)
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", base.name)
        for k in range(1, base.n_robots - 1):
            for v in VARIANTS:
                raw = scenario_to_dict(base.with_overrides(game_players=k, **v.overrides))
                raw["name"] = variant_name(base.name, v.name)
                raw["description"] = f"{base.description} -- game reduction variant '{v.name}': {v.description}"
                path = directory / f"{stem}.k{k}.{v.name}.yaml"
                path.write_text(yaml.safe_dump(raw, sort_keys=False))
                paths.append(path)
    return paths


STUDY_REDUCTION = "game-reduction-variants"
"""The built-in scenarios of up to four robots, for every 1 <= k < N_r - 1, as every variant."""


def reduction_rows(cells: list[RateCell]) -> tuple[list[str], list[list[str]], dict[str, tuple[int, int]]]:
    """The report's table from rate cells keyed ``(scenario name, players)``: one row per scenario
    and k, one column per variant; and each variant's pooled ``(successes, trials)``."""
    by: dict[tuple[str, int], dict[str, RateCell]] = {}
    pooled: dict[str, list[int]] = {v.name: [0, 0] for v in VARIANTS}
    for cell in cells:
        split = split_name(cell.key[0])
        if split is None or split[1] not in pooled:
            continue
        scenario, variant = split
        by.setdefault((scenario, int(cell.key[1])), {})[variant] = cell
        pooled[variant][0] += cell.counts.get("success", 0)
        pooled[variant][1] += cell.trials
    rows = []
    for (scenario, k), found in sorted(by.items()):
        rows.append([scenario, str(k)] + [fmt_rate(found[v.name].rate(), found[v.name].trials) if v.name in found
                                          else "" for v in VARIANTS])
    totals = {name: (s, n) for name, (s, n) in pooled.items() if n}
    rows.append(["**pooled**", ""] + [fmt_rate(wilson_interval(*totals[v.name]), totals[v.name][1])
                                      if v.name in totals else "" for v in VARIANTS])
    return ["scenario", "k"] + [f"`{v.name}`" for v in VARIANTS], rows, totals
