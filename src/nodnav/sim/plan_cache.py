"""Plans computed once per decision round and shared by the agents that pose the same query.

Every robot of a trial (or of one passage of several) plans at the same decision times; robots
that play the same game pose the same joint planning problems, evaluate the same plans of the
round before, and ask which parked robots join a plan with the same arguments. A
:class:`PlanCache` answers each of these once per round, keyed by everything the answer reads,
so a hit returns exactly what the agent would have computed alone.
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
    (:func:`~nodnav.sim.agent.joint_requests`): the bytes of those arrays."""
    return (request.positions.tobytes(), request.velocities.tobytes(), request.destinations.tobytes(),
            request.radii.tobytes(), request.max_speeds.tobytes(),
            None if request.max_accels is None else request.max_accels.tobytes())


class PlanCache:
    """Plans already computed in this decision round, shared by agents that pose the same query.

    The key is everything the planner reads, so a hit returns exactly what the agent would have
    computed alone; the simulator clears the cache at every decision time.
    """

    def __init__(self, planner: Planner):
        self.planner = planner
        self._plans: dict[tuple, PlanResult] = {}
        self._states: dict[tuple, tuple[JointTrajectory, np.ndarray]] = {}
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

    def clear(self) -> None:
        """Forget every plan and evaluation (called when the state of the world has moved on)."""
        self._plans.clear()
        self._states.clear()
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
        key = (request.order, request.entered, request.t0, *(state_key(request) if state is None else state))
        result = self._plans.get(key)
        if result is None:
            self.misses += 1
            result = self.planner.plan(request)
            self._plans[key] = result
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
                self.misses += 1
                request = template if template.order == order else _in_order(template, order)
                result = plans[key] = self.planner.plan(request)
            else:
                self.hits += 1
            out.append(result)
        return out

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


def _in_order(template: PlanRequest, order: tuple[int, ...]) -> PlanRequest:
    """``dataclasses.replace(template, order=order)`` without its field-by-field rebuild (a
    :class:`PlanRequest` has no ``__post_init__``): the same fields, the same class."""
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


__all__ = ["PlanCache", "crossed_state", "hashable", "stack_key", "state_key"]
