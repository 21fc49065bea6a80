"""Scenario files: frozen parameter dataclasses, YAML loading, and all validation.

Validation happens here and only here, at load time: everything downstream may assume a
:class:`Scenario` is well formed. Every problem is reported as one :class:`ScenarioError` line
that names the offending key or robot and says how to fix it.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import numbers
import re
import typing
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from nodnav.errors import NodnavError, one_line, shown, shown_path
from nodnav.scenario import limits
from nodnav.scenario.world import Corridor, World, paper_world


class ScenarioError(NodnavError, ValueError):
    """A scenario file or option is malformed; the message is one line saying what and how to fix.

    ``key`` is the key path the message starts with (``opinion.u``) and ``detail`` the rest.
    """

    def __init__(self, message: str, key: str = ""):
        super().__init__(message)
        self.key = key
        self.detail = message[len(key) + 2:] if key and message.startswith(key + ": ") else message


@dataclass(frozen=True)
class OpinionParams:
    """Parameters of the opinion layer (Sections II-B and III)."""

    u: float = 100.0
    """Attention u_i to the social term (dimensionless); paper: 100 (10 for Fig. 2b/2c)."""
    d: float = 1.0
    """Resistance d_i, the inverse time constant of the opinion (1/s); paper: 1."""
    eta: float = 1.0
    """Softmax temperature eta of eq. (3) (dimensionless); paper: 1."""
    K1: float = 5.0
    """Scaling K_1 of the observed-versus-planned deviation in eq. (4) (1/(m^2 s)); paper: 5."""
    T: float = 1.0
    """Opinion period T: decisions and the estimation window of eq. (4) (s); paper: 1."""
    alpha_min: float = 0.05
    """Lower bound h of the step size alpha(t) = max(1/(t+1), h) of eq. (8); paper: 0.05."""
    init: str = "zero"
    """Initial opinions: ``zero`` (z_ij(0) = 0), ``distance`` (eqs. (10)-(11)) or ``given`` (``z0``); paper: zero."""
    z0: tuple[tuple[float, ...], ...] = ()
    """With ``init: given``, the initial opinions z_i(0) of every robot, one row per robot (dimensionless)."""
    K2: float = 10.0
    """Scaling K_2 of the distance-based initial opinions, eq. (11) (dimensionless); paper: 10."""
    delta: float = 1.0
    """Offset delta of the conflict likelihood, eq. (6) (m); paper: 1."""
    bias: dict[str, float] = field(default_factory=dict)
    """Bias b_ij per strategy name, e.g. ``{S3: 150, S5: 150}`` (dimensionless); paper: none."""
    conflict: str = "paper"
    """Game-player selection, eqs. (6)-(7): ``paper`` (every other robot a candidate) or
    ``undecided`` (robots seen in the corridor only when too few others are left)."""
    standoff_patience: float = 2.0
    """After how long a standoff with a game player (both standing still, this one although its
    plan moves it) the lower-numbered robot of the two goes first (s); 0 never (the paper)."""
    nonplayers: str = "entered"
    """How robots outside N_i(t) enter the robot's planning: ``static`` (the paper: not planned,
    held still in the MPC) or ``entered`` (those seen inside the corridor are planned too, at the
    front of the order, where history has put them)."""

    def bias_indices(self) -> dict[int, float]:
        """The bias b_ij as a mapping from strategy index (0-based: S1 is 0) to value."""
        return {strategy_number(name) - 1: float(value) for name, value in self.bias.items()}

    def bias_vector(self, n_strategies: int) -> np.ndarray:
        """The bias b_i as an array over strategies S1..S_{N_s}."""
        b = np.zeros(n_strategies)
        for name, value in self.bias.items():
            b[strategy_number(name) - 1] = value
        return b


@dataclass(frozen=True)
class RobotSpec:
    """One robot: where it starts, where it goes, and its body."""

    origin: tuple[float, float]
    """Origin O_i (m)."""
    destination: tuple[float, float]
    """Destination D_i (m)."""
    radius: float = 0.2
    """Body radius r_robot (m); paper: not given, 0.2 chosen (see README)."""
    max_speed: float = 1.0
    """Speed limit (m/s); paper: 1."""
    max_accel: float = 2.0
    """Acceleration limit used by the MPC (m/s^2); paper: not given."""
    opinion: OpinionParams | None = None
    """This robot's own opinion parameters; ``None`` means the scenario's ``opinion``."""


@dataclass(frozen=True)
class PlannerParams:
    """Which multi-robot path planner to use and how."""

    name: str = "fast"
    """Planner name: ``fast`` (prioritised space-time, no precomputation) or ``prm`` (paper)."""
    dt: float = 0.1
    """Time step of the planned joint trajectory (s)."""
    margin: float = 0.05
    """Extra separation kept by the planner beyond 2 r_robot (m)."""
    waiting: str = "early"
    """Fast planner: a yielding robot holds back ``early`` (legible) or drives up and waits ``late``."""
    door_clearance: float = 1.0
    """Fast planner: radius of the zone around a corridor entrance kept clear while a robot comes out of it (m)."""
    w1: float = 0.4
    """Weight w_1 of the proximity penalty in the PRM* path cost (1/m); paper: 0.4."""
    varsigma: float = 0.1
    """Safety margin varsigma of Phi_proximity (m); paper: 0.1."""
    roadmap_vertices: int = 2000
    """PRM*: roadmap size is this times the number of robots (vertices); 500 already answers every built-in query."""
    cache_dir: str = ""
    """PRM*: roadmap cache directory; empty means ``$NODNAV_CACHE`` or ``~/.cache/nodnav``."""


@dataclass(frozen=True)
class ControllerParams:
    """The motion controller (appendix, Model Predictive Control)."""

    name: str = "mpc"
    """Controller name: ``mpc`` (the B-spline MPC of the appendix)."""
    dt: float = 0.1
    """Control and physics step (s)."""
    horizon: float = 0.8
    """MPC horizon T_MPC (s); paper: 0.8."""
    w2: float = 1e-6
    """Velocity weight w_2 of the MPC cost (s^2); paper: 1e-6."""
    safety_margin: float = 0.02
    """Separation kept by the MPC beyond 2 r_robot (m); below the planner's ``margin`` so that the
    MPC can track plans that keep exactly that (not in the paper)."""


@dataclass(frozen=True)
class ExecutionParams:
    """How a robot follows its selected joint plan between decisions (not in the paper)."""

    mode: str = "gated"
    """``gated``: by the plan's precedences, waiting for the robots it depends on to move on
    (:mod:`nodnav.sim.execution`); ``timed``: by the clock, as the appendix."""
    lag: float = 0.3
    """Least time between the two samples of a precedence (s); rules out waiting cycles between
    robots that pass each other closely."""
    tolerance: float = 0.05
    """Distance within which an observed robot counts as still at the earliest of its nearest
    planned samples (m): how far it must move before it counts as having moved on."""
    reaction_margin: str = "conflict"
    """When the MPC keeps clear of every other robot's braking trajectory by how far that can move
    in one control step (``nodnav.sim.methods.reaction_margin``): ``always``, ``conflict`` (from
    a step at which the robot could not follow its plan until it can again: two robots that both
    cannot never squeeze each other) or ``off``."""


@dataclass(frozen=True)
class SimParams:
    """How a trial is simulated and judged."""

    goal_tolerance: float = 0.15
    """A robot has arrived when it is this close to its destination (m)."""
    collision_tolerance: float = 1e-3
    """Penetration beyond which a contact counts as a collision (m)."""
    deadlock_time: float = 10.0
    """A trial is a deadlock when no robot has progressed for this long (s)."""
    progress_epsilon: float = 0.2
    """Decrease of a robot's distance-to-go below its best so far that counts as progress (m); a
    robot radius, so that robots creeping a few centimetres at a time in a jam do not count."""
    observation_noise: float = 0.0
    """Standard deviation of the position noise in what each robot observes of the others (m)."""


@dataclass(frozen=True)
class Scenario:
    """A complete, validated description of one navigation problem."""

    name: str
    """Short identifier, e.g. ``3r-case2``."""
    world: World
    """The environment."""
    robots: tuple[RobotSpec, ...]
    """The robots, numbered 1..N_r in this order."""
    description: str = ""
    """One line saying what the scenario shows."""
    opinion: OpinionParams = OpinionParams()
    """Opinion-layer parameters, shared by every robot unless overridden per robot."""
    game_players: int | None = None
    """Number k of game players per robot (eq. (7)); ``None`` means all other robots."""
    time_limit: float = 60.0
    """Simulated time after which a trial is a timeout (s)."""
    planner: PlannerParams = PlannerParams()
    """The multi-robot path planner."""
    controller: ControllerParams = ControllerParams()
    """The motion controller."""
    sim: SimParams = SimParams()
    """Simulation and outcome settings."""
    execution: ExecutionParams = ExecutionParams()
    """How robots follow their plans between decisions."""

    @property
    def n_robots(self) -> int:
        """N_r."""
        return len(self.robots)

    @property
    def n_players(self) -> int:
        """Effective number of game players per robot, between 0 and N_r - 1."""
        return self.n_robots - 1 if self.game_players is None else self.game_players

    def robot_opinion(self, i: int) -> OpinionParams:
        """Robot ``i``'s opinion parameters (its own, else the scenario's)."""
        return self.robots[i].opinion or self.opinion

    @property
    def origins(self) -> np.ndarray:
        """Origins as an ``(N_r, 2)`` array (m)."""
        return np.array([r.origin for r in self.robots], dtype=float)

    @property
    def destinations(self) -> np.ndarray:
        """Destinations as an ``(N_r, 2)`` array (m)."""
        return np.array([r.destination for r in self.robots], dtype=float)

    @property
    def radii(self) -> np.ndarray:
        """Radii as an ``(N_r,)`` array (m)."""
        return np.array([r.radius for r in self.robots], dtype=float)

    @property
    def max_speeds(self) -> np.ndarray:
        """Speed limits as an ``(N_r,)`` array (m/s)."""
        return np.array([r.max_speed for r in self.robots], dtype=float)

    def with_overrides(self, **changes: Any) -> "Scenario":
        """A copy with top-level fields or dotted sub-fields replaced, validated again.

        ``with_overrides(game_players=1, **{"opinion.init": "distance"})``.
        """
        return self.with_options(changes)

    def with_options(self, changes: dict[str, Any], labels: dict[str, str] | None = None) -> "Scenario":
        """:meth:`with_overrides` for values the user typed as options: an error about key ``k``
        (or below it) names ``labels[k]`` instead, e.g. ``{"game_players": "--players"}``."""
        raw = _to_raw(self)
        for key, value in changes.items():
            target = raw
            *parents, leaf = key.split(".")
            for p in parents:
                target = target.setdefault(p, {})
            target[leaf] = value
        try:
            return scenario_from_dict(raw, self.name)
        except ScenarioError as exc:
            for key, label in (labels or {}).items():
                if exc.key == key or exc.key.startswith(key + "."):
                    raise ScenarioError(f"{label}: {exc.detail}", key=label) from None
            raise


# ---------------------------------------------------------------------------------------------
# Loading. Every check names the key path the user wrote (``robot_defaults.radius``,
# ``robots[2].origin``) and, where a number is out of range, the range (nodnav.scenario.limits).


def _fail(where: str, detail: str) -> ScenarioError:
    return ScenarioError(f"{where}: {detail}", key=where)


def nearest_hint(key: str, valid, what: str = "valid keys") -> str:
    """'; did you mean X?' for the closest valid name, else the list of valid names."""
    match = difflib.get_close_matches(str(key)[:100], list(valid), n=1, cutoff=0.5) if isinstance(key, str) else []
    return f"; did you mean '{match[0]}'?" if match else f"; {what}: {', '.join(sorted(valid))}"


def _check_keys(data: dict, valid, where: str) -> None:
    for key in data:
        if key not in valid:
            raise _fail(where, f"unknown key {shown(key)}{nearest_hint(key, valid)}")


_EXPONENT = re.compile(r"[+-]?([0-9]{1,20}\.?[0-9]{0,20}|\.[0-9]{1,20})[eE][+-]?[0-9]{1,3}")


def _number(value: Any, where: str, bound: str | None = None) -> float:
    """A finite real number; with ``bound`` (a key of :data:`~nodnav.scenario.limits.RANGES`) in its range."""
    if isinstance(value, str) and _EXPONENT.fullmatch(value.strip()):
        value = float(value)  # YAML 1.1 reads 1e-6 (no dot) as text; it is a number all the same
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _fail(where, f"expected a number, got {shown(value)}")
    try:
        v = float(value)
    except (OverflowError, ValueError, TypeError):
        raise _fail(where, f"expected a number of ordinary size, got {shown(value)}") from None
    if not math.isfinite(v):
        raise _fail(where, f"expected a finite number, got {shown(value)}")
    if bound is not None and not limits.in_range(bound, v):
        raise _fail(where, f"must be {limits.range_text(bound)}, got {shown(value)}")
    return v


def _coordinate(value: Any, where: str) -> float:
    v = _number(value, where)
    if abs(v) > limits.MAX_COORDINATE:
        raise _fail(where, f"coordinates must lie within +-{limits.MAX_COORDINATE:g} m, got {shown(value)}")
    return v


def _vector(value: Any, n: int, where: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise _fail(where, f"expected a list of {n} numbers, got {shown(value)}")
    return tuple(_coordinate(v, f"{where}[{k}]") for k, v in enumerate(value))


def _mapping(value: Any, where: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _fail(where, f"expected a mapping of keys to values, got {shown(value)}")
    return value


def _text(value: Any, where: str, limit: int) -> str:
    if not isinstance(value, str):
        raise _fail(where, f"expected text, got {shown(value)}")
    if len(value) > limit:
        raise _fail(where, f"at most {limit} characters, got {len(value)}")
    return value


_BIAS_KEY = re.compile(r"S([1-9][0-9]{0,5})")


def strategy_number(name: Any) -> int | None:
    """The number ``j`` of a strategy named ``Sj`` (ASCII digits, no leading zero), else ``None``."""
    m = _BIAS_KEY.fullmatch(name) if isinstance(name, str) else None
    return int(m.group(1)) if m else None


def _params(cls, data: Any, where: str, bounds: str):
    """Build a flat parameter dataclass from a mapping, checking keys, types and ranges
    (``bounds`` is the section of :data:`~nodnav.scenario.limits.RANGES`, e.g. ``planner``)."""
    data = _mapping(data, where)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    _check_keys(data, fields, where)
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for key, value in data.items():
        hint = hints[key]
        name = f"{where}.{key}"
        bound = f"{bounds}.{key}"
        if hint is float:
            kwargs[key] = _number(value, name, bound if bound in limits.RANGES else None)
        elif hint is int:
            if isinstance(value, bool) or not isinstance(value, int):
                raise _fail(name, f"expected a whole number, got {shown(value)}")
            _number(value, name, bound)
            kwargs[key] = value
        elif hint is str:
            kwargs[key] = _text(value, name, 4096)
        elif hint is bool:
            if not isinstance(value, bool):
                raise _fail(name, f"expected true or false, got {shown(value)}")
            kwargs[key] = value
        elif hint == dict[str, float]:
            mapping = _mapping(value, name)
            if len(mapping) > limits.MAX_STRATEGIES:
                raise _fail(name, f"more entries ({len(mapping)}) than there can be strategies")
            kwargs[key] = {}
            for k, v in mapping.items():
                if strategy_number(k) is None:
                    raise _fail(name, f"unknown strategy {shown(k)}; name strategies S1, S2, ...")
                kwargs[key][k] = _number(v, f"{name}.{k}", bound)
        else:  # a matrix of numbers, one row per robot; its shape is checked before its entries
            if (not isinstance(value, (list, tuple)) or len(value) > limits.MAX_ROBOTS
                    or not all(isinstance(row, (list, tuple)) and len(row) <= limits.MAX_STRATEGIES for row in value)):
                raise _fail(name, f"expected a list of rows of numbers (one per robot), got {shown(value)}")
            kwargs[key] = tuple(tuple(_number(v, f"{name}[{k}][{c}]", bound) for c, v in enumerate(row))
                                for k, row in enumerate(value))
    return cls(**kwargs)


def _box(value: Any, where: str) -> tuple[float, float, float, float]:
    box = _vector(value, 4, where)
    if box[0] >= box[2] or box[1] >= box[3]:
        raise _fail(where, f"need x_min < x_max and y_min < y_max, got {list(box)}")
    return box


def _world(data: Any) -> World:
    data = _mapping(data, "world")
    valid = ("bounds", "obstacles", "corridor", "entrances", "corridor_width")
    _check_keys(data, valid, "world")
    if "corridor_width" in data and "corridor" in data:
        raise _fail("world.corridor_width", "give either corridor_width (the paper's layout) or corridor, not both")
    width = _number(data.get("corridor_width", 0.7), "world.corridor_width")
    if not 0.0 < width < 5.0:
        raise _fail("world.corridor_width", f"must be above 0 and below the rooms' height (5 m), got {shown(width)}")
    default = paper_world(corridor_width=width)
    bounds = _box(data["bounds"], "world.bounds") if "bounds" in data else default.bounds
    if max(bounds[2] - bounds[0], bounds[3] - bounds[1]) > limits.MAX_WORLD_SIZE:
        raise _fail("world.bounds", f"sides of at most {limits.MAX_WORLD_SIZE:g} m, got {list(bounds)}")
    if "obstacles" in data:
        raw = data["obstacles"]
        if not isinstance(raw, list) or len(raw) > limits.MAX_OBSTACLES:
            raise _fail("world.obstacles", f"expected a list of at most {limits.MAX_OBSTACLES} "
                        f"[x_min, y_min, x_max, y_max] rectangles, got {shown(raw)}")
        obstacles = tuple(_box(o, f"world.obstacles[{k}]") for k, o in enumerate(raw))
    else:
        obstacles = default.obstacles
    if "corridor" in data:
        c = _mapping(data["corridor"], "world.corridor")
        keys = ("x_min", "x_max", "y_min", "y_max")
        _check_keys(c, keys, "world.corridor")
        missing = [k for k in keys if k not in c]
        if missing:
            raise _fail("world.corridor", f"missing key '{missing[0]}' (give x_min, x_max, y_min, y_max)")
        corridor = Corridor(**{k: _coordinate(c[k], f"world.corridor.{k}") for k in keys})
        if corridor.x_min >= corridor.x_max or corridor.y_min >= corridor.y_max:
            raise _fail("world.corridor", "need x_min < x_max and y_min < y_max")
    else:
        corridor = default.corridor
    inside = (bounds[0] <= corridor.x_min and corridor.x_max <= bounds[2]
              and bounds[1] <= corridor.y_min and corridor.y_max <= bounds[3])
    if not inside:
        raise _fail("world.corridor", f"the corridor x {corridor.x_min:g}..{corridor.x_max:g}, y {corridor.y_min:g}.."
                    f"{corridor.y_max:g} is not inside world.bounds {list(bounds)}")
    if "entrances" in data:
        ent = data["entrances"]
        if not isinstance(ent, list) or len(ent) != 2:
            raise _fail("world.entrances", f"expected two points [[x, y], [x, y]] (left, right), got {shown(ent)}")
        entrances = (_vector(ent[0], 2, "world.entrances[0]"), _vector(ent[1], 2, "world.entrances[1]"))
        if entrances[0] == entrances[1]:
            raise _fail("world.entrances", f"the two entrances are the same point {list(entrances[0])}")
        for k, (point, end, side) in enumerate(zip(entrances, (corridor.x_min, corridor.x_max), ("left", "right"))):
            if abs(point[0] - end) > 1e-9 or not corridor.y_min <= point[1] <= corridor.y_max:
                raise _fail(f"world.entrances[{k}]", f"{list(point)} is not on the corridor's {side} end "
                            f"(x = {end:g}, y from {corridor.y_min:g} to {corridor.y_max:g})")
    else:
        mid = 0.5 * (corridor.y_min + corridor.y_max)
        entrances = ((corridor.x_min, mid), (corridor.x_max, mid))
    return World(bounds=bounds, obstacles=obstacles, corridor=corridor, entrances=entrances)


def _opinion(data: dict, n_robots: int, where: str) -> OpinionParams:
    """Opinion parameters from a mapping, with their cross-field checks."""
    opinion = _params(OpinionParams, data, where, "opinion")
    if opinion.conflict not in ("paper", "undecided"):
        raise _fail(f"{where}.conflict", f"expected 'paper' or 'undecided', got {shown(opinion.conflict)}")
    if opinion.nonplayers not in ("static", "entered"):
        raise _fail(f"{where}.nonplayers", f"expected 'static' or 'entered', got {shown(opinion.nonplayers)}")
    if opinion.init not in ("zero", "distance", "given"):
        raise _fail(f"{where}.init", f"expected 'zero', 'distance' or 'given', got {shown(opinion.init)}")
    n_s = math.factorial(n_robots)
    if opinion.init == "given" and (len(opinion.z0) != n_robots or any(len(row) != n_s for row in opinion.z0)):
        raise _fail(f"{where}.z0", f"with init 'given', give {n_robots} rows of {n_s} numbers (one row per robot)")
    if opinion.init != "given" and opinion.z0:
        raise _fail(f"{where}.z0", "only used with init 'given'; set init: given or remove z0")
    for name in opinion.bias:
        if not 1 <= strategy_number(name) <= n_s:
            raise _fail(f"{where}.bias", f"unknown strategy {shown(name)}; use S1..S{n_s} for {n_robots} robots")
    return opinion


_TOP_KEYS = ("name", "description", "world", "robot_defaults", "robots", "opinion", "game_players",
             "time_limit", "planner", "controller", "sim", "execution")
_ROBOT_KEYS = tuple(f.name for f in dataclasses.fields(RobotSpec))
_BODY_KEYS = ("radius", "max_speed", "max_accel")


def _robots(data: Any, defaults: Any, opinion: dict) -> tuple[tuple[RobotSpec, ...], list[dict[str, str | None]]]:
    """The robots, and for each the key path each of its body values came from (``None``: the default)."""
    defaults = _mapping(defaults, "robot_defaults")
    _check_keys(defaults, _BODY_KEYS, "robot_defaults")
    robots, sources = [], []
    for k, entry in enumerate(data):
        where = f"robots[{k}]"
        entry = _mapping(entry, where)
        _check_keys(entry, _ROBOT_KEYS, where)
        for key in ("origin", "destination"):
            if key not in entry:
                raise _fail(where, f"missing '{key}' for robot {k + 1} (give it as [x, y] in metres)")
        source, body = {}, {}
        for key in _BODY_KEYS:
            if key in entry:
                source[key], value = f"{where}.{key}", entry[key]
            elif key in defaults:
                source[key], value = f"robot_defaults.{key}", defaults[key]
            else:  # the default, which the user did not write
                source[key], value = None, getattr(RobotSpec, key)
            body[key] = _number(value, source[key] or f"{where}.{key}", f"robots.{key}")
        own = entry.get("opinion")
        robots.append(RobotSpec(
            origin=_vector(entry["origin"], 2, f"{where}.origin"),
            destination=_vector(entry["destination"], 2, f"{where}.destination"),
            opinion=_opinion({**opinion, **_mapping(own, f"{where}.opinion")}, len(data), f"{where}.opinion")
            if own else None, **body))
        sources.append(source)
    return tuple(robots), sources


def _check_geometry(world: World, robots: tuple[RobotSpec, ...], sources: list[dict[str, str | None]],
                    corridor_key: str) -> None:
    x0, y0, x1, y1 = world.bounds
    for k, r in enumerate(robots):
        for key in ("origin", "destination"):
            p = np.array(getattr(r, key))
            shown_p = list(getattr(r, key))
            if not (x0 <= p[0] <= x1 and y0 <= p[1] <= y1):
                raise _fail(f"robots[{k}].{key}", f"{shown_p} puts robot {k + 1} outside the world bounds "
                            f"{list(world.bounds)}")
            clearance = float(world.clearance(p))
            if clearance < r.radius:
                raise _fail(f"robots[{k}].{key}",
                            f"{shown_p} puts robot {k + 1} (radius {r.radius:g} m) inside a wall "
                            f"(clearance {clearance:.3f} m); move it at least {r.radius:g} m from every wall")
    # Every robot must fit through the corridor: its clearance along the line joining the entrances.
    a, b = np.asarray(world.entrances, dtype=float)
    samples = max(2, int(np.linalg.norm(b - a) / 0.01) + 1)
    gap = float(world.clearance(a + np.linspace(0.0, 1.0, samples)[:, None] * (b - a)).min())
    for k, r in enumerate(robots):
        if r.radius >= gap:
            raise _fail(sources[k]["radius"] or corridor_key,
                        f"robot {k + 1} (radius {r.radius:g} m) does not fit through the corridor: its walls leave "
                        f"{gap:.3f} m on either side of the line joining the entrances; make the radius smaller "
                        f"than {gap:.3f} m or the corridor wider")
    for key in ("origin", "destination"):
        pts = np.array([getattr(r, key) for r in robots])
        radii = np.array([r.radius for r in robots])
        for a_ in range(len(robots)):
            for b_ in range(a_ + 1, len(robots)):
                distance = float(np.linalg.norm(pts[a_] - pts[b_]))
                if distance < radii[a_] + radii[b_]:
                    raise _fail(f"robots[{b_}].{key}",
                                f"robot {a_ + 1} and robot {b_ + 1}: {key}s overlap ({distance:.3f} m apart, "
                                f"need at least {radii[a_] + radii[b_]:.3f} m)")


def _check_sizes(scenario_time: float, controller: ControllerParams, planner: PlannerParams,
                 robots: tuple[RobotSpec, ...], world: World) -> None:
    """The clock, the controller and the planner's tables stay within memory (nodnav.scenario.limits)."""
    if controller.dt > controller.horizon:
        raise _fail("controller.dt", f"{controller.dt:g} s is longer than the MPC horizon controller.horizon "
                    f"({controller.horizon:g} s); use dt <= horizon")
    steps = scenario_time / controller.dt
    if steps > limits.MAX_CONTROL_STEPS:
        raise _fail("time_limit", f"{scenario_time:g} s at controller.dt {controller.dt:g} s is {steps:.0f} control "
                    f"steps, more than {limits.MAX_CONTROL_STEPS}; shorten time_limit or lengthen controller.dt")
    x0, y0, x1, y1 = world.bounds
    slowest = min(r.max_speed for r in robots)
    plan_steps = math.hypot(x1 - x0, y1 - y0) / (slowest * planner.dt)
    if plan_steps > limits.MAX_PLAN_STEPS:
        raise _fail("planner.dt", f"{planner.dt:g} s with the slowest robot at {slowest:g} m/s needs {plan_steps:.0f} "
                    f"plan steps to cross world.bounds, more than {limits.MAX_PLAN_STEPS}; lengthen planner.dt "
                    "or raise max_speed")


