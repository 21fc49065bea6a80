"""Generated scenario families: a YAML file of ranges, and deterministic draws from it.

A family describes many scenarios at once, so that nobody tunes a method to a few fixed ones.
``draw(family,
       seed)`` (:mod:`nodnav.scenario.draws`) turns it into one :class:`~nodnav.scenario.schema.Scenario`; the same
family and seed give the same scenario on any machine, and every draw is valid and solvable in
principle by construction (:mod:`nodnav.scenario.validity` states and checks the rules).

Format
------
Every key is optional except ``family``; a range is ``[low, high]`` (drawn uniformly) or one
number; weights are relative (they need not sum to 1); the defaults are those of ``mixed``::

    family: my-family            # name: letters, digits, '-' and '_'; drawn scenarios are my-family:SEED
    description: "one line"
    corridor:
      length: [1.0, 10.0]        # m: the wall's thickness, from a doorway to a hallway
      fit: [0.0, 1.0]            # width as a fraction of the single-file interval of the drawn radii,
                                 #   [2 r_max + 0.1, 2 (r_a + r_b) - 0.05] (0: tightest, 1: just too narrow for two)
      # width: [0.6, 0.7]        # or the width in m (instead of fit); must be single file for every radius
    rooms:
      depth: [1.5, 6.0]          # m, each room drawn on its own
      height: [2.5, 8.0]         # m, both rooms (they share the box)
      offset: [-0.5, 0.5]        # rooms' mid-height off the corridor axis, as a fraction of the most that
                                 #   leaves a 5 cm wall beside the corridor
      grow: true                 # enlarge rooms to hold their robots (else such draws are rejected)
    robots:
      count: [2, 4]              # whole numbers, 2..8
      radius: [0.15, 0.5]        # m: the smallest radius r0; mixed radii lie in [r0, min(high, 2 r0 - 0.08)]
      mixed_radii: 0.5           # probability that radii differ within a scenario
      max_speed: [0.2, 2.0]      # m/s
      mixed_speeds: 0.5          # probability that speeds differ within a scenario
      max_accel: [0.1, 3.0]      # m/s^2
      mixed_accels: 0.5          # probability that acceleration limits differ within a scenario
    traffic: {head-on: 1, one-sided: 1, mixed: 1}   # weights: split as evenly as possible, all in one
                                 #   room, or any other split, of the robots that start outside
    inside: {probability: 0.2, max: 2}   # a scenario has 1..max robots starting in the corridor
      # order: {apart: 1}        # weights: robots inside heading left left of those heading right
                                 #   (apart: nobody must pass), in any order, or two teams facing
                                 #   each other (facing: 1..3 a side, 2..max in all; one side must
                                 #   back out), see docs/meet-inside.md
      # bays: 0.0                # probability of a bay (a niche one robot fits into) in a corridor wall
    starts:
      formation: {scatter: 1, abreast: 1, line: 1}  # weights, per room: anywhere, side by side, a queue
      gap: [0.05, 3.0]           # m from the mouth to the front robot's body (side by side and queues)
      spacing: [0.05, 0.8]       # m between neighbours' bodies (side by side, queues, robots inside)
    destinations:
      mouth: 0.15                # probability that one robot parks right outside its far mouth (5-25 cm)
      axis: 0.25                 # probability, per other robot, that its destination is on the corridor axis
    scenario: {}                 # settings of every drawn scenario: opinion, game_players, planner, controller, sim,
                                 # execution, baselines

A drawn scenario is named ``FAMILY:SEED``; ``nodnav run mixed:17`` (or ``path/fam.yaml:17``)
loads it wherever a scenario name is accepted (:mod:`nodnav.scenario.draws` draws it).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from nodnav.errors import nearest_hint
from nodnav.scenario.building_family import BuildingFamily, building_family_from_dict
from nodnav.scenario.family_fields import (
    MAX_ROBOTS,
    ROBOT_KEYS,
    SETTING_KEYS,
    FamilyError,
    Range,
    _check_keys,
    _mapping,
    _range,
    _real,
    _shown,
    _weights,
    check_settings_load,
    robot_ranges,
)
from nodnav.scenario.files import yaml_error_message
from nodnav.scenario.validity import CLEARANCE

TRAFFIC = ("head-on", "one-sided", "mixed")
FORMATIONS = ("scatter", "abreast", "line")
INSIDE_ORDERS = ("apart", "any", "facing")
@dataclass(frozen=True)
class Family:
    """A validated family file: every range a draw uses."""

    name: str
    """Family name; drawn scenarios are named ``name:SEED``."""
    source: str
    """``built-in``, or the family file's path as given."""
    description: str = ""
    """One line saying what the family is for."""
    length: Range = Range(1.0, 10.0)
    """Corridor length, i.e. the wall's thickness (m)."""
    width: Range | None = None
    """Corridor width (m), if given in metres; else ``fit`` decides."""
    fit: Range = Range(0.0, 1.0)
    """Width as a fraction of the single-file interval of the drawn radii (dimensionless)."""
    depth: Range = Range(1.5, 6.0)
    """Depth of each room (m)."""
    height: Range = Range(2.5, 8.0)
    """Height of the rooms (m)."""
    offset: Range = Range(-0.5, 0.5)
    """Rooms' mid-height off the corridor axis, as a fraction of the most that leaves a 5 cm wall (dimensionless)."""
    grow: bool = True
    """Whether rooms are enlarged to hold their robots."""
    count: tuple[int, int] = (2, 4)
    """Number of robots, inclusive range."""
    radius: Range = Range(0.15, 0.5)
    """Smallest robot radius of a scenario (m)."""
    mixed_radii: float = 0.5
    """Probability that radii differ within a scenario."""
    max_speed: Range = Range(0.2, 2.0)
    """Robot speed limit (m/s); paper: 1."""
    mixed_speeds: float = 0.5
    """Probability that speed limits differ within a scenario."""
    max_accel: Range = Range(0.1, 3.0)
    """Robot acceleration limit (m/s^2); the paper gives none. A single number draws nothing
    (the draws of a family with one acceleration are those it had before this key was a range)."""
    mixed_accels: float = 0.5
    """Probability that acceleration limits differ within a scenario."""
    traffic: tuple[tuple[str, float], ...] = (("head-on", 1.0), ("one-sided", 1.0), ("mixed", 1.0))
    """Weights of the ways the robots outside split between the rooms."""
    inside_probability: float = 0.2
    """Probability that some robots start inside the corridor."""
    inside_max: int = 2
    """Most robots that start inside the corridor."""
    inside_order: tuple[tuple[str, float], ...] = (("apart", 1.0),)
    """Weights of the ways robots inside are placed: apart (nobody must pass), any order, or two
    teams facing each other (:mod:`nodnav.scenario.meeting`)."""
    bays: float = 0.0
    """Probability that a corridor wall has a bay one robot fits into (:mod:`nodnav.scenario.meeting`)."""
    formations: tuple[tuple[str, float], ...] = (("scatter", 1.0), ("abreast", 1.0), ("line", 1.0))
    """Weights of the start formations, drawn per room."""
    gap: Range = Range(0.05, 3.0)
    """Distance from the mouth to the front robot's body, side by side and in queues (m)."""
    spacing: Range = Range(0.05, 0.8)
    """Distance between neighbours' bodies, side by side, in queues and inside (m)."""
    mouth: float = 0.15
    """Probability that one robot parks right outside its far mouth."""
    axis: float = 0.25
    """Probability, per other robot, that its destination is on the corridor axis."""
    settings: dict = field(default_factory=dict)
    """Scenario settings of every draw (``opinion``, ``game_players``, ``planner``, ``controller``, ``sim``,
    ``execution``, ``baselines``)."""


