"""The environment E of the paper: a bounded plane with walls and single-file passages.

Everything here is geometry on arrays; nothing knows about opinions, planners or controllers.
Points are ``(..., 2)`` arrays in metres. Walls are axis-aligned boxes (the fast path every
built-in scenario uses) and polygons, convex or not, kept as convex pieces
(:mod:`nodnav.scenario.polygons`). A passage is a straight single-file corridor between two
mouths at any angle; sides, mouths and order are reasoned about in its own frame
(:class:`Passage`), never in raw x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from nodnav.compiled import compiled
from nodnav.geometry import TOL, clearance_of, piece_clearance, segment_clearance
from nodnav.wall_grid import WallGrid, clearance_indexed

#: Sides of the passage, as returned by :meth:`World.side_of`: before its first mouth
#: (``LEFT``, the paper's left room), between the mouths (``INSIDE``), beyond the second mouth
#: (``RIGHT``). The names are the paper's horizontal corridor's; in general they mean "on the
#: first mouth's side" and "on the second mouth's side".
LEFT, INSIDE, RIGHT = -1, 0, 1


def _read_only(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Corridor:
    """The paper's shorthand for its one passage: an axis-aligned box along x."""

    x_min: float
    """Left end of the passage (m); the paper's left entrance is at x = -3."""
    x_max: float
    """Right end of the passage (m); the paper's right entrance is at x = 3."""
    y_min: float
    """Lower wall of the passage (m)."""
    y_max: float
    """Upper wall of the passage (m)."""

    @property
    def width(self) -> float:
        """Clear width of the passage (m)."""
        return self.y_max - self.y_min

    @property
    def length(self) -> float:
        """Length of the passage (m)."""
        return self.x_max - self.x_min


