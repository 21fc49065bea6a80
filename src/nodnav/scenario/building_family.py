"""The ``building`` kind of family: random floor plans, read from a family file with a ``building`` section.

A family file with a top-level ``building`` key draws floor plans (:mod:`nodnav.scenario.building`)
instead of the two rooms of the corridor families. Every key is optional; omitted keys take the
built-in ``building`` family's values::

    family: my-building
    description: "one line"
    building:
      doors: [1, 3]              # single-file passages in the plan: rooms in a chain, doors + 1 of them
                                 #   (1 restricts every draw to one passage)
      crossings: [1, 3]          # passages each robot's route crosses (at most the plan's doors)
      depth: [3.0, 7.0]          # m: each room's narrowest extent along the chain
      height: [4.0, 9.0]         # m: the building's extent across the chain
      corridors: 0.3             # probability that a passage is a corridor rather than a door
      door_length: [0.1, 0.4]    # m: a door's wall thickness
      corridor_length: [1.0, 4.0]  # m: a corridor's length
      fit: [0.0, 1.0]            # width within the single-file interval of the drawn radii
      tilt: [-30.0, 30.0]        # degrees: each wall off square to the chain
      turn: [0.0, 360.0]         # degrees: the whole plan
      furniture: [0, 3]          # pieces per room (convex polygons)
      furniture_size: [0.3, 1.5] # m: a piece's largest extent
    robots: {count: [2, 8], radius: [0.15, 0.35], ...}   # as in the corridor families
    scenario: {game_players: 2}  # settings of every draw
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from nodnav.scenario.family_fields import (
    ROBOT_KEYS,
    SETTING_KEYS,
    FamilyError,
    Range,
    _check_keys,
    _mapping,
    _range,
    _real,
    _shown,
    check_settings_load,
    robot_ranges,
)

#: Most single-file passages in a drawn floor plan (the issue's 1-3 per route).
MAX_DOORS = 3


@dataclass(frozen=True)
class BuildingFamily:
    """A validated ``building`` family file: every range a floor-plan draw uses."""

    name: str
    """Family name; drawn scenarios are named ``name:SEED``."""
    source: str
    """``built-in``, or the family file's path as given."""
    description: str = ""
    """One line saying what the family is for."""
    doors: tuple[int, int] = (1, 3)
    """Single-file passages in the plan (rooms in a chain: doors + 1), inclusive range."""
    crossings: tuple[int, int] = (1, 3)
    """Passages each robot's route crosses, inclusive range (capped at the plan's doors)."""
    depth: Range = Range(3.0, 7.0)
    """Each room's narrowest extent along the chain (m)."""
    height: Range = Range(4.0, 9.0)
    """The building's extent across the chain (m)."""
    corridors: float = 0.3
    """Probability that a passage is a corridor (``corridor_length``) rather than a door."""
    door_length: Range = Range(0.1, 0.4)
    """A door's length, i.e. its wall's thickness (m)."""
    corridor_length: Range = Range(1.0, 4.0)
    """A corridor's length (m)."""
    fit: Range = Range(0.0, 1.0)
    """Width as a fraction of the single-file interval of the drawn radii (dimensionless)."""
    tilt: Range = Range(-30.0, 30.0)
    """Each wall's angle off square to the chain (degrees)."""
    turn: Range = Range(0.0, 360.0)
    """The whole plan's angle (degrees)."""
    furniture: tuple[int, int] = (0, 3)
    """Furniture pieces tried per room, inclusive range."""
    furniture_size: Range = Range(0.3, 1.5)
    """A piece's largest extent (m)."""
    count: tuple[int, int] = (2, 8)
    """Number of robots, inclusive range."""
    radius: Range = Range(0.15, 0.35)
    """Smallest robot radius of a scenario (m)."""
    mixed_radii: float = 0.5
    """Probability that radii differ within a scenario."""
    max_speed: Range = Range(0.2, 2.0)
    """Robot speed limit (m/s); paper: 1."""
    mixed_speeds: float = 0.5
    """Probability that speed limits differ within a scenario."""
    max_accel: Range = Range(0.1, 3.0)
    """Robot acceleration limit (m/s^2)."""
    mixed_accels: float = 0.5
    """Probability that acceleration limits differ within a scenario."""
    settings: dict = field(default_factory=dict)
    """Scenario settings of every draw (``opinion``, ``game_players``, ...)."""