def _robot_list(data: Any) -> list:
    robots = data.get("robots")
    if not isinstance(robots, list) or not robots:
        raise _fail("robots", f"expected a non-empty list of {{origin: [x, y], destination: [x, y]}}, got {shown(robots)}")
    if len(robots) > limits.MAX_ROBOTS:
        raise _fail("robots", f"{len(robots)} robots; at most {limits.MAX_ROBOTS} are supported")
    return robots


def scenario_from_dict(data: Any, source: str = "scenario") -> Scenario:
    """Validate a parsed YAML mapping and build a :class:`Scenario`.

    Every problem raises one :class:`ScenarioError` line naming the key path (``opinion.u``,
    ``robot_defaults.radius``, ``robots[1].origin``) and what to do; ``source`` names the file
    in errors that concern the whole mapping.
    """
    if not isinstance(data, dict):
        raise _fail(shown_path(source), "expected a mapping with keys such as 'name' and 'robots', "
                    f"got {type(data).__name__}")
    _check_keys(data, _TOP_KEYS, shown_path(source))
    if "robots" not in data:
        raise _fail("robots", "missing (a list of {origin: [x, y], destination: [x, y]})")
    name = data.get("name", Path(str(source)).stem)
    _text(name, "name", limits.MAX_NAME)
    if not name.strip() or not name.isprintable():
        raise _fail("name", f"expected one line of printable text, got {shown(name)}")
    description = _text(data.get("description", ""), "description", limits.MAX_DESCRIPTION)
    description = " ".join(description.split())  # one line, wherever it is printed
    raw_robots = _robot_list(data)
    opinion_raw = _mapping(data.get("opinion"), "opinion")
    opinion = _opinion(opinion_raw, len(raw_robots), "opinion")
    world = _world(data.get("world"))
    robots, sources = _robots(raw_robots, data.get("robot_defaults"), opinion_raw)
    for k, r in enumerate(robots):
        if r.opinion is not None and r.opinion.T != opinion.T:
            raise _fail(f"robots[{k}].opinion.T", "the opinion period is shared by every robot; set it in 'opinion'")
    world_raw = _mapping(data.get("world"), "world")
    corridor_key = "world.corridor" if "corridor" in world_raw else "world.corridor_width"
    _check_geometry(world, robots, sources, corridor_key)
    players = data.get("game_players", "all")
    if players == "all" or players is None:
        game_players = None
    elif isinstance(players, int) and not isinstance(players, bool) and 0 <= players < len(robots):
        game_players = players
    else:
        raise _fail("game_players", f"expected 'all' or a whole number 0..{len(robots) - 1}, got {shown(players)}")
    game = len(robots) if game_players is None else game_players + 1
    if math.factorial(game) > limits.MAX_STRATEGIES:
        largest = limits.MAX_GAME - 1
        raise _fail("game_players", f"{'all' if game_players is None else game_players} game players make every robot "
                    f"weigh {game}! = {math.factorial(game)} passing orders, more than {limits.MAX_STRATEGIES}; "
                    f"give game_players: {largest} or fewer")
    time_limit = _number(data.get("time_limit", 60.0), "time_limit", "time_limit")
    planner = _params(PlannerParams, data.get("planner"), "planner", "planner")
    controller = _params(ControllerParams, data.get("controller"), "controller", "controller")
    from nodnav.control import CONTROLLERS
    from nodnav.planning import PLANNERS

    if planner.name not in PLANNERS:
        raise _fail("planner.name", f"unknown planner {shown(planner.name)}{nearest_hint(planner.name, PLANNERS, 'planners')}")
    if controller.name not in CONTROLLERS:
        raise _fail("controller.name", f"unknown controller {shown(controller.name)}"
                    f"{nearest_hint(controller.name, CONTROLLERS, 'controllers')}")
    if planner.waiting not in ("early", "late"):
        raise _fail("planner.waiting", f"expected 'early' or 'late', got {shown(planner.waiting)}")
    if "\0" in planner.cache_dir:
        raise _fail("planner.cache_dir", "a directory name cannot hold a NUL character")
    _check_sizes(time_limit, controller, planner, robots, world)
    ratio = opinion.T / controller.dt
    if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
        raise _fail("opinion.T", f"{opinion.T:g} s must be a whole multiple of controller.dt ({controller.dt:g} s)")
    sim = _params(SimParams, data.get("sim"), "sim", "sim")
    execution = _params(ExecutionParams, data.get("execution"), "execution", "execution")
    if execution.reaction_margin not in ("always", "conflict", "off"):
        raise _fail("execution.reaction_margin",
                    f"expected 'always', 'conflict' or 'off', got {shown(execution.reaction_margin)}")
    if execution.mode not in ("gated", "timed"):
        raise _fail("execution.mode", f"expected 'gated' or 'timed', got {shown(execution.mode)}")
    return Scenario(name=name, description=description, world=world, robots=robots, opinion=opinion,
                    game_players=game_players, time_limit=time_limit, planner=planner,
                    controller=controller, sim=sim, execution=execution)