# ---------------------------------------------------------------------------------------------
# Loading


_SECTIONS = {
    "corridor": ("length", "fit", "width"),
    "rooms": ("depth", "height", "offset", "grow"),
    "robots": ROBOT_KEYS,
    "inside": ("probability", "max", "order", "bays"),
    "starts": ("formation", "gap", "spacing"),
    "destinations": ("mouth", "axis"),
}
_TOP = ("family", "description", *_SECTIONS, "traffic", "scenario", "building")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")


def family_from_dict(data: Any, source: str = "family") -> Family | BuildingFamily:
    """Validate a parsed family mapping (see the module docstring) and build a :class:`Family`."""
    if not isinstance(data, dict):
        raise FamilyError(f"{source}: expected a mapping with keys such as 'family' and 'robots', "
                          f"got {type(data).__name__}")
    _check_keys(data, _TOP, source)
    name = data.get("family")
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise FamilyError(f"{source}: family: expected a name of letters, digits, '-' and '_', got {_shown(name)}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise FamilyError(f"{source}: description: expected one line of text")
    if "building" in data:  # a family of floor plans (issue 20)
        return building_family_from_dict(data, source, name, description)
    sec = {}
    for section, keys in _SECTIONS.items():
        sec[section] = _mapping(data.get(section), f"{source}: {section}")
        _check_keys(sec[section], keys, f"{source}: {section}")
    c, rooms, robots, inside = sec["corridor"], sec["rooms"], sec["robots"], sec["inside"]
    starts, dests = sec["starts"], sec["destinations"]
    w = f"{source}: "
    kw: dict[str, Any] = {}

    def put(key, section, attr, parse):
        if attr in section:
            kw[key] = parse(section[attr])

    put("length", c, "length", lambda v: _range(v, w + "corridor.length", 0.1, 30.0, " (m)"))
    put("fit", c, "fit", lambda v: _range(v, w + "corridor.fit", 0.0, 1.0))
    put("width", c, "width", lambda v: _range(v, w + "corridor.width", 0.1, 10.0, " (m)"))
    if "fit" in c and "width" in c:
        raise FamilyError(f"{w}corridor: give either 'fit' or 'width', not both")
    put("depth", rooms, "depth", lambda v: _range(v, w + "rooms.depth", 0.1, 30.0, " (m)"))
    put("height", rooms, "height", lambda v: _range(v, w + "rooms.height", 0.1, 30.0, " (m)"))
    put("offset", rooms, "offset", lambda v: _range(v, w + "rooms.offset", -1.0, 1.0))
    if "grow" in rooms:
        if not isinstance(rooms["grow"], bool):
            raise FamilyError(f"{w}rooms.grow: expected true or false, got {_shown(rooms['grow'])}")
        kw["grow"] = rooms["grow"]
    kw.update(robot_ranges(robots, w + "robots", radius_hi=2.0))
    if "traffic" in data:
        kw["traffic"] = _weights(data["traffic"], w + "traffic", TRAFFIC)
    put("inside_probability", inside, "probability", lambda v: _real(v, w + "inside.probability", 0.0, 1.0,
                                                                     " (a probability)"))
    if "max" in inside:
        m = inside["max"]
        if isinstance(m, bool) or not isinstance(m, int) or not 0 <= m < MAX_ROBOTS:
            raise FamilyError(f"{w}inside.max: expected a whole number in 0..{MAX_ROBOTS - 1}, got {_shown(m)}")
        kw["inside_max"] = m
    if "order" in inside:
        kw["inside_order"] = _weights(inside["order"], w + "inside.order", INSIDE_ORDERS)
    put("bays", inside, "bays", lambda v: _real(v, w + "inside.bays", 0.0, 1.0, " (a probability)"))
    put("formations", starts, "formation", lambda v: _weights(v, w + "starts.formation", FORMATIONS))
    put("gap", starts, "gap", lambda v: _range(v, w + "starts.gap", CLEARANCE, 30.0, " (m)"))
    put("spacing", starts, "spacing", lambda v: _range(v, w + "starts.spacing", CLEARANCE, 10.0, " (m)"))
    put("mouth", dests, "mouth", lambda v: _real(v, w + "destinations.mouth", 0.0, 1.0, " (a probability)"))
    put("axis", dests, "axis", lambda v: _real(v, w + "destinations.axis", 0.0, 1.0, " (a probability)"))
    settings = _mapping(data.get("scenario"), w + "scenario")
    _check_keys(settings, SETTING_KEYS, w + "scenario")
    family = Family(name=name, source=source, description=description, settings=dict(settings), **kw)
    _check_consistent(family, w)
    return family


def _check_consistent(f: Family, w: str) -> None:
    """Cross-key checks: a width in metres must be single file for every radius; settings must load."""
    if f.width is not None:
        lo, hi = 2 * f.radius.hi + 0.1, 4 * f.radius.lo - 0.05
        if f.width.lo < lo - 1e-9 or f.width.hi > hi + 1e-9:
            raise FamilyError(f"{w}corridor.width: [{f.width.lo:g}, {f.width.hi:g}] m is not single file for radii "
                              f"[{f.radius.lo:g}, {f.radius.hi:g}] m; keep it within [{lo:.3f}, {hi:.3f}] m "
                              "(2 r_max + 0.1 to 4 r_min - 0.05) or use 'fit'")
    # The settings, tried on a plain scenario with the fewest robots the family draws.
    robots = [{"origin": [-5.0, 2.0 - k], "destination": [5.0, 2.0 - k]} for k in range(f.count[0])]
    check_settings_load(f.settings, robots, w)


def builtin_families() -> list[str]:
    """Names of the built-in families, sorted."""
    files = resources.files("nodnav.scenario") / "builtin" / "families"
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".yaml"))