_BUILDING_KEYS = ("doors", "crossings", "depth", "height", "corridors", "door_length", "corridor_length", "fit",
                  "tilt", "turn", "furniture", "furniture_size")


def _small_count(value: Any, where: str, lo: int, hi: int) -> tuple[int, int]:
    values = list(value) if isinstance(value, (list, tuple)) else [value, value]
    if len(values) != 2 or not all(isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi for v in values):
        raise FamilyError(f"{where}: expected a whole number or [low, high] in {lo}..{hi}, got {_shown(value)}")
    if values[0] > values[1]:
        raise FamilyError(f"{where}: low {values[0]} is above high {values[1]}; write [low, high]")
    return values[0], values[1]


def building_family_from_dict(data: dict, source: str, name: str, description: str) -> BuildingFamily:
    """Validate a parsed family mapping with a ``building`` section (the module docstring)."""
    w = f"{source}: "
    _check_keys(data, ("family", "description", "building", "robots", "scenario"), source)
    b = _mapping(data.get("building"), w + "building")
    _check_keys(b, _BUILDING_KEYS, w + "building")
    robots = _mapping(data.get("robots"), w + "robots")
    _check_keys(robots, ROBOT_KEYS, w + "robots")
    kw: dict[str, Any] = {}
    parse = {
        "doors": lambda v, k: _small_count(v, k, 1, MAX_DOORS),
        "crossings": lambda v, k: _small_count(v, k, 1, MAX_DOORS),
        "depth": lambda v, k: _range(v, k, 1.5, 30.0, " (m)"),
        "height": lambda v, k: _range(v, k, 2.0, 30.0, " (m)"),
        "corridors": lambda v, k: _real(v, k, 0.0, 1.0, " (a probability)"),
        "door_length": lambda v, k: _range(v, k, 0.05, 2.0, " (m)"),
        "corridor_length": lambda v, k: _range(v, k, 0.5, 15.0, " (m)"),
        "fit": lambda v, k: _range(v, k, 0.0, 1.0),
        "tilt": lambda v, k: _range(v, k, -45.0, 45.0, " (degrees)"),
        "turn": lambda v, k: _range(v, k, -360.0, 360.0, " (degrees)"),
        "furniture": lambda v, k: _small_count(v, k, 0, 6),
        "furniture_size": lambda v, k: _range(v, k, 0.1, 3.0, " (m)"),
    }
    for key, fn in parse.items():
        if key in b:
            kw[key] = fn(b[key], f"{w}building.{key}")
    kw.update(robot_ranges(robots, w + "robots", radius_hi=1.0))
    settings = _mapping(data.get("scenario"), w + "scenario")
    _check_keys(settings, SETTING_KEYS, w + "scenario")
    family = BuildingFamily(name=name, source=source, description=description, settings=dict(settings), **kw)
    _check_settings(family, w)
    if family.crossings[0] > family.doors[1]:
        raise FamilyError(f"{w}building.crossings: routes cross at least {family.crossings[0]} passages but plans "
                          f"have at most {family.doors[1]} doors; lower crossings or raise doors")
    return family


def _check_settings(f: BuildingFamily, w: str) -> None:
    """The settings must load: tried on a plain scenario with the most robots the family draws."""
    robots = [{"origin": [-6.0, 2.0 - 0.5 * k], "destination": [6.0, 2.0 - 0.5 * k]} for k in range(f.count[1])]
    check_settings_load(f.settings, robots, w)