def builtin_names() -> list[str]:
    """Names of the built-in scenarios, sorted."""
    files = resources.files("nodnav.scenario") / "builtin"
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".yaml"))


def read_yaml(path: Path, what: str = "scenario") -> Any:
    """Parse a YAML file the user named, every failure one :class:`ScenarioError` line naming the file.

    Refuses directories, files over :data:`~nodnav.scenario.limits.MAX_FILE_BYTES`, text that is
    not UTF-8, YAML that does not parse, numbers too long to convert, and nesting too deep.
    """
    label = shown_path(path)
    try:
        is_dir, is_file, size = path.is_dir(), path.is_file(), path.stat().st_size
    except (OSError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else "not a usable file name"
        raise ScenarioError(f"{label}: cannot read the {what} file ({reason})", key=str(path)) from None
    if is_dir:
        raise ScenarioError(f"{label}: is a directory; give a {what} YAML file", key=str(path))
    if not is_file:  # a pipe or a device would be read forever
        raise ScenarioError(f"{label}: not a regular file; give a {what} YAML file", key=str(path))
    if size > limits.MAX_FILE_BYTES:
        raise ScenarioError(f"{label}: {size} bytes; a {what} file may have at most {limits.MAX_FILE_BYTES}",
                            key=str(path))
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{label}: cannot read the {what} file ({exc.strerror or exc})", key=str(path)) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{label}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); "
                            f"save the {what} file as UTF-8", key=str(path)) from None
    return parse_yaml(text, label)


