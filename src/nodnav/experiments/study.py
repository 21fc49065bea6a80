"""Study files: a sweep's cross product written down in YAML, and its validation.

A study file::

    name: game-reduction          # optional; default: the file's stem ('sweep' on the command line)
    scenarios: [3r-case1, 4r-case4]   # or all: every built-in scenario
    players: [0, 1, all]          # optional; default: each scenario's own setting
    init: [zero, distance]        # optional; default: each scenario's own setting
    bias: [none, {S3: 150, S5: 150}]   # optional; 'none', a mapping or "S3=150,S5=150"
    planners: [fast]              # optional; default: each scenario's own planner
    methods: [nod]                # optional; default: [nod]
    trials: 40                    # seeds 1..40 for every combination
    families: [mixed]             # optional: generated families; seed s runs draw s (FAMILY:s)

Any single value may stand for a one-element list. The command line builds the same
:class:`SweepSpec` through :func:`study_from_dict`, so both are checked by the same code and
every problem is one :class:`StudyError` line naming the key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from nodnav.errors import NodnavError
from nodnav.scenario.schema import builtin_names, nearest_hint, yaml_error_message

STUDY_KEYS = ("name", "scenarios", "players", "init", "bias", "planners", "methods", "trials", "families")

INIT_MODES = ("zero", "distance")

Bias = tuple[tuple[str, float], ...]
"""A bias as ``(("S3", 150.0), ("S5", 150.0))``, sorted by strategy; ``()`` is no bias."""


class StudyError(NodnavError, ValueError):
    """A study file or sweep option is malformed; the message is one line saying what and how to fix."""


@dataclass(frozen=True)
class SweepSpec:
    """The cross product a sweep runs: scenarios x players x init x bias x planners x methods x seeds 1..trials.

    ``None`` in an axis means "the scenario's own setting".
    """

    name: str
    """Study name, stored with every trial it runs."""
    scenarios: tuple[str, ...]
    """Built-in scenario names or YAML paths."""
    players: tuple[int | str | None, ...] = (None,)
    """Game players per robot: a whole number K, ``all`` (N_r - 1), or ``None``."""
    init: tuple[str | None, ...] = (None,)
    """Initial-opinion modes (``zero``, ``distance``) or ``None``."""
    bias: tuple[Bias | None, ...] = (None,)
    """Biases (``()`` for none) or ``None``."""
    planners: tuple[str | None, ...] = (None,)
    """Planner names or ``None``."""
    methods: tuple[str, ...] = ("nod",)
    """Navigation methods."""
    trials: int = 1
    """Number of seeds: every combination runs with seeds 1..trials."""
    families: tuple[str, ...] = ()
    """Generated families (built-in names or family files): seed s runs the family's draw s."""

    def to_dict(self) -> dict:
        """The spec as a study-file mapping that :func:`study_from_dict` reads back unchanged."""
        out: dict[str, Any] = {"name": self.name, "scenarios": list(self.scenarios)}
        for key, values in (("players", self.players), ("init", self.init), ("planners", self.planners)):
            if values != (None,):
                out[key] = list(values)
        if self.bias != (None,):
            out["bias"] = [dict(b) if b else "none" for b in self.bias]
        out["methods"] = list(self.methods)
        out["trials"] = self.trials
        if self.families:
            out["families"] = list(self.families)
        return out


def _listed(value: Any) -> list:
    return list(value) if isinstance(value, (list, tuple)) else [value]


def parse_players(value: Any, where: str = "players") -> int | str:
    """One game-player setting: ``all`` or a whole number >= 0 (also given as text)."""
    if value == "all":
        return "all"
    if isinstance(value, str) and value.strip().isdigit():
        return int(value)
    if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
        return value
    raise StudyError(f"{where}: expected 'all' or a whole number >= 0, got {value!r}")


def parse_bias(value: Any, where: str = "bias") -> Bias:
    """One bias: ``none``, a mapping ``{S3: 150}`` or text ``S3=150,S5=150``."""
    if value in ("none", None):
        return ()
    if isinstance(value, str):
        entries = {}
        for item in filter(None, (s.strip() for s in value.split(","))):
            name, sep, number = item.partition("=")
            if not sep:
                raise StudyError(f"{where}: expected entries like S3=150, got {item!r}")
            entries[name.strip()] = number.strip()
        value = entries
    if not isinstance(value, dict):
        raise StudyError(f"{where}: expected 'none', a mapping like {{S3: 150}} or text like S3=150,S5=150, got {value!r}")
    out = []
    for name, number in value.items():
        name = str(name)
        if not (name.startswith("S") and name[1:].isdigit() and int(name[1:]) >= 1):
            raise StudyError(f"{where}: unknown strategy '{name}'; name strategies S1, S2, ...")
        try:
            v = float(number)
        except (TypeError, ValueError):
            raise StudyError(f"{where}.{name}: expected a number, got {number!r}") from None
        if v != v or v in (float("inf"), float("-inf")):
            raise StudyError(f"{where}.{name}: expected a finite number, got {number!r}")
        out.append((name, v))
    return tuple(sorted(out, key=lambda e: int(e[0][1:])))


