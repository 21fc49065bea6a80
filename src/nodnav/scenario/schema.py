"""A scenario: the :class:`Scenario` dataclass, and its validation from a mapping and back.

Validation happens here and only here, at load time: everything downstream may assume a
:class:`Scenario` is well formed. Every problem is reported as one
:class:`~nodnav.scenario.fields.ScenarioError` line that names the offending key or robot and
says how to fix it. Reading files is :mod:`nodnav.scenario.files`; finding a scenario by name
(built-in, file, or drawn from a family) is :func:`nodnav.scenario.loading.load_scenario`.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from nodnav.errors import shown, shown_path
from nodnav.registry import CONTROLLERS, PLANNERS, Registry, RegistryError
from nodnav.scenario import limits
from nodnav.scenario.fields import (
    ScenarioError,
    check_keys,
    fail,
    mapping,
    number,
    point,
    range_of,
    read_params,
    strategy_number,
    text,
)
from nodnav.scenario.limits import accepted
from nodnav.scenario.overrides import merge_overrides, relabel
from nodnav.scenario.params import (
    BaselineParams,
    ControllerParams,
    ExecutionParams,
    FastPlannerParams,
    MPCParams,
    OpinionParams,
    PlannerParams,
    PRMParams,
    RobotSpec,
    SensingParams,
    SimParams,
)
from nodnav.scenario.world import World
from nodnav.scenario.world_schema import check_single_file, read_world

__all__ = ["Scenario", "ScenarioError", "scenario_from_dict", "scenario_to_dict"]


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
    time_limit: float = field(default=60.0, metadata=accepted(0.0, 3600.0, False,
                                                           why="at most MAX_CONTROL_STEPS control steps"))
    """Simulated time after which a trial is a timeout (s)."""
    planner: PlannerParams = FastPlannerParams()
    """The multi-robot path planner."""
    controller: ControllerParams = MPCParams()
    """The motion controller."""
    sim: SimParams = SimParams()
    """Simulation and outcome settings."""
    execution: ExecutionParams = ExecutionParams()
    """How robots follow their plans between decisions."""
    baselines: BaselineParams = BaselineParams()
    """Settings of the methods NOD is compared with."""
    sensing: SensingParams = SensingParams()
    """What each robot sees of the others (default: everyone, exactly, as in the paper)."""

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
        (or below it) names ``labels[k]`` instead, e.g. ``{"game_players": "--players"}``
        (:mod:`nodnav.scenario.overrides` merges them)."""
        return apply_overrides(_to_raw(self), self.name, changes, labels)


# ---------------------------------------------------------------------------------------------
# Loading. Every check names the key path the user wrote (``robot_defaults.radius``,
# ``robots[2].origin``) and, where a number is out of range, the range its field declares.


def _component(registry: Registry, base: type[PlannerParams] | type[ControllerParams], data: Any, where: str) -> Any:
    """A planner's or controller's parameters: the class registered under ``name`` (the base
    class's default name when none is given), read from the mapping. Settings that belong to
    another registered implementation are accepted, checked and dropped: files written before
    each implementation had its own class name them all."""
    data = mapping(data, where)
    name = text(data.get("name", base.name), f"{where}.name", 100)
    try:
        cls = registry.params(name)
    except RegistryError as exc:
        raise fail(f"{where}.name", str(exc)) from None
    if cls is None or not issubclass(cls, base):
        raise fail(f"{where}.name", f"{registry.kind} {name!r} has no parameter class deriving from "
                   f"{base.__name__}; register it with params=...")
    others = {f.name: e.params for e in reversed(registry.entries()) if e.params is not None and e.params is not cls
              for f in dataclasses.fields(e.params)}
    return read_params(cls, data, where, ignored=others)