def parse_yaml(text: str, label: str) -> Any:
    """``yaml.safe_load(text)``, every failure one :class:`ScenarioError` line starting with ``label``."""
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{label}: {yaml_error_message(exc)}", key=label) from None
    except RecursionError:
        raise ScenarioError(f"{label}: invalid YAML: nested too deeply", key=label) from None
    except (ValueError, OverflowError, TypeError) as exc:  # e.g. an integer of more than 4300 digits
        problem = "a number with more than 4300 digits" if "digits" in str(exc) else one_line(str(exc), 120)
        raise ScenarioError(f"{label}: invalid YAML: {problem}", key=label) from None


def load_scenario(spec: str | Path) -> Scenario:
    """Load a scenario by built-in name (``3r-case2``), from a YAML file path, or drawn from a
    family as ``FAMILY:SEED`` (``mixed:17``, ``path/fam.yaml:17``; :mod:`nodnav.scenario.draws`)."""
    spec = str(spec)
    if spec in builtin_names():
        text = (resources.files("nodnav.scenario") / "builtin" / f"{spec}.yaml").read_text()
        return scenario_from_dict(parse_yaml(text, spec), spec)
    path = Path(spec)
    try:
        exists = path.exists()
    except (OSError, ValueError):  # a name too long for the file system, or holding a NUL
        exists = False
    if not exists:
        from nodnav.scenario.draws import draw_spec  # FAMILY:SEED, a generated scenario

        drawn = draw_spec(spec)
        if drawn is not None:
            return drawn
        hint = nearest_hint(spec, builtin_names(), "built-in scenarios")
        raise ScenarioError(f"{shown_path(spec)}: no such built-in scenario or file{hint}", key=spec)
    return scenario_from_dict(read_yaml(path), spec)


