"""Random floor plans: rooms in a chain, joined by single-file doors and corridors at any angle.

One draw of a ``building`` family (:mod:`nodnav.scenario.building_family`), in its own frame first
(the chain along x, the building centred on the origin), then turned as a whole:

1. **Robots**: 2-8, their radii, speed and acceleration limits drawn as in the corridor families.
2. **Walls**: ``doors`` walls split a box of ``height`` into ``doors + 1`` rooms, each wall turned
   by its own ``tilt`` off square to the chain and as thick as its passage is long (a door, or with
   probability ``corridors`` a corridor). Each is pierced by one slot, the passage: its width is
   single file for the drawn radii (``fit`` within ``[2 r_max + 0.1, 2 (r_a + r_b) - 0.05]``), its
   place along the wall drawn where at least 0.3 m of wall stays on either side. Rooms are at least
   ``depth`` deep everywhere (the walls are spaced for their tilt).
3. **Furniture**: up to ``furniture`` convex polygons per room (rectangles, triangles, pentagons of
   ``furniture_size``), each kept :func:`furniture_gap` from every wall, every other piece and every
   mouth zone: two of the largest robots pass abreast everywhere round furniture, so furniture makes
   no single-file place that is not a declared passage. A piece that finds no place is left out.
4. **Routes**: each robot crosses ``crossings`` passages (at most the plan's): it starts in room
   ``a`` and ends in room ``a + m`` or the reverse. Origins and destinations are drawn uniformly in
   their rooms, at least ``r + 0.05`` m from walls and furniture, ``r_a + r_b + 0.05`` m from every
   other robot's origin and destination, and out of every mouth zone (the half disc of radius
   ``rho = w/2 + 2 r_max + 0.1`` about each mouth), with :data:`~nodnav.scenario.layout.SLACK` to spare.
5. **Turn**: the plan turns by ``turn`` about the origin; the world's bounds are the box round it,
   with the four corners outside the building as wall triangles. Coordinates are rounded to the mm.

The result is checked by :func:`nodnav.scenario.building_check.check_building` (validity and a
serial witness of solvability); :func:`nodnav.scenario.draws.draw` redraws from the same stream
until a plan passes. The time limit is ``ceil(20 + 1.5 (max_i t_i(1.25 l_i) + sum_i sum_p
t_i(L_p + 4 r_max)))`` s: ``l_i`` the straight route through the mouths of the passages robot i
crosses (1.25 for the detours round walls and furniture), ``L_p`` the length of each passage it
crosses, ``t_i`` as in :func:`~nodnav.scenario.layout.travel_time` at half the acceleration limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodnav.scenario.building_family import BuildingFamily
from nodnav.scenario.layout import SLACK, _Draws, _mm, _Reject, draw_bodies, travel_time
from nodnav.scenario.validity import ABREAST_MARGIN, CLEARANCE, FIT_MARGIN, mouth_zone_radius
from nodnav.scenario.world import Passage, World

#: Wall (m) kept beside a passage's slot on either side, and round the building's box.
MIN_SIDE_WALL = 0.3
#: Places tried for one furniture piece, and for one robot's origin or destination.
FURNITURE_TRIES, SPOT_TRIES = 20, 60
#: Route length factor of the time limit, for detours round walls and furniture.
DETOUR = 1.25


def furniture_gap(r_max: float) -> float:
    """Least distance (m) between furniture and walls, other furniture and mouth zones: two of the
    largest robots abreast with 5 cm a side, ``4 r_max + 0.1``."""
    return 4.0 * r_max + 2.0 * CLEARANCE


@dataclass
class _BRobot:
    radius: float
    speed: float
    accel: float
    rooms: tuple[int, int] = (0, 1)
    origin: np.ndarray | None = None
    destination: np.ndarray | None = None


def _turn(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    p = np.asarray(points, dtype=float)
    return np.stack([c * p[..., 0] - s * p[..., 1], s * p[..., 0] + c * p[..., 1]], axis=-1)


def _pt(p) -> list[float]:
    return [_mm(p[0]), _mm(p[1])]


class BuildingAttempt:
    """One attempt at a floor-plan draw; raises :class:`~nodnav.scenario.layout._Reject` when a step fails."""

    def __init__(self, f: BuildingFamily, d: _Draws):
        self.f, self.d = f, d

    # -- 1. robots -------------------------------------------------------------------------------

    def robots(self) -> list[_BRobot]:
        return [_BRobot(r, v, a) for r, v, a in zip(*draw_bodies(self.f, self.d))]

    # -- 2. walls and passages -------------------------------------------------------------------

    def plan(self, robots: list[_BRobot]) -> None:
        """Rooms, walls (local frame) and passages; sets ``self.walls``, ``self.passages``, ``self.rooms``."""
        import shapely

        f, d = self.f, self.d
        radii = sorted(r.radius for r in robots)
        r_max = radii[-1]
        lo_mm = round(1000 * (2 * r_max + FIT_MARGIN)) + 1
        hi_mm = round(1000 * (2 * (radii[0] + radii[1]) - ABREAST_MARGIN)) - 1
        if lo_mm > hi_mm:
            raise _Reject("no single-file width for these radii")
        k_doors = d.integer(*f.doors)
        height = _mm(d.range(f.height))
        depths = [d.range(f.depth) for _ in range(k_doors + 1)]
        tilts = [math.radians(d.range(f.tilt)) for _ in range(k_doors)]
        lengths = [d.range(f.corridor_length) if d.chance(f.corridors) else d.range(f.door_length)
                   for _ in range(k_doors)]
        widths = [(lo_mm + round(d.range(f.fit) * (hi_mm - lo_mm))) / 1000 for _ in range(k_doors)]
        # Wall centres along x: each room at least its depth wide at its narrowest.
        reach = [0.5 * lengths[k] / math.cos(tilts[k]) + 0.5 * height * abs(math.tan(tilts[k]))
                 for k in range(k_doors)]
        xs, x = [], depths[0]
        for k in range(k_doors):
            x += reach[k]
            xs.append(x)
            x += reach[k] + depths[k + 1]
        total = x
        shift = 0.5 * total
        xs = [v - shift for v in xs]
        half = 0.5 * height
        box = shapely.box(-shift, -half, total - shift, half)
        walls, passages, bands = [], [], []
        for k in range(k_doors):
            phi, length, width = tilts[k], lengths[k], widths[k]
            n = np.array([math.cos(phi), math.sin(phi)])
            t = np.array([-math.sin(phi), math.cos(phi)])
            span = half / math.cos(phi) - 0.5 * length * abs(math.tan(phi)) - MIN_SIDE_WALL - 0.5 * width
            if span <= 0.0:
                raise _Reject("a wall too short for its door")
            offset = d.uniform(-span, span)
            c = np.array([xs[k], 0.0])
            q = c + offset * t
            big = 4.0 * (height + total)

            def strip(centre, across, along, a=n, b=t):
                return shapely.Polygon([centre + sa * across * a + sb * along * b
                                        for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))])

            band = strip(c, 0.5 * length, big)
            slot = strip(q, 0.5 * length + 1.0, 0.5 * width)
            bands.append(band.intersection(box))
            # The wall reaches 5 cm past the building's box (clipped to the bounds when turned), so
            # that rounding never leaves a sliver between it and the outer wall.
            pieces = band.intersection(box.buffer(0.05, join_style="mitre")).difference(slot)
            parts = list(pieces.geoms) if hasattr(pieces, "geoms") else [pieces]
            if len(parts) != 2:
                raise _Reject("a wall not split in two by its door")
            walls += [np.asarray(p.exterior.coords)[:-1] for p in parts]
            passages.append((q - 0.5 * length * n, q + 0.5 * length * n, width, length))
        self.box, self.half, self.walls, self.passages = box, half, walls, passages
        free = box.difference(shapely.union_all(bands)) if bands else box
        rooms = sorted(free.geoms if hasattr(free, "geoms") else [free], key=lambda g: g.centroid.x)
        if len(rooms) != k_doors + 1:
            raise _Reject("walls that do not split the building into a chain of rooms")
        self.rooms = rooms
        self.rho = mouth_zone_radius(0.5 * max(widths), r_max)
        self.mouths = np.array([m for p in passages for m in p[:2]]).reshape(-1, 2)

    # -- 3. furniture ----------------------------------------------------------------------------

    def furniture(self, robots: list[_BRobot]) -> None:
        import shapely

        f, d = self.f, self.d
        gap = furniture_gap(max(r.radius for r in robots))
        zones = shapely.MultiPoint(self.mouths).buffer(self.rho + gap) if len(self.mouths) else None
        pieces: list = []
        for room in self.rooms:
            inner = room.buffer(-gap)
            if inner.is_empty:
                continue
            x0, y0, x1, y1 = inner.bounds
            for _ in range(d.integer(*f.furniture)):
                size = d.range(f.furniture_size)
                kind = d.integer(0, 2)
                angle = d.uniform(0.0, 2.0 * math.pi)
                if kind == 0:  # a table or cupboard: a rectangle
                    a, b = 0.5 * size, 0.5 * size * d.uniform(0.3, 1.0)
                    shape = np.array([[-a, -b], [a, -b], [a, b], [-a, b]])
                else:  # a triangle or a pentagon, round a circle of diameter size
                    m = 3 if kind == 1 else 5
                    shape = np.array([[0.5 * size * math.cos(2 * math.pi * j / m),
                                       0.5 * size * math.sin(2 * math.pi * j / m)] for j in range(m)])
                shape = _turn(shape, angle)
                for _ in range(FURNITURE_TRIES):
                    centre = np.array([d.uniform(x0, x1), d.uniform(y0, y1)])
                    poly = shapely.Polygon(shape + centre)
                    if not inner.contains(poly):
                        continue
                    if zones is not None and poly.intersects(zones):
                        continue
                    if any(poly.distance(other) < gap for other in pieces):
                        continue
                    pieces.append(poly)
                    break
        self.pieces = [np.asarray(p.exterior.coords)[:-1] for p in pieces]

    # -- 4. routes -------------------------------------------------------------------------------

    def routes(self, robots: list[_BRobot]) -> None:
        f, d = self.f, self.d
        k_doors = len(self.passages)
        for r in robots:
            m = d.integer(f.crossings[0], min(f.crossings[1], k_doors)) if f.crossings[0] <= k_doors else k_doors
            a = d.integer(0, k_doors - m)
            r.rooms = (a, a + m) if d.chance(0.5) else (a + m, a)
        walls = World(bounds=self.box.bounds, obstacles=(), passages=(Passage((0.0, 0.0), (1.0, 0.0), 1.0),),
                      polygons=tuple(tuple(map(tuple, w)) for w in self.walls + self.pieces))
        placed: list[tuple[np.ndarray, float]] = []
        for r in robots:
            r.origin = self._spot(self.rooms[r.rooms[0]], r.radius, walls, placed)
            placed.append((r.origin, r.radius))
            r.destination = self._spot(self.rooms[r.rooms[1]], r.radius, walls, placed)
            placed.append((r.destination, r.radius))

    def _spot(self, room, radius: float, walls: World, placed) -> np.ndarray:
        d = self.d
        x0, y0, x1, y1 = room.bounds
        need = radius + CLEARANCE + SLACK
        for _ in range(SPOT_TRIES):
            p = np.array([d.uniform(x0 + need, x1 - need), d.uniform(y0 + need, y1 - need)])
            if np.linalg.norm(self.mouths - p, axis=-1).min() < self.rho + radius + SLACK:
                continue
            if any(np.linalg.norm(p - q) < radius + rq + CLEARANCE + SLACK for q, rq in placed):
                continue
            if float(walls.clearance(p)) < need:
                continue
            import shapely

            if not room.contains(shapely.Point(p)):
                continue
            return p
        raise _Reject("no free place for a robot in its room")

    # -- 5. the scenario -------------------------------------------------------------------------

    def draw(self, seed: int) -> dict:
        """One attempt's scenario mapping (``world.passages`` lists every passage)."""
        import shapely

        f, d = self.f, self.d
        robots = self.robots()
        self.plan(robots)
        self.furniture(robots)
        self.routes(robots)
        angle = math.radians(d.range(f.turn))
        quarter = angle / (0.5 * math.pi)
        if abs(quarter - round(quarter)) < 1e-12:  # exact for quarter turns: no corner walls
            q = round(quarter) % 4
            c, s = ((1, 0), (0, 1), (-1, 0), (0, -1))[q]
            turn = lambda p: np.stack([c * np.asarray(p)[..., 0] - s * np.asarray(p)[..., 1],  # noqa: E731
                                       s * np.asarray(p)[..., 0] + c * np.asarray(p)[..., 1]], axis=-1)
        else:
            turn = lambda p: _turn(p, angle)  # noqa: E731
        corners = np.array([_pt(p) for p in turn(np.asarray(self.box.exterior.coords)[:-1])])
        bounds = [float(corners[:, 0].min()), float(corners[:, 1].min()),
                  float(corners[:, 0].max()), float(corners[:, 1].max())]
        outside = shapely.box(*bounds).difference(shapely.Polygon(corners))
        corner_walls = [[_pt(p) for p in np.asarray(g.exterior.coords)[:-1]]
                        for g in getattr(outside, "geoms", [outside]) if not g.is_empty and g.area > 1e-4]
        inside = shapely.box(*bounds)
        clipped = [np.asarray(shapely.Polygon(turn(w)).intersection(inside).exterior.coords)[:-1] for w in self.walls]
        polygons = corner_walls + [[_pt(p) for p in w] for w in clipped] + [[_pt(p) for p in turn(w)]
                                                                              for w in self.pieces]
        passages = [{"from": _pt(turn(a)), "to": _pt(turn(b)), "width": w} for a, b, w, _ in self.passages]
        r_max = max(r.radius for r in robots)
        routes, queues = [], []
        for r in robots:
            lo, hi = sorted(r.rooms)
            ways = [self.passages[k] for k in range(lo, hi)]
            if r.rooms[0] > r.rooms[1]:
                ways = [(b, a, w, length) for a, b, w, length in reversed(ways)]
            stops = [r.origin] + [m for a, b, _, _ in ways for m in (a, b)] + [r.destination]
            routes.append(DETOUR * sum(float(np.linalg.norm(np.asarray(p) - np.asarray(q)))
                                       for p, q in zip(stops[:-1], stops[1:])))
            half_a = 0.5 * r.accel
            queues.append(sum(travel_time(length + 4 * r_max, r.speed, half_a) for _, _, _, length in ways))
        own = max(travel_time(ell, r.speed, 0.5 * r.accel) for ell, r in zip(routes, robots))
        crossing = [abs(r.rooms[1] - r.rooms[0]) for r in robots]
        settings = dict(f.settings)
        players = settings.get("game_players")
        if isinstance(players, int) and not isinstance(players, bool) and players > len(robots) - 1:
            settings["game_players"] = len(robots) - 1  # two robots: one game player each
        return {
            **settings,
            "name": f"{f.name}:{seed}",
            "description": f"draw {seed} of family {f.name} ({f.source}): {len(robots)} robots, "
                           f"{len(self.passages)} passages ({len(self.rooms)} rooms, {len(self.pieces)} furniture), "
                           f"routes crossing {', '.join(map(str, crossing))}",
            "world": {"bounds": bounds, "obstacles": polygons, "passages": passages},
            "robots": [{"origin": _pt(turn(r.origin)), "destination": _pt(turn(r.destination)),
                        "radius": r.radius, "max_speed": r.speed, "max_accel": r.accel} for r in robots],
            "time_limit": float(math.ceil(20.0 + 1.5 * (own + sum(queues)))),
        }