def _opinion(data: dict, n_robots: int, where: str) -> OpinionParams:
    """Opinion parameters from a mapping, with their cross-field checks."""
    opinion = read_params(OpinionParams, data, where)
    n_s = math.factorial(n_robots)
    if opinion.init == "given" and (len(opinion.z0) != n_robots or any(len(row) != n_s for row in opinion.z0)):
        raise fail(f"{where}.z0", f"with init 'given', give {n_robots} rows of {n_s} numbers (one row per robot)")
    if opinion.init != "given" and opinion.z0:
        raise fail(f"{where}.z0", "only used with init 'given'; set init: given or remove z0")
    for name in opinion.bias:
        number = strategy_number(name)
        if number is None or not 1 <= number <= n_s:
            raise fail(f"{where}.bias", f"unknown strategy {shown(name)}; use S1..S{n_s} for {n_robots} robots")
    return opinion


_TOP_KEYS = ("name", "description", "world", "robot_defaults", "robots", "opinion", "game_players",
             "time_limit", "planner", "controller", "sim", "execution", "baselines", "sensing")
_ROBOT_KEYS = tuple(f.name for f in dataclasses.fields(RobotSpec))
_BODY_KEYS = ("radius", "max_speed", "max_accel")


_METHOD_NAME = re.compile(r"[a-z0-9][a-z0-9._-]{0,39}")


def _method_name(value: Any, where: str) -> str | None:
    """A robot's own method: ``None`` (the trial's) or a method name. Whether the name is a
    registered method is checked when the trial is built (methods register in the sim layer)."""
    if value is None:
        return None
    if not isinstance(value, str) or not _METHOD_NAME.fullmatch(value):
        raise fail(where, f"expected a method name such as nod, person or closest-first, got {shown(value)}")
    return value


def _robots(data: Any, defaults: Any, opinion: dict) -> tuple[tuple[RobotSpec, ...], list[dict[str, str | None]]]:
    """The robots, and for each the key path each of its body values came from (``None``: the default)."""
    defaults = mapping(defaults, "robot_defaults")
    check_keys(defaults, _BODY_KEYS, "robot_defaults")
    robots: list[RobotSpec] = []
    sources: list[dict[str, str | None]] = []
    for k, entry in enumerate(data):
        where = f"robots[{k}]"
        entry = mapping(entry, where)
        check_keys(entry, _ROBOT_KEYS, where)
        for key in ("origin", "destination"):
            if key not in entry:
                raise fail(where, f"missing '{key}' for robot {k + 1} (give it as [x, y] in metres)")
        source: dict[str, str | None] = {}
        body: dict[str, float] = {}
        for key in _BODY_KEYS:
            if key in entry:
                source[key], value = f"{where}.{key}", entry[key]
            elif key in defaults:
                source[key], value = f"robot_defaults.{key}", defaults[key]
            else:  # the default, which the user did not write
                source[key], value = None, getattr(RobotSpec, key)
            body[key] = number(value, source[key] or f"{where}.{key}", range_of(RobotSpec, key))
        own = entry.get("opinion")
        robots.append(RobotSpec(
            origin=point(entry["origin"], f"{where}.origin"),
            destination=point(entry["destination"], f"{where}.destination"),
            opinion=_opinion({**opinion, **mapping(own, f"{where}.opinion")}, len(data), f"{where}.opinion")
            if own else None, method=_method_name(entry.get("method"), f"{where}.method"), **body))
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
                raise fail(f"robots[{k}].{key}", f"{shown_p} puts robot {k + 1} outside the world bounds "
                            f"{list(world.bounds)}")
            clearance = float(world.clearance(p))
            if clearance < r.radius:
                raise fail(f"robots[{k}].{key}",
                            f"{shown_p} puts robot {k + 1} (radius {r.radius:g} m) inside a wall "
                            f"(clearance {clearance:.3f} m); move it at least {r.radius:g} m from every wall")
    # Every robot must fit through the corridor: its clearance along the line joining the entrances.
    a, b = np.asarray(world.entrances, dtype=float)
    samples = max(2, int(np.linalg.norm(b - a) / 0.01) + 1)
    gap = float(world.clearance(a + np.linspace(0.0, 1.0, samples)[:, None] * (b - a)).min())
    for k, r in enumerate(robots):
        if r.radius >= gap:
            raise fail(sources[k]["radius"] or corridor_key,
                        f"robot {k + 1} (radius {r.radius:g} m) does not fit through the corridor: its walls leave "
                        f"{gap:.3f} m on either side of the line joining the entrances; make the radius smaller "
                        f"than {gap:.3f} m or the corridor wider")
    for m, g in enumerate(world.passages[1:], start=1):  # the second and later of several passages
        a, b = np.asarray(g.start, dtype=float), np.asarray(g.end, dtype=float)
        samples = max(2, int(np.linalg.norm(b - a) / 0.01) + 1)
        gap = float(world.clearance(a + np.linspace(0.0, 1.0, samples)[:, None] * (b - a)).min())
        for k, r in enumerate(robots):
            if r.radius >= gap:
                raise fail(sources[k]["radius"] or corridor_key.replace("[0]", f"[{m}]"),
                           f"robot {k + 1} (radius {r.radius:g} m) does not fit through passage {m + 1}: its walls "
                           f"leave {gap:.3f} m on either side of its centreline; make the radius smaller than "
                           f"{gap:.3f} m or the passage wider")
    for key in ("origin", "destination"):
        pts = np.array([getattr(r, key) for r in robots])
        radii = np.array([r.radius for r in robots])
        for a_ in range(len(robots)):
            for b_ in range(a_ + 1, len(robots)):
                distance = float(np.linalg.norm(pts[a_] - pts[b_]))
                if distance < radii[a_] + radii[b_]:
                    raise fail(f"robots[{b_}].{key}",
                                f"robot {a_ + 1} and robot {b_ + 1}: {key}s overlap ({distance:.3f} m apart, "
                                f"need at least {radii[a_] + radii[b_]:.3f} m)")


