"""Solvable in principle with a back-out: the witness of :mod:`nodnav.scenario.validity` learns
that robots inside the passage may first get off the line (issue 19, item 6).

The serial witness (:func:`~nodnav.scenario.validity.find_witness`) has every robot cross while
the others stand still. Robots inside heading opposite ways would have to pass each other, so it
finds no schedule and such scenarios were left out. Robots can do better, and the planner now
does (docs/meet-inside.md): one side yields. So before the witness, one *team* (every robot
inside heading one way) gets off the line, one robot at a time, the robot nearest the mouth
behind it first: each moves, among the walls and the others standing still, to the nearest
reachable place off the line: back out of the passage into the room behind it (clear of that
room's mouth zone, as the witness's step aside), or into a bay (a place between the mouths
beside the passage, its disc clear of the line). Then the witness runs from where everybody
waits. Either team may yield; the scenario is solvable in principle if either way leads to a
witness. Checked on the same grid, with the same clearances, as the witness.

Bays are the walls' own: a world made by :func:`~nodnav.scenario.bay_walls.with_bay` (a niche
cut into one wall of the passage) is a two-room world with a bay
(:func:`~nodnav.scenario.bay_walls.without_bays` gives back the plain layout that
:func:`~nodnav.scenario.validity.is_two_room_world` recognises).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from nodnav.scenario.schema import Scenario
from nodnav.scenario.validity import (
    CLEARANCE,
    WITNESS_BUDGET,
    Verdict,
    _Grid,
    _OutOfBudget,
    _sides,
    find_witness,
    mouth_zone_radius,
)
from nodnav.scenario.world import INSIDE, LEFT


def _off_line(scenario: Scenario, k: int, waiting: np.ndarray, grid: _Grid) -> np.ndarray | None:
    """Where robot ``k`` (inside) gets off the line: the nearest reachable place in the room behind
    it clear of the mouth zone, or in a bay; ``None`` if there is none."""
    world, r = scenario.world, float(scenario.radii[k])
    c = world.shorthand
    behind = -int(_sides(world, scenario)[1][k])  # the room it came from: away from its goal
    mouth = np.array([c.x_min if behind == LEFT else c.x_max, 0.0])
    rho = mouth_zone_radius(c.y_max, float(scenario.radii.max()))
    others = [(waiting[j], float(scenario.radii[j])) for j in range(len(waiting)) if j != k]
    reach = grid.component(grid.free(r, others), waiting[k])
    pts = grid.points
    room = (behind * (pts[..., 0] - mouth[0]) >= r + CLEARANCE) & (np.linalg.norm(pts - mouth, axis=-1) >= rho + r)
    bay = (pts[..., 0] > c.x_min) & (pts[..., 0] < c.x_max) & (np.abs(pts[..., 1]) >= c.y_max + r + CLEARANCE)
    ok = reach & (room | bay) & grid.free(r, others, CLEARANCE)
    if not ok.any():
        return None
    d = np.linalg.norm(pts[ok] - waiting[k], axis=-1)
    return pts[ok][int(np.argmin(d))]


def find_witness_backing_out(scenario: Scenario, budget: int = WITNESS_BUDGET) -> Verdict:
    """The witness after one team inside gets off the line (the module docstring), or why not."""
    world = scenario.world
    start, goal = _sides(world, scenario)
    inside = [k for k in range(scenario.n_robots) if start[k] == INSIDE]
    if not {int(goal[k]) for k in inside} >= {-1, 1}:
        return Verdict(False, "no robots inside heading opposite ways, so nobody needs to back out")
    grid = _Grid(world)
    reasons = []
    for team in (1, -1):  # the robots inside heading this way yield
        yielding = sorted((k for k in inside if goal[k] == team), key=lambda k: team * scenario.origins[k][0])
        waiting = scenario.origins.copy()
        moves = []
        for k in yielding:  # the one nearest the mouth behind it first
            spot = _off_line(scenario, k, waiting, grid)
            if spot is None:
                break
            waiting[k] = spot
            moves.append((int(k), (float(spot[0]), float(spot[1]))))
        else:
            moved = dataclasses.replace(scenario, robots=tuple(
                dataclasses.replace(robot, origin=(float(p[0]), float(p[1])))
                for robot, p in zip(scenario.robots, waiting)))
            try:
                verdict = find_witness(moved, budget)
            except _OutOfBudget:
                verdict = Verdict(False, f"no crossing schedule found within {budget} connectivity checks")
            if verdict.ok:
                return dataclasses.replace(verdict, waits=tuple(moves) + verdict.waits)
            reasons.append(verdict.reason)
            continue
        reasons.append(f"robot {k + 1} has nowhere off the line to back out to")
    return Verdict(False, f"no schedule with either side backing out ({reasons[-1]})")
