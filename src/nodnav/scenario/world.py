"""The environment E of the paper: a bounded plane with rectangular walls and one narrow corridor.

Everything here is geometry on arrays; nothing knows about opinions, planners or controllers.
Points are ``(..., 2)`` arrays in metres.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from nodnav.geometry import TOL, clearance_of, segment_clearance

#: Sides of the corridor, as returned by :meth:`World.side_of`.
LEFT, INSIDE, RIGHT = -1, 0, 1


def _read_only(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Corridor:
    """The single-file passage, an axis-aligned box."""

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
class World:
    """Free space ``E``: the box ``bounds`` minus the rectangles ``obstacles``, with one corridor.

    The corridor is the passage between the two entrances; it is what the passing order is about.
    Walls are given explicitly as ``obstacles`` so that a user can build other layouts.
    """

    bounds: tuple[float, float, float, float]
    """Outer boundary ``(x_min, y_min, x_max, y_max)`` (m); robots stay inside it."""
    obstacles: tuple[tuple[float, float, float, float], ...]
    """Axis-aligned wall rectangles ``(x_min, y_min, x_max, y_max)`` (m)."""
    corridor: Corridor
    """The single-file passage."""
    entrances: tuple[tuple[float, float], tuple[float, float]]
    """Left and right entrance points used by eqs. (6) and (10) (m); paper: (-3, 0) and (3, 0)."""

    @cached_property
    def obstacle_array(self) -> np.ndarray:
        """Walls as an ``(M, 4)`` array (read-only: computed once and shared)."""
        return _read_only(np.asarray(self.obstacles, dtype=float).reshape(-1, 4))

    @cached_property
    def bounds_array(self) -> np.ndarray:
        """The outer boundary as a ``(4,)`` array (read-only: computed once and shared)."""
        return _read_only(np.asarray(self.bounds, dtype=float))

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m) from each point to the nearest wall or boundary; negative inside a wall."""
        p = np.asarray(points, dtype=float)
        flat = np.ascontiguousarray(p.reshape(-1, 2))
        return clearance_of(flat, self.bounds_array, self.obstacle_array).reshape(p.shape[:-1])

    def segment_clearance(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Least clearance (m) along each segment ``a -> b`` (:func:`nodnav.geometry.segment_clearance`)."""
        return segment_clearance(self, a, b)

    def is_free(self, points: np.ndarray, radius: float | np.ndarray) -> np.ndarray:
        """Whether a disc of ``radius`` centred at each point lies in free space."""
        return self.clearance(points) >= np.asarray(radius) - TOL

    def side_of(self, points: np.ndarray) -> np.ndarray:
        """``LEFT`` (-1) left of the corridor, ``INSIDE`` (0) between the entrances, ``RIGHT`` (+1)."""
        x = np.asarray(points, dtype=float)[..., 0]
        return np.where(x < self.corridor.x_min, LEFT, np.where(x > self.corridor.x_max, RIGHT, INSIDE))

    def entrance_for(self, side: np.ndarray) -> np.ndarray:
        """The entrance a robot approaching from ``side`` (-1 or +1) uses, shape ``(..., 2)``."""
        ent = np.asarray(self.entrances, dtype=float)
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
        x = p[..., 0]
        passed_entrance = np.where(side > 0, x <= self.corridor.x_max, x >= self.corridor.x_min)
        not_exited = (x >= self.corridor.x_min) & (x <= self.corridor.x_max)
        return np.where(passed_entrance & not_exited, 0.0, dist)

    def in_corridor(self, points: np.ndarray) -> np.ndarray:
        """Whether each point is between the entrances (inside the single-file passage)."""
        return self.side_of(points) == INSIDE


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
    side) go straight. Used to measure progress, not to plan.
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
