"""Robots done with the corridor that join a robot's planning: those packed round a destination.

With ``opinion.nonplayers: entered`` a robot plans, besides its game players, the robots it sees
inside the corridor. Robots that have crossed (parked at their destinations, or on their way to
park) were left to the MPC alone, and in crowds that left a late robot blind: its destination
lies among robots parked at theirs, its game holds two of them, and its plan runs through the gap
the third one closes; when the game changes with its position, the plan runs through another gap
closed by another one, and it loops for ever (docs/execution.md, "Parked robots making way in
crowds"). With ``opinion.crossed: planned`` the crossed robots packed round the destination of a
robot of the plan join the planning too, at the front of the order, where history has put them:
the planner then routes round them, or has those that close off the destination wait aside and
park again afterwards (:mod:`nodnav.planning.parking`, :mod:`nodnav.planning.making_way`).
"""

from __future__ import annotations

import numpy as np

from nodnav.planning.base import crossing_directions
from nodnav.scenario.world import World


def packed_crossed(world: World, positions: np.ndarray, destinations: np.ndarray, radii: np.ndarray,
                   known: np.ndarray, planning: list[int], goal_tolerance: float, margin: float) -> list[int]:
    """The robots not in ``planning`` that join it: every robot seen (``known`` ``(N,)``, a mask)
    that has crossed (outside the corridor, on its destination's side) and stands packed round the
    destination of a robot that has not arrived (farther than ``goal_tolerance`` from it), where
    that robot plans with this one or the robots packed round its destination include one of
    ``planning``; with that robot, if it has crossed too. Packed: closer to the destination than
    leaves its robot a way in (its diameter and twice the planner's ``margin`` between the bodies),
    or, in turn, that close to a robot already packed round it. Increasing index."""
    crossed = known & (crossing_directions(world, positions, destinations) == 0) & ~world.in_corridor(positions)
    mine = np.zeros(len(positions), dtype=bool)
    mine[planning] = True
    arriving = np.linalg.norm(positions - destinations, axis=1) > goal_tolerance
    joining = np.zeros(len(positions), dtype=bool)
    for k in np.flatnonzero(arriving & (mine | crossed)):
        way = 2.0 * radii[k] + 2.0 * margin  # the room robot k needs between two bodies
        packed = np.zeros(len(positions), dtype=bool)
        # Round its destination first, then round each robot found, until nobody new is found.
        centres, reach = destinations[k][None], np.array([radii[k]])
        while True:
            gaps = np.linalg.norm(positions[:, None] - centres[None], axis=2) - radii[:, None] - reach[None]
            new = crossed & ~packed & (gaps < way).any(axis=1)
            new[k] = False
            if not new.any():
                break
            packed |= new
            centres, reach = positions[new], radii[new]
        if mine[k] or (packed & mine).any():
            joining |= packed
            joining[k] = True
    return np.flatnonzero(joining & ~mine).tolist()
