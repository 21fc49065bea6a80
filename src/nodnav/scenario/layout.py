"""One attempt at drawing a scenario from a family: robots, corridor, rooms, starts, destinations.

:class:`_Attempt` lays a scenario out step by step and raises :class:`_Reject` when a step cannot
satisfy a rule; :func:`nodnav.scenario.draws.draw` makes attempts until one is valid and
solvable, and its module docstring describes the construction and the time limit
(:func:`time_limit`). The robots-meeting-inside construction (:mod:`nodnav.scenario.meeting`)
builds on :class:`_Attempt`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodnav.scenario.building_family import BuildingFamily
from nodnav.scenario.families import Family, Range
from nodnav.scenario.validity import CLEARANCE, room_needs
from nodnav.scenario.world import INSIDE, LEFT, RIGHT

__all__ = ["SLACK", "MOUTH_GAP", "MIN_WALL", "travel_time", "time_limit", "robots_routes"]

SLACK = 0.002
"""Extra room (m) the construction keeps beyond every rule, so that rounding to mm never breaks one."""
MOUTH_GAP = (0.05, 0.25)
"""Distance (m) from the mouth to the body of a robot parked right outside it."""
MIN_WALL = 0.05
"""Thinnest wall (m) left beside the corridor when it is off the rooms' mid-height."""



class _Draws:
    """Uniform numbers from one generator, used only through ``random()`` for portability."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def u(self) -> float:
        return float(self.rng.random())

    def uniform(self, lo: float, hi: float) -> float:
        return lo + (hi - lo) * self.u()

    def range(self, r: Range) -> float:
        return self.uniform(r.lo, r.hi)

    def integer(self, lo: int, hi: int) -> int:
        return lo + min(int(self.u() * (hi - lo + 1)), hi - lo)

    def chance(self, p: float) -> bool:
        return self.u() < p

    def choice(self, weights: tuple[tuple[str, float], ...]) -> str:
        x, total = self.u() * sum(w for _, w in weights), 0.0
        for name, w in weights:
            total += w
            if x < total and w > 0:
                return name
        return next(name for name, w in reversed(weights) if w > 0)

    def shuffled(self, items: list) -> list:
        items = list(items)
        for k in range(len(items) - 1, 0, -1):
            j = self.integer(0, k)
            items[k], items[j] = items[j], items[k]
        return items


def _mm(x: float) -> float:
    return round(float(x), 3) + 0.0  # + 0.0 turns -0.0 into 0.0


class _Reject(Exception):
    """This attempt broke a rule; draw again."""


@dataclass
class _Robot:
    radius: float
    speed: float
    start: int  # LEFT, RIGHT or INSIDE
    goal: int  # LEFT or RIGHT
    accel: float = 2.0
    origin: np.ndarray | None = None
    destination: np.ndarray | None = None


def _placed(p: np.ndarray | None) -> np.ndarray:
    """A robot's origin or destination, which the draw has placed by the time it is used."""
    if p is None:
        raise ValueError("a robot's origin or destination was used before it was placed")
    return p


def draw_bodies(f: Family | BuildingFamily, d: _Draws) -> tuple[list[float], list[float], list[float]]:
    """The robots' count, radii, speed limits and acceleration limits of a draw (either kind of
    family): alike, or half the time (``mixed_*``) each robot its own."""
    n = d.integer(*f.count)
    r0 = _mm(d.range(f.radius))
    top = max(r0, min(f.radius.hi, 2 * r0 - 0.08))  # any two radii then sum to r_max + 0.08
    radii = [_mm(d.uniform(r0, top)) for _ in range(n)] if d.chance(f.mixed_radii) else [r0] * n
    v0 = _mm(d.range(f.max_speed))
    speeds = [_mm(d.range(f.max_speed)) for _ in range(n)] if d.chance(f.mixed_speeds) else [v0] * n
    # A single acceleration draws nothing: such a family's draws are what they were before
    # accelerations were drawn.
    accels = [f.max_accel.lo] * n
    if f.max_accel.hi > f.max_accel.lo:
        a0 = _mm(d.range(f.max_accel))
        accels = [_mm(d.range(f.max_accel)) for _ in range(n)] if d.chance(f.mixed_accels) else [a0] * n
    return radii, speeds, accels


