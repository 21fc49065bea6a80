"""Plans for a fixed passing order, shared by the baselines at one passage
(:mod:`nodnav.sim.baselines`) and at each passage of several (:mod:`nodnav.sim.passage_baselines`)."""

from __future__ import annotations

import numpy as np

from nodnav.planning.base import PlanResult, relabel
from nodnav.scenario.schema import Scenario
from nodnav.sim.agent_queries import joint_requests, local_order
from nodnav.sim.plan_cache import PlanCache
from nodnav.sim.views import RobotView

#: Opinions or probabilities of a method that has none: nothing.
NO_OPINION = np.zeros(0)


def closest_first_order(distances: np.ndarray, resolution: float) -> tuple[int, ...]:
    """Robots sorted by distance to their entrance (eq. (10)'s d_{i,corridor}), nearest first;
    distances equal at ``resolution`` (m) are ordered by robot number, so that robots placed
    symmetrically by hand tie exactly."""
    d = np.asarray(distances, dtype=float)
    key = np.round(d / resolution)
    return tuple(int(k) for k in np.lexsort((np.arange(len(d)), key)))


def plan_for_order(scenario: Scenario, plans: PlanCache, view: RobotView, robots: tuple[int, ...],
                   order: tuple[int, ...]) -> PlanResult:
    """The joint plan of ``robots`` (scenario indices, the planning robot first) in ``order``
    projected onto them, from ``view``, with its robots listed as in ``robots``.

    The query lists the robots in increasing index, as :meth:`NODAgent.plan_all` does, so that
    robots posing the same joint problem share the answer through the plan cache.
    """
    canonical = tuple(sorted(robots))
    request = joint_requests(scenario, view, canonical, [local_order(order, canonical)])[0]
    return relabel(plans.plan(request), [canonical.index(k) for k in robots])
