"""Deferred parking: a robot whose parking would block the robots after it waits aside first.

In a prioritised plan a robot parks at its destination as soon as it arrives, and a robot planned
after it whose way runs past that destination is then blocked for good. The fast planner
(:mod:`nodnav.planning.prioritized`) detects that (:meth:`DeferredParking._blockers`) and plans the
order again with the blocking robot sent to a holding spot in its destination's room, clear of the
ways of the robots after it (:meth:`DeferredParking._deferring`); once everybody is planned, it
drives on from there to park when the way is free (:meth:`DeferredParking._park`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from nodnav.geometry import TOL
from nodnav.planning.fast_state import FastPlannerHooks, RobotPlan, State, timed_motion
from nodnav.planning.occupancy import join_motions
from nodnav.planning.polylines import polyline_point_distance
from nodnav.planning.waiting_spots import in_door_zone, ring_spots
from nodnav.scenario.world import World


class DeferredParking(FastPlannerHooks):
    """Robots that wait aside before they park (a mixin of
    :class:`~nodnav.planning.prioritized.PrioritizedPlanner`)."""

    def _blockers(self, world: World, state: State, earlier: tuple, k: int, start: np.ndarray) -> frozenset:
        """The robots of ``earlier`` whose destination lies on robot ``k``'s way among the walls
        from ``start`` (where it stands, or where it got out of the way to), closer to it than
        their required distance: parked there, they block it for good."""
        if not earlier:
            return frozenset()
        way = self.graph(world, state.radii[k]).shortest_paths(start[None], state.destinations[k][None])[0]
        dest = state.destinations[list(earlier)]
        near = polyline_point_distance(way.points, dest) < state.required[k, list(earlier)] - TOL
        return frozenset(int(i) for i in np.asarray(earlier)[near])

    def _deferring(self, world: World, state: State, planned: tuple, deferred: frozenset) -> State | None:
        """The state with each robot of ``deferred`` going to a holding spot instead of its
        destination: the spot (on rings around its destination, or where it stands now) nearest its
        destination that keeps the required distance from the
        ways (among the walls) of the robots after it in ``planned``, from where every other robot
        stands and parks, and from the other holding spots, out of the corridor and of both door
        zones, in the room of its destination (so that it has passed the corridor where the order
        says), and from which its destination stays in reach once the others have parked; ``None``
        if a robot has no such spot (one that parks in the corridor has none).
        """
        goals = state.destinations.copy()
        for i in sorted(deferred, key=planned.index):
            later = list(planned[planned.index(i) + 1:])
            others = [m for m in range(len(goals)) if m != i]
            graph = self.graph(world, state.radii[i])
            # Where it stands now is a candidate too: a robot already waiting aside need not move.
            rings = ring_spots(state.destinations[i], self.params.retreat_radii, self.params.retreat_angles,
                                  world.passage.angle)
            spots = np.vstack([state.positions[i][None], rings])
            ok = (world.clearance(spots) >= graph.clearance - TOL) & (world.side_of(spots) == world.side_of(goals[i]))
            ok &= ~world.in_corridor(spots)
            door = self.params.door_clearance
            ok &= ~in_door_zone(world, spots, 0, door) & ~in_door_zone(world, spots, 1, door)
            req = state.required[i]
            for m in others:
                ok &= np.hypot(*(spots - goals[m]).T) >= req[m] - TOL
                ok &= np.hypot(*(spots - state.positions[m]).T) >= req[m] - TOL
            for m in later:
                ok &= polyline_point_distance(state.natural[m], spots) >= req[m] - TOL
            spots = spots[ok][np.argsort(np.hypot(*(spots[ok] - state.destinations[i]).T), kind="stable")]
            ways = graph.shortest_paths(np.repeat(state.positions[i][None], len(spots), 0), spots)
            # From the spot, its destination must stay in reach once everybody else has parked.
            parked, rads = goals[others], req[others]
            for spot in (spots[q] for q, way in enumerate(ways) if way.success):
                if graph.shortest_path(spot, state.destinations[i], parked, rads).success:
                    goals[i] = spot
                    break
            else:
                return None
        return self._state(world, state.positions, goals, state.radii, state.max_speeds, planned, state.velocities,
                           state.accels)

    def _park(self, world: World, state: State, k: int, plans: dict) -> RobotPlan | None:
        """Robot ``k``'s plan to its holding spot, then on to its destination once every other
        robot's planned motion leaves the way free (None if it never does)."""
        head = plans[k].motion
        others = [j for j in plans if j != k]
        centres = np.array([plans[j].motion.samples[-1] for j in others]).reshape(-1, 2)
        track = self._track(world, state.radii[k], state.max_speeds[k] * self.params.dt, head.samples[-1],
                            state.destinations[k], centres, state.required[k, others], 0)
        if not track.route.path.success:
            return None
        timing = self._timing(state, k, track, [(j, plans[j].motion) for j in others], (), head.last_step)
        if not timing.success:
            return None
        tail = timed_motion(track, timing)
        return replace(plans[k], motion=join_motions(head, tail))
