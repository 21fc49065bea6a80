"""Where a robot may wait: candidate waiting spots and the door zones a waiting robot keeps out of.

Every planner part that sends a robot somewhere to wait draws its candidates here and filters
them with its own rules (clear of the walls, of the passage, of the others and their ways):

* :func:`ring_spots`: rings of spots around a point, nearest ring first (the fast planner's
  retreats and holding spots, ``retreat_radii``/``retreat_angles``; the recovery of a failed plan,
  ``clearing_radii``/``clearing_directions``);
* :func:`grid_spots`: a grid of :data:`FINE_GRID` over the whole world, tried by the fast planner
  when no spot of the rings will do (the rings' directions are far apart at large radii);
* :func:`bay_spots`: one spot per bay beside the passage (below);
* :func:`in_door_zone`: the door zone of an entrance, the disc of the planner's
  ``door_clearance`` around it (open: a point at exactly that distance is out of it). Robots
  waiting for their turn wait out of it, so that the robot coming out has room;
* :func:`nearest_ways`: the ways to the spots that are shortest, found without computing the
  ways to the spots far off.

Bays (issue 19) are places beside a single-file passage where one robot fits off the line.

A passage is single file: two robots cannot pass each other in it. A real corridor often has
places where one can step aside (a niche, a doorway off the corridor). Bays are found from the
walls, not declared: walking along the passage, a spot at across-offset ``t`` beyond the line
(``|t - t_centre| >= width / 2 + radius``: the robot's whole disc is off the line) whose
clearance from the walls admits the robot is a bay spot; the spots of one run along the passage
form one bay, represented by the spot in the middle of the run as deep off the line as the
robot fits (up to ``BAY_DEPTH``): a passing robot keeps the most room. The fast planner offers bay
spots as waiting spots to robots that must get out of another's way
(:meth:`~nodnav.planning.making_way.MakingWay._waiting_spots`), beside the spots outside the
passage: the nearest reachable spot is taken, so a robot ducks into a bay where that is shorter
than backing out. A bay is never a second lane: it is only ever a place to wait in (every
robot's path through the passage follows the line, and the corridor rule treats the line alone
as the passage), and a waiting spot keeps the full separation from every other robot's, so one
robot waits in a bay at a time.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from nodnav.geometry import TOL
from nodnav.scenario.world import World

if TYPE_CHECKING:
    from nodnav.planning.visibility import GeometricPath, VisibilityGraph

#: Spacing of the fine grid of waiting spots tried when no spot of the rings will do (m).
FINE_GRID = 0.25
#: Sampling step along and across the passage when looking for bays (m).
BAY_STEP = 0.05
#: How far beside the line a bay spot may lie (m): deeper than this is a room, not a bay.
BAY_DEPTH = 1.5
#: How much shorter than the straight line a way's length may read from rounding, relative and
#: absolute (m): far more than the few units in the last place a sum of a few segments can lose.
ROUNDING = 1e-9


def ring_spots(centre: np.ndarray, radii: tuple[float, ...], directions: int, turn: float = 0.0) -> np.ndarray:
    """Candidate spots: rings of ``radii`` (m) around ``centre`` with ``directions`` spots each,
    nearest ring first, the first of each ring at angle ``turn`` (rad; the passage's,
    :attr:`Passage.angle`), ``(M, 2)``."""
    ring = unit_ring(directions, turn)
    return (np.asarray(centre, dtype=float)[None, None] + np.asarray(radii)[:, None, None] * ring[None]).reshape(-1, 2)


@lru_cache(maxsize=16)
def unit_ring(directions: int, turn: float = 0.0) -> np.ndarray:
    """``directions`` unit vectors evenly around the circle, the first at angle ``turn`` (rad),
    ``(directions, 2)`` (remembered, read-only: every ring of a planner has the same few)."""
    angles = 2.0 * np.pi * np.arange(directions) / directions
    if turn:
        angles = angles + turn
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    ring.setflags(write=False)
    return ring


def grid_spots(world: World, step: float = FINE_GRID) -> np.ndarray:
    """Candidate spots: a grid of ``step`` (m) over ``world``'s bounds, row by row, ``(M, 2)``."""
    x0, y0, x1, y1 = world.bounds
    xs, ys = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
    return np.stack([xs.ravel(), ys.ravel()], axis=1)