@dataclass(frozen=True)
class Passage:
    """A straight single-file passage: its centreline runs from the mouth ``start`` to ``end``.

    Its frame has the unit ``axis`` from ``start`` to ``end`` and the unit ``normal`` (the axis
    turned a quarter left). A point's coordinates in it are ``s = p . axis`` (along) and
    ``t = p . normal`` (across); the mouths are at ``s_start < s_end``. The coordinates are
    projections on the axis through the world's origin rather than offsets from ``start``: for
    the paper's corridor (axis ``(1, 0)``) ``s`` is then exactly ``x`` and the mouths exactly
    ``x_min`` and ``x_max``, so every comparison gives the bits the raw-x code gave.
    """

    start: tuple[float, float]
    """Centre of the first mouth (m); the paper's left entrance (-3, 0)."""
    end: tuple[float, float]
    """Centre of the second mouth (m); the paper's right entrance (3, 0)."""
    width: float
    """Clear width (m); single file: less than two robots abreast."""

    def __post_init__(self) -> None:
        if not (self.width > 0.0 and math.isfinite(self.width)):
            raise ValueError(f"a passage's width must be positive, got {self.width}")
        if self.start == self.end:
            raise ValueError(f"a passage's mouths must differ, got {self.start} twice")

    @cached_property
    def axis(self) -> tuple[float, float]:
        """Unit vector from the first mouth to the second."""
        dx, dy = self.end[0] - self.start[0], self.end[1] - self.start[1]
        n = math.hypot(dx, dy)
        return dx / n, dy / n

    @cached_property
    def normal(self) -> tuple[float, float]:
        """Unit vector across the passage, the axis turned a quarter counter-clockwise."""
        ux, uy = self.axis
        return -uy, ux

    @cached_property
    def length(self) -> float:
        """Distance between the mouths (m)."""
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])

    @cached_property
    def angle(self) -> float:
        """Direction of the axis (rad); exactly 0 for the paper's corridor. Planners turn their
        rings of candidate spots and the octagons around other robots by it, so that they keep
        the same place relative to the passage at any angle."""
        return 0.0 if self.along_x else math.atan2(self.axis[1], self.axis[0])

    @cached_property
    def s_start(self) -> float:
        """Along-coordinate of the first mouth (m)."""
        return self.start[0] * self.axis[0] + self.start[1] * self.axis[1]

    @cached_property
    def s_end(self) -> float:
        """Along-coordinate of the second mouth (m)."""
        return self.end[0] * self.axis[0] + self.end[1] * self.axis[1]

    @cached_property
    def t_centre(self) -> float:
        """Across-coordinate of the centreline (m)."""
        return self.start[0] * self.normal[0] + self.start[1] * self.normal[1]

    @cached_property
    def along_x(self) -> bool:
        """Whether the axis is exactly ``(1, 0)``: then ``s`` is ``x`` itself (the paper's case)."""
        return self.axis == (1.0, 0.0)

    def along(self, points: np.ndarray) -> np.ndarray:
        """Along-coordinate ``s`` of each point, shape ``(...)``."""
        p = np.asarray(points, dtype=float)
        if self.along_x:
            return p[..., 0]
        return p[..., 0] * self.axis[0] + p[..., 1] * self.axis[1]

    def across(self, points: np.ndarray) -> np.ndarray:
        """Across-coordinate ``t`` of each point, shape ``(...)``."""
        p = np.asarray(points, dtype=float)
        return p[..., 0] * self.normal[0] + p[..., 1] * self.normal[1]

    def to_world(self, s: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Points ``(..., 2)`` at frame coordinates ``(s, t)``; exact for the paper's axis."""
        s, t = np.asarray(s, dtype=float), np.asarray(t, dtype=float)
        if self.along_x:
            return np.stack(np.broadcast_arrays(s, t), axis=-1)
        (ux, uy), (nx, ny) = self.axis, self.normal
        return np.stack([s * ux + t * nx, s * uy + t * ny], axis=-1)

    def side_of_along(self, s: np.ndarray) -> np.ndarray:
        """``LEFT`` before the first mouth, ``INSIDE`` between the mouths, ``RIGHT`` beyond the second."""
        s = np.asarray(s, dtype=float)
        if not s.ndim or not self.s_start <= self.s_end:  # a 0-d array stays one
            return np.where(s < self.s_start, LEFT, np.where(s > self.s_end, RIGHT, INSIDE))
        # RIGHT (1) beyond the second mouth minus 1 before the first: with the mouths in order
        # at most one holds; half the cost of the two np.where (the closed loop asks this
        # thousands of times a trial).
        side = (s > self.s_end).astype(int)
        side -= s < self.s_start
        return side

    def outline(self) -> np.ndarray:
        """The passage's clear rectangle, ``(4, 2)`` counter-clockwise (for figures and checks)."""
        h = 0.5 * self.width
        s = np.array([self.s_start, self.s_end, self.s_end, self.s_start])
        t = self.t_centre + np.array([-h, -h, h, h])
        return self.to_world(s, t)

    @staticmethod
    def of_corridor(c: Corridor) -> "Passage":
        """The passage of the paper's shorthand: along x through the box's middle."""
        yc = 0.5 * (c.y_min + c.y_max)
        return Passage(start=(c.x_min, yc), end=(c.x_max, yc), width=c.width)


@dataclass(frozen=True)
class World:
    """Free space ``E``: the box ``bounds`` minus the walls, with its single-file passages.

    Walls are ``obstacles`` (axis-aligned boxes) and ``polygons`` (any simple polygons). The
    passage is given either as ``passages`` or, as the paper does, as the axis-aligned
    ``corridor`` with its two ``entrances``; the other form is derived. The entrances are the
    points of eqs. (6) and (10): the mouths' centres unless the shorthand gave others.
    """

    bounds: tuple[float, float, float, float]
    """Outer boundary ``(x_min, y_min, x_max, y_max)`` (m); robots stay inside it."""
    obstacles: tuple[tuple[float, float, float, float], ...]
    """Axis-aligned wall rectangles ``(x_min, y_min, x_max, y_max)`` (m)."""
    corridor: Corridor | None = None
    """The paper's shorthand for its horizontal passage; None when the passage is given as
    ``passages`` (code that may see such a world reads :attr:`passage`)."""
    entrances: tuple[tuple[float, float], ...] = ()
    """First and second entrance points used by eqs. (6) and (10) (m); paper: (-3, 0) and (3, 0).
    Derived from the passage's mouths when not given."""
    passages: tuple[Passage, ...] = ()
    """The single-file passages. With several, each robot plays the passing-order game of the next
    one on its route (docs/several-passages.md); the one-passage code sees one at a time through
    :meth:`with_passage`."""
    polygons: tuple[tuple[tuple[float, float], ...], ...] = field(default=())
    """Wall polygons, each its vertices ``((x, y), ...)`` in order (m), convex or not."""
    map_file: str = ""
    """The occupancy-grid map (its YAML file) the first :attr:`map_walls` boxes of ``obstacles``
    come from (:mod:`nodnav.scenario.maps`); "" without a map."""
    map_walls: int = 0
    """How many of ``obstacles``, from the first, are the map's walls."""

    def __post_init__(self) -> None:
        passages = tuple(self.passages)
        if self.corridor is not None:
            derived = (Passage.of_corridor(self.corridor),)
            if passages and passages != derived:  # e.g. dataclasses.replace of the corridor alone
                raise ValueError("give either passages or the corridor shorthand, not both")
            passages = derived
        elif not passages:
            raise ValueError("a world needs a passage: give passages or corridor")
        object.__setattr__(self, "passages", passages)
        if not self.entrances:
            p = passages[0]
            object.__setattr__(self, "entrances", (tuple(p.start), tuple(p.end)))
        object.__setattr__(self, "polygons", tuple(tuple(tuple(map(float, v)) for v in poly) for poly in self.polygons))

    @property
    def shorthand(self) -> Corridor:
        """The axis-aligned corridor of the paper's shorthand, for code that reads only such worlds
        (the families'); a world given as ``passages`` has none (ValueError)."""
        if self.corridor is None:
            raise ValueError("this world's passage is given as passages, not as the corridor shorthand")
        return self.corridor

    @property
    def passage(self) -> Passage:
        """The passage the passing order is about (the first of several)."""
        return self.passages[0]

    def with_passage(self, k: int) -> "World":
        """The same walls with passage ``k`` alone: the one-passage view a robot reasons in while
        it plays that passage's game (docs/several-passages.md)."""
        if len(self.passages) == 1 and k == 0:
            return self
        return World(bounds=self.bounds, obstacles=self.obstacles, passages=(self.passages[k],),
                     polygons=self.polygons, map_file=self.map_file, map_walls=self.map_walls)

    @cached_property
    def obstacle_array(self) -> np.ndarray:
        """Wall boxes as an ``(M, 4)`` array (read-only: computed once and shared)."""
        return _read_only(np.asarray(self.obstacles, dtype=float).reshape(-1, 4))

    @cached_property
    def piece_array(self) -> np.ndarray:
        """The polygons' convex pieces ``(P, K, 2)``, counter-clockwise, padded by repeating the
        last vertex (read-only; ``(0, 3, 2)`` without polygons)."""
        if not self.polygons:
            return _read_only(np.zeros((0, 3, 2)))
        from nodnav.scenario.polygons import convex_pieces, padded_pieces

        return _read_only(padded_pieces([q for poly in self.polygons for q in convex_pieces(poly)]))

    @cached_property
    def wall_grid(self) -> WallGrid | None:
        """A bucket index of the wall boxes for a map's world (thousands of boxes): the clearance
        routines then look only at the boxes near each query, with the same results. None for a
        world without a map (the paper's and every built-in keep the plain loop)."""
        return WallGrid(self.obstacle_array, self.bounds_array) if self.map_walls else None

    @cached_property
    def entrance_array(self) -> np.ndarray:
        """The entrances as a ``(2, 2)`` array (read-only: computed once and shared)."""
        return _read_only(np.asarray(self.entrances, dtype=float))

    @cached_property
    def bounds_array(self) -> np.ndarray:
        """The outer boundary as a ``(4,)`` array (read-only: computed once and shared)."""
        return _read_only(np.asarray(self.bounds, dtype=float))

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m) from each point to the nearest wall or boundary; negative inside a wall."""
        p = np.asarray(points, dtype=float)
        flat = np.ascontiguousarray(p.reshape(-1, 2))
        grid = self.wall_grid
        if grid is not None:
            d = clearance_indexed(flat, self.bounds_array, self.obstacle_array, *grid.arrays())
        else:
            d = clearance_of(flat, self.bounds_array, self.obstacle_array)
        if len(self.piece_array):
            d = np.minimum(d, piece_clearance(flat, self.piece_array))
        return d.reshape(p.shape[:-1])

    def segment_clearance(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Least clearance (m) along each segment ``a -> b`` (:func:`nodnav.geometry.segment_clearance`)."""
        return segment_clearance(self, a, b)

    def is_free(self, points: np.ndarray, radius: float | np.ndarray) -> np.ndarray:
        """Whether a disc of ``radius`` centred at each point lies in free space."""
        return self.clearance(points) >= np.asarray(radius) - TOL

    # -- the passage's frame ----------------------------------------------------------------------

    def along(self, points: np.ndarray) -> np.ndarray:
        """Along-coordinate of each point in the passage's frame (:meth:`Passage.along`)."""
        return self.passage.along(points)

    def side_of(self, points: np.ndarray) -> np.ndarray:
        """``LEFT`` (-1) before the first mouth, ``INSIDE`` (0) between the mouths, ``RIGHT`` (+1)
        beyond the second, along the passage's axis."""
        return self.passage.side_of_along(self.passage.along(points))

    def entrance_for(self, side: np.ndarray) -> np.ndarray:
        """The entrance a robot approaching from ``side`` (-1 or +1) uses, shape ``(..., 2)``."""
        ent = self.entrance_array
        return np.where((np.asarray(side) > 0)[..., None], ent[1], ent[0])

    def corridor_distance(self, points: np.ndarray, approach_side: np.ndarray) -> np.ndarray:
        """Distance d_{i,corridor} of eqs. (6) and (10) (m).

        Euclidean distance to the entrance on the side the robot approaches from; zero once the
        robot has passed that entrance and until it exits at the other end (Section III-A).
        """
        p = np.asarray(points, dtype=float)
        side = np.asarray(approach_side)
        ent = self.entrance_for(side)
        dist = np.linalg.norm(p - ent, axis=-1)
        g = self.passage
        s = g.along(p)
        passed_entrance = np.where(side > 0, s <= g.s_end, s >= g.s_start)
        not_exited = (s >= g.s_start) & (s <= g.s_end)
        return np.where(passed_entrance & not_exited, 0.0, dist)

    def in_corridor(self, points: np.ndarray) -> np.ndarray:
        """Whether each point is between the entrances (inside the single-file passage)."""
        return self.side_of(points) == INSIDE

    def on_line(self, points: np.ndarray, reach: float = 0.0) -> np.ndarray:
        """Whether each point is in the single-file line itself: between the entrances and no
        farther than ``reach`` beyond the passage's clear width from its centreline. A point
        between the entrances but off the line is in a bay (a niche beside the passage, which
        the walls leave room for; issue 19)."""
        p = self.passage
        beside = np.abs(p.across(points) - p.t_centre) - 0.5 * p.width
        return self.in_corridor(points) & (beside < reach)


