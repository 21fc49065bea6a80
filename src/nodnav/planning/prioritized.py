"""The fast planner: prioritised planning in the passing order with path-velocity decomposition.

The paper plans the joint path of all robots with PRM* in the joint space (appendix); any
planner that returns collision-free joint paths respecting a passing order serves the framework
(Section IV-A-2: "the specific choice of the planner has minimal impact"). This one needs no
precomputation and is fast enough for the closed loop to ask for every strategy of every robot
at every decision step: a few milliseconds for four robots from a new state, and much less for
the further orders asked from the same state (see "Reuse" below).

How a query is answered
-----------------------
1. Orders ruled out by history are repaired with :func:`~nodnav.planning.base.feasible_order`.
   Robots standing inside the corridor count as entered even when the request does not list
   them (appended in the requested order), since their entry has physically happened.
2. Robots are planned one by one in the (planned) passing order; each one moves along its own
   geometric path and chooses only its timing, treating the robots planned before it as moving
   obstacles (path-velocity decomposition).
3. Geometric path (:mod:`nodnav.planning.geometric_paths`): the shortest collision-free
   polyline (:class:`VisibilityGraph`) around the
   walls, around where the robots after it in the order stand (so that every later robot can
   always wait there), and around the destinations of the robots before it (where they will
   park for good). A robot that starts closer than required to one of these may move away but
   not closer (:func:`~nodnav.planning.visibility.disc_violations`). When that is impossible the
   robot falls back to avoiding the destinations only, then the walls only; the timing step
   then decides.
4. Timing: the path is cut into cells of at most ``v_max dt / 2``; per time step the robot waits,
   advances one cell, or advances two (full speed; only where the straight chord between the
   two cells keeps clear of walls). The set of cells reachable at each step is a bitset of
   64-bit words, ``reach[t+1] = (reach[t] | reach[t] << 1 | (reach[t] & ok2) << 2) & free[t+1]``,
   which makes the search exact and fast (compiled with numba); ``free[t]`` removes every cell
   closer than the required separation to an earlier robot during ``[t, t+1]`` and every cell
   the corridor and door rules (below) close at that step. The robot arrives at the first step at which its
   destination is reachable and stays free for good. Among the equally fast timings it waits
   early (holds back, then drives through), which makes its intention legible to the others'
   eq. (4), or, with ``waiting: late``, drives up and waits late (:func:`earliest_arrival_bits`).
   With ``timing: feasible`` (the default) and the robots' acceleration limits in the request,
   those cells are then retimed within the robot's acceleration limit from its present speed,
   never ahead of them, and the retimed motion is checked against the same free cells
   (:func:`~nodnav.planning.retiming.retimed`); it is what the robots after it are planned
   around, what the controller tracks and what eq. (4) compares with (docs/safety.md).
5. Getting out of the way. Before a robot is planned, every robot after it that stands in its
   way (its path had to ignore them) or in the door zone it will come out of (below) first
   moves to a nearby spot clear of the ways of every robot still to plan, waits there, and
   later goes on from there; the robot being planned waits until the way is free. A robot
   that is itself boxed in first has the robots in its way move (up to ``planner.cascade`` deep),
   and one pinned where only the planned robot's own place would let it out gets that room:
   the planned robot backs off first. Finally a robot that an earlier robot's motion corners
   anyway backs out of the way when its turn comes.

Separation: :func:`separation_requirements` between every pair, relaxed to a hair below their
present distance for a pair that starts closer (:func:`relaxed_separation`): they may stay or
move apart, and the full separation holds again once the earlier robot's motion keeps it from
where the later one started for good.

Corridor rule (single file): a robot may enter the corridor only after every robot before it in
the order that uses the corridor has entered (same direction: following at a safe distance is
fine) and, for opposite directions, only after that robot has left it. Entry and exit are judged
on the samples with :meth:`World.in_corridor`, exactly as :func:`corridor_entry_order` does.

Door rule: the door zone of an entrance is the disc of radius ``door_clearance`` around it. A
crossing robot does not enter the door zone of the entrance it uses while a robot before it
that does not go its way (one coming out towards it) has not left that zone for good (or
parked in it), so that robots waiting for their turn wait clear of the door and the robot
coming out has room. Same-direction following is untouched by it.

Cost: the sum over robots of their arrival times, in seconds after the request's time.

Reuse
-----
A robot's plan depends only on the state (positions, destinations, radii, speeds), on which
robots go before it and on the set of robots after it, so a planner instance remembers, in
bounded memos, the order-independent part of each state, each robot's plan per beginning of
the order, the joint plan of each (repaired) order, each prepared geometric path, and the cells
each path has closed by each planned motion; the closed loop asks for all ``N_r!`` orders from
one state, orders that share a beginning share those plans, and orders repaired to the same one
share its joint plan (whose arrays are therefore read-only). Results do not depend on what is
remembered. Share one instance between the robots of a trial to benefit from it.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np

from nodnav.planning.base import JointTrajectory, PlanRequest, PlanResult, crossing_directions, feasible_order
from nodnav.planning.disc_checks import disc_violations
from nodnav.planning.fast_state import (
    Attempt,
    Cut,
    Joint,
    Layout,
    RobotPlan,
    State,
    Track,
    joint_arrays,
    reject_request,
    state_problem,
)
from nodnav.planning.geometric_paths import GeometricPaths
from nodnav.planning.making_way import MakingWay
from nodnav.planning.memo import remember, remember_briefly
from nodnav.planning.occupancy import Motion, separation_requirements
from nodnav.planning.parking import DeferredParking
from nodnav.planning.velocity_tuning import VelocityTuning
from nodnav.planning.visibility import VisibilityGraph
from nodnav.planning.waiting_spots import in_door_zone
from nodnav.registry import register_planner
from nodnav.scenario.params import FastPlannerParams
from nodnav.scenario.world import World

logger = logging.getLogger(__name__)


def _points(a) -> np.ndarray:
    """``np.asarray(a, dtype=float).reshape(-1, 2)``; a float array of that shape itself (the
    same values, without a new view: the closed loop asks many orders of the same arrays)."""
    if type(a) is np.ndarray and a.dtype == np.float64 and a.ndim == 2 and a.shape[1] == 2:
        return a
    return np.asarray(a, dtype=float).reshape(-1, 2)


def _values(a) -> np.ndarray:
    """``np.asarray(a, dtype=float).reshape(-1)``; a flat float array itself (see :func:`_points`)."""
    if type(a) is np.ndarray and a.dtype == np.float64 and a.ndim == 1:
        return a
    return np.asarray(a, dtype=float).reshape(-1)


@register_planner("fast")
class PrioritizedPlanner(GeometricPaths, VelocityTuning, MakingWay, DeferredParking):
    """Prioritised space-time planner (see the module docstring); deterministic, no precomputation."""

    name = "fast"

    def __init__(self, world: World, params: FastPlannerParams | None = None):
        self.world = world
        self.params = params if params is not None else FastPlannerParams()
        self._graphs: dict[tuple[int, float], VisibilityGraph] = {}
        self._world_ids: dict[int, tuple[World, int]] = {}
        self._world_tokens: dict[World, int] = {}
        self._tracks: dict[tuple, Track] = {}
        self._still_tracks: dict[tuple, Track] = {}
        self._cuts: dict[tuple, Cut] = {}
        self._rows: dict[tuple, tuple] = {}
        self._rows_by_id: dict[tuple, tuple] = {}
        self._geometries: dict[int, tuple] = {}
        self._states: dict[tuple, State] = {}
        self._fixed_parts: dict[tuple, tuple] = {}
        self._repairs: dict[tuple, tuple] = {}
        self._attempts: dict[tuple, Attempt] = {}
        self._joints: dict[tuple, Joint] = {}
        self._orders: dict[tuple, tuple] = {}
        self._int_orders: dict[tuple, tuple] = {}
        self._disc_rows: dict[tuple, tuple] = {}

    def plan(self, request: PlanRequest) -> PlanResult:
        """Plan every robot of the request through the corridor in its (feasible) passing order."""
        began = time.perf_counter()
        world = request.world
        pos, dest = _points(request.positions), _points(request.destinations)
        radii, vmax = _values(request.radii), _values(request.max_speeds)
        order = self._int_order(request.order, len(pos))
        if order is None:
            reject_request(tuple(int(k) for k in request.order), pos, dest, radii, vmax)
        vel = accels = None
        if self.params.timing == "feasible" and request.max_accels is not None:
            vel, accels = _points(request.velocities), _values(request.max_accels)
        state = self._state(world, pos, dest, radii, vmax, order, vel, accels)
        # The same few (order, entered) pairs come back for every robot: remembered per state.
        asked = (state.key, order, tuple(request.entered))
        known = self._orders.get(asked)
        if known is None:
            entered = tuple(int(k) for k in request.entered)
            inside = state.inside_robots
            if inside:
                entered += tuple(k for k in order if k in inside and k not in entered)
            if not entered:  # nobody has entered: the order itself (what feasible_order gives)
                planned = order
            else:
                back_out = self.params.inside == "back-out"
                # The repair depends on these three only: the same few come back round after round.
                repair = (order, entered, state.directions.tobytes() if back_out else None)
                repaired = self._repairs.get(repair)
                if repaired is None:
                    repaired = feasible_order(order, entered, state.direction_list if back_out else None)
                    remember_briefly(self._repairs, repair, repaired)
                planned = repaired
            known = (entered, planned)
            remember_briefly(self._orders, asked, known)
        entered, planned = known

        def failure(reason: str) -> PlanResult:
            logger.debug("fast planner: order %s failed: %s", planned, reason)
            return replace(PlanResult.failure(request, reason, time.perf_counter() - began), order_planned=planned)

        if state.problem:
            return failure(state.problem)
        # Orders repaired to the same one share its joint plan; only the notes differ.
        key = (state.key, planned, float(request.t0))
        joint = self._joints.get(key)
        if joint is None:
            joint = self._joint(world, state, planned, float(request.t0))
            remember(self._joints, key, joint)
        if not joint.success:
            return failure(joint.reason)
        notes = []
        if planned != order:
            notes.append(f"order {order} repaired to {planned}: robots {entered} have already entered the corridor")
        if joint.retreats:
            notes.append(f"robots {joint.retreats} back out of the way of robots before them")
        if joint.deferred:
            notes.append(f"robots {joint.deferred} wait aside before they park, clear of the robots after them")
        assert joint.trajectory is not None  # a successful joint plan has one
        info = {"arrival_times": joint.arrival, "path_lengths": joint.lengths, "paths": joint.paths,
                "retreats": joint.retreats, "deferred": joint.deferred, "entered": entered}
        return PlanResult(True, "; ".join(notes), joint.cost, joint.trajectory, order, planned,
                          time.perf_counter() - began, info)

    # -----------------------------------------------------------------------------------------

    def _int_order(self, order, n: int) -> tuple | None:
        """``tuple(int(k) for k in order)`` if it is a permutation of ``0..n-1``, else None;
        remembered: the same few orders come back in every round (an order of NumPy integers
        hashes and compares as its Python ints)."""
        try:
            known = self._int_orders.get((order, n))
        except TypeError:  # a list, say: not a key
            known = None
            order = tuple(order)
        if known is None:
            ints = tuple(int(k) for k in order)
            known = (ints if sorted(ints) == list(range(n)) else None,)
            remember_briefly(self._int_orders, (order, n), known)
        return known[0]

    def _joint(self, world: World, state: State, planned: tuple, t0: float,
               deferred: frozenset = frozenset()) -> Joint:
        """Every robot planned in the order ``planned``, one after the other.

        A robot whose way is blocked for good by where a robot before it parks has that robot
        wait aside instead (``deferred``): it is planned to a holding spot clear of the ways of
        the robots after it, and goes on to its destination once they have passed
        (:meth:`_park`).
        """
        work = self._deferring(world, state, planned, deferred) if deferred else state
        if work is None:
            return Joint(False, f"robots {tuple(sorted(deferred))} would block the way where they park, "
                                 "and have no spot nearby to wait aside")
        plans: dict[int, RobotPlan] = {}
        heads: dict[int, Motion] = {}
        for rank, k in enumerate(planned):
            # A robot's plan depends only on the state, on who goes before it and on the set of
            # robots after it, so orders that share a beginning share those plans.
            key = (work.key, planned[:rank + 1])
            attempt = self._attempts.get(key)
            if attempt is None:
                layout = Layout(dict(plans), dict(heads), tuple(sorted(planned[rank + 1:])))
                attempt = self._plan_robot(world, work, k, layout)
                remember(self._attempts, key, attempt)
            if not attempt.success:
                start = heads[k].samples[-1] if k in heads else state.positions[k]
                blockers = self._blockers(world, state, planned[:rank], k, start) - deferred
                if blockers:
                    retry = self._joint(world, state, planned, t0, deferred | blockers)
                    if retry.success:
                        return retry
                return Joint(False, f"robot {k}: {attempt.reason}")
            assert attempt.plan is not None  # a successful attempt has one
            plans[k] = attempt.plan
            heads.pop(k, None)
            heads.update(attempt.evasions)
        for k in planned:
            if k in deferred:
                parked = self._park(world, state, k, plans)
                if parked is None:
                    return Joint(False, f"robot {k} waits aside for the robots after it, and cannot park afterwards")
                plans[k] = parked
        dt = float(self.params.dt)
        n = len(plans)
        motions = [plans[k].motion for k in range(n)]
        samples = [m.samples for m in motions]
        ends = [len(x) for x in samples]  # each robot's arrival step + 1
        # Each robot standing at its last sample once it has arrived, in one compiled call.
        trajectory = JointTrajectory(*joint_arrays(np.concatenate(samples), np.array(ends, dtype=np.int64), t0, dt))
        arrival = np.array([(e - 1) * dt for e in ends])
        lengths = np.array([m.length for m in motions])
        # Shared by every result of this order: nobody may change them in place.
        for a in (trajectory.times, trajectory.positions, trajectory.velocities, arrival, lengths):
            a.setflags(write=False)
        return Joint(True, "", float(arrival.sum()), trajectory, arrival, lengths,
                      tuple(m.path for m in motions), tuple(k for k in planned if plans[k].retreat),
                      tuple(k for k in planned if k in deferred))

    def _state(self, world: World, pos: np.ndarray, dest: np.ndarray, radii: np.ndarray, vmax: np.ndarray,
               order: tuple, vel: np.ndarray | None = None, accels: np.ndarray | None = None) -> State:
        """What every order planned from this state shares (memoised; checked when first seen,
        ``order`` is only quoted in the error). With ``vel`` and ``accels`` the paths are timed
        within the acceleration limits, from the present velocities."""
        key: tuple = (self.world_token(world), pos.tobytes(), dest.tobytes(), radii.tobytes(), vmax.tobytes())
        if accels is not None and vel is not None:
            key += (vel.tobytes(), accels.tobytes())
        state = self._states.get(key)
        if state is None:
            n = len(pos)
            if (dest.shape != pos.shape or radii.shape != (n,) or vmax.shape != (n,) or not (
                    np.isfinite(pos).all() and np.isfinite(dest).all() and (radii > 0).all() and (vmax > 0).all())):
                reject_request(order, pos, dest, radii, vmax)
            # Copies: the memos keep them, and the caller may reuse its arrays.
            pos, dest, radii, vmax = pos.copy(), dest.copy(), radii.copy(), vmax.copy()
            fixed = self._fixed_part(world, key, dest, radii, vmax)
            dirs = crossing_directions(world, pos, dest)
            door = np.where(dirs > 0, 0, np.where(dirs < 0, 1, -1))
            in_door = (door >= 0) & in_door_zone(world, pos, np.maximum(door, 0), self.params.door_clearance)
            natural: list[np.ndarray] = [np.zeros((0, 2))] * n
            # The distinct radii in increasing order, as np.unique gives them (without its cost).
            for radius in sorted(set(radii.tolist())):
                group = np.flatnonzero(radii == radius)
                graph = self.graph(world, radii[group[0]])  # the array's own scalar, as before
                for k, path in zip(group, graph.shortest_paths(pos[group], dest[group])):
                    natural[k] = path.points
            state = State(key, pos, dest, radii, vmax, fixed[0], dirs, world.in_corridor(pos), door, in_door,
                           tuple(natural), fixed[1],
                           None if vel is None else vel.copy(), None if accels is None else accels.copy())
            remember(self._states, key, state)
        return state

    def _fixed_part(self, world: World, key: tuple, dest: np.ndarray, radii: np.ndarray,
                    vmax: np.ndarray) -> tuple[np.ndarray, str]:
        """The separations and the destinations' problem of a state: they depend on the world,
        the destinations, radii and speeds only, the same in every round of a trial (remembered;
        ``key`` is the state's, whose first, third, fourth and fifth entries name them). The
        separations are read-only: every state of the trial shares them."""
        part = (key[0], key[2], key[3], key[4])
        hit = self._fixed_parts.get(part)
        if hit is None:
            required = separation_requirements(dest, radii, vmax, self.params.dt, self.params.margin)
            required.setflags(write=False)
            hit = (required, state_problem(dest, world.clearance(dest), radii))
            remember(self._fixed_parts, part, hit)
        return hit

    def _start(self, state: State, k: int, layout: Layout) -> np.ndarray:
        """Where robot ``k`` stands once it has got out of the way (its position if it need not)."""
        head = layout.heads.get(k)
        return head.samples[-1] if head is not None else state.positions[k]

    def _plan_robot(self, world: World, state: State, k: int, layout: Layout) -> Attempt:
        """Robot ``k``'s path and timing among the robots before it. Robots after it that stand
        in its way, or in the door zone it will come out of, get out of the way first; one pinned
        where only ``k``'s own place would let it out gets that room: ``k`` backs off first."""
        dirs = state.direction_list  # Python ints: the same comparisons, without NumPy scalars
        heads = dict(layout.heads)  # grows as robots get out of the way
        evasions: dict[int, Motion] = {}
        seen: list = [layout]  # the layout now; None once evade() has changed heads

        def now() -> Layout:
            if seen[0] is None:
                seen[0] = Layout(layout.plans, dict(heads), layout.later)
            return seen[0]

        def evade(j: int) -> None:
            moves = self._get_out_of_way(world, state, j, k, now())
            if not moves and k not in heads:
                back = self._make_room(world, state, k, j, now())
                if back:
                    moves = self._get_out_of_way(world, state, j, k, Layout(layout.plans, {**heads, **back},
                                                                                layout.later))
                    moves = {**back, **moves} if moves else {}
            if k in moves:
                heads[k] = moves.pop(k)
            heads.update(moves)
            evasions.update(moves)
            seen[0] = None

        if dirs[k] != 0:
            in_door = state.in_door_list
            for j in layout.later:
                if j not in heads and in_door[j] and dirs[j] == -dirs[k]:
                    evade(j)
        track = self._track_for(world, state, k, now())
        if track.route.detour:
            standing = now()  # nobody moves while the list is built
            stand = np.array([self._start(state, j, standing) for j in layout.later]).reshape(-1, 2)
            start, goal = track.cells[0], track.cells[-1]
            crossed = disc_violations(track.route.path.points, stand, state.required[k, list(layout.later)],
                                      np.linalg.norm(stand - start, axis=1), np.linalg.norm(stand - goal, axis=1))
            for j in np.asarray(layout.later)[crossed]:
                if int(j) not in heads:
                    evade(int(j))
        here = now()
        if len(heads) > len(layout.heads):
            track = self._track_for(world, state, k, here)
        if not track.route.path.success:
            return Attempt(False, track.route.path.reason)
        attempt = self._time(world, state, k, track, here)
        if not attempt.success and attempt.trapped and k not in heads:
            retreat = self._back_out(world, state, k, here)
            if retreat.success:
                attempt = retreat
        if not evasions and not attempt.evasions:  # the same fields: the attempt itself
            return attempt
        return Attempt(attempt.success, attempt.reason, attempt.plan, attempt.trapped, tuple(sorted(evasions.items())))

    def _track_for(self, world: World, state: State, k: int, layout: Layout) -> Track:
        """Robot ``k``'s prepared path from where it starts (after getting out of the way, if it
        must), around the robots after it standing and the destinations of those before it."""
        dest = state.destinations
        later = layout.later
        earlier = frozenset(layout.plans)
        # Nobody has moved out of the way: the track depends on the state, on k and on who is
        # before and after it only, the same in every order that shares those (remembered).
        moved = not layout.heads.keys().isdisjoint(later)
        still = not moved and k not in layout.heads
        if still:
            known = self._still_tracks.get((state.key, k, later, earlier))
            if known is not None:
                return known
        start = self._start(state, k, layout)
        # The rows of the discs, by the robots before and after it (the same few in every round).
        rows = self._disc_rows.get((len(dest), later, earlier))
        if rows is None:
            rows = self._rows_of_discs(len(dest), later, sorted(layout.plans))
        if moved:
            stand = np.array([self._start(state, j, layout) for j in later]).reshape(-1, 2)
            centres = np.concatenate((stand, dest[rows[2]]))
        else:  # nobody after it has moved: where they stand now, then the destinations (the same values)
            centres = state.stands_and_goals[rows[0]]
        rads = state.required[k][rows[1]]
        track = self._track(world, state.radii[k], state.max_speeds[k] * self.params.dt, start, dest[k], centres,
                            rads, len(later))
        if still:
            remember(self._still_tracks, (state.key, k, later, earlier), track)
        return track

    def _rows_of_discs(self, n: int, later: tuple, earlier: list) -> tuple:
        """For :meth:`_track_for`: the rows of ``State.stands_and_goals`` (the later robots'
        positions, then the earlier robots' destinations), of a row of ``State.required``
        (later, then earlier) and the earlier robots, as index arrays (read-only, remembered by
        ``n``, ``later`` and the set of ``earlier``)."""
        stands = np.array(list(later) + [n + i for i in earlier], dtype=np.intp)
        pairs = np.array(list(later) + earlier, dtype=np.intp)
        before = np.array(earlier, dtype=np.intp)
        for a in (stands, pairs, before):
            a.setflags(write=False)
        rows = (stands, pairs, before)
        remember_briefly(self._disc_rows, (n, later, frozenset(earlier)), rows)
        return rows
