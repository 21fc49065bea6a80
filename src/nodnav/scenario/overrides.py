"""Settings given on top of a scenario (``--set KEY=VALUE``, ``overrides=``), merged before its one validation.

An override names a scenario key as a file writes it: a dotted path with list indices,
``sim.observation_noise``, ``planner.name``, ``robots[1].max_speed`` (0-based, as validation errors name
robots), ``robot_defaults.max_accel``. Its value replaces what the file holds at that key (a
mapping or list value replaces the whole entry; other keys beside it stay). Overrides are written
into the scenario's raw mapping (the file as parsed, a family draw's mapping) and the result is
validated once by :func:`~nodnav.scenario.schema.scenario_from_dict`, so an override can rescue a
file that would not load alone (an 8-robot file with ``game_players: all`` run with
``game_players=2``) and is checked exactly as the same key written in the file.

One rule differs from writing the key in the file: ``robot_defaults.K`` set as an override applies
to every robot, also to robots whose own entry gives ``K`` (an override is stronger than the file);
``robots[i].K`` overrides still apply on top of it.

Every problem is one :class:`~nodnav.scenario.fields.ScenarioError` line starting with the
override's label (``--set robots[7].radius=0.3: the scenario has 4 robots (robots[0] to robots[3])``).
"""

from __future__ import annotations

import copy
import json
import re
from collections.abc import Mapping
from typing import Any

from nodnav.errors import shown, shown_path
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.files import parse_yaml

__all__ = ["parse_setting", "key_path", "merge_overrides", "relabel", "setting_text"]

_NAME = r"[A-Za-z_][A-Za-z0-9_]*"
_SEGMENT = re.compile(rf"(?P<name>{_NAME})(?P<indices>(\[[0-9]{{1,4}}\])*)")
_INDEX = re.compile(r"\[([0-9]{1,4})\]")
EXAMPLE = "e.g. planner.name=prm or robots[1].max_speed=0.5"


def key_path(key: Any, label: str | None = None) -> list[str | int]:
    """``robots[1].max_speed`` as ``["robots", 1, "max_speed"]``; a malformed key is a :class:`ScenarioError`."""
    label = label or f"{shown(key)}"
    if not isinstance(key, str) or not 0 < len(key) <= 200:
        raise ScenarioError(f"{label}: expected a scenario key as a file writes it, {EXAMPLE}", key=label)
    path: list[str | int] = []
    for part in key.split("."):
        m = _SEGMENT.fullmatch(part)
        if m is None:
            raise ScenarioError(f"{label}: {shown(key)} is not a scenario key as a file writes it (names joined "
                                f"by dots, list entries as [i]), {EXAMPLE}", key=label)
        path.append(m["name"])
        path += [int(i) for i in _INDEX.findall(m["indices"])]
    return path


def parse_setting(text: str, option: str = "--set") -> tuple[str, Any, str]:
    """``KEY=VALUE`` as typed: the key, the value parsed as YAML (so ``3``, ``[1, 2]``, ``{S3: 150}``
    work) and the label errors start with (``--set KEY=VALUE``)."""
    label = f"{option} {text}" if text.isprintable() and len(text) <= 120 else f"{option} {shown(text)}"
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise ScenarioError(f"{label}: expected KEY=VALUE, {EXAMPLE}", key=label)
    key = key.strip()
    key_path(key, label)
    return key, parse_yaml(value, label), label


def setting_text(key: str, value: Any) -> str:
    """``KEY=VALUE`` that :func:`parse_setting` reads back as ``(key, value)`` (for redo commands)."""
    if isinstance(value, str):
        try:
            plain = parse_yaml(value, key) == value
        except ScenarioError:
            plain = False
        return f"{key}={value}" if plain and value.strip() == value and value else f"{key}={json.dumps(value)}"
    return f"{key}={json.dumps(value, separators=(',', ':'))}"


def _joined(path: list[str | int]) -> str:
    return "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")


def _child(container: Any, seg: str | int, nxt: str | int, walked: list[str | int], label: str) -> Any:
    """The entry ``seg`` of ``container``, made a mapping if absent and ``nxt`` names a key."""
    here = _joined([*walked, seg])
    value = _entry(container, seg, walked, label)
    if value is None and isinstance(nxt, str):
        value = {}
        container[seg] = value
    if isinstance(nxt, str) and not isinstance(value, dict):
        raise ScenarioError(f"{label}: {here} is {shown(value)}, not a section of keys", key=label)
    if isinstance(nxt, int) and not isinstance(value, list):
        what = "not written in the scenario (it has its default)" if value is None else f"{shown(value)}, not a list"
        raise ScenarioError(f"{label}: {here} is {what}; set the whole list, e.g. {here}=[...]", key=label)
    return value