def _check_sizes(scenario_time: float, controller: ControllerParams, planner: PlannerParams,
                 robots: tuple[RobotSpec, ...], world: World) -> None:
    """The clock, the controller and the planner's tables stay within memory (nodnav.scenario.limits)."""
    if controller.dt > controller.horizon:
        raise fail("controller.dt", f"{controller.dt:g} s is longer than the MPC horizon controller.horizon "
                    f"({controller.horizon:g} s); use dt <= horizon")
    steps = scenario_time / controller.dt
    if steps > limits.MAX_CONTROL_STEPS:
        raise fail("time_limit", f"{scenario_time:g} s at controller.dt {controller.dt:g} s is {steps:.0f} control "
                    f"steps, more than {limits.MAX_CONTROL_STEPS}; shorten time_limit or lengthen controller.dt")
    x0, y0, x1, y1 = world.bounds
    slowest = min(r.max_speed for r in robots)
    plan_steps = math.hypot(x1 - x0, y1 - y0) / (slowest * planner.dt)
    if plan_steps > limits.MAX_PLAN_STEPS:
        raise fail("planner.dt", f"{planner.dt:g} s with the slowest robot at {slowest:g} m/s needs {plan_steps:.0f} "
                    f"plan steps to cross world.bounds, more than {limits.MAX_PLAN_STEPS}; lengthen planner.dt "
                    "or raise max_speed")


def _robot_list(data: Any) -> list:
    robots = data.get("robots")
    if not isinstance(robots, list) or not robots:
        raise fail("robots",
                   f"expected a non-empty list of {{origin: [x, y], destination: [x, y]}}, got {shown(robots)}")
    if len(robots) > limits.MAX_ROBOTS:
        raise fail("robots", f"{len(robots)} robots; at most {limits.MAX_ROBOTS} are supported")
    return robots


#: Game players per robot of a scenario that does not name ``game_players`` and has more robots
#: than all-player games allow (:data:`~nodnav.scenario.limits.MAX_GAME`): the crowds' value.
CROWD_PLAYERS = 2


def default_players(n_robots: int) -> str | int:
    """``game_players`` of a scenario that does not name it: ``all`` (the paper's) up to
    :data:`~nodnav.scenario.limits.MAX_GAME` robots, above that :data:`CROWD_PLAYERS` (all
    players would weigh N_r! > MAX_STRATEGIES orders, which is refused)."""
    return "all" if n_robots <= limits.MAX_GAME else CROWD_PLAYERS


