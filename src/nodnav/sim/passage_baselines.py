"""Baselines at one passage of several (docs/several-passages.md): the deciders that
:class:`~nodnav.sim.several.PassageAgent` runs per passage for the methods of
:mod:`nodnav.sim.baselines` that have a per-passage form."""

from __future__ import annotations

import numpy as np

from nodnav.decision.players import conflict_likelihood
from nodnav.decision.strategies import strategy_index
from nodnav.planning.base import relabel
from nodnav.scenario.schema import Scenario
from nodnav.sim.agent_queries import clearing_plan, players_in_sight
from nodnav.sim.order_plans import NO_OPINION, closest_first_order, plan_for_order
from nodnav.sim.plan_cache import PlanCache
from nodnav.sim.views import Decision, RobotView


class ClosestFirstPassage:
    """Robot ``index``'s closest-first convention at one passage of several, on the passage's
    one-passage ``scenario``: at its first decision there it ranks the robots it may play with
    (``eligible``, set by :class:`~nodnav.sim.several.PassageAgent`) and itself by their distance
    (eq. (10)) to the entrance of **each one's own next passage** (robots met between passages
    head for another passage than this one), nearest first, the others after them by number; it
    ranks again whenever any robot moves on to another passage (``rank_from``), so that every
    robot ranks at the same moments from the same positions and the orders agree; in between it
    keeps its order, with the game players of eqs. (6)-(7) among the eligible robots, exactly as
    :class:`FixedOrderMethod` does with one passage (docs/several-passages.md)."""

    def __init__(self, scenario: Scenario, index: int, plans: PlanCache, sides: np.ndarray):
        self.scenario = scenario
        self.index = index
        self.plans = plans
        self.sides = sides
        self.eligible: np.ndarray | None = None
        self.next_distances: np.ndarray | None = None
        """Each robot's distance to the entrance of its own next passage (set by
        :class:`~nodnav.sim.several.PassageAgent`; None: this passage's eq. (10) distance)."""
        self.order: tuple[int, ...] | None = None
        self._graphs: dict = {}
        self.stages: np.ndarray | None = None
        """How many passages of its route each robot has left behind, as this robot sees it (set
        by :class:`~nodnav.sim.several.PassageAgent`; None with one passage)."""
        self._ranked: tuple | None = None

    def rank_from(self, next_distances: np.ndarray, stages: np.ndarray) -> None:
        """Rank by ``next_distances`` (each robot's distance to the entrance of its own next
        passage, :meth:`~nodnav.sim.several.PassageViews.next_distances`), again whenever
        ``stages`` (the passages each robot has left behind, as this robot sees them) change."""
        self.next_distances = next_distances
        self.stages = stages

    def decide(self, view: RobotView) -> Decision:
        s, i = self.scenario, self.index
        d_corr = s.world.corridor_distance(view.positions, self.sides)
        L = conflict_likelihood(view.positions, d_corr, s.opinion.delta)
        players = players_in_sight(L, view, i, s.n_players, self.eligible)
        ranked = view.seen.copy() if self.eligible is None else view.seen & self.eligible
        ranked[i] = True
        # Ranked again whenever any robot moves on to another passage (or the robots it ranks
        # change): every robot then ranks at the same moment, from the same positions, by the
        # same distances, so the orders of robots in different games agree where they overlap.
        key = (tuple(ranked.tolist()), None if self.stages is None else tuple(int(k) for k in self.stages))
        if self.order is None or key != self._ranked:
            self._ranked = key
            d_rank = d_corr if self.next_distances is None else self.next_distances
            self.order = closest_first_order(np.where(ranked, d_rank, np.inf), s.baselines.closest_first_tie)
        robots = (i, *players)
        plan = plan_for_order(s, self.plans, view, robots, self.order)
        if not plan.success:  # nothing to follow: get out of everybody's way
            canonical = tuple(sorted(robots))
            plan = relabel(clearing_plan(s, view, canonical, i, plan, self._graphs),
                           [canonical.index(k) for k in robots])
        return Decision(strategy=strategy_index(self.order), robots=robots, plan=plan, opinions=NO_OPINION,
                        probabilities=NO_OPINION, players=players, game=tuple(range(s.n_robots)), order=self.order)
