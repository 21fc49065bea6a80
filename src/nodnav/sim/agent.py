"""One robot running Algorithm 1 on its own observations.

The agent sees the positions and velocities of the other robots (and knows their destinations,
as the paper assumes); it never sees their opinions, probabilities or choices. Every period T
it estimates the social terms (4) from the last window of observed motion against the joint
paths it planned one period earlier, updates its opinion with (8), re-selects its game players
(7), computes the strategy probabilities (3), samples its strategy, and plans the joint paths
for every strategy.
"""

from __future__ import annotations

import numpy as np

from nodnav.decision.estimation import (
    estimate_social_term,
    estimated_opinions,
    mismatch_predictions,
    reachable_predictions,
)
from nodnav.decision.games import carry_groups, carry_opinions, class_size, game_bias, game_orders
from nodnav.decision.initial import distance_initial_opinions
from nodnav.decision.opinion import opinion_update, selection_probabilities, step_size, strategy_probabilities
from nodnav.decision.players import conflict_likelihood, undecided_first
from nodnav.decision.standoff import STALL_DISTANCE, progress_beyond_best, standoff_partner
from nodnav.decision.strategies import passing_orders, precedence_mask
from nodnav.planning.base import PlanRequest, PlanResult, relabel
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import distance_to_go
from nodnav.sim.agent_queries import (
    approach_sides,
    clearing_plan,
    joint_requests,
    players_in_sight,
    robot_arrays,
    weighted_choice,
)
from nodnav.sim.plan_cache import PlanCache, crossed_state, hashable, stack_key, state_key
from nodnav.sim.views import Decision, RobotView  # defined there, imported from here by the methods


