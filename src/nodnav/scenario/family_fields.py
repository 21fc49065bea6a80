"""What family files share: the error, the interval drawn, and the checks of a mapping's values.

Both kinds of family (:mod:`nodnav.scenario.families`, corridors, and
:mod:`nodnav.scenario.building_family`, floor plans) read their files with these; each message is
one line naming the key and how to fix it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from nodnav.errors import nearest_hint
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.schema import scenario_from_dict

MAX_ROBOTS = 8
"""Most robots a family may draw (the scaling issue's largest scenarios)."""
SETTING_KEYS = ("opinion", "game_players", "planner", "controller", "sim", "execution", "baselines", "sensing")


class FamilyError(ScenarioError):
    """A family file or draw is malformed; the message is one line saying what and how to fix."""


@dataclass(frozen=True)
class Range:
    """A closed interval drawn uniformly."""

    lo: float
    """Lower end."""
    hi: float
    """Upper end (equal to ``lo`` for a fixed value)."""


def _shown(value: Any) -> str:
    """``repr(value)``, cut to 40 characters so that an error stays one readable line."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _real(value: Any, where: str, lo: float, hi: float, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FamilyError(f"{where}: expected a number{unit}, got {_shown(value)}")
    try:
        v = float(value)
    except OverflowError:  # an integer beyond any float
        v = math.inf
    if not (math.isfinite(v) and lo <= v <= hi):
        raise FamilyError(f"{where}: expected a number{unit} in [{lo:g}, {hi:g}], got {_shown(value)}")
    return v


def _range(value: Any, where: str, lo: float, hi: float, unit: str = "") -> Range:
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise FamilyError(f"{where}: expected [low, high]{unit}, got {_shown(value)}")
        a, b = (_real(v, where, lo, hi, unit) for v in value)
        if a > b:
            raise FamilyError(f"{where}: low {a:g} is above high {b:g}; write [low, high]")
        return Range(a, b)
    v = _real(value, where, lo, hi, unit)
    return Range(v, v)


def _count(value: Any, where: str) -> tuple[int, int]:
    values = list(value) if isinstance(value, (list, tuple)) else [value, value]
    if len(values) != 2 or not all(isinstance(v, int) and not isinstance(v, bool) and 2 <= v <= MAX_ROBOTS
                                   for v in values):
        raise FamilyError(f"{where}: expected a whole number or [low, high] in 2..{MAX_ROBOTS}, got {_shown(value)}")
    if values[0] > values[1]:
        raise FamilyError(f"{where}: low {values[0]} is above high {values[1]}; write [low, high]")
    return values[0], values[1]


def _weights(value: Any, where: str, names: tuple[str, ...]) -> tuple[tuple[str, float], ...]:
    if not isinstance(value, dict) or not value:
        raise FamilyError(f"{where}: expected weights like {{{names[0]}: 1, {names[1]}: 2}}, got {_shown(value)}")
    out = []
    for key, w in value.items():
        if key not in names:
            raise FamilyError(f"{where}: unknown key '{key}'{nearest_hint(str(key), names)}")
        out.append((key, _real(w, f"{where}.{key}", 0.0, 1e6, " (a weight)")))
    if sum(w for _, w in out) <= 0:
        raise FamilyError(f"{where}: at least one weight must be positive")
    return tuple(out)


def _mapping(value: Any, where: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise FamilyError(f"{where}: expected a mapping of keys to values, got {_shown(value)}")
    return value


def _check_keys(data: dict, valid, where: str) -> None:
    for key in data:
        if key not in valid:
            raise FamilyError(f"{where}: unknown key '{key}'{nearest_hint(str(key), valid)}")


#: The keys of a family's ``robots`` section, shared by both kinds of family.
ROBOT_KEYS = ("count", "radius", "mixed_radii", "max_speed", "mixed_speeds", "max_accel", "mixed_accels")


def robot_ranges(robots: dict, where: str, radius_hi: float) -> dict[str, Any]:
    """The values given in a family's ``robots`` section (``where``: its place in the file,
    ``"FILE: robots"``), checked; radii up to ``radius_hi`` metres."""
    parse = {
        "count": lambda v, k: _count(v, k),
        "radius": lambda v, k: _range(v, k, 0.08, radius_hi, " (m)"),
        "mixed_radii": lambda v, k: _real(v, k, 0.0, 1.0, " (a probability)"),
        "max_speed": lambda v, k: _range(v, k, 0.01, 5.0, " (m/s)"),
        "mixed_speeds": lambda v, k: _real(v, k, 0.0, 1.0, " (a probability)"),
        "max_accel": lambda v, k: _range(v, k, 0.1, 20.0, " (m/s^2)"),
        "mixed_accels": lambda v, k: _real(v, k, 0.0, 1.0, " (a probability)"),
    }
    return {key: fn(robots[key], f"{where}.{key}") for key, fn in parse.items() if key in robots}


def check_settings_load(settings: dict, robots: list[dict], where: str) -> None:
    """A family's ``scenario`` settings must load: tried on a plain scenario with ``robots``
    (``where``: the file's name and ``": "``)."""
    try:
        scenario_from_dict({**settings, "name": "check", "robots": robots}, "check")
    except ScenarioError as exc:
        raise FamilyError(f"{where}scenario.{exc}") from None
    except (ValueError, OverflowError, RecursionError, TypeError) as exc:  # what the scenario loader let through
        raise FamilyError(f"{where}scenario: settings the scenario loader cannot use ({type(exc).__name__})") from None