def _entry(container: Any, seg: str | int, walked: list[str | int], label: str) -> Any:
    if isinstance(seg, str):
        return container.get(seg)
    if seg >= len(container):
        there = _joined(walked)
        count = (f"the scenario has {len(container)} robot{'s' if len(container) != 1 else ''}" if walked == ["robots"]
                 else f"{there} has {len(container)} entr{'ies' if len(container) != 1 else 'y'}")
        span = f" ({there}[0] to {there}[{len(container) - 1}])" if container else ""
        raise ScenarioError(f"{label}: {count}{span}", key=label)
    return container[seg]


def _put(raw: dict, path: list[str | int], value: Any, label: str) -> None:
    target = raw
    for k, (seg, nxt) in enumerate(zip(path, path[1:])):
        target = _child(target, seg, nxt, path[:k], label)
    leaf = path[-1]
    if isinstance(leaf, int):
        _entry(target, leaf, path[:-1], label)  # in range
    target[leaf] = _plain(value)


def _plain(value: Any) -> Any:
    """``value`` as a file would hold it: NumPy arrays and numbers, and tuples, as lists and Python numbers."""
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return copy.deepcopy(value)


def merge_overrides(raw: Any, overrides: Mapping[str, Any], labels: Mapping[str, str] | None = None) -> Any:
    """A copy of the scenario mapping ``raw`` with every override written at its key path.

    ``robot_defaults.K`` overrides go first and drop ``K`` from every robot's own entry (module
    docstring); the others follow in their order. ``raw`` that is not a mapping is returned as it
    is, for validation to report.
    """
    if not isinstance(raw, dict):
        return raw
    raw = copy.deepcopy(raw)
    parsed = [(key, key_path(key, (labels or {}).get(key) or key), value) for key, value in overrides.items()]
    defaults = [len(path) == 2 and path[0] == "robot_defaults" for _, path, _ in parsed]
    for n in [n for n in range(len(parsed)) if defaults[n]] + [n for n in range(len(parsed)) if not defaults[n]]:
        key, path, value = parsed[n]
        _put(raw, path, value, (labels or {}).get(key) or key)
        if defaults[n] and isinstance(raw.get("robots"), list):  # every robot takes it (module docstring)
            for robot in raw["robots"]:
                if isinstance(robot, dict):
                    robot.pop(path[1], None)
    return raw


def _within(inner: str, outer: str) -> bool:
    """Whether key path ``inner`` is ``outer`` or lies below it."""
    return inner == outer or inner.startswith((outer + ".", outer + "["))


def relabel(exc: ScenarioError, overrides: Mapping[str, Any], labels: Mapping[str, str], source: str) -> ScenarioError:
    """The validation error ``exc`` as the user typed it: starting with the override it concerns."""
    def label(key: str) -> str:
        return labels.get(key) or key

    below = [k for k in overrides if _within(exc.key, k)]
    if below:  # the override's value, or a part of it, is wrong
        key = max(below, key=len)
        return ScenarioError(f"{label(key)}: {exc.detail}", key=label(key))
    parent = "" if exc.key == shown_path(source) else exc.key
    try:
        depth = len(key_path(parent)) if parent else 0
    except ScenarioError:  # the error names no key path
        depth = -1
    for k in overrides:  # an unknown key under the error's key (or at the top, named by the source)
        if depth >= 0 and "unknown key" in exc.detail and (not parent or _within(k, parent)) and k != parent:
            if f"'{key_path(k)[depth]}'" in exc.detail:
                return ScenarioError(f"{label(k)}: {exc.detail}", key=label(k))
    above = [k for k in overrides if _within(k, parent) and k != parent] if parent and depth >= 0 else []
    if above:  # an override wrote keys into what is not a section (time_limit.x)
        return ScenarioError(f"{label(above[0])}: {exc}", key=label(above[0]))
    typed = ", ".join(label(k) for k in overrides)
    return ScenarioError(f"{exc} (with {typed})", key=exc.key)