def corridor_world(
    x_min: float,
    x_max: float,
    half_width: float,
    left_depth: float,
    right_depth: float,
    y_min: float,
    y_max: float,
) -> World:
    """Two rooms joined by a corridor through a thick wall: the layout of every generated scenario.

    The corridor runs along the x axis from ``x_min`` to ``x_max`` with clear width
    ``2 half_width`` about ``y = 0``; the wall it pierces is two blocks spanning the corridor's
    length, from the corridor to ``y_min`` and ``y_max``. The rooms are ``left_depth`` and
    ``right_depth`` deep and share the box's height ``y_max - y_min`` (the corridor need not be at
    mid-height). Entrances are the mouths' centres, ``(x_min, 0)`` and ``(x_max, 0)``.
    """
    w = half_width
    return World(
        bounds=(x_min - left_depth, y_min, x_max + right_depth, y_max),
        obstacles=((x_min, y_min, x_max, -w), (x_min, w, x_max, y_max)),
        corridor=Corridor(x_min=x_min, x_max=x_max, y_min=-w, y_max=w),
        entrances=((x_min, 0.0), (x_max, 0.0)),
    )


def paper_world(
    corridor_half_length: float = 3.0,
    corridor_width: float = 0.7,
    room_depth: float = 4.0,
    room_height: float = 5.0,
) -> World:
    """The paper's layout: a corridor centred on the origin with an open room on each side.

    The paper fixes only the entrances at (-3, 0) and (3, 0). The width 0.7 m admits one robot of
    radius 0.2 m with 0.15 m to spare on each side but not two abreast (that needs 0.8 m); the
    rooms, 4 m deep and 5 m high, leave room for four robots to wait and manoeuvre.
    """
    h = corridor_half_length
    ymax = room_height / 2.0
    return corridor_world(-h, h, corridor_width / 2.0, room_depth, room_depth, -ymax, ymax)


