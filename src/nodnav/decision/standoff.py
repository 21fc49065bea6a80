"""Standoffs: two robots that each wait for the other (not in the paper).

Eq. (4) reads a robot's intention from how it moves. A robot that stands still looks like a robot
that yields, so two robots that each want to go first, and each wait for the other to get out of
the way, each read the other as yielding and stay as they are: the symmetric trap the paper's
Fig. 2c shows as alternation. Nothing either of them observes breaks the symmetry, except what the
paper already has every robot share: the robot numbering in which strategies are written.

The convention: when a robot and one of its game players both made no progress over the last
period, although the robot's selected plan had one of them progress, the two are in a standoff
(:func:`standoff_partner`): each waits for the other ("you first", "no, you first"), or each
wants to go and neither gives way. Once that has lasted ``patience``, the lower-numbered robot of
the pair goes first. Both robots of a standoff see it alike, so both apply the convention; a
robot whose plan has both of them wait (for a third robot) is never in a standoff.

Progress over a period is judged against the best each robot reached over the patience
(:func:`progress_beyond_best`, ``opinion.standoff_progress: best``): two robots that both press and
both back off in turn, each period, each a few decimetres (the alternation of Fig. 2c, carried out
by the motion), get nowhere, although every other period each came closer than at the start of
that period. Judged period by period (``period``, as before) they "progressed" every other period
and the standoff was never seen (docs/sight-standoffs.md).
"""

from __future__ import annotations

import numpy as np

#: A robot that came less than this closer to its destination over a period (m) made no progress;
#: one whose plan took it more than twice as far wanted to.
STALL_DISTANCE = 0.1


def progress_beyond_best(to_go_now: np.ndarray, to_go_before: np.ndarray | list[np.ndarray]) -> np.ndarray:
    """How much closer to its destination each robot is now than the closest it was over the span
    before (m; negative: farther). ``to_go_now`` ``(n,)`` is each robot's distance to go now,
    ``to_go_before`` ``(S, n)`` (or a list of its S rows) its distances to go at S earlier times
    (the start of the last period among them). With the start of the last period alone this is
    the progress over the period; a robot that backs off and comes back to where it was has made
    none.
    """
    if isinstance(to_go_before, list):  # rows given apart: their minimum row by row (min is exact)
        best = np.asarray(to_go_before[0], dtype=float)
        for row in to_go_before[1:]:
            best = np.minimum(best, row)
        return best - np.asarray(to_go_now, dtype=float)
    before = np.atleast_2d(np.asarray(to_go_before, dtype=float))
    return before.min(axis=0) - np.asarray(to_go_now, dtype=float)


def standoff_partner(own_progress: float, players_progress: np.ndarray, own_planned: float,
                     players_planned: np.ndarray, stall: float = STALL_DISTANCE,
                     players_distance: np.ndarray | None = None,
                     players_arrived: np.ndarray | None = None) -> int:
    """The game player (an index into the players' arrays) a robot is in a standoff with, or -1.

    Progress is how much closer to its destination (along its way through the corridor) a robot
    came over the last period (m): the robot's own and each game player's as observed, and as
    the robot's selected joint plan had them (``own_planned``, ``players_planned``). A standoff
    with a player: neither progressed (less than ``stall``: a robot that jostles in a jam gets
    nowhere), although the plan had one of the two progress (more than ``2 stall``): the robot
    wanted to go and did not, or expected the player to go and it did not. Among several, the
    player the plan had progress most, and among those the nearest (``players_distance``, m: the
    robot in the way, not one standing elsewhere). A player that has arrived
    (``players_arrived``) wants to go nowhere and is in no standoff: with a robot that wanted to
    go, every stalled player ties on the robot's own planned progress, and a robot standing at
    its destination would otherwise be picked, the convention applied to it (which changes
    nothing), and the real partner never given way to.
    """
    players_progress = np.asarray(players_progress, dtype=float)
    players_planned = np.asarray(players_planned, dtype=float)
    if own_progress >= stall or not len(players_progress):
        return -1
    expected = np.maximum(players_planned, own_planned)
    stalled = (players_progress < stall) & (expected > 2.0 * stall)
    if players_arrived is not None:
        stalled &= ~np.asarray(players_arrived, dtype=bool)
    candidates = np.flatnonzero(stalled)
    if not len(candidates):
        return -1
    distance = np.zeros(len(players_progress)) if players_distance is None else np.asarray(players_distance, float)
    best = candidates[np.lexsort((distance[candidates], -expected[candidates]))]
    return int(best[0])
