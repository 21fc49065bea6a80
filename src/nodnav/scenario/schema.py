"""Scenario files: frozen parameter dataclasses, YAML loading, and all validation.

Validation happens here and only here, at load time: everything downstream may assume a
:class:`Scenario` is well formed. Every problem is reported as one :class:`ScenarioError` line
that names the offending key or robot and says how to fix it.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import typing
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from nodnav.errors import NodnavError
from nodnav.scenario.world import Corridor, World, paper_world


class ScenarioError(NodnavError, ValueError):
    """A scenario file or option is malformed; the message is one line saying what and how to fix."""


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
    standoff_patience: float = 2.0
    """After how long a standoff with a game player (both standing still, this one although its
    plan moves it) the lower-numbered robot of the two goes first (s); 0 never (the paper)."""
    nonplayers: str = "entered"
    """How robots outside N_i(t) enter the robot's planning: ``static`` (the paper: not planned,
    held still in the MPC) or ``entered`` (those seen inside the corridor are planned too, at the
    front of the order, where history has put them)."""

    def bias_vector(self, n_strategies: int) -> np.ndarray:
        """The bias b_i as an array over strategies S1..S_{N_s}."""
        b = np.zeros(n_strategies)
        for name, value in self.bias.items():
            b[int(name[1:]) - 1] = value
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
    reaction_margin: bool = False
    """Whether the MPC keeps clear of every other robot's braking trajectory by how far that can
    move in one control step (``nodnav.sim.methods.reaction_margin``), so that two robots that
    both cannot follow their plans never squeeze each other."""


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
        raw = _to_raw(self)
        for key, value in changes.items():
            target = raw
            *parents, leaf = key.split(".")
            for p in parents:
                target = target.setdefault(p, {})
            target[leaf] = value
        return scenario_from_dict(raw)


# ---------------------------------------------------------------------------------------------
# Loading


def nearest_hint(key: str, valid, what: str = "valid keys") -> str:
    """'; did you mean X?' for the closest valid name, else the list of valid names."""
    match = difflib.get_close_matches(key, list(valid), n=1, cutoff=0.5)
    return f"; did you mean '{match[0]}'?" if match else f"; {what}: {', '.join(sorted(valid))}"


def _check_keys(data: dict, valid, where: str) -> None:
    for key in data:
        if key not in valid:
            raise ScenarioError(f"{where}: unknown key '{key}'{nearest_hint(str(key), valid)}")


def _number(value: Any, where: str, *, positive: bool = False, nonneg: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{where}: expected a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ScenarioError(f"{where}: expected a finite number, got {value!r}")
    if positive and v <= 0:
        raise ScenarioError(f"{where}: must be positive, got {value!r}")
    if nonneg and v < 0:
        raise ScenarioError(f"{where}: must not be negative, got {value!r}")
    return v


def _vector(value: Any, n: int, where: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ScenarioError(f"{where}: expected a list of {n} numbers, got {value!r}")
    return tuple(_number(v, f"{where}[{k}]") for k, v in enumerate(value))


def _mapping(value: Any, where: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ScenarioError(f"{where}: expected a mapping of keys to values, got {value!r}")
    return value


def _params(cls, data: Any, where: str, overrides: dict | None = None):
    """Build a flat parameter dataclass from a mapping, checking keys and types."""
    data = {**_mapping(data, where), **(overrides or {})}
    fields = {f.name: f for f in dataclasses.fields(cls)}
    _check_keys(data, fields, where)
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for key, value in data.items():
        hint = hints[key]
        name = f"{where}.{key}"
        if hint is float:
            kwargs[key] = _number(value, name, nonneg=True)
        elif hint is int:
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ScenarioError(f"{name}: expected a whole number >= 0, got {value!r}")
            kwargs[key] = value
        elif hint is str:
            if not isinstance(value, str):
                raise ScenarioError(f"{name}: expected text, got {value!r}")
            kwargs[key] = value
        elif hint is bool:
            if not isinstance(value, bool):
                raise ScenarioError(f"{name}: expected true or false, got {value!r}")
            kwargs[key] = value
        elif hint == dict[str, float]:
            kwargs[key] = {str(k): _number(v, f"{name}.{k}") for k, v in _mapping(value, name).items()}
        else:  # a matrix of numbers, one row per robot
            if not isinstance(value, (list, tuple)) or not all(isinstance(row, (list, tuple)) for row in value):
                raise ScenarioError(f"{name}: expected a list of rows of numbers, got {value!r}")
            kwargs[key] = tuple(_vector(row, len(row), f"{name}[{k}]") for k, row in enumerate(value))
    return cls(**kwargs)


def _world(data: Any) -> World:
    data = _mapping(data, "world")
    valid = ("bounds", "obstacles", "corridor", "entrances", "corridor_width")
    _check_keys(data, valid, "world")
    default = paper_world(corridor_width=_number(data.get("corridor_width", 0.7), "world.corridor_width", positive=True))
    bounds = _vector(data["bounds"], 4, "world.bounds") if "bounds" in data else default.bounds
    if bounds[0] >= bounds[2] or bounds[1] >= bounds[3]:
        raise ScenarioError(f"world.bounds: need x_min < x_max and y_min < y_max, got {list(bounds)}")
    if "obstacles" in data:
        if not isinstance(data["obstacles"], list):
            raise ScenarioError("world.obstacles: expected a list of [x_min, y_min, x_max, y_max] rectangles")
        obstacles = tuple(_vector(o, 4, f"world.obstacles[{k}]") for k, o in enumerate(data["obstacles"]))
        for k, o in enumerate(obstacles):
            if o[0] >= o[2] or o[1] >= o[3]:
                raise ScenarioError(f"world.obstacles[{k}]: need x_min < x_max and y_min < y_max, got {list(o)}")
    else:
        obstacles = default.obstacles
    if "corridor" in data:
        c = _mapping(data["corridor"], "world.corridor")
        keys = ("x_min", "x_max", "y_min", "y_max")
        _check_keys(c, keys, "world.corridor")
        missing = [k for k in keys if k not in c]
        if missing:
            raise ScenarioError(f"world.corridor: missing key '{missing[0]}' (give x_min, x_max, y_min, y_max)")
        corridor = Corridor(**{k: _number(c[k], f"world.corridor.{k}") for k in keys})
        if corridor.x_min >= corridor.x_max or corridor.y_min >= corridor.y_max:
            raise ScenarioError("world.corridor: need x_min < x_max and y_min < y_max")
    else:
        corridor = default.corridor
    if "entrances" in data:
        ent = data["entrances"]
        if not isinstance(ent, list) or len(ent) != 2:
            raise ScenarioError("world.entrances: expected two points [[x, y], [x, y]] (left, right)")
        entrances = (_vector(ent[0], 2, "world.entrances[0]"), _vector(ent[1], 2, "world.entrances[1]"))
    else:
        entrances = ((corridor.x_min, 0.5 * (corridor.y_min + corridor.y_max)), (corridor.x_max, 0.5 * (corridor.y_min + corridor.y_max)))
    return World(bounds=bounds, obstacles=obstacles, corridor=corridor, entrances=entrances)


def _opinion(data: dict, n_robots: int, where: str) -> OpinionParams:
    """Opinion parameters from a mapping, with their cross-field checks."""
    opinion = _params(OpinionParams, data, where)
    if opinion.nonplayers not in ("static", "entered"):
        raise ScenarioError(f"{where}.nonplayers: expected 'static' or 'entered', got {opinion.nonplayers!r}")
    if opinion.init not in ("zero", "distance", "given"):
        raise ScenarioError(f"{where}.init: expected 'zero', 'distance' or 'given', got {opinion.init!r}")
    n_s = math.factorial(n_robots)
    if opinion.init == "given" and (len(opinion.z0) != n_robots or any(len(row) != n_s for row in opinion.z0)):
        raise ScenarioError(f"{where}.z0: with init 'given', give {n_robots} rows of {n_s} numbers (one row per robot)")
    if opinion.init != "given" and opinion.z0:
        raise ScenarioError(f"{where}.z0: only used with init 'given'; set init: given or remove z0")
    for p in ("d", "eta", "T"):
        if getattr(opinion, p) <= 0:
            raise ScenarioError(f"{where}.{p}: must be positive, got {getattr(opinion, p)}")
    for name in opinion.bias:
        if not (name.startswith("S") and name[1:].isdigit() and 1 <= int(name[1:]) <= n_s):
            raise ScenarioError(f"{where}.bias: unknown strategy '{name}'; use S1..S{n_s} for {n_robots} robots")
    return opinion


_TOP_KEYS = ("name", "description", "world", "robot_defaults", "robots", "opinion", "game_players",
             "time_limit", "planner", "controller", "sim", "execution")
_ROBOT_KEYS = tuple(f.name for f in dataclasses.fields(RobotSpec))


def _robots(data: Any, defaults: Any, opinion: dict) -> tuple[RobotSpec, ...]:
    defaults = _mapping(defaults, "robot_defaults")
    _check_keys(defaults, [k for k in _ROBOT_KEYS if k not in ("origin", "destination", "opinion")], "robot_defaults")
    if not isinstance(data, list) or not data:
        raise ScenarioError("robots: expected a non-empty list of {origin: [x, y], destination: [x, y]}")
    robots = []
    for k, r in enumerate(data, start=1):
        where = f"robot {k}"
        r = {**defaults, **_mapping(r, where)}
        _check_keys(r, _ROBOT_KEYS, where)
        for key in ("origin", "destination"):
            if key not in r:
                raise ScenarioError(f"{where}: missing '{key}' (give it as [x, y] in metres)")
        robots.append(RobotSpec(
            origin=_vector(r["origin"], 2, f"{where}.origin"),
            destination=_vector(r["destination"], 2, f"{where}.destination"),
            radius=_number(r.get("radius", RobotSpec.radius), f"{where}.radius", positive=True),
            max_speed=_number(r.get("max_speed", RobotSpec.max_speed), f"{where}.max_speed", positive=True),
            max_accel=_number(r.get("max_accel", RobotSpec.max_accel), f"{where}.max_accel", positive=True),
            opinion=_opinion({**opinion, **_mapping(r["opinion"], f"{where}.opinion")}, len(data), f"{where}.opinion")
            if r.get("opinion") else None,
        ))
    return tuple(robots)


def _check_geometry(world: World, robots: tuple[RobotSpec, ...]) -> None:
    for k, r in enumerate(robots, start=1):
        for key in ("origin", "destination"):
            p = np.array(getattr(r, key))
            shown = list(getattr(r, key))
            x0, y0, x1, y1 = world.bounds
            if not (x0 <= p[0] <= x1 and y0 <= p[1] <= y1):
                raise ScenarioError(f"robot {k}: {key} {shown} is outside the world bounds {list(world.bounds)}")
            clearance = float(world.clearance(p))
            if clearance < r.radius:
                raise ScenarioError(
                    f"robot {k}: {key} {shown} puts the robot (radius {r.radius} m) inside a wall "
                    f"(clearance {clearance:.3f} m); move it at least {r.radius} m from every wall")
    for key in ("origin", "destination"):
        pts = np.array([getattr(r, key) for r in robots])
        radii = np.array([r.radius for r in robots])
        for a in range(len(robots)):
            for b in range(a + 1, len(robots)):
                gap = float(np.linalg.norm(pts[a] - pts[b]))
                if gap < radii[a] + radii[b]:
                    raise ScenarioError(
                        f"robot {a + 1} and robot {b + 1}: {key}s overlap ({gap:.3f} m apart, "
                        f"need at least {radii[a] + radii[b]:.3f} m)")


def scenario_from_dict(data: Any, source: str = "scenario") -> Scenario:
    """Validate a parsed YAML mapping and build a :class:`Scenario`."""
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: expected a mapping with keys such as 'name' and 'robots', got {type(data).__name__}")
    _check_keys(data, _TOP_KEYS, source)
    if "robots" not in data:
        raise ScenarioError(f"{source}: missing key 'robots' (a list of {{origin: [x, y], destination: [x, y]}})")
    name = data.get("name", Path(source).stem)
    if not isinstance(name, str) or not name:
        raise ScenarioError(f"{source}: 'name' must be non-empty text")
    world = _world(data.get("world"))
    n_robots = len(data["robots"]) if isinstance(data["robots"], list) else 0
    opinion = _opinion(_mapping(data.get("opinion"), "opinion"), n_robots, "opinion")
    robots = _robots(data["robots"], data.get("robot_defaults"), _mapping(data.get("opinion"), "opinion"))
    _check_geometry(world, robots)
    for k, r in enumerate(robots, start=1):
        if r.opinion is not None and r.opinion.T != opinion.T:
            raise ScenarioError(f"robot {k}.opinion.T: the opinion period is shared by every robot; set it in 'opinion'")
    players = data.get("game_players", "all")
    if players == "all" or players is None:
        game_players = None
    elif isinstance(players, int) and not isinstance(players, bool) and 0 <= players < len(robots):
        game_players = players
    else:
        raise ScenarioError(f"game_players: expected 'all' or a whole number 0..{len(robots) - 1}, got {players!r}")
    time_limit = _number(data.get("time_limit", 60.0), "time_limit", positive=True)
    planner = _params(PlannerParams, data.get("planner"), "planner")
    controller = _params(ControllerParams, data.get("controller"), "controller")
    for p in ("dt", "horizon"):
        if getattr(controller, p) <= 0:
            raise ScenarioError(f"controller.{p}: must be positive, got {getattr(controller, p)}")
    from nodnav.control import CONTROLLERS
    from nodnav.planning import PLANNERS

    if planner.name not in PLANNERS:
        raise ScenarioError(f"planner.name: unknown planner '{planner.name}'{nearest_hint(planner.name, PLANNERS, 'planners')}")
    if controller.name not in CONTROLLERS:
        raise ScenarioError(f"controller.name: unknown controller '{controller.name}'{nearest_hint(controller.name, CONTROLLERS, 'controllers')}")
    if planner.waiting not in ("early", "late"):
        raise ScenarioError(f"planner.waiting: expected 'early' or 'late', got {planner.waiting!r}")
    if planner.dt <= 0:
        raise ScenarioError(f"planner.dt: must be positive, got {planner.dt}")
    ratio = opinion.T / controller.dt
    if abs(ratio - round(ratio)) > 1e-9:
        raise ScenarioError(f"opinion.T ({opinion.T} s) must be a whole multiple of controller.dt ({controller.dt} s)")
    sim = _params(SimParams, data.get("sim"), "sim")
    execution = _params(ExecutionParams, data.get("execution"), "execution")
    if execution.mode not in ("gated", "timed"):
        raise ScenarioError(f"execution.mode: expected 'gated' or 'timed', got {execution.mode!r}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError(f"{source}: 'description' must be text")
    return Scenario(name=name, description=description, world=world, robots=robots, opinion=opinion,
                    game_players=game_players, time_limit=time_limit, planner=planner,
                    controller=controller, sim=sim, execution=execution)


def builtin_names() -> list[str]:
    """Names of the built-in scenarios, sorted."""
    files = resources.files("nodnav.scenario") / "builtin"
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".yaml"))


def load_scenario(spec: str | Path) -> Scenario:
    """Load a scenario by built-in name (``3r-case2``), from a YAML file path, or drawn from a
    family as ``FAMILY:SEED`` (``mixed:17``, ``path/fam.yaml:17``; :mod:`nodnav.scenario.draws`)."""
    spec = str(spec)
    if spec in builtin_names():
        text = (resources.files("nodnav.scenario") / "builtin" / f"{spec}.yaml").read_text()
        source = spec
    else:
        path = Path(spec)
        if not path.exists():
            from nodnav.scenario.draws import draw_spec  # FAMILY:SEED, a generated scenario

            drawn = draw_spec(spec)
            if drawn is not None:
                return drawn
            hint = nearest_hint(spec, builtin_names(), "built-in scenarios")
            raise ScenarioError(f"{spec}: no such built-in scenario or file{hint}")
        text, source = path.read_text(), str(path)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{source}: {yaml_error_message(exc)}") from None
    return scenario_from_dict(data, source)


def yaml_error_message(exc: yaml.YAMLError) -> str:
    """'invalid YAML at line L, column C: problem', one line, for any YAML parse error."""
    mark = getattr(exc, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    return f"invalid YAML{where}: {problem}"


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