def _read_yaml(text: str, source: str) -> Any:
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise FamilyError(f"{source}: {yaml_error_message(exc)}") from None
    except RecursionError:
        raise FamilyError(f"{source}: the YAML is nested too deeply to be a family file") from None


def load_family(spec: str | Path) -> Family | BuildingFamily:
    """A built-in family by name (``mixed``) or a family file by path."""
    spec = str(spec)
    if spec in builtin_families():
        text = (resources.files("nodnav.scenario") / "builtin" / "families" / f"{spec}.yaml").read_text()
        return family_from_dict(_read_yaml(text, spec), "built-in")
    path = Path(spec)
    if not path.is_file():
        raise FamilyError(f"{spec}: no such built-in family or family file"
                          f"{nearest_hint(spec, builtin_families(), 'built-in families')}")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise FamilyError(f"{spec}: cannot read the family file ({exc})") from None
    return family_from_dict(_read_yaml(text, spec), spec)


def is_family(spec: str | Path) -> bool:
    """Whether ``spec`` names a built-in family or a YAML file with a top-level ``family`` key."""
    spec = str(spec)
    if spec in builtin_families():
        return True
    path = Path(spec)
    if not (path.is_file() and path.suffix in (".yaml", ".yml")):
        return False
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return False
    return isinstance(data, dict) and "family" in data


_DRAW_SPEC = re.compile(r"(?P<family>.+):(?P<seed>[0-9]+)")


def parse_draw_spec(spec: str) -> tuple[str, int] | None:
    """``("mixed", 17)`` for ``mixed:17`` (or ``path/fam.yaml:17``); ``None`` if ``spec`` has no ``:SEED``."""
    m = _DRAW_SPEC.fullmatch(str(spec))
    if m is None:
        return None
    seed = int(m["seed"])
    if seed >= 2**63:
        raise FamilyError(f"{spec}: seed {seed} is too large; use 0 .. 2^63 - 1")
    return m["family"], seed


def redo_spec(scenario_name: str, description: str) -> str | None:
    """The ``FAMILY:SEED`` that redraws a stored scenario (a file family's path comes from its description)."""
    m = re.match(r"draw (?P<seed>[0-9]+) of family (?P<name>\S+) \((?P<source>[^)]*)\)", description or "")
    if m is None or scenario_name != f"{m['name']}:{m['seed']}":
        return None
    return scenario_name if m["source"] == "built-in" else f"{m['source']}:{m['seed']}"
