"""Reading the values of a scenario file: numbers in range, texts, lists, and parameter dataclasses.

Every reader raises one :class:`ScenarioError` line naming the key path the user wrote
(``planner.dt``, ``robots[2].origin``) and how to fix the value. :func:`read_params` reads any
flat frozen dataclass from a mapping by its type hints, so that a parameter class (a built-in
one or a plugin's) is validated without code of its own: numbers against the range in the
field's ``metadata`` (:func:`~nodnav.scenario.limits.accepted`), choices against their
``Literal`` type.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import re
import typing
from typing import Any, Literal

from nodnav.errors import NodnavError, nearest_hint, shown
from nodnav.scenario import limits
from nodnav.scenario.limits import Range


class ScenarioError(NodnavError, ValueError):
    """A scenario file or option is malformed; the message is one line saying what and how to fix.

    ``key`` is the key path the message starts with (``opinion.u``) and ``detail`` the rest.
    """

    def __init__(self, message: str, key: str = ""):
        super().__init__(message)
        self.key = key
        self.detail = message[len(key) + 2:] if key and message.startswith(key + ": ") else message


def fail(where: str, detail: str) -> ScenarioError:
    return ScenarioError(f"{where}: {detail}", key=where)


def check_keys(data: dict, valid, where: str) -> None:
    for key in data:
        if key not in valid:
            raise fail(where, f"unknown key {shown(key)}{nearest_hint(key, valid)}")


_EXPONENT = re.compile(r"[+-]?([0-9]{1,20}\.?[0-9]{0,20}|\.[0-9]{1,20})[eE][+-]?[0-9]{1,3}")


def number(value: Any, where: str, bound: Range | None = None) -> float:
    """A finite real number; with ``bound``, a range ``(least, greatest, least_included)``, in it."""
    if isinstance(value, str) and _EXPONENT.fullmatch(value.strip()):
        value = float(value)  # YAML 1.1 reads 1e-6 (no dot) as text; it is a number all the same
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise fail(where, f"expected a number, got {shown(value)}")
    try:
        v = float(value)
    except (OverflowError, ValueError, TypeError):
        raise fail(where, f"expected a number of ordinary size, got {shown(value)}") from None
    if not math.isfinite(v):
        raise fail(where, f"expected a finite number, got {shown(value)}")
    if bound is not None and not limits.in_range(bound, v):
        raise fail(where, f"must be {limits.range_text(bound)}, got {shown(value)}")
    return v


def coordinate(value: Any, where: str) -> float:
    v = number(value, where)
    if abs(v) > limits.MAX_COORDINATE:
        raise fail(where, f"coordinates must lie within +-{limits.MAX_COORDINATE:g} m, got {shown(value)}")
    return v


def vector(value: Any, n: int, where: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise fail(where, f"expected a list of {n} numbers, got {shown(value)}")
    return tuple(coordinate(v, f"{where}[{k}]") for k, v in enumerate(value))


def point(value: Any, where: str) -> tuple[float, float]:
    """A point ``[x, y]`` of the world (m)."""
    x, y = vector(value, 2, where)
    return x, y


def mapping(value: Any, where: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise fail(where, f"expected a mapping of keys to values, got {shown(value)}")
    return value


def text(value: Any, where: str, limit: int) -> str:
    if not isinstance(value, str):
        raise fail(where, f"expected text, got {shown(value)}")
    if len(value) > limit:
        raise fail(where, f"at most {limit} characters, got {len(value)}")
    return value


_BIAS_KEY = re.compile(r"S([1-9][0-9]{0,5})")


def strategy_number(name: Any) -> int | None:
    """The number ``j`` of a strategy named ``Sj`` (ASCII digits, no leading zero), else ``None``."""
    m = _BIAS_KEY.fullmatch(name) if isinstance(name, str) else None
    return int(m.group(1)) if m else None


def strategy_name_index(name: str) -> int:
    """The index (0-based: S1 is 0) of a strategy name that validation has accepted."""
    number = strategy_number(name)
    if number is None:
        raise ValueError(f"not a strategy name: {name!r}")
    return number - 1


def choices_text(options: tuple) -> str:
    """``'a'``, ``'a' or 'b'``, ``'a', 'b' or 'c'``."""
    quoted = [f"'{o}'" for o in options]
    return quoted[0] if len(quoted) == 1 else f"{', '.join(quoted[:-1])} or {quoted[-1]}"


def field_range(field: dataclasses.Field) -> Range | None:
    """The accepted range a parameter field declares (``metadata["range"]``), else ``None``."""
    own = field.metadata.get("range")
    return None if own is None else (own[0], own[1], own[2])


def range_of(cls: type, name: str) -> Range:
    """The accepted range that field ``name`` of the dataclass ``cls`` declares."""
    bound = field_range(next(f for f in dataclasses.fields(cls) if f.name == name))
    if bound is None:
        raise ValueError(f"{cls.__name__}.{name} declares no range")
    return bound


def read_value(hint: Any, value: Any, name: str, bound: Range | None) -> Any:
    """One value of a parameter dataclass, read and checked by its type hint."""
    if hint is float:
        return number(value, name, bound)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise fail(name, f"expected a whole number, got {shown(value)}")
        number(value, name, bound)
        return value
    if hint is str:
        return text(value, name, 4096)
    if hint is bool:
        if not isinstance(value, bool):
            raise fail(name, f"expected true or false, got {shown(value)}")
        return value
    if typing.get_origin(hint) is Literal:
        options = typing.get_args(hint)
        if value not in options or not isinstance(value, str):
            text(value, name, 4096)
            raise fail(name, f"expected {choices_text(options)}, got {shown(value)}")
        return value
    if hint == dict[str, float]:
        entries = mapping(value, name)
        if len(entries) > limits.MAX_STRATEGIES:
            raise fail(name, f"more entries ({len(entries)}) than there can be strategies")
        out = {}
        for k, v in entries.items():
            if strategy_number(k) is None:
                raise fail(name, f"unknown strategy {shown(k)}; name strategies S1, S2, ...")
            out[k] = number(v, f"{name}.{k}", bound)
        return out
    if hint == tuple[float, ...]:
        if not isinstance(value, (list, tuple)) or not 1 <= len(value) <= limits.MAX_LIST:
            raise fail(name, f"expected a list of 1 to {limits.MAX_LIST} numbers, got {shown(value)}")
        return tuple(number(v, f"{name}[{k}]", bound) for k, v in enumerate(value))
    if hint == tuple[tuple[float, ...], ...]:  # a matrix of numbers, one row per robot; its shape first
        if (not isinstance(value, (list, tuple)) or len(value) > limits.MAX_ROBOTS
                or not all(isinstance(row, (list, tuple)) and len(row) <= limits.MAX_STRATEGIES for row in value)):
            raise fail(name, f"expected a list of rows of numbers (one per robot), got {shown(value)}")
        return tuple(tuple(number(v, f"{name}[{k}][{c}]", bound) for c, v in enumerate(row))
                     for k, row in enumerate(value))
    raise TypeError(f"{name}: parameter fields of type {hint!r} cannot be read from a scenario file")


@functools.lru_cache(maxsize=256)
def type_hints(cls: type) -> dict[str, Any]:
    """``typing.get_type_hints(cls)``, remembered per class (read-only by convention): evaluating the
    string annotations anew for every key of every file read was most of a study's expansion time."""
    return typing.get_type_hints(cls)


def read_params(cls: type, data: Any, where: str, ignored: dict[str, type] | None = None) -> Any:
    """Build the flat frozen parameter dataclass ``cls`` from a mapping, checking keys, types and
    the ranges its fields declare.

    ``ignored`` maps keys that are not fields of ``cls`` but are accepted all the same (another
    implementation's settings, which files written before the parameters were split name) to a
    class that has them: they are checked as that class would, then dropped.
    """
    data = mapping(data, where)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    ignored = {k: c for k, c in (ignored or {}).items() if k not in fields}
    check_keys(data, {**fields, **ignored}, where)
    kwargs = {}
    for key, value in data.items():
        owner = cls if key in fields else ignored[key]
        field = next(f for f in dataclasses.fields(owner) if f.name == key)
        hint = type_hints(owner)[key]
        checked = read_value(hint, value, f"{where}.{key}", field_range(field))
        if owner is cls:
            kwargs[key] = checked
    return cls(**kwargs)