def distance_to_go(world: World, points: np.ndarray, destinations: np.ndarray, approach_side: np.ndarray) -> np.ndarray:
    """Length (m) of the shortest route through the corridor's entrances to each destination.

    A robot before the corridor goes via both entrances, one inside goes via the far entrance,
    one past it goes straight; robots with no crossing (``approach_side`` on the destination's
    side) go straight. Used to measure progress, not to plan. The arguments broadcast against
    each other (points ``(..., 2)``); one compiled loop (:func:`_distance_to_go_kernel`, the
    same float operations as :func:`distance_to_go_plain`).
    """
    p = np.asarray(points, dtype=float)
    dest = np.asarray(destinations, dtype=float)
    side = np.asarray(approach_side)
    shape = np.broadcast_shapes(p.shape[:-1], dest.shape[:-1], side.shape)
    if p.shape[:-1] != shape:
        p = np.broadcast_to(p, shape + (2,))
    if dest.shape[:-1] != shape:
        dest = np.broadcast_to(dest, shape + (2,))
    if side.shape != shape:
        side = np.broadcast_to(side, shape)
    g = world.passage
    out = _distance_to_go_kernel(np.ascontiguousarray(p.reshape(-1, 2)), np.ascontiguousarray(dest.reshape(-1, 2)),
                                 np.ascontiguousarray(side.reshape(-1), dtype=np.int64),
                                 world.entrance_array, g.along_x, g.axis[0], g.axis[1],
                                 g.s_start, g.s_end)
    return out.reshape(shape)