class _Attempt:
    """One attempt at a draw; raises :class:`_Reject` when a construction step cannot satisfy a rule."""

    def __init__(self, f: Family, d: _Draws):
        self.f, self.d = f, d

    def robots(self) -> list[_Robot]:
        f, d = self.f, self.d
        radii, speeds, accels = draw_bodies(f, d)
        n = len(radii)
        n_in = 0
        if f.inside_max >= 1 and d.chance(f.inside_probability):
            n_in = d.integer(1, min(f.inside_max, n - 1))
        m = n - n_in
        pattern = d.choice(f.traffic)
        if pattern == "one-sided" or m == 1:
            n_left = m if d.chance(0.5) else 0
        elif pattern == "head-on":
            n_left = m // 2 + (m % 2 if d.chance(0.5) else 0)
        else:
            n_left = d.integer(1, m - 1)
        in_left = d.integer(0, n_in)
        roles = ([(LEFT, RIGHT)] * n_left + [(RIGHT, LEFT)] * (m - n_left)
                 + [(INSIDE, LEFT)] * in_left + [(INSIDE, RIGHT)] * (n_in - in_left))
        return [_Robot(r, v, s, g, a) for r, v, (s, g), a in zip(radii, speeds, roles, accels)]

    def corridor(self, robots: list[_Robot]) -> tuple[float, float]:
        """Half length and half width (m), the width single file for these radii."""
        f, d = self.f, self.d
        r_mm = sorted(round(r.radius * 1000) for r in robots)
        lo_mm, hi_mm = 2 * r_mm[-1] + 100, 2 * (r_mm[0] + r_mm[1]) - 50
        w = d.range(f.width) * 1000 if f.width is not None else lo_mm + d.range(f.fit) * (hi_mm - lo_mm)
        half_lo, half_hi = -(-lo_mm // 2), hi_mm // 2
        if half_lo > half_hi:
            raise _Reject("no single-file width for these radii")
        half = min(max(round(w / 2), half_lo), half_hi) / 1000
        return max(_mm(d.range(f.length) / 2), 0.05), half

    def draw(self, seed: int) -> dict:
        f, d = self.f, self.d
        robots = self.robots()
        h, half = self.corridor(robots)
        r_max = max(r.radius for r in robots)
        depth = {LEFT: d.range(f.depth), RIGHT: d.range(f.depth)}
        height, offset = d.range(f.height), d.range(f.offset)
        need = {side: room_needs([r.radius for r in robots if side in (r.start, r.goal)], r_max, half)
                for side in (LEFT, RIGHT)}
        if f.grow:
            height = max(height, need[LEFT][1], need[RIGHT][1]) + SLACK
            for side in (LEFT, RIGHT):
                depth[side] = max(depth[side], need[side][0] + SLACK, need[side][2] / height + SLACK)
        centre = -offset * max(0.0, height / 2 - half - MIN_WALL)
        self.y = [centre - height / 2, centre + height / 2]
        self.h, self.half, self.depth = h, half, depth
        for side in (LEFT, RIGHT):
            self.formation(side, [r for r in robots if r.start == side])
        self.inside([r for r in robots if r.start == INSIDE])
        if any(not self._free(r.origin, r.radius, robots, r) for r in robots if r.origin is not None):
            raise _Reject("robots inside the corridor stand on robots in front of it")
        self.bounds = (_mm(-h - depth[LEFT]), _mm(self.y[0]), _mm(h + depth[RIGHT]), _mm(self.y[1]))
        for side in (LEFT, RIGHT):
            for r in robots:
                if r.start == side and r.origin is None:
                    r.origin = self.scatter(side, r.radius, robots)
        self.destinations(robots)
        return self.mapping(seed, d.shuffled(robots))

    # -- where robots start ------------------------------------------------------------------

    def _mouth(self, side: int) -> float:
        return -self.h if side == LEFT else self.h

    def _fit(self, side: int, p: np.ndarray, r: float) -> None:
        """Grow the room to hold a disc at ``p`` (or reject the attempt if the family does not grow)."""
        room = side * (p[0] - self._mouth(side)) + r + CLEARANCE + SLACK
        lo, hi = p[1] - r - CLEARANCE - SLACK, p[1] + r + CLEARANCE + SLACK
        if room > self.depth[side] or lo < self.y[0] or hi > self.y[1]:
            if not self.f.grow:
                raise _Reject("a start formation does not fit in its room")
            self.depth[side] = max(self.depth[side], room)
            self.y = [min(self.y[0], lo), max(self.y[1], hi)]

    def formation(self, side: int, group: list[_Robot]) -> None:
        """Side by side or in a queue in front of the mouth (scattered robots are placed later)."""
        if not group:
            return
        d, x_m = self.d, self._mouth(side)
        kind = d.choice(self.f.formations)
        if kind == "scatter":
            return
        gap = d.range(self.f.gap) + SLACK
        gaps = [d.range(self.f.spacing) + SLACK for _ in group]
        if kind == "line":
            t = d.uniform(-1.0, 1.0)
            u = np.array([side, t]) / math.sqrt(1.0 + t * t)
            p = np.array([x_m + side * (group[0].radius + gap), d.uniform(-self.half, self.half)])
            for k, r in enumerate(group):
                if k:
                    p = p + (group[k - 1].radius + r.radius + gaps[k]) * u
                r.origin = np.array([_mm(p[0]), _mm(p[1])])
        else:  # abreast
            x = x_m + side * (max(r.radius for r in group) + gap)
            total = sum(2 * r.radius for r in group) + sum(gaps[1:])
            y = d.uniform(-self.half, self.half) - total / 2 - group[0].radius
            for k, r in enumerate(group):
                y += (group[k - 1].radius + gaps[k] if k else 0.0) + r.radius
                r.origin = np.array([_mm(x), _mm(y)])
        for r in group:
            self._fit(side, _placed(r.origin), r.radius)

    def inside(self, group: list[_Robot]) -> None:
        """Robots in the corridor, those heading left left of those heading right: nobody must pass."""
        if not group:
            return
        group.sort(key=lambda r: r.goal)
        self._place(group)

    def _place(self, group: list[_Robot]) -> None:
        """Robots ``group`` in the corridor in the given order, spaced as the family says."""
        d = self.d
        gaps = [d.range(self.f.spacing) + SLACK for _ in group[1:]]
        span = sum(a.radius + b.radius + g for a, b, g in zip(group, group[1:], gaps))
        room = 2 * self.h - 2 * SLACK
        if span > room:
            raise _Reject("the corridor is too short for the robots inside it")
        x = -self.h + SLACK + d.uniform(0.0, room - span)
        for k, r in enumerate(group):
            if k:
                x += group[k - 1].radius + r.radius + gaps[k - 1]
            lateral = max(0.0, self.half - r.radius - CLEARANCE - SLACK)
            r.origin = np.array([_mm(x), _mm(d.uniform(-lateral, lateral))])

    def _free(self, p: np.ndarray, r: float, robots: list[_Robot], skip: _Robot | None) -> bool:
        """Whether a disc at ``p`` keeps the clearance from every placed origin and destination."""
        for o in robots:
            if o is skip:
                continue
            for q in (o.origin, o.destination):
                if q is not None and np.linalg.norm(p - q) < r + o.radius + CLEARANCE + SLACK:
                    return False
        return True

    def _room_point(self, side: int, r: float, on_axis: bool) -> np.ndarray:
        d, c = self.d, r + CLEARANCE + SLACK
        x0, y0, x1, y1 = self.bounds
        depth = (-self.h - x0) if side == LEFT else (x1 - self.h)
        if depth < 2 * c or (not on_axis and y1 - y0 < 2 * c):
            raise _Reject("a room is too small for its robots")
        x = self._mouth(side) + side * d.uniform(c, depth - c)
        y = 0.0 if on_axis else d.uniform(y0 + c, y1 - c)
        return np.array([_mm(x), _mm(y)])

    def scatter(self, side: int, r: float, robots: list[_Robot]) -> np.ndarray:
        for _ in range(100):
            p = self._room_point(side, r, False)
            if self._free(p, r, robots, None):
                return p
        raise _Reject("no free place to start in a room")

    # -- where robots go ---------------------------------------------------------------------

    def destinations(self, robots: list[_Robot]) -> None:
        d = self.d
        if d.chance(self.f.mouth):
            r = robots[d.integer(0, len(robots) - 1)]
            x = self._mouth(r.goal) + r.goal * (r.radius + d.uniform(*MOUTH_GAP) + SLACK)
            p = np.array([_mm(x), 0.0])
            if not self._free(p, r.radius, robots, r):
                raise _Reject("the robot parked at the mouth would stand on another robot")
            r.destination = p
        for r in robots:
            if r.destination is not None:
                continue
            on_axis = d.chance(self.f.axis)
            for _ in range(100):
                p = self._room_point(r.goal, r.radius, on_axis)
                if self._free(p, r.radius, robots, r):
                    r.destination = p
                    break
            else:
                raise _Reject("no free destination in a room")

    # -- the scenario --------------------------------------------------------------------------

    def mapping(self, seed: int, robots: list[_Robot]) -> dict:
        f, h, half = self.f, self.h, self.half
        x0, y0, x1, y1 = self.bounds
        n_left = sum(r.start == LEFT for r in robots)
        n_in = sum(r.start == INSIDE for r in robots)
        counts = ((n_left, "left"), (len(robots) - n_left - n_in, "right"), (n_in, "inside"))
        parts = [f"{k} {where}" for k, where in counts if k]
        return {
            **f.settings,
            "name": f"{f.name}:{seed}",
            "description": f"draw {seed} of family {f.name} ({f.source}): {len(robots)} robots "
                           f"({', '.join(parts)}), corridor {2 * h:.2f} x {2 * half:.3f} m",
            "world": {"bounds": [x0, y0, x1, y1], "obstacles": [[-h, y0, h, -half], [-h, half, h, y1]],
                      "corridor": {"x_min": -h, "x_max": h, "y_min": -half, "y_max": half},
                      "entrances": [[-h, 0.0], [h, 0.0]]},
            "robots": [{"origin": [float(x) for x in _placed(r.origin)[:2]],
                        "destination": [float(x) for x in _placed(r.destination)[:2]],
                        "radius": r.radius, "max_speed": r.speed, "max_accel": r.accel} for r in robots],
            "time_limit": time_limit(robots_routes(h, robots), [r.speed for r in robots], 2 * h,
                                     max(r.radius for r in robots), [r.accel for r in robots]),
        }


def robots_routes(h: float, robots: list[_Robot]) -> list[float]:
    """Length (m) of each robot's route through the entrances to its destination."""
    out = []
    for r in robots:
        far = np.array([r.goal * h, 0.0])
        tail = float(np.linalg.norm(r.destination - far))
        if r.start == INSIDE:
            out.append(float(np.linalg.norm(r.origin - far)) + tail)
        else:
            near = np.array([r.start * h, 0.0])
            out.append(float(np.linalg.norm(r.origin - near)) + 2 * h + tail)
    return out


def travel_time(distance: float, speed: float, accel: float | None) -> float:
    """Least time (s) to cover ``distance`` from rest to rest at most at ``speed`` and ``accel``
    (``None``: at once at full speed): ``l / v + v / a`` if the robot reaches its speed (``l >=
    v^2 / a``), else ``2 sqrt(l / a)``."""
    if accel is None:
        return distance / speed
    if distance >= speed * speed / accel:
        return distance / speed + speed / accel
    return 2.0 * math.sqrt(distance / accel)


def time_limit(routes, speeds, corridor_length: float, r_max: float, accels=None) -> float:
    """``ceil(20 + 1.5 (max_i t(l_i) + sum_i t(L + 4 r_max)))`` seconds (module docstring), with
    ``t(l)`` robot i's :func:`travel_time` over ``l`` at half its acceleration limit (the
    controller brakes below its limit; ``accels`` None: ``l / v_i``)."""
    half = [None] * len(speeds) if accels is None else [0.5 * a for a in accels]
    own = max(travel_time(route, v, a) for route, v, a in zip(routes, speeds, half))
    queue = sum(travel_time(corridor_length + 4 * r_max, v, a) for v, a in zip(speeds, half))
    return float(math.ceil(20.0 + 1.5 * (own + queue)))
