"""``--set KEY=VALUE`` and the options that are shorthands for it (``--players``, ``--init``, ...).

Every option that changes a scenario setting becomes an override (:mod:`nodnav.scenario.overrides`)
named as typed; they are merged into the scenario's mapping before its one validation, so an
option can rescue a file that would not load alone, and an error names the option.
"""

from __future__ import annotations

import argparse
from typing import Any

from nodnav.errors import NodnavError


def _players(text: str) -> Any:
    from nodnav.experiments.study import parse_players

    return parse_players(text, "--players")


def _bias(text: str) -> Any:
    from nodnav.experiments.study import parse_bias

    return dict(parse_bias(text, "--bias"))


#: Options of ``run`` and ``plan`` that set one scenario key each: attribute -> (option, keys it
#: sets given the parsed value). ``--init`` also drops initial opinions given in the file (they
#: belong to ``init: given``), as a sweep's ``init`` axis does.
SHORTHANDS = {
    "players": ("--players", lambda v: {"game_players": _players(v)}),
    "init": ("--init", lambda v: {"opinion.init": v, "opinion.z0": []}),
    "bias": ("--bias", lambda v: {"opinion.bias": _bias(v)}),
    "u": ("--u", lambda v: {"opinion.u": v}),
    "planner": ("--planner", lambda v: {"planner.name": v}),
    "noise": ("--noise", lambda v: {"sim.observation_noise": v}),
}


def add_set_option(p: argparse.ArgumentParser) -> None:
    """``--set KEY=VALUE``, repeatable."""
    p.add_argument("--set", action="append", dest="settings", metavar="KEY=VALUE",
                   help="set any scenario key as a file writes it, the value read as YAML, e.g. --set "
                   "planner.name=prm --set robots[1].max_speed=0.5 (repeatable; docs/settings-and-export.md)")


def parse_settings(texts: list[str] | None) -> tuple[dict[str, Any], dict[str, str]]:
    """The ``--set`` options typed: overrides in their order, and each key's label for errors."""
    from nodnav.scenario.overrides import parse_setting

    overrides: dict[str, Any] = {}
    labels: dict[str, str] = {}
    for text in texts or ():
        key, value, label = parse_setting(text)
        overrides.pop(key, None)  # the last one of a key wins, in its place
        overrides[key], labels[key] = value, label
    return overrides, labels


def overrides_of(args: argparse.Namespace) -> tuple[dict[str, Any], dict[str, str]]:
    """Every scenario setting the command line gives: the shorthand options, then ``--set``.

    A key given by a shorthand and by ``--set`` with different values is an error naming both.
    """
    overrides: dict[str, Any] = {}
    labels: dict[str, str] = {}
    for attr, (option, keys) in SHORTHANDS.items():
        value = getattr(args, attr, None)
        if value is None or value == "":
            continue
        for key, v in keys(value).items():
            overrides[key], labels[key] = v, option
    settings, set_labels = parse_settings(getattr(args, "settings", None))
    for key, value in settings.items():
        if key in overrides and overrides[key] != value:
            raise NodnavError(f"{set_labels[key]}: {labels[key]} sets {key} too; give it once")
        overrides[key], labels[key] = value, set_labels[key]
    return overrides, labels


def scenario_with_options(args: argparse.Namespace, spec: str | None = None):
    """The scenario named on the command line (or ``spec``) with every setting the options give,
    validated once; an error about an option names the option as typed."""
    from nodnav.scenario.loading import load_scenario

    overrides, labels = overrides_of(args)
    return load_scenario(args.scenario if spec is None else spec, overrides, labels)