def scenario_from_dict(data: Any, source: str = "scenario") -> Scenario:
    """Validate a parsed YAML mapping and build a :class:`Scenario`.

    Every problem raises one :class:`ScenarioError` line naming the key path (``opinion.u``,
    ``robot_defaults.radius``, ``robots[1].origin``) and what to do; ``source`` names the file
    in errors that concern the whole mapping.
    """
    if not isinstance(data, dict):
        raise fail(shown_path(source), "expected a mapping with keys such as 'name' and 'robots', "
                    f"got {type(data).__name__}")
    check_keys(data, _TOP_KEYS, shown_path(source))
    if "robots" not in data:
        raise fail("robots", "missing (a list of {origin: [x, y], destination: [x, y]})")
    name = data.get("name", Path(str(source)).stem)
    text(name, "name", limits.MAX_NAME)
    if not name.strip() or not name.isprintable():
        raise fail("name", f"expected one line of printable text, got {shown(name)}")
    description = text(data.get("description", ""), "description", limits.MAX_DESCRIPTION)
    description = " ".join(description.split())  # one line, wherever it is printed
    raw_robots = _robot_list(data)
    opinion_raw = mapping(data.get("opinion"), "opinion")
    opinion = _opinion(opinion_raw, len(raw_robots), "opinion")
    robots, sources = _robots(raw_robots, data.get("robot_defaults"), opinion_raw)
    world = read_world(data.get("world"), robots)
    for k, r in enumerate(robots):
        if r.opinion is not None and r.opinion.T != opinion.T:
            raise fail(f"robots[{k}].opinion.T", "the opinion period is shared by every robot; set it in 'opinion'")
    world_raw = mapping(data.get("world"), "world")
    corridor_key = ("world.passages[0]" if "passages" in world_raw else "world.map" if "map" in world_raw else
                    "world.corridor" if "corridor" in world_raw else "world.corridor_width")
    _check_geometry(world, robots, sources, corridor_key)
    check_single_file(world, np.array([r.radius for r in robots]), corridor_key)
    players = data.get("game_players", default_players(len(robots)))
    if players == "all" or players is None:
        game_players = None
    elif isinstance(players, int) and not isinstance(players, bool) and 0 <= players < len(robots):
        game_players = players
    else:
        raise fail("game_players", f"expected 'all' or a whole number 0..{len(robots) - 1}, got {shown(players)}")
    game = len(robots) if game_players is None else game_players + 1
    if math.factorial(game) > limits.MAX_STRATEGIES:
        raise fail("game_players", f"{'all' if game_players is None else game_players} game players make every robot "
                   f"weigh {game}! = {math.factorial(game)} passing orders, more than {limits.MAX_STRATEGIES}; "
                   f"give game_players: {limits.MAX_GAME - 1} or fewer")
    time_limit = number(data.get("time_limit", 60.0), "time_limit", range_of(Scenario, "time_limit"))
    planner = _component(PLANNERS, PlannerParams, data.get("planner"), "planner")
    controller = _component(CONTROLLERS, ControllerParams, data.get("controller"), "controller")
    if isinstance(planner, PRMParams) and "\0" in planner.cache_dir:
        raise fail("planner.cache_dir", "a directory name cannot hold a NUL character")
    _check_sizes(time_limit, controller, planner, robots, world)
    ratio = opinion.T / controller.dt
    if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
        raise fail("opinion.T", f"{opinion.T:g} s must be a whole multiple of controller.dt ({controller.dt:g} s)")
    sim = read_params(SimParams, data.get("sim"), "sim")
    execution = read_params(ExecutionParams, data.get("execution"), "execution")
    baselines = read_params(BaselineParams, data.get("baselines"), "baselines")
    sensing = read_params(SensingParams, data.get("sensing"), "sensing")
    return Scenario(name=name, description=description, world=world, robots=robots, opinion=opinion,
                    game_players=game_players, time_limit=time_limit, planner=planner,
                    controller=controller, sim=sim, execution=execution, baselines=baselines, sensing=sensing)


