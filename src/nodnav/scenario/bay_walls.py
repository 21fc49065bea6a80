"""Bays cut into the walls of a two-room world: a niche one robot fits into beside the passage.

Pure geometry of the families' worlds (:func:`~nodnav.scenario.world.corridor_world`): the
drawing of robots meeting inside (:mod:`nodnav.scenario.meeting`) cuts bays, and the checks of
:mod:`nodnav.scenario.validity` and :mod:`nodnav.scenario.backing_out` see through them.
"""

from __future__ import annotations

import dataclasses

from nodnav.scenario.world import World


def with_bay(obstacles: list, h: float, half: float, x0: float, x1: float, depth: float, upper: bool) -> list:
    """The two walls ``obstacles`` (``[lower, upper]`` boxes of a passage from ``-h`` to ``h``,
    ``half`` wide each side) with a niche from ``x0`` to ``x1``, ``depth`` deep, cut into the upper
    (``upper``) or lower wall: that wall becomes three boxes."""
    lower_box, upper_box = (list(b) for b in obstacles)
    if upper:
        y1 = upper_box[3]
        cut = [[-h, half, x0, y1], [x1, half, h, y1], [x0, half + depth, x1, y1]]
        return [lower_box] + cut
    y0 = lower_box[1]
    cut = [[-h, y0, x0, -half], [x1, y0, h, -half], [x0, y0, x1, -half - depth]]
    return cut + [upper_box]


def without_bays(world: World) -> World:
    """``world`` with every niche of :func:`with_bay` filled in again (unchanged if it has none)."""
    obstacles = list(world.obstacles)
    if len(obstacles) != 4:
        return world
    c = world.shorthand
    walls: list[tuple[float, float, float, float]] = []
    for side in (-1, 1):
        edge = c.y_min if side < 0 else c.y_max
        pieces = [b for b in obstacles if (b[3] <= c.y_min + 1e-12 if side < 0 else b[1] >= c.y_max - 1e-12)]
        if len(pieces) == 1:
            walls.append(pieces[0])
            continue
        if len(pieces) != 3:
            return world
        x0, x1 = min(b[0] for b in pieces), max(b[2] for b in pieces)
        far = min(b[1] for b in pieces) if side < 0 else max(b[3] for b in pieces)
        walls.append((x0, far, x1, edge) if side < 0 else (x0, edge, x1, far))
    return dataclasses.replace(world, obstacles=tuple(walls))