def in_door_zone(world: World, points: np.ndarray, entrance, radius: float) -> np.ndarray:
    """Which of ``points`` ``(M, 2)`` lie in the door zone of ``entrance`` (0 left, 1 right; or one
    entrance per point, an ``(M,)`` array): strictly nearer to it than ``radius`` (m, the
    planner's ``door_clearance``)."""
    e = np.asarray(world.entrances, dtype=float)[entrance]
    return np.hypot(points[:, 0] - e[..., 0], points[:, 1] - e[..., 1]) < radius


@lru_cache(maxsize=64)
def bay_spots(world: World, radius: float, clearance: float) -> np.ndarray:
    """One spot per bay of ``world``'s passage for a robot of ``radius`` that keeps ``clearance``
    (>= radius) from the walls, ``(M, 2)`` (see the module docstring)."""
    p = world.passage
    s = np.arange(p.s_start + radius, p.s_end - radius + BAY_STEP / 2, BAY_STEP)
    offsets = np.arange(0.5 * p.width + radius, 0.5 * p.width + BAY_DEPTH + BAY_STEP / 2, BAY_STEP)
    if not len(s) or not len(offsets):
        return np.zeros((0, 2))  # a passage too short for the robot to stand beside
    spots = []
    for sign in (1.0, -1.0):
        t = p.t_centre + sign * offsets
        grid = p.to_world(np.repeat(s[:, None], len(t), 1), np.repeat(t[None], len(s), 0))  # (S, T, 2)
        clear = world.clearance(grid.reshape(-1, 2)).reshape(len(s), len(t))
        ok = clear >= clearance - TOL
        # The nearest fitting offset at each place along the passage, if any.
        first = np.where(ok.any(axis=1), ok.argmax(axis=1), -1)
        run: list[int] = []
        for i in list(range(len(s))) + [-1]:
            if i >= 0 and first[i] >= 0:
                run.append(i)
                continue
            if run:  # the middle of the run, as deep off the line as the robot fits
                j = run[len(run) // 2]
                spots.append(grid[j, int(np.flatnonzero(ok[j])[-1])])
                run = []
    out = np.array(spots).reshape(-1, 2)
    out.setflags(write=False)  # remembered: shared by every caller
    return out


def nearest_ways(graph: VisibilityGraph, start: np.ndarray, spots: np.ndarray, count: int,
                 batch: int = 4) -> Iterator[tuple[int, GeometricPath]]:
    """The ``count`` shortest of ``graph``'s ways among the walls from ``start`` to ``spots``
    ``(M, 2)``, each with the index of its spot, shortest first, equal ones (and the failed ways,
    of infinite length) in the spots' order: what a stable sort of all ``M`` ways by length gives.

    Computed as they are asked for: no way is shorter than the straight line to its spot, so the
    ways are computed nearest spot (in a straight line) first, ``batch`` spots at a time (and any
    as near as the last of them: a ring's spots), and the shortest way computed is the next one
    once no spot left is as near in a straight line as it is long (less :data:`ROUNDING`); if
    one is, every such spot's way is computed first. A way does not depend on the batch it is
    computed in (:meth:`~nodnav.planning.visibility.VisibilityGraph.shortest_paths` answers each
    query on its own, and remembers the answers)."""
    start = np.asarray(start, dtype=float)
    n = len(spots)
    dx, dy = spots[:, 0] - start[0], spots[:, 1] - start[1]
    straight = np.sqrt(dx * dx + dy * dy)  # a straight way's length, exactly
    by_line = np.argsort(straight, kind="stable")
    line = straight[by_line]
    ways: dict[int, GeometricPath] = {}
    known: list[tuple[float, int]] = []  # (length, index) of the ways computed, not yet given
    done = given = 0
    while given < min(count, n):
        # The spots that could come before the shortest way known (or, knowing none, the next batch).
        limit = known[0][0] if known else float(line[min(done + batch, n) - 1])
        upto = int(np.searchsorted(line, limit * (1.0 + ROUNDING) + ROUNDING, side="right"))
        if upto > done:
            more = by_line[done:upto]
            for q, way in zip(more.tolist(), graph.shortest_paths(np.repeat(start[None], len(more), 0), spots[more])):
                ways[q] = way
                heapq.heappush(known, (way.length, q))
            done = upto
            continue
        q = heapq.heappop(known)[1]
        given += 1
        yield q, ways[q]