def yaml_error_message(exc: yaml.YAMLError) -> str:
    """'invalid YAML at line L, column C: problem', one line, for any YAML parse error."""
    mark = getattr(exc, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    return one_line(f"invalid YAML{where}: {problem}", 200)


def _opinion_to_raw(opinion: OpinionParams) -> dict:
    return {**dataclasses.asdict(opinion), "z0": [list(r) for r in opinion.z0]}


def _robot_to_raw(robot: RobotSpec) -> dict:
    raw = {"origin": list(robot.origin), "destination": list(robot.destination), "radius": robot.radius,
           "max_speed": robot.max_speed, "max_accel": robot.max_accel}
    if robot.opinion is not None:
        raw["opinion"] = _opinion_to_raw(robot.opinion)
    return raw


def _to_raw(scenario: Scenario) -> dict:
    """Inverse of :func:`scenario_from_dict`, for overrides and for storing a scenario with results."""
    w = scenario.world
    return {
        "name": scenario.name,
        "description": scenario.description,
        "world": {
            "bounds": list(w.bounds),
            "obstacles": [list(o) for o in w.obstacles],
            "corridor": dataclasses.asdict(w.corridor),
            "entrances": [list(e) for e in w.entrances],
        },
        "robots": [_robot_to_raw(r) for r in scenario.robots],
        "opinion": _opinion_to_raw(scenario.opinion),
        "game_players": "all" if scenario.game_players is None else scenario.game_players,
        "time_limit": scenario.time_limit,
        "planner": dataclasses.asdict(scenario.planner),
        "controller": dataclasses.asdict(scenario.controller),
        "sim": dataclasses.asdict(scenario.sim),
        "execution": dataclasses.asdict(scenario.execution),
    }


def scenario_to_dict(scenario: Scenario) -> dict:
    """The scenario as a plain mapping that :func:`scenario_from_dict` reads back unchanged."""
    return _to_raw(scenario)
