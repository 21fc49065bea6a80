"""Plans computed once per decision round and shared by the agents that pose the same query.

Every robot of a trial (or of one passage of several) plans at the same decision times; robots
that play the same game pose the same joint planning problems, evaluate the same plans of the
round before, and ask which parked robots join a plan with the same arguments. A
:class:`PlanCache` answers each of these once per round, keyed by everything the answer reads,
so a hit returns exactly what the agent would have computed alone.

With ``planner.reuse_tolerance`` above 0 (the fast planner's, 0.05 m by default; a planner
without the setting plans every query anew) a query the round before asked too is
answered with that round's plan of it, carried on to now (:func:`plan_tail`), when the robots
have moved as that plan said they would (:func:`on_plan`): Algorithm 1 plans every strategy from
the state X(t) each period; a plan that X(t) follows to within the tolerance is kept instead.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nodnav.compiled import compiled
from nodnav.planning.base import JointTrajectory, Planner, PlanRequest, PlanResult, interpolate_positions
from nodnav.scenario.world import World
from nodnav.sim.parked import crossed_and_arriving, packed_crossed


def state_key(request: PlanRequest) -> tuple[bytes | None, ...]:
    """The part of a plan cache's key that requests sharing their state arrays share
    (:func:`~nodnav.sim.agent_queries.joint_requests`): the bytes of those arrays."""
    return (request.positions.tobytes(), request.velocities.tobytes(), request.destinations.tobytes(),
            request.radii.tobytes(), request.max_speeds.tobytes(),
            None if request.max_accels is None else request.max_accels.tobytes())


class PlanCache:
    """Plans already computed in this decision round, shared by agents that pose the same query.

    The key is everything the planner reads, so a hit returns exactly what the agent would have
    computed alone; the simulator clears the cache at every decision time.
    """

    def __init__(self, planner: Planner, reuse_tolerance: float = 0.0, plan_step: float = 0.0):
        self.planner = planner
        self.reuse_tolerance = float(reuse_tolerance)
        """How far (m) the robots may be from last round's plan of a query for it to be kept
        (:func:`on_plan`); 0: every query planned anew each round
        (:func:`~nodnav.scenario.params.plan_reuse` gives a scenario's)."""
        self._step = float(plan_step)  # the planner's time step: a kept plan's samples
        self._plans: dict[tuple, PlanResult] = {}
        # With reuse: this round's and the last round's answers by their key without the state.
        self._fresh: dict[tuple, PlanResult] = {}
        self._previous: dict[tuple, PlanResult] = {}
        self.reused = 0
        """Queries answered with the round before's plan (neither hits nor misses: the planner
        was not asked)."""
        self._states: dict[tuple, tuple[JointTrajectory, np.ndarray]] = {}
        self._tails: dict[tuple, tuple[PlanResult, tuple | None]] = {}
        self.hits = 0
        self.misses = 0
        self.graphs: dict = {}
        """Visibility graphs by (world, radius), kept across rounds and shared by the agents that
        share this cache: each graph remembers its answers keyed by the exact query, so an agent
        asking what another already asked (:func:`~nodnav.sim.parked.packed_crossed`) gets the
        same path without searching again."""
        self._crossed: dict[tuple, tuple[int, ...]] = {}
        self._packed: dict[tuple, tuple[tuple[np.ndarray, np.ndarray], dict, World]] = {}
        self._stacks: dict[tuple, tuple[list, np.ndarray]] = {}
        self._shared: dict[tuple, tuple[object, np.ndarray]] = {}
        self._once: dict[tuple, tuple[object, Any]] = {}

    @property
    def asked(self) -> int:
        """Queries answered so far: from this round's answers (:attr:`hits`), by the planner
        (:attr:`misses`) or with a plan of the round before (:attr:`reused`)."""
        return self.hits + self.misses + self.reused

    def clear(self) -> None:
        """Forget every plan and evaluation (called when the state of the world has moved on); with
        reuse, this round's plans become the round before's."""
        if self.reuse_tolerance > 0:
            self._previous, self._fresh = self._fresh, {}
        self._plans.clear()
        self._states.clear()
        self._tails.clear()
        self._crossed.clear()
        self._packed.clear()
        self._stacks.clear()
        self._shared.clear()
        self._once.clear()

    def once(self, key: tuple, compute, keep: object = None) -> Any:
        """``compute()``, any object its callers only read, computed at most once per round for
        ``key`` (which must name everything it reads); ``keep`` as in :meth:`shared`."""
        hit = self._once.get(key)
        if hit is None:
            hit = self._once[key] = (keep, compute())
        return hit[1]

    def shared(self, key: tuple, compute, keep: object = None) -> np.ndarray:
        """``compute()``, an array, computed at most once per round for ``key`` (which must name
        everything the answer reads) and returned read-only to everyone who asks: the agents of a
        round that see the same (every agent, with exact sensing) ask alike. ``keep``: an object
        whose ``id`` is part of ``key``, held with the answer so that the id stays unique."""
        hit = self._shared.get(key)
        if hit is None:
            value = compute()
            value.flags.writeable = False
            hit = self._shared[key] = (keep, value)
        return hit[1]

    def plan(self, request: PlanRequest, state: tuple | None = None) -> PlanResult:
        """The planner's answer to ``request``, computed at most once per round; ``state`` is
        :func:`state_key` of the request if the caller has it already."""
        if state is None:
            state = state_key(request)
        key = (request.order, request.entered, request.t0, *state)
        result = self._plans.get(key)
        if result is None:
            result = self._plans[key] = self._answer(request, request.order, state)
        else:
            self.hits += 1
        return result

    def plan_order(self, template: PlanRequest, order: tuple[int, ...], state: tuple) -> PlanResult:
        """:meth:`plan` of ``template`` asked in ``order`` (``state``: :func:`state_key` of the
        template): the request is built only when the round has not answered it yet, since most
        of an agent's queries were posed by a game player before it."""
        return self.plan_orders(template, [order], state)[0]

    def plan_orders(self, template: PlanRequest, orders: list[tuple[int, ...]], state: tuple) -> list[PlanResult]:
        """:meth:`plan_order` of ``template`` in each of ``orders``, in one call: the key of an order
        is ``(order, entered, t0, *state)``, its part after the order built once."""
        rest = (template.entered, template.t0, *state)
        plans = self._plans
        out = []
        for order in orders:
            key = (order, *rest)
            result = plans.get(key)
            if result is None:
                result = plans[key] = self._answer(template, order, state)
            else:
                self.hits += 1
            out.append(result)
        return out

    def _answer(self, template: PlanRequest, order: tuple[int, ...], state: tuple) -> PlanResult:
        """A query the round has not answered, ``template`` asked in ``order`` (``state``: its
        :func:`state_key`): last round's plan of it carried on to now if the robots are on it
        within :attr:`reuse_tolerance`, else the planner's. The request in ``order`` is built
        only for the planner: the keeping test reads what every order of the template shares."""
        if self.reuse_tolerance <= 0:
            self.misses += 1
            return self.planner.plan(_in_order(template, order))
        # Everything the planner reads but the robots' positions and velocities (and the time).
        unmoved = (order, template.entered, *state[2:])
        last = self._previous.get(unmoved)
        result = None if last is None else self._kept(last, template, state)
        if result is None:
            self.misses += 1
            result = self.planner.plan(_in_order(template, order))
        else:
            self.reused += 1
        self._fresh[unmoved] = result
        return result

    def _kept(self, last: PlanResult, template: PlanRequest, state: tuple) -> PlanResult | None:
        """:func:`kept_plan` of ``last`` for ``template`` (``state``: its :func:`state_key`), the
        test and the tail's arrays once per round for each trajectory and arrival times: orders
        a planner repaired to the same one shared them, and their kept plans share them again
        (a kept plan's tail is read-only, as the planner's plans are)."""
        traj, arrival = last.trajectory, arrivals(last.info)
        key = (id(traj), id(arrival), last.success, template.t0, *state)
        hit = self._tails.get(key)
        if hit is None:
            steps = kept_steps(last, template.t0, template.positions, template.velocities, template.max_accels,
                               self.reuse_tolerance, self._step)
            tail = tail_of(traj, arrival, steps, template.t0, self._step) if steps else None
            hit = self._tails[key] = (last, tail)  # holding the plan keeps the ids unique
        tail = hit[1]
        return None if tail is None else tailed_result(last, *tail)

    def packed_crossed(self, world: World, positions: np.ndarray, destinations: np.ndarray, radii: np.ndarray,
                       known: np.ndarray, planning: list[int], goal_tolerance: float,
                       margin: float, state: tuple | None = None) -> tuple[int, ...]:
        """:func:`~nodnav.sim.parked.packed_crossed` with this cache's graphs, computed at most
        once per round for the same arguments: robots that see the same and plan the same robots
        (every game player of a shared game) ask it alike. Keyed by every argument (arrays by
        their bytes, ``planning`` as a set: only membership counts); ``state``: the key of every
        argument but ``planning`` if the caller has built it (:func:`crossed_state`)."""
        if state is None:
            state = crossed_state(world, hashable(positions), hashable(destinations), hashable(radii),
                                  hashable(known), goal_tolerance, margin)
        key = (*state, tuple(sorted(planning)))
        hit = self._crossed.get(key)
        if hit is None:
            # What is packed round each robot's way does not depend on who plans: shared by every
            # planning set of the same state.
            shared = self._packed.get(state)
            if shared is None:
                masks = crossed_and_arriving(world, positions, destinations, known, goal_tolerance)
                shared = self._packed[state] = (masks, {}, world)  # holding the world keeps its id unique
            masks, packed, _ = shared
            hit = self._crossed[key] = tuple(packed_crossed(world, positions, destinations, radii, known,
                                                            list(planning), goal_tolerance, margin, self.graphs,
                                                            packed, masks))
        return hit

    def stacked_states(self, plans: list[PlanResult], times: np.ndarray, key: tuple | None = None) -> np.ndarray:
        """:meth:`states_at` of every plan of ``plans`` stacked, ``(G, n, M, 4)``, once per round
        for the same plans and times: every game player of a shared game reads the whole list
        of the round before, each keeping its own players' columns. Plans of unequal robot
        counts cannot be stacked: their states are stacked by the caller per column. ``key``:
        :func:`stack_key` of the arguments, if the caller has it."""
        if key is None:
            key = stack_key(plans, times)
        hit = self._stacks.get(key)
        if hit is None:
            states = [self._states_at(p.trajectory, times, key[1]) for p in plans]
            stacked = np.zeros(0)
            if states and all(a.shape == states[0].shape for a in states):
                stacked = np.empty((len(states), *states[0].shape))  # what np.stack builds, without its checks
                for g, a in enumerate(states):
                    stacked[g] = a
            hit = self._stacks[key] = (list(plans), stacked)  # holding the plans keeps their ids unique
        return hit[1]

    def states_at(self, result: PlanResult, times: np.ndarray) -> np.ndarray:
        """Planned states (px, py, vx, vy) of every robot of ``result`` at ``times``, ``(n, M, 4)``.

        Every robot of a round evaluates the plans of the round before against the same window,
        and orders a planner repairs to the same one share a trajectory, so each trajectory is
        evaluated once per round whoever asks.
        """
        return self._states_at(result.trajectory, times, times.tobytes())

    def _states_at(self, traj: JointTrajectory, times: np.ndarray, times_key: bytes) -> np.ndarray:
        """:meth:`states_at` of a trajectory, the times' bytes given."""
        key = (id(traj), times_key)
        hit = self._states.get(key)
        if hit is None:
            states = trajectory_states(traj.times, traj.positions, traj.velocities, np.asarray(times, dtype=float))
            hit = self._states[key] = (traj, states)  # holding the trajectory keeps its id unique
        return hit[1]


def trajectory_states_plain(trajectory: JointTrajectory, times: np.ndarray) -> np.ndarray:
    """Planned states (px, py, vx, vy) of every robot of ``trajectory`` at ``times``, ``(n, M, 4)``:
    :meth:`~nodnav.planning.base.JointTrajectory.positions_at` and ``velocities_at``, the
    reference :func:`trajectory_states` is tested against."""
    return np.concatenate([trajectory.positions_at(times), trajectory.velocities_at(times)], axis=-1).transpose(1, 0, 2)


@compiled
def trajectory_states(times, positions, velocities, query):
    """:func:`trajectory_states_plain` in one compiled call: the positions by the same
    interpolation (:func:`~nodnav.planning.base.interpolate_positions`), the velocities of the
    segment each query time falls in (zero from the last sample on), ``(n, M, 4)``."""
    at = interpolate_positions(times, positions, query)
    k, n, m = times.shape[0], positions.shape[1], query.shape[0]
    out = np.empty((n, m, 4))
    for q in range(m):
        i = min(max(np.searchsorted(times, query[q], side="right") - 1, 0), k - 1)
        end = query[q] >= times[k - 1]
        for r in range(n):
            out[r, q, 0] = at[q, r, 0]
            out[r, q, 1] = at[q, r, 1]
            out[r, q, 2] = 0.0 if end else velocities[i, r, 0]
            out[r, q, 3] = 0.0 if end else velocities[i, r, 1]
    return out


def kept_plan(last: PlanResult, request: PlanRequest, tolerance: float, dt: float) -> PlanResult | None:
    """``last`` (a plan of the round before, of a query that differs from ``request`` in the
    robots' positions, velocities and time only) carried on to ``request.t0`` (:func:`plan_tail`)
    if it is still good (:func:`kept_steps`), None otherwise.

    Robots outside the query do not enter the planner, so they cannot make it wrong; robots that
    entered the corridor or joined or left the query change the key it is found by."""
    steps = kept_steps(last, request.t0, request.positions, request.velocities, request.max_accels, tolerance, dt)
    return plan_tail(last, steps, request.t0, dt) if steps else None


def kept_steps(last: PlanResult, t0: float, positions: np.ndarray, velocities: np.ndarray,
               accels: np.ndarray | None, tolerance: float, dt: float) -> int:
    """How many of the planner's steps ``dt`` ``last`` is to be carried on to be kept at ``t0``
    (the robots at ``positions``, ``velocities``, with acceleration limits ``accels``), or 0 if it
    is not good: it must have planned successfully, ``t0`` must be a whole number (at least 1)
    of steps after its start, and every robot :func:`on_plan` within ``tolerance``."""
    trajectory = last.trajectory
    if not last.success or dt <= 0:
        return 0
    elapsed = t0 - float(trajectory.times[0])
    steps = int(round(elapsed / dt))
    if steps < 1 or abs(elapsed - steps * dt) > 1e-6 * dt:
        return 0
    if not on_plan(trajectory, steps, positions, velocities, accels, tolerance):
        return 0
    return steps


def on_plan(trajectory: JointTrajectory, steps: int, positions: np.ndarray, velocities: np.ndarray,
            accels: np.ndarray | None, tolerance: float) -> bool:
    """Whether every robot is within ``tolerance`` (m) of its state in ``trajectory`` at its sample
    ``steps`` (held after the last): its distance from the planned position plus, with
    acceleration limits ``accels``, how much farther its velocity error ``dv`` takes it while it
    is braked away at that limit, ``|dv|^2 / 2a`` (:func:`plan_offsets_plain`, in one compiled
    loop). Within it, the planner, which places a robot on its path to a cell of ``v_max dt / 2``,
    would start from nearly the same state."""
    last = len(trajectory.times) - 1
    k = min(steps, last)
    braking = accels is not None
    return bool(within_plan(positions, velocities, accels if braking else _NO_ACCELS, trajectory.positions[k],
                            trajectory.velocities[k], steps >= last, braking, tolerance))


_NO_ACCELS = np.zeros(0)


def plan_offsets_plain(positions: np.ndarray, velocities: np.ndarray, accels: np.ndarray | None,
                       planned_positions: np.ndarray, planned_velocities: np.ndarray) -> np.ndarray:
    """How far each robot is from its planned state ``(n,)`` (m): its distance from the planned
    position plus, with ``accels``, ``|dv|^2 / 2a`` of its velocity error (the reference
    :func:`within_plan` is tested against)."""
    off = np.linalg.norm(positions - planned_positions, axis=1)
    if accels is not None:
        off = off + np.sum((velocities - planned_velocities) ** 2, axis=1) / (2.0 * accels)
    return off


@compiled
def within_plan(positions, velocities, accels, planned_positions, planned_velocities, held, braking, tolerance):
    """Whether every robot's :func:`plan_offsets_plain` is within ``tolerance``, the planned
    velocity zero if ``held`` (after the plan's last sample), the velocity not read unless
    ``braking``: one loop, stopping at the first robot off the plan."""
    for r in range(positions.shape[0]):
        dx = positions[r, 0] - planned_positions[r, 0]
        dy = positions[r, 1] - planned_positions[r, 1]
        off = np.sqrt(dx * dx + dy * dy)
        if braking:
            ux = velocities[r, 0] - (0.0 if held else planned_velocities[r, 0])
            uy = velocities[r, 1] - (0.0 if held else planned_velocities[r, 1])
            off += (ux * ux + uy * uy) / (2.0 * accels[r])
        if off > tolerance:
            return False
    return True


def plan_tail(result: PlanResult, steps: int, t0: float, dt: float) -> PlanResult:
    """``result`` from its sample ``steps`` on, started at ``t0``, as the planner would return a
    plan asked at ``t0``: its times ``t0 + dt j`` (execution starts its clocks at the first
    sample); with the fast planner's ``info["arrival_times"]``, those counted from ``t0`` (at
    least 0) and the cost their sum, as the fast planner's (another planner's cost is kept);
    ``info["kept_from"]`` the plan's first time. After its last sample the plan holds every
    robot where it ends, as before."""
    return tailed_result(result, *tail_of(result.trajectory, arrivals(result.info), steps, t0, dt))


def arrivals(info: dict) -> np.ndarray | None:
    """A plan's ``info["arrival_times"]`` as :func:`tail_of` takes them: None without the entry,
    none (an empty array) if it is None."""
    if "arrival_times" not in info:
        return None
    arrival = info["arrival_times"]
    return _NO_ACCELS if arrival is None else arrival


def tail_of(traj: JointTrajectory, arrival: np.ndarray | None, steps: int, t0: float,
            dt: float) -> tuple[JointTrajectory, np.ndarray | None, float]:
    """What :func:`plan_tail` makes of a plan's trajectory and arrival times (:func:`arrivals`;
    None: the planner gives none): the trajectory's tail and, with arrival times, those left and
    their sum (the cost), all read-only. Plans sharing the trajectory and arrival times share these."""
    k = min(steps, len(traj.times) - 1)
    times, left, cost = tail_arrays(len(traj.times) - k, t0, dt, _NO_ACCELS if arrival is None else arrival,
                                    steps * dt)  # (the arrival times' part unread without them)
    times.setflags(write=False)  # the planner's plans are shared read-only, and so is this one
    if arrival is None:
        return _trajectory(times, traj.positions[k:], traj.velocities[k:]), None, 0.0
    left.setflags(write=False)
    return _trajectory(times, traj.positions[k:], traj.velocities[k:]), left, cost


def tailed_result(result: PlanResult, trajectory: JointTrajectory, arrival: np.ndarray | None,
                  cost: float) -> PlanResult:
    """``result`` on the tail :func:`tail_of` made of it: its ``info`` with ``kept_from`` (the
    plan's first time) and, if ``arrival`` is not None, the arrival times left, whose sum
    ``cost`` replaces the result's; built as the constructor builds it, without the frozen
    dataclass's assignment of one field at a time."""
    info = {**result.info, "kept_from": float(result.trajectory.times[0])}
    if arrival is not None:
        info["arrival_times"] = arrival
    else:
        cost = result.cost
    kept = object.__new__(PlanResult)
    kept.__dict__.update(success=result.success, reason=result.reason, cost=cost, trajectory=trajectory,
                         order=result.order, order_planned=result.order_planned, compute_time=0.0, info=info)
    return kept


def _trajectory(times: np.ndarray, positions: np.ndarray, velocities: np.ndarray) -> JointTrajectory:
    """``JointTrajectory(times, positions, velocities)`` without the frozen dataclass's
    assignment of one field at a time (it has no ``__post_init__``)."""
    trajectory = object.__new__(JointTrajectory)
    trajectory.__dict__.update(times=times, positions=positions, velocities=velocities)
    return trajectory


@compiled
def tail_arrays(count, t0, dt, arrival, elapsed):
    """For :func:`plan_tail`, in one compiled call: the times ``t0 + dt j`` of ``count`` samples,
    the arrival times ``arrival`` less ``elapsed`` (at least 0), and their sum."""
    times = np.empty(count)
    for j in range(count):
        times[j] = t0 + dt * j
    left = np.empty(arrival.shape[0])
    cost = 0.0
    for r in range(arrival.shape[0]):
        left[r] = max(arrival[r] - elapsed, 0.0)
        cost += left[r]
    return times, left, cost


def _in_order(template: PlanRequest, order: tuple[int, ...]) -> PlanRequest:
    """``dataclasses.replace(template, order=order)`` without its field-by-field rebuild (a
    :class:`PlanRequest` has no ``__post_init__``): the same fields, the same class; ``template``
    itself if it is asked in ``order``."""
    if template.order == order:
        return template
    request = object.__new__(PlanRequest)
    request.__dict__.update(template.__dict__)
    object.__setattr__(request, "order", order)
    return request


def stack_key(plans: list[PlanResult], times: np.ndarray) -> tuple[tuple[int, ...], bytes]:
    """What :meth:`PlanCache.stacked_states` is keyed by: the plans' trajectories by ``id`` (the
    cache holds the plans) and the times' bytes."""
    return tuple(id(p.trajectory) for p in plans), times.tobytes()


def crossed_state(world: World, positions: tuple, destinations: tuple, radii: tuple, known: tuple,
                  goal_tolerance: float, margin: float) -> tuple:
    """The key :meth:`PlanCache.packed_crossed` gives the arguments other than ``planning``, the
    arrays already made :func:`hashable`: the world by its ``id`` (hashing the frozen dataclass
    walks every field at every look-up; the cache holds the world with the answer)."""
    return (id(world), positions, destinations, radii, known, goal_tolerance, margin)


def hashable(value):
    """``value`` as part of a memo's key: arrays by their dtype, shape and bytes, lists as tuples."""
    if isinstance(value, np.ndarray):
        return (value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, list):
        return tuple(hashable(v) for v in value)
    return value


__all__ = ["PlanCache", "arrivals", "crossed_state", "hashable", "kept_plan", "kept_steps", "on_plan",
           "plan_offsets_plain", "plan_tail", "stack_key", "state_key", "tail_arrays", "tail_of", "tailed_result",
           "within_plan"]
