"""Robots done with the corridor that join a robot's planning: those packed round a destination.

With ``opinion.nonplayers: entered`` a robot plans, besides its game players, the robots it sees
inside the corridor. Robots that have crossed (parked at their destinations, or on their way to
park) were left to the MPC alone, and in crowds that left a late robot blind: its destination
lies among robots parked at theirs (or its way to the mouth runs past robots parked right outside
it), its game holds two of them, and its plan runs through the gap the third one closes; when the
game changes with its position, the plan runs through another gap closed by another one, and it
loops for ever (docs/execution.md, "Parked robots making way in crowds"). With
``opinion.crossed: planned`` the crossed robots packed round the way of a robot of the plan join
the planning too, at the front of the order, where history has put them:
the planner then routes round them, or has those that close off the destination wait aside and
park again afterwards (:mod:`nodnav.planning.parking`, :mod:`nodnav.planning.making_way`).
"""

from __future__ import annotations

import numpy as np

from nodnav.planning.base import crossing_directions
from nodnav.planning.polylines import polyline_point_distance
from nodnav.planning.visibility import VisibilityGraph
from nodnav.scenario.world import World


def packed_crossed(world: World, positions: np.ndarray, destinations: np.ndarray, radii: np.ndarray,
                   known: np.ndarray, planning: list[int], goal_tolerance: float, margin: float,
                   graphs: dict | None = None, packed_round: dict | None = None,
                   masks: tuple[np.ndarray, np.ndarray] | None = None) -> list[int]:
    """The robots not in ``planning`` that join it: every robot seen (``known`` ``(N,)``, a mask)
    that has crossed (outside the corridor, on its destination's side) and stands packed round the
    way of a robot that has not arrived (farther than ``goal_tolerance`` from its destination):
    its shortest path among the walls from where it stands to its destination. That robot is one
    of ``planning``, or has crossed too and the robots packed round its way include one of
    ``planning`` (then it joins as well). Packed: closer to the way than leaves its robot room to
    pass (its diameter and twice the planner's ``margin`` between the bodies), or, in turn, that
    close to a robot already packed round it. ``graphs`` caches visibility graphs by radius;
    ``packed_round`` (robot -> its packed robots) those found for the same arguments but
    ``planning``, which they do not read; ``masks``: :func:`crossed_and_arriving` of the same
    arguments, which does not read ``planning`` either. Increasing index."""
    graphs = {} if graphs is None else graphs
    if masks is None:
        masks = crossed_and_arriving(world, positions, destinations, known, goal_tolerance)
    crossed, arriving = masks
    mine = np.zeros(len(positions), dtype=bool)
    mine[planning] = True
    # Only crossed robots join (those packed round a way, and crossed robots whose way has one of
    # the plan packed round it), and what is packed is crossed: with no crossed robot outside the
    # plan nobody joins, and with no crossed robot in the plan no crossed robot's way matters.
    if not (crossed & ~mine).any():
        return []
    joining = np.zeros(len(positions), dtype=bool)
    packed_round = {} if packed_round is None else packed_round
    for k in np.flatnonzero(arriving & (mine | crossed) if (crossed & mine).any() else arriving & mine):
        packed = packed_round.get(int(k))
        if packed is None:
            packed = packed_round[int(k)] = _packed_round(world, positions, destinations, radii, crossed, int(k),
                                                          margin, graphs)
        if mine[k] or (packed & mine).any():
            joining |= packed
            joining[k] = True
    return np.flatnonzero(joining & ~mine).tolist()


def crossed_and_arriving(world: World, positions: np.ndarray, destinations: np.ndarray, known: np.ndarray,
                         goal_tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """The robots of :func:`packed_crossed` seen to have crossed, and those that have not
    arrived, ``(N,)`` masks each."""
    crossed = known & (crossing_directions(world, positions, destinations) == 0) & ~world.in_corridor(positions)
    arriving = np.linalg.norm(positions - destinations, axis=1) > goal_tolerance
    return crossed, arriving


def _packed_round(world: World, positions: np.ndarray, destinations: np.ndarray, radii: np.ndarray,
                  crossed: np.ndarray, k: int, margin: float, graphs: dict) -> np.ndarray:
    """The ``crossed`` robots packed round robot ``k``'s way (:func:`packed_crossed`), ``(N,)``."""
    if not (crossed.sum() - crossed[k]):  # nobody else has crossed: nobody to find, no way to search
        return np.zeros(len(positions), dtype=bool)
    way = 2.0 * radii[k] + 2.0 * margin  # the room robot k needs between two bodies
    key = (world, float(radii[k]))
    graph = graphs.get(key)
    if graph is None:
        graph = graphs[key] = VisibilityGraph(world, float(radii[k]))
    path = graph.shortest_path(positions[k], destinations[k])
    line = path.points if path.success else np.array([positions[k], destinations[k]])
    # Round its way first, then round each robot found, until nobody new is found.
    gaps = polyline_point_distance(line, positions) - radii - radii[k]
    packed = np.zeros(len(positions), dtype=bool)
    new = crossed & (gaps < way)
    new[k] = False
    while new.any():
        packed |= new
        centres, reach = positions[new], radii[new]
        gaps = np.linalg.norm(positions[:, None] - centres[None], axis=2) - radii[:, None] - reach[None]
        new = crossed & ~packed & (gaps < way).any(axis=1)
        new[k] = False
    return packed