@compiled
def _side_along(px, py, along_x, ax, ay, s_start, s_end):
    """:meth:`Passage.side_of_along` of :meth:`Passage.along` for one point."""
    s = px if along_x else px * ax + py * ay
    return LEFT if s < s_start else (RIGHT if s > s_end else INSIDE)


@compiled
def _distance_to_go_kernel(p, dest, side, ent, along_x, ax, ay, s_start, s_end):
    """:func:`distance_to_go_plain` point by point (its norms are ``sqrt(x * x + y * y)``, as NumPy's)."""
    out = np.empty(p.shape[0])
    for k in range(p.shape[0]):
        sd = side[k]
        near = ent[1] if sd > 0 else ent[0]
        far = ent[1] if -sd > 0 else ent[0]
        px, py, dx, dy = p[k, 0], p[k, 1], dest[k, 0], dest[k, 1]
        crossing = _side_along(dx, dy, along_x, ax, ay, s_start, s_end) == -sd
        where = _side_along(px, py, along_x, ax, ay, s_start, s_end)
        if crossing and where == sd:  # before the corridor: via both entrances
            tx, ty = dx - far[0], dy - far[1]
            ux, uy = near[0] - px, near[1] - py
            wx, wy = far[0] - near[0], far[1] - near[1]
            out[k] = np.sqrt(ux * ux + uy * uy) + np.sqrt(wx * wx + wy * wy) + np.sqrt(tx * tx + ty * ty)
        elif crossing and where == INSIDE:  # inside: via the far entrance
            tx, ty = dx - far[0], dy - far[1]
            ux, uy = far[0] - px, far[1] - py
            out[k] = np.sqrt(ux * ux + uy * uy) + np.sqrt(tx * tx + ty * ty)
        else:
            ux, uy = dx - px, dy - py
            out[k] = np.sqrt(ux * ux + uy * uy)
    return out


def distance_to_go_plain(world: World, points: np.ndarray, destinations: np.ndarray,
                         approach_side: np.ndarray) -> np.ndarray:
    """Length (m) of the shortest route through the corridor's entrances to each destination.

    A robot before the corridor goes via both entrances, one inside goes via the far entrance,
    one past it goes straight; robots with no crossing (``approach_side`` on the destination's
    side) go straight. Used to measure progress, not to plan. The NumPy reference of
    :func:`distance_to_go`.
    """
    p = np.asarray(points, dtype=float)
    dest = np.asarray(destinations, dtype=float)
    side = np.asarray(approach_side)
    near = world.entrance_for(side)
    far = world.entrance_for(-side)
    straight = np.linalg.norm(dest - p, axis=-1)
    tail = np.linalg.norm(dest - far, axis=-1)
    via_far = np.linalg.norm(far - p, axis=-1) + tail
    via_both = np.linalg.norm(near - p, axis=-1) + np.linalg.norm(far - near, axis=-1) + tail
    where = world.side_of(p)
    dest_side = world.side_of(dest)
    crossing = dest_side == -side
    before = crossing & (where == side)
    inside = crossing & (where == INSIDE)
    return np.where(before, via_both, np.where(inside, via_far, straight))