class NODAgent:
    """Robot ``index`` deciding with Nonlinear Opinion Dynamics (Algorithm 1).

    Its opinions are over the passing orders of its game, itself and its game players
    (:mod:`nodnav.decision.games`): ``(k+1)!`` of them for ``k`` players, however many robots
    there are. ``n_players`` overrides the scenario's number of game players; ``social=False``
    removes the social term (u = 0), so the agent keeps its own preference (used by baselines).
    """

    def __init__(self, scenario: Scenario, index: int, rng: np.random.Generator, plans: PlanCache,
                 *, n_players: int | None = None, social: bool = True):
        self.scenario = scenario
        self.index = index
        self.rng = rng
        self.plans = plans
        self.params = scenario.robot_opinion(index)
        self.n_players = scenario.n_players if n_players is None else n_players
        self.social = social
        self.bias = self.params.bias_indices()
        self.sides = approach_sides(scenario)
        self.eligible: np.ndarray | None = None
        """With several passages, the robots that may be game players (whose next passage is this
        robot's, :class:`~nodnav.sim.several.PassageAgent`); None: every robot."""
        self.settled: np.ndarray | None = None
        """With several passages, the robots with no passage left on their route (set by
        :class:`~nodnav.sim.several.PassageAgent`): only they may count as done with this one
        (``crossed: planned``); None (one passage): every robot past the corridor."""
        self.start_positions = scenario.origins
        """Where the robots are when this robot starts playing (eqs. (10)-(11)'s initial opinions):
        their origins, or where it sees them when it reaches a later passage of several."""
        self.arrays = robot_arrays(scenario)
        """The scenario's destinations, radii, speed and acceleration limits (:func:`robot_arrays`)."""
        self.destinations, self.radii = self.arrays[0], self.arrays[1]
        self.accel = self.arrays[3]
        self._accel_key = self.accel.tobytes()  # part of the plan cache's keys, taken once
        self._arrays_keys = (hashable(self.destinations), hashable(self.radii))
        """:func:`hashable` of the (read-only) destinations and radii, for the plan cache's keys."""
        self._everyone = np.ones(scenario.n_robots, dtype=bool)
        self._everyone.flags.writeable = False
        self._everyone_key = hashable(self._everyone)
        """What ``RobotView.known`` is with the paper's sensing (no ages): every robot, and its key."""
        self.game: tuple[int, ...] = ()
        """The robots the opinions are about: this robot and its game players, in increasing index."""
        self.z = np.zeros(0)
        """Opinions over the orders of :attr:`game` (:func:`~nodnav.decision.games.game_orders`)."""
        self.previous: tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...], list[PlanResult]] | None = None
        """The last decision's planning robots, game players, game and plan for each order of the game."""
        self.selected = -1
        """The order (index among the game's) selected at the last decision."""
        self.standoff_periods = 0
        """For how many periods in a row the robot has been in a standoff (:mod:`nodnav.decision.standoff`)."""
        self._to_go_seen: list[np.ndarray] = []
        """Every robot's distance to go as this robot saw it at its last decisions (newest last),
        over the standoff patience (``opinion.standoff_progress: best``)."""
        # How many of those are kept: the periods the standoff patience spans, worked out once.
        self._span = max(1, int(np.ceil(self.params.standoff_patience / self.params.T - 1e-9)))
        # Pure functions of a game (and of the robots planned with it), asked again every period.
        self._games: dict[tuple[int, ...], tuple[np.ndarray, np.ndarray]] = {}
        self._local: dict[tuple[tuple[int, ...], tuple[int, ...]], list[tuple[int, ...]]] = {}
        self._to_go_args: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        self._graphs = plans.graphs  # visibility graphs by radius, shared through the plan cache

    @property
    def sides(self) -> np.ndarray:
        """The side each robot approaches the corridor from (:func:`approach_sides`), ``(N_r,)``;
        with several passages the passage's (:func:`~nodnav.sim.methods.passage_nod_agent` sets them)."""
        return self._sides

    @sides.setter
    def sides(self, sides: np.ndarray) -> None:
        self._sides = sides
        self._sides_key = sides.tobytes()  # part of the plan cache's keys, taken once

    def _positions_key(self, view: RobotView) -> tuple:
        """:func:`hashable` of ``view.positions``, once per round for every agent that sees
        through the same (read-only) window: every agent, with exact sensing."""
        window = view.window_states
        return self.plans.once(("positions", id(window)), lambda: hashable(view.positions), window)

    def _known(self, view: RobotView) -> np.ndarray:
        """``view.known``; with the paper's sensing (no ages) the agent's read-only array of every robot."""
        if view.age is None and view.window_states.shape[0] == len(self._everyone):
            return self._everyone
        return view.known

    def orders_of(self, game: tuple[int, ...]) -> np.ndarray:
        """The passing orders of ``game`` ``((k+1)!, k+1)`` (scenario indices, :func:`game_orders`)."""
        return self._tables(game)[0]

    def _tables(self, game: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        """The orders of ``game`` and this robot's bias over them (memoised)."""
        tables = self._games.get(game)
        if tables is None:
            tables = self._games[game] = (game_orders(game), game_bias(self.bias, game, self.scenario.n_robots,
                                                                       self.params.eta))
        return tables

    def initial_opinions(self, game: tuple[int, ...]) -> np.ndarray:
        """z_i(0) over the orders of ``game``: zero, eqs. (10)-(11) among the game's robots, or the
        given opinions over every order of all robots carried to the game."""
        if self.params.init == "distance":
            d = self.scenario.world.corridor_distance(self.start_positions[list(game)], self.sides[list(game)])
            return distance_initial_opinions(d, passing_orders(len(game)), self.params.K2)
        if self.params.init == "given":
            everyone = tuple(range(self.scenario.n_robots))
            return carry_opinions(np.array(self.params.z0[self.index], dtype=float), everyone, game, self.params.eta)
        return np.zeros(len(self.orders_of(game)))

    def _enter_game(self, game: tuple[int, ...]) -> None:
        """Opinions over ``game``: initial ones at the first decision, else carried over from the
        last game (:func:`carry_opinions`)."""
        if not self.game:
            self.z = self.initial_opinions(game)
        elif game != self.game:
            self.z = carry_opinions(self.z, self.game, game, self.params.eta, carry_groups(self.game, game))
        self.game = game

    def _update_opinion(self, view: RobotView) -> None:
        """Eqs. (4), (9), (8): compare the players' observed motion with last period's plans."""
        assert self.previous is not None  # called from the second decision on
        planning, players, game, plans = self.previous
        social = np.zeros(len(plans))
        if players and self.social:
            columns = [planning.index(k) for k in players]
            # The game's players share the list of plans (plan_all): what follows up to their own
            # columns, once per round for every agent that read the same window with the same plans.
            window = view.window_states
            key = ("eq4 of plans", id(plans), id(window), view.window_times.tobytes(), planning,
                   self.params.estimation, self.params.K1, self._accel_key)
            everyone, planned_ok, dt = self.plans.once(key, lambda: self._eq4_of_plans(view, planning, plans),
                                                       (plans, window))
            if everyone is not None:
                z_prime = np.ascontiguousarray(everyone[:, columns]).T  # the layout decides mean's summation order
            else:
                planned = np.stack([self.plans.states_at(p, view.window_times)[columns] for p in plans])
                z_prime = self._estimated(view.window_states[list(players)], planned, list(players), dt).T
            r = estimate_social_term(z_prime, planned_ok)
            # Eq. (5): A^{jl} = 1 for the strategies l that order the game as j does, each order
            # of the game standing for class_size of the N_r! strategies.
            social = class_size(self.scenario.n_robots, len(game)) * np.add.reduce(r, axis=0)  # r.sum's reduction
        u = self.params.u if self.social else 0.0
        alpha = step_size(view.t, self.params.alpha_min)
        self.z = opinion_update(self.z, social, u, self.params.d, self._tables(game)[1], alpha)

    def _eq4_of_plans(self, view: RobotView, planning: tuple[int, ...],
                      plans: list[PlanResult]) -> tuple[np.ndarray | None, np.ndarray, float]:
        """What :meth:`_update_opinion` reads of the last decision's ``plans`` of the robots
        ``planning``: eq. (4a) of every robot of the plans against ``view``'s window, ``(G, n)``
        (None if the plans' robot counts differ: each agent stacks its players' columns), which
        plans succeeded ``(G,)``, and the window's time step."""
        stacked_key = stack_key(plans, view.window_times)  # its key, part of eq. (4a)'s below
        stacked = self.plans.stacked_states(plans, view.window_times, stacked_key)  # (G, n, M, 4), for the round
        dt = float(view.window_times[1] - view.window_times[0])
        planned_ok = np.array([p.success for p in plans])
        if stacked.ndim != 4:
            return None, planned_ok, dt
        # Eq. (4a) of every robot of the plan, once per round for every agent that saw the
        # same and planned alike (each element reads its own robot's row only).
        rows = list(planning)
        key = ("eq4", *stacked_key, planning,
               self.params.estimation, self.params.K1, view.window_states[rows].tobytes(),
               self.accel[rows].tobytes())
        everyone = self.plans.shared(key, lambda: self._estimated(view.window_states[rows], stacked, rows, dt),
                                     list(plans))
        return everyone, planned_ok, dt

    def _estimated(self, observed: np.ndarray, planned: np.ndarray, robots: list[int], dt: float) -> np.ndarray:
        """Eq. (4a) (:func:`estimated_opinions`) of the robots ``robots`` observed as ``observed``
        ``(N_k, M, 4)`` against ``planned`` ``(G, N_k, M, 4)``, after ``opinion.estimation``'s
        correction, transposed: ``(G, N_k)``."""
        if self.params.estimation == "reachable":
            planned = reachable_predictions(observed, planned, self.accel[robots], dt)
        elif self.params.estimation == "mismatch":
            planned = mismatch_predictions(observed, planned, self.accel[robots], dt)
        return estimated_opinions(observed, planned, dt, self.params.K1).T

    def _select_players(self, view: RobotView) -> tuple[int, ...]:
        """Eqs. (6)-(7) on the observed positions; with ``conflict: undecided``, among the robots
        not yet seen to enter the corridor first (those that have are ahead in every order)."""
        world, positions = self.scenario.world, view.positions
        n = len(positions)
        if self.n_players == n - 1 and self.eligible is None and (view.age is None or view.seen.all()):
            # Eq. (7) picks every other robot whatever the likelihoods are (select_game_players).
            return tuple(j for j in range(n) if j != self.index)
        undecided = self.params.conflict == "undecided" and view.entered

        def likelihoods() -> np.ndarray:
            L = conflict_likelihood(positions, world.corridor_distance(positions, self.sides), self.params.delta)
            return undecided_first(L, view.entered) if undecided else L

        # Every agent of the round that sees the same asks the same (its own row differs only).
        key = ("likelihoods", id(world), self._positions_key(view), self._sides_key, self.params.delta,
               view.entered if undecided else None)
        L = self.plans.shared(key, likelihoods, world)
        return players_in_sight(L, view, self.index, self.n_players, self.eligible)

    def plan_all(self, view: RobotView, game: tuple[int, ...], planning: tuple[int, ...]) -> list[PlanResult]:
        """The joint plan of the robots ``planning`` (increasing index) for every order of ``game``.

        Robots of ``planning`` outside the game have already entered the corridor, so every order
        puts them first, where history has them (:func:`~nodnav.planning.base.feasible_order`);
        game players inside heading opposite ways keep the game's order, and the planner has
        the later of them back out (docs/meet-inside.md).
        Queries list the robots in increasing index whoever asks, so that robots posing the
        same joint problem pose the same query and share its answer through the plan cache.
        """
        key = (game, planning)
        orders = self._local.get(key)
        if orders is None:
            extra = tuple(k for k in planning if k not in game)
            # local_order of each order: every robot of (*extra, *order) is in planning, so the
            # projection keeps the whole order and only the numbering changes.
            local_of = {k: m for m, k in enumerate(planning)}
            orders = self._local[key] = [tuple(local_of[k] for k in (*extra, *order))
                                         for order in self.orders_of(game).tolist()]
        if not orders:
            return []
        # The queries of all orders share their state: one request, asked in each order. Every
        # agent of the round that plans the same robots from the same observed window (with exact
        # sensing the simulator hands every view the same read-only window) builds the same one:
        # built once, keyed by what joint_requests reads (the scenario's world and robot_arrays,
        # the window, the time, the entry records, the robots; its first order is no part of the
        # queries: plan_order asks each order of it).
        template_key = ("template", id(self.scenario), id(view.window_states), view.t, view.entered, planning)
        keep = (self.scenario, view.window_states)
        computed = []

        def every_order() -> list[PlanResult]:
            computed.append(True)
            template, state = self.plans.once(template_key, lambda: self._template(view, planning, orders[0]), keep)
            return self.plans.plan_orders(template, orders, state)

        # The game's players that plan the same robots ask the same queries (orders is a function
        # of the game and planning): answered once per round, the list only read.
        plans = self.plans.once(("plans", *template_key, game), every_order, keep)
        if not computed:
            self.plans.hits += len(orders)  # counted as plan_orders counts answers from the round
        return plans

    def _template(self, view: RobotView, planning: tuple[int, ...],
                  order: tuple[int, ...]) -> tuple[PlanRequest, tuple]:
        """The planning query of ``planning`` in ``order`` from ``view`` and its :func:`state_key`."""
        template = joint_requests(self.scenario, view, planning, [order], self.arrays)[0]
        return template, state_key(template)

    def committed(self, view: RobotView, players: tuple[int, ...]) -> tuple[int, ...]:
        """Robots that are not game players but join the plan, as robots whose place in the order
        is already decided: with ``nonplayers: entered``, every robot seen inside the corridor.

        Planning with them costs little (history fixes them at the front of every order) and
        keeps a robot from planning into a corridor that someone it does not play with is coming
        through; they take no part in eq. (4). With ``crossed: planned``, also the robots seen done
        with the corridor that stand packed round the way of a robot of the plan
        (:func:`~nodnav.sim.parked.packed_crossed`). A robot with no game players (k = 0) is the paper's
        no-coordination case, its Fig. 3 baseline, and stays literal: it plans alone, as with
        ``static``. (Planning robots it saw enter would be coordination of its own: first come,
        first served.)
        """
        if self.params.nonplayers != "entered" or self.n_players == 0:
            return ()
        world = self.scenario.world
        entered: tuple[int, ...] = ()
        if view.entered:  # the corridor test only for the robots seen to enter
            window = view.window_states  # every agent of the round that sees through it asks the same
            inside = self.plans.shared(("in corridor", id(world), id(window)),
                                       lambda: world.in_corridor(view.positions), (world, window))
            known = self._known(view)
            entered = tuple(k for k in view.entered if inside[k] and known[k] and k != self.index and k not in players)
        if self.params.crossed != "planned":
            return entered
        # Robots done with the corridor packed round the way of a robot of the plan (sim/parked.py).
        # With several passages only robots with no passage left are done: one that has crossed
        # this passage on its way to another is moving on (its destination in this view is a
        # local goal it drives through), not parked, and planning it as parked at the front of
        # every order blocks the robots that wait for it (docs/several-passages.md).
        s = self.scenario
        planning = [self.index, *players, *entered]
        if len(planning) == s.n_robots:  # packed_crossed adds robots outside the plan only: there are none
            return entered
        known = self._known(view)
        if known is self._everyone and self.settled is None:  # every robot known and done: the key is the agent's
            done, done_key = known, self._everyone_key
        else:
            done = known if self.settled is None else known & self.settled
            done_key = hashable(done)
        # Game players of one game ask the same, so the plan cache answers once per round.
        state = crossed_state(world, self._positions_key(view), *self._arrays_keys, done_key,
                              s.sim.goal_tolerance, s.planner.margin)
        return entered + self.plans.packed_crossed(world, view.positions, self.destinations, self.radii, done,
                                                   planning, s.sim.goal_tolerance, s.planner.margin, state)

    def standoff(self, view: RobotView, players: tuple[int, ...]) -> int:
        """The game player this robot has been in a standoff with for ``standoff_patience``
        seconds (:mod:`nodnav.decision.standoff`), or -1."""
        patience = self.params.standoff_patience
        partner = -1
        to_go_now = None
        if patience > 0 and self.previous is not None and self.selected >= 0 and players:
            planning, _, _, plans = self.previous
            # Every robot at the start and end of the period: one look-up per window for the round.
            window = view.window_states
            to_go = self.plans.once(("ends to go", id(self.scenario.world), id(window), self._sides_key,
                                     self._arrays_keys[0]),
                                    lambda: self._shared_to_go(window[:, [0, -1], :2]), window)
            to_go_now = to_go[:, 1].copy()  # where every robot is now, as below
            if self.params.standoff_progress == "best":  # beyond the best over the patience
                progress = progress_beyond_best(to_go[:, 1], [to_go[:, 0], *self._to_go_seen])
            else:
                progress = -(to_go[:, 1] - to_go[:, 0])  # -np.diff(to_go, axis=1)[:, 0], the same operations
            if progress[self.index] < STALL_DISTANCE:
                rows = list(players)
                now = view.positions[rows]
                arrived = np.linalg.norm(now - self.destinations[rows], axis=1) <= self.scenario.sim.goal_tolerance
                # standoff_partner reads the plan only for a robot that has stalled while a player
                # that has not arrived stalled too: it finds no partner among the others.
                if ((progress[rows] < STALL_DISTANCE) & ~arrived).any():
                    selected = self.plans.states_at(plans[self.selected], view.window_times)
                    plan = selected[:, [0, -1], :2]  # (n_plan, 2, 2)
                    plan_to_go = self._shared_to_go(plan, planning)
                    planned = -(plan_to_go[:, 1] - plan_to_go[:, 0])
                    columns = [planning.index(k) if k in planning else -1 for k in players]
                    players_planned = np.array([planned[c] if c >= 0 else 0.0 for c in columns])
                    found = standoff_partner(progress[self.index], progress[rows],
                                             planned[planning.index(self.index)], players_planned,
                                             players_distance=np.linalg.norm(now - view.positions[self.index], axis=1),
                                             players_arrived=arrived)
                    partner = players[found] if found >= 0 else -1
        if patience > 0 and self.params.standoff_progress == "best":
            span = self._span
            if to_go_now is None:
                to_go_now = self._to_go(view.positions[:, None])[:, 0]
            self._to_go_seen = [*self._to_go_seen, to_go_now][-span:]
        self.standoff_periods = self.standoff_periods + 1 if partner >= 0 else 0
        return partner if self.standoff_periods * self.params.T >= patience - 1e-9 else -1

    def _shared_to_go(self, positions: np.ndarray, robots: tuple[int, ...] | None = None) -> np.ndarray:
        """:meth:`_to_go`, computed once per round for every agent that asks it of the same
        positions, robots, approach sides and destinations (read-only)."""
        world = self.scenario.world
        key = ("to_go", id(world), positions.shape, positions.tobytes(), robots, self._sides_key,
               self._arrays_keys[0])
        return self.plans.shared(key, lambda: self._to_go(positions, robots), world)

    def _to_go(self, positions: np.ndarray, robots=None) -> np.ndarray:
        """Distance to go (m) through the corridor of ``robots`` (default all) at ``positions``
        ``(n, M, 2)``."""
        shape = positions.shape[:-1]
        args = self._to_go_args.get((robots, shape))
        if args is None:
            # The destinations and sides laid out as the positions (distance_to_go broadcasts them
            # so otherwise, at every call): the same values, read-only.
            rows = list(range(self.scenario.n_robots)) if robots is None else list(robots)
            args = self._to_go_args[(robots, shape)] = (
                np.ascontiguousarray(np.broadcast_to(self.destinations[rows][:, None], (*shape, 2))),
                np.ascontiguousarray(np.broadcast_to(self.sides[rows][:, None], shape)))
        return distance_to_go(self.scenario.world, positions, *args)

    def decide(self, view: RobotView) -> Decision:
        """Algorithm 1, procedure RobotNavigation(t)."""
        if self.previous is not None:
            self._update_opinion(view)
        players = self._select_players(view)
        game = tuple(sorted((self.index, *players)))
        self._enter_game(game)
        x = strategy_probabilities(self.z, self.params.eta)
        robots = (self.index, *players, *self.committed(view, players))
        planning = tuple(sorted(robots))
        plans = self.plan_all(view, game, planning)
        # Algorithm 1 selects by x; an order the planner found no path for cannot be followed.
        available = np.array([p.success for p in plans])
        partner = self.standoff(view, players)
        orders = self.orders_of(game)
        if partner >= 0:  # the lower number of a standoff goes first
            first, second = min(self.index, partner), max(self.index, partner)
            by_convention = available & precedence_mask(orders, first, second)
            available = by_convention if by_convention.any() else available
        choice = selection_probabilities(x, available)
        strategy = weighted_choice(self.rng, choice)
        self.selected = strategy
        self.previous = (planning, players, game, plans)
        plan = plans[strategy]
        if not available.any():  # nothing to follow: get out of everybody's way
            plan = clearing_plan(self.scenario, view, planning, self.index, plan, self._graphs)
        return Decision.built(strategy=strategy, robots=robots, plan=relabel(plan, [planning.index(k) for k in robots]),
                        opinions=self.z.copy(), probabilities=x, players=players, game=game,
                        order=tuple(orders[strategy].tolist()))
