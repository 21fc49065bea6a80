"""Head-on crowds at the paper's doors, built by one rule for any number of robots.

The scaling benchmark (``nodnav bench scaling``) compares robot counts, so its scenarios differ
in nothing but the count: :func:`door_crowd` places ``N_r`` robots by a fixed rule in the
paper's world (corridor x in [-3, 3], 0.7 m wide, rooms 4 m deep and 5 m high; r = 0.2 m,
1 m/s, 2 m/s^2):

* ``ceil(N_r / 2)`` robots start in the left room and ``floor(N_r / 2)`` in the right one
  (head-on; the extra robot of an odd count on the left);
* at each door they stand in rows parallel to the wall, row ``j`` with its centres
  ``0.6 + 0.75 j`` m from the wall: two abreast at y = +-0.45 m (the mouth is 0.7 m wide, so
  both are beside it, neither in it), and a robot left over on the corridor's axis in the last row;
* destinations lie on a line 3 m into the far room, spread evenly over y in [-1.8, 1.8] m
  (y = 0 for a single robot), matched top to bottom so that paths do not cross in the room;
* the time limit is the generated families' rule (:func:`~nodnav.scenario.layout.time_limit`).

Every count from 2 to :data:`~nodnav.scenario.limits.MAX_ROBOTS` gives a valid scenario that is
solvable in principle (:func:`~nodnav.scenario.solvable.check_scenario`; a test checks it).
"""

from __future__ import annotations

import math

import numpy as np

from nodnav.scenario.layout import time_limit
from nodnav.scenario.limits import MAX_ROBOTS
from nodnav.scenario.schema import Scenario, scenario_from_dict

#: Distance (m) of the first row's centres from the wall, and between rows.
FIRST_ROW, ROW_SPACING = 0.6, 0.75
#: Distance (m) of the two robots of a row from the corridor's axis.
ABREAST = 0.45
#: Depth (m) of the destinations' line in the far room, and how far (m) it spreads either way.
DESTINATION_DEPTH, DESTINATION_SPREAD = 3.0, 1.8
#: The paper's half corridor length (m) and robot radius (m).
HALF_LENGTH, RADIUS = 3.0, 0.2


def door_formation(count: int) -> np.ndarray:
    """Where ``count`` robots wait at a door, as ``(count, 2)`` (distance from the wall, y) in m."""
    spots = []
    for m in range(count):
        row, place = divmod(m, 2)
        alone = place == 0 and m == count - 1
        spots.append((FIRST_ROW + ROW_SPACING * row, 0.0 if alone else (ABREAST if place == 0 else -ABREAST)))
    return np.array(spots, dtype=float).reshape(-1, 2)


def destination_line(count: int) -> np.ndarray:
    """The ``count`` destinations' y (m) on their line, from the top down."""
    return np.linspace(DESTINATION_SPREAD, -DESTINATION_SPREAD, count) if count > 1 else np.zeros(count)


def _side(count: int, sign: int) -> list[dict]:
    """The robots of one room: ``sign`` -1 starts on the left and crosses right, +1 the reverse."""
    spots = door_formation(count)
    origins = np.column_stack([sign * (HALF_LENGTH + spots[:, 0]), spots[:, 1]])
    by_height = np.lexsort((np.abs(origins[:, 0]), -origins[:, 1]))  # top first; nearer the door first
    ys = destination_line(count)
    destinations = np.zeros_like(origins)
    destinations[by_height] = np.column_stack([np.full(count, -sign * (HALF_LENGTH + DESTINATION_DEPTH)), ys])
    return [{"origin": [round(float(x), 3), round(float(y), 3)],
             "destination": [round(float(a), 3), round(float(b), 3)]} for (x, y), (a, b) in zip(origins, destinations)]


def door_crowd(n_robots: int, game_players: int | str | None = None) -> Scenario:
    """The head-on crowd of ``n_robots`` (module docstring) with ``game_players`` per robot
    (a number or ``all``; by default 2, or 1 with two robots), named ``door-crowd-N``."""
    if not 2 <= n_robots <= MAX_ROBOTS:
        raise ValueError(f"door_crowd needs 2 to {MAX_ROBOTS} robots, got {n_robots}")
    left, right = math.ceil(n_robots / 2), n_robots // 2
    robots = _side(left, -1) + _side(right, +1)
    # Each route runs from the origin to its entrance, through the corridor, then to the destination.
    routes = [math.hypot(abs(r["origin"][0]) - HALF_LENGTH, r["origin"][1]) + 2 * HALF_LENGTH
              + math.hypot(abs(r["destination"][0]) - HALF_LENGTH, r["destination"][1]) for r in robots]
    return scenario_from_dict({
        "name": f"door-crowd-{n_robots}",
        "description": f"{left} against {right} robots crowding the paper's doors (nodnav.scenario.crowds)",
        "time_limit": time_limit(routes, [1.0] * n_robots, 2 * HALF_LENGTH, RADIUS),
        "game_players": min(2, n_robots - 1) if game_players is None else game_players,
        "robots": robots,
    })