def _names(value: Any, where: str) -> tuple[str, ...]:
    names = _listed(value)
    if not names or not all(isinstance(n, str) and n for n in names):
        raise StudyError(f"{where}: expected a name or a non-empty list of names, got {value!r}")
    return tuple(names)


def _scenario_names(value: Any, where: str) -> tuple[str, ...]:
    names = _names(value, where)
    return tuple(builtin_names()) if names == ("all",) else names


def _family_names(value: Any, where: str) -> tuple[str, ...]:
    from nodnav.scenario.families import FamilyError, load_family

    names = _names(value, where)
    for n in names:
        try:
            load_family(n)
        except FamilyError as exc:
            raise StudyError(f"{where}: {exc}") from None
    return names


def _choices(value: Any, valid, where: str, what: str) -> tuple[str, ...]:
    names = _names(value, where)
    for n in names:
        if n not in valid:
            raise StudyError(f"{where}: unknown {what} '{n}'{nearest_hint(n, valid, what + 's')}")
    return names


def known_methods() -> tuple[str, ...]:
    """Names of the navigation methods the simulator knows."""
    from nodnav.sim.methods import METHODS

    return tuple(METHODS)


def study_from_dict(data: Any, source: str = "study") -> SweepSpec:
    """Validate a study mapping (parsed YAML, or the command line's options) and build a :class:`SweepSpec`."""
    from nodnav.planning import PLANNERS

    if not isinstance(data, dict):
        raise StudyError(f"{source}: expected a mapping with keys such as 'scenarios' and 'trials', got {type(data).__name__}")
    for key in data:
        if key not in STUDY_KEYS:
            raise StudyError(f"{source}: unknown key '{key}'{nearest_hint(str(key), STUDY_KEYS, 'valid keys')}")
    if "scenarios" not in data and not data.get("families"):
        raise StudyError(f"{source}: missing key 'scenarios' (a list of built-in names or YAML paths) or 'families'")
    name = data.get("name", "sweep")
    if not isinstance(name, str) or not name.strip():
        raise StudyError(f"{source}: 'name' must be non-empty text")
    trials = data.get("trials", 1)
    if isinstance(trials, str) and trials.strip().isdigit():
        trials = int(trials)
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise StudyError(f"{source}: trials: expected a whole number >= 1, got {trials!r}")
    spec = SweepSpec(
        name=name.strip(),
        scenarios=_scenario_names(data["scenarios"], f"{source}: scenarios") if "scenarios" in data else (),
        trials=trials,
        methods=_choices(data.get("methods", "nod"), known_methods(), f"{source}: methods", "method"),
    )
    changes: dict[str, tuple] = {}
    if "players" in data:
        changes["players"] = tuple(parse_players(v, f"{source}: players") for v in _listed(data["players"]))
    if "init" in data:
        changes["init"] = _choices(data["init"], INIT_MODES, f"{source}: init", "initial-opinion mode")
    if "bias" in data:
        changes["bias"] = tuple(parse_bias(v, f"{source}: bias") for v in _listed(data["bias"]))
    if "planners" in data:
        changes["planners"] = _choices(data["planners"], PLANNERS, f"{source}: planners", "planner")
    if "families" in data:
        changes["families"] = _family_names(data["families"], f"{source}: families")
    for key, values in changes.items():
        if not values:
            raise StudyError(f"{source}: {key}: expected at least one value")
    return dataclasses.replace(spec, **changes)


def load_study(path: str | Path, overrides: dict | None = None) -> SweepSpec:
    """Read a study file; ``overrides`` (study keys, e.g. from the command line) replace its values."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise StudyError(f"{path}: cannot read the study file ({exc.strerror})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise StudyError(f"{path}: {yaml_error_message(exc)}") from None
    if isinstance(data, dict):
        data = {"name": path.stem, **data, **(overrides or {})}
    return study_from_dict(data, str(path))
