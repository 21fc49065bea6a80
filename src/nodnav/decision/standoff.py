"""Standoffs: two robots that each wait for the other (not in the paper).

Eq. (4) reads a robot's intention from how it moves. A robot that stands still looks like a robot
that yields, so two robots that each want to go first, and each wait for the other to get out of
the way, each read the other as yielding and stay as they are: the symmetric trap the paper's
Fig. 2c shows as alternation. Nothing either of them observes breaks the symmetry, except what the
paper already has every robot share: the robot numbering in which strategies are written.

The convention: a robot that wanted to move over the last period, did not, and stands close to a
game player that did not move either, is in a standoff with it; once that has lasted ``patience``
periods, the lower-numbered robot of the pair goes first. Both robots of a standoff see it alike,
so both apply the convention; a robot that only waits as its plan says never counts as stalled.
"""

from __future__ import annotations

import numpy as np

#: A robot that came less than this closer to its destination over a period (m) made no progress;
#: one whose plan took it more than twice as far wanted to.
STALL_DISTANCE = 0.1
#: A player farther than this from the robot, surface to surface (m), is not what holds it up.
REACH = 1.0


def standoff_partner(own_progress: float, planned_progress: float, players_progress: np.ndarray,
                     players_clearance: np.ndarray, reach: float = REACH, stall: float = STALL_DISTANCE) -> int:
    """The game player (an index into the players' arrays) a robot is in a standoff with, or -1.

    Progress is how much closer to its destination (along its way through the corridor) a robot
    came over the last period (m): the robot's own, what its selected plan gave it, and each game
    player's; ``players_clearance`` is each player's distance from the robot, surface to surface
    (m). A standoff: the robot wanted to progress (planned more than ``2 stall``) but did not
    (less than ``stall``: a robot that jostles in a jam gets nowhere), and a player that made no
    progress either stands within ``reach`` of it; the nearest such player.
    """
    if own_progress >= stall or planned_progress <= 2.0 * stall or not len(players_progress):
        return -1
    clearance = np.asarray(players_clearance, dtype=float)
    candidates = np.flatnonzero((np.asarray(players_progress) < stall) & (clearance < reach))
    if not len(candidates):
        return -1
    return int(candidates[np.argmin(clearance[candidates])])
