"""What a robot does when no passing order can be planned: it clears the way.

A robot whose planner finds a joint path for none of its strategies has nothing to follow. Holding
its position (the planner's failed result) is the worst it can do where it stands in somebody's
way: a robot parked in a mouth keeps everyone else from planning too. So it moves, along the
shortest path among the walls, to the nearest spot from which it blocks nobody: out of the
corridor and of both door zones, and at the required distance from where every other robot stands
and from each one's way to its destination (among the walls). There it waits; at the next
decision it plans again from there. The result still says the plan failed, and why, so the
failure is counted and visible in the trial's events (``kind: plan``).

Planner-independent: it needs only the world and the robots' states, so every planner (and every
method built on one) gets the same recovery.
"""

from __future__ import annotations

import numpy as np

from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult
from nodnav.planning.polylines import arc_length_grid, polyline_point_distance
from nodnav.planning.visibility import VisibilityGraph
from nodnav.planning.waiting_spots import in_door_zone, ring_spots
from nodnav.scenario.params import PlannerParams


def clear_the_way(request: PlanRequest, robot: int, reason: str, settings: PlannerParams,
                  graphs: dict | None = None) -> PlanResult:
    """A failed plan in which robot ``robot`` of ``request`` moves out of everybody's way and waits
    while the others hold still (see the module docstring); a plain failure (everyone holding) when
    it already stands clear or no spot can be reached. ``settings``: the planner's ``door_clearance``,
    ``margin``, ``dt``, ``clearing_radii`` and ``clearing_directions``; ``graphs`` caches visibility
    graphs by radius."""
    door_clearance, margin, dt = settings.door_clearance, settings.margin, settings.dt
    world = request.world
    pos = np.asarray(request.positions, dtype=float)
    dest = np.asarray(request.destinations, dtype=float)
    radii = np.asarray(request.radii, dtype=float)
    me, r = pos[robot], float(radii[robot])
    graphs = {} if graphs is None else graphs
    graph = graphs.setdefault((world, r), VisibilityGraph(world, r))
    others = [k for k in range(len(pos)) if k != robot]
    need = radii[others] + r + margin
    ways = [graphs.setdefault((world, float(radii[k])), VisibilityGraph(world, float(radii[k])))
            .shortest_paths(pos[k][None], dest[k][None])[0].points for k in others]

    def clear(points: np.ndarray) -> np.ndarray:
        ok = (world.clearance(points) >= r) & ~world.in_corridor(points)
        ok &= ~in_door_zone(world, points, 0, door_clearance) & ~in_door_zone(world, points, 1, door_clearance)
        for k, way, d in zip(others, ways, need):
            ok &= np.linalg.norm(points - pos[k], axis=1) >= d
            ok &= polyline_point_distance(way, points) >= d
        return ok

    failure = PlanResult.failure(request, reason)
    if clear(me[None])[0]:
        return failure  # already out of everybody's way: wait here
    spots = ring_spots(me, settings.clearing_radii, settings.clearing_directions, world.passage.angle)
    spots = spots[clear(spots)]
    for spot in spots:
        way = graph.shortest_path(me, spot, pos[others], radii[others] + r)
        if not way.success:
            continue
        cells = arc_length_grid(way.points, float(request.max_speeds[robot]) * dt).points
        steps = len(cells)
        positions = np.repeat(pos[None], steps, axis=0)
        positions[:, robot] = cells
        trajectory = JointTrajectory.from_positions(request.t0 + dt * np.arange(steps), positions)
        where = f"({spot[0]:.2f}, {spot[1]:.2f})"
        return PlanResult(False, f"{reason}; clearing the way to {where}", float("inf"), trajectory,
                          failure.order, failure.order_planned, 0.0, {"clearing_spot": spot})
    return failure
