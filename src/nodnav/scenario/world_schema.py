"""Reading the ``world`` section of a scenario: bounds, walls (boxes and polygons), passages.

Every check names the key path the user wrote and says how to fix it. Two ways to give the
passage: the paper's shorthand ``corridor`` (an axis-aligned box along x) with ``entrances``, or
``passages: [{from: [x, y], to: [x, y], width: W}]`` at any angle.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from nodnav.errors import shown
from nodnav.scenario import limits
from nodnav.scenario.fields import check_keys, coordinate, fail, mapping, number, point, vector
from nodnav.scenario.world import Corridor, Passage, World, paper_world

#: Keys of the ``world`` section.
WORLD_KEYS = ("bounds", "obstacles", "corridor", "entrances", "corridor_width", "passages", "map")


def _box(value: Any, where: str) -> tuple[float, float, float, float]:
    x0, y0, x1, y1 = vector(value, 4, where)
    if x0 >= x1 or y0 >= y1:
        raise fail(where, f"need x_min < x_max and y_min < y_max, got {[x0, y0, x1, y1]}")
    return x0, y0, x1, y1


def _polygon(value: list, where: str) -> tuple[tuple[float, float], ...]:
    from nodnav.scenario.polygons import polygon_problem

    pts = tuple(point(p, f"{where}[{k}]") for k, p in enumerate(value))
    problem = polygon_problem(pts)
    if problem:
        raise fail(where, f"{problem}; a polygon wall is a list of at least 3 points [[x, y], ...] in order "
                          f"round its boundary")
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts = pts[:-1]
    return pts


def _walls(raw: Any) -> tuple[tuple, tuple]:
    """``world.obstacles``: boxes ``[x_min, y_min, x_max, y_max]`` and polygons ``[[x, y], ...]``."""
    if not isinstance(raw, list) or len(raw) > limits.MAX_OBSTACLES:
        raise fail("world.obstacles", f"expected a list of at most {limits.MAX_OBSTACLES} walls, each a rectangle "
                   f"[x_min, y_min, x_max, y_max] or a polygon [[x, y], [x, y], [x, y], ...], got {shown(raw)}")
    boxes, polygons = [], []
    for k, o in enumerate(raw):
        where = f"world.obstacles[{k}]"
        if isinstance(o, (list, tuple)) and o and all(isinstance(p, (list, tuple)) for p in o):
            polygons.append(_polygon(list(o), where))
        else:
            boxes.append(_box(o, where))
    return tuple(boxes), tuple(polygons)


def _passages(raw: Any, bounds: tuple[float, float, float, float]) -> tuple[Passage, ...]:
    if not isinstance(raw, list) or not raw:
        raise fail("world.passages", f"expected a list of passages [{{from: [x, y], to: [x, y], width: W}}], "
                   f"got {shown(raw)}")
    out = []
    for k, entry in enumerate(raw):
        where = f"world.passages[{k}]"
        entry = mapping(entry, where)
        check_keys(entry, ("from", "to", "width"), where)
        for key in ("from", "to", "width"):
            if key not in entry:
                raise fail(where, f"missing key '{key}' (give from: [x, y], to: [x, y], width: W)")
        a, b = point(entry["from"], f"{where}.from"), point(entry["to"], f"{where}.to")
        width = number(entry["width"], f"{where}.width")
        if width <= 0.0:
            raise fail(f"{where}.width", f"must be above 0, got {shown(entry['width'])}")
        if a == b:
            raise fail(where, f"its two mouths are the same point {list(a)}; give from and to apart")
        for key, p in (("from", a), ("to", b)):
            if not (bounds[0] <= p[0] <= bounds[2] and bounds[1] <= p[1] <= bounds[3]):
                raise fail(f"{where}.{key}", f"{list(p)} is outside world.bounds {list(bounds)}")
        out.append(Passage(start=a, end=b, width=width))
    _check_overlaps(out)
    return tuple(out)


def _check_overlaps(passages: list[Passage], numbers: Sequence[int] = ()) -> None:
    """Two passages whose clear rectangles meet: one line naming both (found ones by ``numbers``)."""
    if len(passages) < 2:
        return
    import shapely

    shapes = [shapely.Polygon(p.outline()) for p in passages]
    for i in range(len(shapes)):
        for j in range(i + 1, len(shapes)):
            if shapes[i].intersects(shapes[j]):
                if numbers:
                    raise fail("world.map", f"the robots' routes cross found passages {numbers[i]} and {numbers[j]}, "
                               f"which overlap ('nodnav passages' lists them); give world.passages")
                raise fail(f"world.passages[{j}]", f"overlaps world.passages[{i}]; passages must be apart "
                           f"(move one, or make them one passage)")


def read_world(data: Any, robots: Sequence[Any] = ()) -> World:
    """The :class:`World` of a scenario's ``world`` section (defaults: the paper's layout).

    ``robots`` (each with ``origin``, ``destination`` and ``radius``) choose, on a map given
    without ``passages``, the passage their routes use (:func:`read_map_world`)."""
    data = mapping(data, "world")
    check_keys(data, WORLD_KEYS, "world")
    if "map" in data:
        return read_map_world(data, robots)
    if "corridor_width" in data and "corridor" in data:
        raise fail("world.corridor_width", "give either corridor_width (the paper's layout) or corridor, not both")
    if "passages" in data:
        for other in ("corridor", "entrances", "corridor_width"):
            if other in data:
                raise fail(f"world.{other}", "give either passages or the paper's corridor shorthand "
                           "(corridor, entrances, corridor_width), not both")
    width = number(data.get("corridor_width", 0.7), "world.corridor_width")
    if not 0.0 < width < 5.0:
        raise fail("world.corridor_width", f"must be above 0 and below the rooms' height (5 m), got {shown(width)}")
    default = paper_world(corridor_width=width)
    bounds = _box(data["bounds"], "world.bounds") if "bounds" in data else default.bounds
    if max(bounds[2] - bounds[0], bounds[3] - bounds[1]) > limits.MAX_WORLD_SIZE:
        raise fail("world.bounds", f"sides of at most {limits.MAX_WORLD_SIZE:g} m, got {list(bounds)}")
    if "obstacles" in data:
        obstacles, polygons = _walls(data["obstacles"])
    else:
        obstacles, polygons = default.obstacles, ()
    if "passages" in data:
        return World(bounds=bounds, obstacles=obstacles, passages=_passages(data["passages"], bounds),
                     polygons=polygons)
    if "corridor" in data:
        c = mapping(data["corridor"], "world.corridor")
        keys = ("x_min", "x_max", "y_min", "y_max")
        check_keys(c, keys, "world.corridor")
        missing = [k for k in keys if k not in c]
        if missing:
            raise fail("world.corridor", f"missing key '{missing[0]}' (give x_min, x_max, y_min, y_max)")
        corridor = Corridor(**{k: coordinate(c[k], f"world.corridor.{k}") for k in keys})
        if corridor.x_min >= corridor.x_max or corridor.y_min >= corridor.y_max:
            raise fail("world.corridor", "need x_min < x_max and y_min < y_max")
    else:
        corridor = default.shorthand
    inside = (bounds[0] <= corridor.x_min and corridor.x_max <= bounds[2]
              and bounds[1] <= corridor.y_min and corridor.y_max <= bounds[3])
    if not inside:
        raise fail("world.corridor", f"the corridor x {corridor.x_min:g}..{corridor.x_max:g}, y {corridor.y_min:g}.."
                    f"{corridor.y_max:g} is not inside world.bounds {list(bounds)}")
    if "entrances" in data:
        ent = data["entrances"]
        if not isinstance(ent, list) or len(ent) != 2:
            raise fail("world.entrances", f"expected two points [[x, y], [x, y]] (left, right), got {shown(ent)}")
        entrances = (point(ent[0], "world.entrances[0]"), point(ent[1], "world.entrances[1]"))
        if entrances[0] == entrances[1]:
            raise fail("world.entrances", f"the two entrances are the same point {list(entrances[0])}")
        for k, (entrance, end, side) in enumerate(zip(entrances, (corridor.x_min, corridor.x_max), ("left", "right"))):
            if abs(entrance[0] - end) > 1e-9 or not corridor.y_min <= entrance[1] <= corridor.y_max:
                raise fail(f"world.entrances[{k}]", f"{list(entrance)} is not on the corridor's {side} end "
                            f"(x = {end:g}, y from {corridor.y_min:g} to {corridor.y_max:g}); for a passage "
                            f"at another angle give world.passages: [{{from: [x, y], to: [x, y], width: W}}]")
    else:
        mid = 0.5 * (corridor.y_min + corridor.y_max)
        entrances = ((corridor.x_min, mid), (corridor.x_max, mid))
    return World(bounds=bounds, obstacles=obstacles, corridor=corridor, entrances=entrances, polygons=polygons)


def check_single_file(world: World, radii: np.ndarray, key: str) -> None:
    """A passage given as ``passages`` must be single file for the scenario's robots: its walls
    (the least clearance along its centreline, doubled) leave less than the two smallest robots
    need abreast, ``2 (r_a + r_b)``."""
    if world.corridor is not None or len(radii) < 2:
        return
    for k, g in enumerate(world.passages):
        where = key if len(world.passages) == 1 or not key.startswith("world.passages") else f"world.passages[{k}]"
        _check_one_single_file(world, g, radii, where)


def _check_one_single_file(world: World, g: Passage, radii: np.ndarray, key: str) -> None:
    a, b = np.asarray(g.start, dtype=float), np.asarray(g.end, dtype=float)
    samples = max(2, int(g.length / 0.01) + 1)
    gap = 2.0 * float(world.clearance(a + np.linspace(0.0, 1.0, samples)[:, None] * (b - a)).min())
    r = np.sort(np.asarray(radii, dtype=float))
    abreast = 2.0 * (r[0] + r[1])
    if gap >= abreast:
        raise fail(key, f"is not single file for these robots: its walls leave {gap:.3f} m, two robots of radii "
                        f"{r[0]:g} and {r[1]:g} m pass abreast in {abreast:.3f} m; narrow the walls or give this "
                        f"opening no passage")


def read_map_world(data: dict, robots: Sequence[Any]) -> World:
    """A world whose walls come from ``world.map`` (a map_server YAML file; a relative path is
    relative to the scenario file, :func:`nodnav.scenario.loading.load_scenario` resolves it).

    ``bounds`` default to the map's extent; given, they crop the map to the cells they meet (a
    scenario on part of a building keeps only the walls there). ``obstacles`` add walls
    (furniture) to the map's.
    Without ``passages`` the passage is found (:mod:`nodnav.scenario.passage_finding`): the
    single-file places for the scenario's robots (a robot of the largest radius fits, the two
    smallest cannot pass abreast) that their shortest routes cross; exactly one must remain."""
    from nodnav.scenario.maps import read_map

    for other in ("corridor", "entrances", "corridor_width"):
        if other in data:
            raise fail(f"world.{other}", "a map's passages are given as world.passages or found; the paper's "
                       "corridor shorthand does not apply to a map")
    where = data["map"]
    if not isinstance(where, str) or not where.strip():
        raise fail("world.map", f"expected the map's YAML file (ROS map_server format), got {shown(where)}")
    m = read_map(where)
    bounds = _box(data["bounds"], "world.bounds") if "bounds" in data else m.bounds
    m = m.cropped(bounds)
    if not m.free.any():
        raise fail("world.bounds", f"{list(bounds)} holds no free cell of the map (whose extent is "
                   f"{[round(b, 3) for b in read_map(where).bounds]})")
    if max(bounds[2] - bounds[0], bounds[3] - bounds[1]) > limits.MAX_WORLD_SIZE:
        raise fail("world.bounds" if "bounds" in data else "world.map",
                   f"sides of at most {limits.MAX_WORLD_SIZE:g} m, got {[round(b, 3) for b in bounds]}")
    extra, polygons = _walls(data["obstacles"]) if "obstacles" in data else ((), ())
    if "passages" in data:
        passages = _passages(data["passages"], bounds)
    else:
        passages = _found_passages(m, robots)
    return World(bounds=bounds, obstacles=m.walls + tuple(extra), passages=passages, polygons=polygons,
                 map_file=m.path, map_walls=len(m.walls))


def _found_passages(m: Any, robots: Sequence[Any]) -> tuple[Passage, ...]:
    """The passages the robots' routes cross, found on the map (in the order of their numbers in
    ``nodnav passages``); one line when there is none or two of them overlap."""
    from nodnav.scenario.passage_finding import clearance_grid, find_passages, route_passages, shortest_route

    if len(robots) < 2:
        raise fail("world.map", "finding a map's passages needs the scenario's robots (at least two); "
                   "or give world.passages")
    radii = np.sort([float(r.radius) for r in robots])
    one, abreast = float(radii[-1]), float(radii[0] + radii[1])
    clearance = clearance_grid(m)
    found = find_passages(m, one, abreast, clearance)
    used: list[int] = []
    for k, r in enumerate(robots):
        route = shortest_route(m, clearance, np.asarray(r.origin), np.asarray(r.destination), float(r.radius))
        if route.problem:
            key = "origin" if "origin" in route.problem else "destination"
            raise fail(f"robots[{k}].{key}", f"robot {k + 1} (radius {float(r.radius):g} m): {route.problem}")
        used += [i for i in route_passages(found, route, m.resolution) if i not in used]
    if not used:
        raise fail("world.map", f"the robots' routes cross none of the map's {len(found)} single-file passages for "
                   f"radii {radii[0]:g} to {radii[-1]:g} m ('nodnav passages' lists them); move the robots or give "
                   f"world.passages")
    _check_overlaps([found[i].passage for i in sorted(used)], [i + 1 for i in sorted(used)])
    return tuple(found[i].passage for i in sorted(used))