def _opinion_to_raw(opinion: OpinionParams) -> dict:
    return {**dataclasses.asdict(opinion), "z0": [list(r) for r in opinion.z0]}


def _robot_to_raw(robot: RobotSpec) -> dict:
    raw = {"origin": list(robot.origin), "destination": list(robot.destination), "radius": robot.radius,
           "max_speed": robot.max_speed, "max_accel": robot.max_accel}
    if robot.opinion is not None:
        raw["opinion"] = _opinion_to_raw(robot.opinion)
    if robot.method is not None:  # absent otherwise, so that trial keys of one-method teams do not change
        raw["method"] = robot.method
    return raw


def _listed(params: dict) -> dict:
    """Parameters with tuples as lists, as YAML and JSON write them."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in params.items()}


def _world_to_raw(w: World) -> dict:
    """The ``world`` section that reads back as ``w``; the paper's shorthand stays as it was written."""
    out: dict = {"bounds": list(w.bounds),
                 "obstacles": [list(o) for o in w.obstacles[w.map_walls:]] + [[list(p) for p in poly]
                                                                           for poly in w.polygons]}
    if w.map_file:
        out["map"] = w.map_file
    if w.corridor is not None:
        out["corridor"] = dataclasses.asdict(w.corridor)
        out["entrances"] = [list(e) for e in w.entrances]
    else:
        out["passages"] = [{"from": list(g.start), "to": list(g.end), "width": g.width} for g in w.passages]
    return out


def _to_raw(scenario: Scenario) -> dict:
    """Inverse of :func:`scenario_from_dict`, for overrides and for storing a scenario with results."""
    w = scenario.world
    # Absent when it is the paper's, so that the keys and records of existing trials do not change.
    sensing = {} if scenario.sensing == SensingParams() else {"sensing": dataclasses.asdict(scenario.sensing)}
    return {
        "name": scenario.name,
        "description": scenario.description,
        "world": _world_to_raw(w),
        "robots": [_robot_to_raw(r) for r in scenario.robots],
        "opinion": _opinion_to_raw(scenario.opinion),
        "game_players": "all" if scenario.game_players is None else scenario.game_players,
        "time_limit": scenario.time_limit,
        "planner": _listed(dataclasses.asdict(scenario.planner)),
        "controller": _listed(dataclasses.asdict(scenario.controller)),
        "sim": dataclasses.asdict(scenario.sim),
        "execution": dataclasses.asdict(scenario.execution),
        "baselines": dataclasses.asdict(scenario.baselines),
        **sensing,
    }


def scenario_to_dict(scenario: Scenario) -> dict:
    """The scenario as a plain mapping that :func:`scenario_from_dict` reads back unchanged."""
    return _to_raw(scenario)


# ---------------------------------------------------------------------------------------------
# Settings on top of a scenario (--set KEY=VALUE, overrides=): merged into its mapping
# (nodnav.scenario.overrides), then validated once, as the same keys written in the file.


def apply_overrides(raw: Any, source: str, overrides: Mapping[str, Any] | None = None,
                    labels: Mapping[str, str] | None = None) -> Scenario:
    """The scenario of mapping ``raw`` with ``overrides`` merged in, validated once.

    ``labels`` gives, per override key, how the user typed it (``--set robots[1].radius=0.3``,
    ``--players``); errors about an override start with its label (default: the key).
    """
    if not overrides:
        return scenario_from_dict(raw, source)
    labels = dict(labels or {})
    merged = merge_overrides(raw, overrides, labels)
    try:
        return scenario_from_dict(merged, source)
    except ScenarioError as exc:
        raise relabel(exc, overrides, labels, source) from None


def override_scenario(scenario: Scenario, overrides: Mapping[str, Any] | None = None,
                      labels: Mapping[str, str] | None = None) -> Scenario:
    """``scenario`` (already built, e.g. a family's draw) with ``overrides`` merged into its mapping."""
    if not overrides:
        return scenario
    return apply_overrides(scenario_to_dict(scenario), scenario.name, overrides, labels)
