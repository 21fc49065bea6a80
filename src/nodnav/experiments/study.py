"""Study files: a sweep's cross product written down in YAML, and its validation.

A study file::

    name: game-reduction          # optional; default: the file's stem ('sweep' on the command line)
    scenarios: [3r-case1, 4r-case4]   # or all (every built-in), paper (the paper's ten), crowds (5-8 robots)
    players: [0, 1, all]          # optional; default: each scenario's own setting
    init: [zero, distance]        # optional; default: each scenario's own setting
    bias: [none, {S3: 150, S5: 150}]   # optional; 'none', a mapping or "S3=150,S5=150"
    planners: [fast]              # optional; default: each scenario's own planner
    methods: [nod]                # optional; default: [nod]
    trials: 40                    # seeds 1..40 for every combination
    families: [mixed]             # optional: generated families; seed s runs draw s (FAMILY:s)
    set: {sim.observation_noise: 0.02, robot_defaults.max_accel: 1.0}   # optional: scenario keys set in every
                                  # scenario and every family draw (as --set KEY=VALUE does)
    roles: [none, {1: person}, {last: closest-first}]   # optional: robots running another method

Any single value may stand for a one-element list. The command line builds the same
:class:`SweepSpec` through :func:`study_from_dict`, so both are checked by the same code and
every problem is one :class:`StudyError` line naming the key.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nodnav.errors import NodnavError, nearest_hint, shown, shown_path
from nodnav.planning import PLANNERS
from nodnav.scenario.fields import ScenarioError, range_of, strategy_number
from nodnav.scenario.files import builtin_names, read_yaml
from nodnav.scenario.limits import MAX_ROBOTS
from nodnav.scenario.params import OpinionParams
from nodnav.sim import METHODS

STUDY_KEYS = ("name", "scenarios", "players", "init", "bias", "planners", "methods", "trials", "families", "set",
              "roles")

#: The scenario key each axis of a study sets: giving it in ``set`` too would be ambiguous.
AXIS_KEYS = {"players": "game_players", "init": "opinion.init", "bias": "opinion.bias", "planners": "planner.name"}

INIT_MODES = ("zero", "distance")

Bias = tuple[tuple[str, float], ...]
"""A bias as ``(("S3", 150.0), ("S5", 150.0))``, sorted by strategy; ``()`` is no bias."""

Roles = tuple[tuple[str, str], ...]
"""Robots that run their own method, as ``(("1", "person"), ("last", "orca"))``: a robot number
from 1 or ``last``, and a method name; ``()`` is none (every robot runs the trial's method)."""


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
    overrides: dict[str, Any] = dataclasses.field(default_factory=dict)
    """Scenario keys set in every scenario and family draw (``set:``, ``--set``), in their order."""
    roles: tuple[Roles, ...] = ((),)
    """Role assignments (``robots[i].method`` for some robots), one axis of the cross product."""

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
        if self.overrides:
            out["set"] = dict(self.overrides)
        if self.roles != ((),):
            out["roles"] = [dict(r) if r else "none" for r in self.roles]
        return out


#: Most seeds per combination (``trials``).
MAX_TRIALS = 10_000
#: Most trials one sweep may expand to (every combination times its seeds): each is held in
#: memory with its key while the sweep runs.
MAX_SWEEP_TRIALS = 100_000

#: The command-line option that sets each study key, named in errors about what was typed.
OPTION_NAMES = {"name": "--name", "scenarios": "--scenario", "players": "--players", "init": "--init",
                "bias": "--bias", "planners": "--planner", "methods": "--method", "trials": "--trials", "set": "--set"}

_WHOLE = re.compile(r"[0-9]{1,6}")


def _listed(value: Any) -> list:
    return list(value) if isinstance(value, (list, tuple)) else [value]


def parse_players(value: Any, where: str = "players") -> int | str:
    """One game-player setting: ``all`` or a whole number >= 0 (also given as text)."""
    if value == "all":
        return "all"
    if isinstance(value, str) and _WHOLE.fullmatch(value.strip()):
        return int(value)
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 10**6:
        return value
    raise StudyError(f"{where}: expected 'all' or a whole number >= 0, got {shown(value)}")


def parse_bias(value: Any, where: str = "bias") -> Bias:
    """One bias: ``none``, a mapping ``{S3: 150}`` or text ``S3=150,S5=150``."""
    if value in ("none", None):
        return ()
    if isinstance(value, str):
        entries = {}
        for item in filter(None, (s.strip() for s in value.split(","))):
            name, sep, number = item.partition("=")
            if not sep:
                raise StudyError(f"{where}: expected entries like S3=150, got {shown(item)}")
            entries[name.strip()] = number.strip()
        value = entries
    if not isinstance(value, dict):
        raise StudyError(f"{where}: expected 'none', a mapping like {{S3: 150}} or text like S3=150,S5=150, "
                         f"got {shown(value)}")
    out: list[tuple[int, str, float]] = []
    for name, number in value.items():
        j = strategy_number(name)
        if j is None or j > math.factorial(MAX_ROBOTS):
            raise StudyError(f"{where}: unknown strategy {shown(name)}; name strategies S1, S2, ... "
                             f"(at most S{math.factorial(MAX_ROBOTS)})")
        try:
            v = float(number) if isinstance(number, (str, int, float)) and not isinstance(number, bool) else None
        except (ValueError, OverflowError):
            v = None
        entry = f"{where}: {name}" if where.startswith("--") else f"{where}.{name}"
        if v is None:
            raise StudyError(f"{entry}: expected a number, got {shown(number)}")
        low, high, _ = range_of(OpinionParams, "bias")
        if not low <= v <= high:  # also refuses nan and inf
            raise StudyError(f"{entry}: expected a number from {low:g} to {high:g}, got {shown(number)}")
        out.append((j, name, v))
    return tuple((name, v) for _, name, v in sorted(out, key=lambda e: e[0]))


def parse_roles(value: Any, where: str = "roles") -> Roles:
    """One role assignment: ``none`` or a mapping from a robot (a number from 1, or ``last``) to a
    method name, e.g. ``{1: person}``."""
    if value in ("none", None):
        return ()
    if not isinstance(value, dict) or not value:
        raise StudyError(f"{where}: expected 'none' or a mapping like {{1: person}} or {{last: orca}}, "
                         f"got {shown(value)}")
    out: dict[str, str] = {}
    for robot, method in value.items():
        key = str(robot).strip()
        if key != "last" and not (_WHOLE.fullmatch(key) and int(key) >= 1):
            raise StudyError(f"{where}: expected a robot number from 1 or 'last', got {shown(robot)}")
        if method not in known_methods():
            raise StudyError(f"{where}.{key}: unknown method {shown(method)}"
                             f"{nearest_hint(str(method), known_methods(), 'methods')}")
        out[key] = method
    return tuple(sorted(out.items()))


def _names(value: Any, where: str) -> tuple[str, ...]:
    names = _listed(value)
    if not names or not all(isinstance(n, str) and n for n in names):
        raise StudyError(f"{where}: expected a name or a non-empty list of names, got {shown(value)}")
    return tuple(names)


def _scenario_names(value: Any, where: str) -> tuple[str, ...]:
    from nodnav.scenario.catalogue import PAPER_SCENARIOS, crowd_scenarios

    names = _names(value, where)
    groups = {("all",): builtin_names, ("paper",): lambda: PAPER_SCENARIOS, ("crowds",): crowd_scenarios}
    return tuple(groups[names]()) if names in groups else names


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
            raise StudyError(f"{where}: unknown {what} {shown(n)}{nearest_hint(n, valid, what + 's')}")
    return names


def _settings(value: Any, data: dict, at) -> dict[str, Any]:
    """The ``set`` mapping: scenario keys (checked as key paths; their values when a scenario loads)."""
    from nodnav.scenario.overrides import key_path

    if not isinstance(value, dict):
        raise StudyError(f"{at('set')}: expected a mapping of scenario keys to values, e.g. "
                         f"{{planner.name: prm, robots[1].max_speed: 0.5}}, got {shown(value)}")
    for key in value:
        try:
            key_path(key, f"{at('set')}: {key}" if isinstance(key, str) else at("set"))
        except ScenarioError as exc:
            raise StudyError(str(exc)) from None
        for axis, axis_key in AXIS_KEYS.items():
            if axis in data and key == axis_key:
                raise StudyError(f"{at('set')}: {key} is also the study's axis {at(axis)}; give it in one place")
    return dict(value)


def known_methods() -> tuple[str, ...]:
    """Names of the navigation methods the simulator knows (:data:`~nodnav.registry.METHODS`)."""
    return METHODS.names()


def study_from_dict(data: Any, source: str = "study", labels: dict[str, str] | None = None) -> SweepSpec:
    """Validate a study mapping (parsed YAML, or the command line's options) and build a :class:`SweepSpec`.

    Errors name ``labels[key]`` for a key the user typed as an option (``--players``), else
    ``source: key``.
    """
    def at(key: str) -> str:
        return (labels or {}).get(key) or f"{source}: {key}"

    if not isinstance(data, dict):
        raise StudyError(f"{source}: expected a mapping with keys such as 'scenarios' and 'trials', "
                         f"got {type(data).__name__}")
    for key in data:
        if key not in STUDY_KEYS:
            raise StudyError(f"{source}: unknown key {shown(key)}{nearest_hint(key, STUDY_KEYS, 'valid keys')}")
    if "scenarios" not in data and not data.get("families"):
        if labels and "scenarios" in labels:
            raise StudyError(f"{labels['scenarios']}: give at least one scenario (a built-in name, a YAML path, "
                             "or all)")
        raise StudyError(f"{source}: missing key 'scenarios' (a list of built-in names or YAML paths, or all) "
                         "or 'families'")
    name = data.get("name", "sweep")
    if not isinstance(name, str) or not name.strip() or len(name) > 100 or not name.isprintable():
        raise StudyError(f"{at('name')}: expected one line of text (at most 100 characters), got {shown(name)}")
    trials = data.get("trials", 1)
    if isinstance(trials, str) and _WHOLE.fullmatch(trials.strip()):
        trials = int(trials)
    if isinstance(trials, bool) or not isinstance(trials, int) or not 1 <= trials <= MAX_TRIALS:
        raise StudyError(f"{at('trials')}: expected a whole number >= 1 (at most {MAX_TRIALS}), got {shown(trials)}")
    spec = SweepSpec(
        name=name.strip(),
        scenarios=_scenario_names(data["scenarios"], at("scenarios")) if "scenarios" in data else (),
        trials=trials,
        methods=_choices(data.get("methods", "nod"), known_methods(), at("methods"), "method"),
    )
    changes: dict[str, Any] = {}
    if "players" in data:
        changes["players"] = tuple(parse_players(v, at("players")) for v in _listed(data["players"]))
    if "init" in data:
        changes["init"] = _choices(data["init"], INIT_MODES, at("init"), "initial-opinion mode")
    if "bias" in data:
        changes["bias"] = tuple(parse_bias(v, at("bias")) for v in _listed(data["bias"]))
    if "planners" in data:
        changes["planners"] = _choices(data["planners"], PLANNERS, at("planners"), "planner")
    if "families" in data:
        changes["families"] = _family_names(data["families"], at("families"))
    if data.get("set") is not None:
        changes["overrides"] = _settings(data["set"], data, at)
    if "roles" in data:
        changes["roles"] = tuple(dict.fromkeys(parse_roles(v, at("roles")) for v in _listed(data["roles"])))
    for key, values in changes.items():
        if not values and key != "overrides":
            raise StudyError(f"{at(key)}: expected at least one value")
    spec = dataclasses.replace(spec, **changes)
    size = math.prod(len(axis) for axis in (spec.scenarios, spec.players, spec.init, spec.bias, spec.planners,
                                            spec.methods, spec.roles)) * spec.trials
    if size > MAX_SWEEP_TRIALS:
        raise StudyError(f"{at('trials')}: the study expands to {size} trials, more than one sweep may run "
                         f"({MAX_SWEEP_TRIALS}); split it into several studies")
    return spec


def load_study(path: str | Path, overrides: dict | None = None) -> SweepSpec:
    """Read a study file; ``overrides`` (study keys, e.g. from the command line) replace its values
    and are named by their option in errors."""
    path = Path(path)
    try:
        data = read_yaml(path, "study")
    except ScenarioError as exc:
        raise StudyError(str(exc)) from None
    if isinstance(data, dict):
        in_file = data.get("set")
        data = {"name": path.stem, **data, **(overrides or {})}
        if isinstance(in_file, dict) and isinstance(data.get("set"), dict):  # --set beside the file's set:
            data["set"] = {**in_file, **data["set"]}
    labels = {k: OPTION_NAMES[k] for k in (overrides or {}) if k in OPTION_NAMES}
    return study_from_dict(data, shown_path(path), labels)
