"""What every decision rule of a trial shares, beside :class:`~nodnav.sim.agent.NODAgent`: the
scenario's per-robot arrays, the planning queries of a set of robots in given passing orders (and
the plan that clears the way when none can be planned), the side each robot approaches from,
eq. (7)'s game players among the robots in sight, and a strategy's draw. The NOD agent, the
baselines, people, the several-passage rules and the simulator import them from here.
"""

from __future__ import annotations

from bisect import bisect_right

import numpy as np

from nodnav.decision.players import select_game_players
from nodnav.decision.strategies import project_order
from nodnav.planning.base import PlanRequest, PlanResult, crossing_directions
from nodnav.planning.clearing import clear_the_way
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import LEFT, RIGHT
from nodnav.sim.views import RobotView


def local_order(order, robots: tuple[int, ...]) -> tuple[int, ...]:
    """A passing order of every robot projected onto ``robots`` (scenario indices) and numbered
    by the robots' places in ``robots``, as a planning query of those robots expects it."""
    local_of = {k: m for m, k in enumerate(robots)}
    return tuple(local_of[k] for k in project_order(order, robots))


def robot_arrays(scenario: Scenario) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The scenario's destinations, radii, speed and acceleration limits, ``(N_r, 2)`` and
    ``(N_r,)`` arrays, read-only: the scenario builds them anew at every access, a trial's
    objects build them once."""
    arrays = (scenario.destinations, scenario.radii, scenario.max_speeds,
              np.array([r.max_accel for r in scenario.robots], dtype=float))
    for a in arrays:
        a.flags.writeable = False
    return arrays


def weighted_choice(rng: np.random.Generator, p: np.ndarray) -> int:
    """``int(rng.choice(len(p), p=p))`` for probabilities ``p`` that sum to 1, the same draw
    and the same index: numpy's ``Generator.choice`` takes ``cdf = p.cumsum()``, divides it by
    its last element, draws one ``rng.random()`` and returns ``cdf.searchsorted(u, side="right")``
    (``bisect_right`` of the same sorted list). Without ``choice``'s argument checks, which
    cost more than the draw (the probabilities come from eq. (3), checked there)."""
    cdf = np.add.accumulate(np.asarray(p, dtype=float))  # np.cumsum's operation, without its wrapper
    cdf /= cdf[-1]
    return bisect_right(cdf.tolist(), rng.random())


def joint_requests(scenario: Scenario, view: RobotView, robots: tuple[int, ...], orders,
                   arrays: tuple[np.ndarray, ...] | None = None) -> list[PlanRequest]:
    """The planning queries of ``robots`` (scenario indices, in increasing index) passing in each
    of ``orders`` (numbered by place in ``robots``, :func:`local_order`), from what ``view``
    shows; the queries share their state arrays. ``arrays``: :func:`robot_arrays` of the
    scenario, if the caller holds them."""
    local_of = {k: m for m, k in enumerate(robots)}
    rows = list(robots)
    positions, velocities = view.positions[rows].copy(), view.velocities[rows].copy()
    entered = tuple(local_of[k] for k in view.entered if k in local_of)
    all_destinations, all_radii, all_speeds, all_accels = robot_arrays(scenario) if arrays is None else arrays
    accels = all_accels[rows]
    destinations, radii, max_speeds = all_destinations[rows], all_radii[rows], all_speeds[rows]
    return [PlanRequest(world=scenario.world, positions=positions, velocities=velocities,
                        destinations=destinations, radii=radii, max_speeds=max_speeds, order=order,
                        entered=entered, t0=view.t, max_accels=accels)
            for order in orders]


def clearing_plan(scenario: Scenario, view: RobotView, planning: tuple[int, ...], robot: int, failed: PlanResult,
                  graphs: dict) -> PlanResult:
    """When no order can be planned for ``robot`` (a scenario index, in ``planning``): the plan in
    which it clears the way (:func:`~nodnav.planning.clearing.clear_the_way`), a failure still."""
    request = joint_requests(scenario, view, planning, [tuple(range(len(planning)))])[0]
    return clear_the_way(request, planning.index(robot), failed.reason, scenario.planner, graphs)


def players_in_sight(L: np.ndarray, view: RobotView, i: int, k: int,
                     eligible: np.ndarray | None = None) -> tuple[int, ...]:
    """Robot ``i``'s ``k`` game players by eq. (7) from the likelihoods ``L`` ``(N, N)``, among
    the robots it sees now: one it does not see has no observed window for eq. (4), so it is
    no candidate (fewer than ``k`` players when fewer are in sight). With several passages only
    the ``eligible`` robots ``(N,)`` (those whose next passage is ``i``'s) are candidates."""
    if eligible is not None:
        ok = eligible & view.seen
        k = min(k, int(ok.sum()))
        L = np.where(ok[None, :], L, -np.inf)
        return tuple(sorted(select_game_players(L, i, k)))
    if view.age is not None:
        seen = view.seen
        k = min(k, int(seen.sum()) - 1)
        L = np.where(seen[None, :], L, -np.inf)
    return tuple(sorted(select_game_players(L, i, k)))


def approach_sides(scenario: Scenario) -> np.ndarray:
    """The side each robot approaches the corridor from (towards its destination)."""
    direction = crossing_directions(scenario.world, scenario.origins, scenario.destinations)
    origin_side = scenario.world.side_of(scenario.origins)
    return np.where(direction > 0, LEFT, np.where(direction < 0, RIGHT, origin_side))
