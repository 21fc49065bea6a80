"""The closed loop: decisions every opinion period T, control and physics every control step.

:class:`Simulation` has one visible shape, like a Gymnasium environment: :meth:`Simulation.step`
advances one control step (calling the method's decision rule first when a period starts) and
says whether the trial is over. :func:`run_trial` runs a whole trial and returns a
:class:`TrialResult`.
"""

from __future__ import annotations

import logging
import time
from typing import Callable

import numpy as np

from nodnav.control.base import STEP_FRACTIONS
from nodnav.decision.games import selections_agree
from nodnav.decision.strategies import strategy_index
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import INSIDE, RIGHT, _distance_to_go_kernel
from nodnav.sim.agent_queries import approach_sides, robot_arrays
from nodnav.sim.contact_checks import contact_counts, contact_tally, straight_substeps
from nodnav.sim.failure import collision_kind
from nodnav.sim.history import History
from nodnav.sim.methods import is_pedestrian, make_team, robot_methods
from nodnav.sim.metrics import compute_metrics
from nodnav.sim.progress import PlanProgress, judge_progress, sides_changed
from nodnav.sim.sensing import Sight, Tracker, within_sight
from nodnav.sim.several import passage_sides, several, team_routes
from nodnav.sim.team_contacts import PeopleContacts, team_metrics
from nodnav.sim.trial_result import TrialResult  # defined there; imported from here by callers
from nodnav.sim.views import RobotView

log = logging.getLogger(__name__)

#: Sub-steps at which contacts are checked between two control steps: where the controllers
#: report their motion (:data:`~nodnav.control.base.STEP_FRACTIONS`), else on straight lines.
CONTACT_SUBSTEPS = len(STEP_FRACTIONS)

#: Side code of a robot the observer does not see: neither inside nor on a side, so that it
#: neither enters nor leaves the observer's record of corridor entries.
UNSEEN = 99


def _frozen(array: np.ndarray) -> np.ndarray:
    """``array``, made read-only (it is shared by every reader of a step's views)."""
    array.flags.writeable = False
    return array


def trial_generators(seed: int, n_robots: int) -> tuple[list[np.random.Generator], list[np.random.Generator]]:
    """Independent generators for one trial: one per robot for its decisions, one per robot for its sensing."""
    children = np.random.SeedSequence(seed).spawn(2 * n_robots)
    gens = [np.random.default_rng(c) for c in children]
    return gens[:n_robots], gens[n_robots:]


class Simulation:
    """One trial of ``scenario`` with ``method``, seeded by ``seed``."""

    def __init__(self, scenario: Scenario, method: str = "nod", seed: int = 0, planner=None):
        scenario = within_sight(scenario)  # speed limits for a sensor range (itself by default)
        self.scenario = scenario
        self.seed = int(seed)
        n = scenario.n_robots
        decision_rngs, self.sensor_rngs = trial_generators(self.seed, n)
        self.method = make_team(scenario, method, decision_rngs, planner)
        self.robot_methods = robot_methods(scenario, method)
        """Each robot's method (``robots[i].method``, else ``method``)."""
        self.pedestrians = np.array([is_pedestrian(m) for m in self.robot_methods], dtype=bool)
        """Which robots are people (:mod:`nodnav.sim.person`): their contacts are attributed, not fatal."""
        self.people = PeopleContacts(scenario, self.pedestrians) if self.pedestrians.any() else None
        ctrl = scenario.controller
        self.dt = ctrl.dt
        self.steps_per_decision = int(round(scenario.opinion.T / ctrl.dt))
        self.sides = approach_sides(scenario)
        # The scenario builds these anew at every access: once per trial, read-only.
        self._destinations, self._radii, self._max_speeds, _ = robot_arrays(scenario)
        self.k = 0
        self.t = 0.0
        self.positions = scenario.origins.copy()
        self.velocities = np.zeros_like(self.positions)
        sensing = scenario.sensing
        self.sight = Sight(scenario.world, sensing, scenario.destinations) if sensing.limited else None
        """Who sees whom and what each robot keeps of those it does not (:mod:`nodnav.sim.sensing`);
        None with the paper's sensing (everyone sees everyone)."""
        if self.sight is not None:
            self.sight.update(self.t, self.positions)
        noisy = scenario.sim.observation_noise > 0 or sensing.drop_probability > 0
        accel = np.array([r.max_accel for r in scenario.robots])
        self.trackers = ([Tracker(self.dt, accel, scenario.sim.observation_noise) for _ in range(n)]
                         if noisy and sensing.filter == "kalman" else None)
        """Each robot's Kalman filters of the others (:class:`~nodnav.sim.sensing.Tracker`); None
        without noise or loss, or with ``sensing.filter: none``."""
        self._exact = not noisy and self.sight is None
        """Whether every robot observes exactly the truth (the paper's sensing): then all observe
        the same states, computed once a step and shared (read-only) by every robot's record."""
        self.observed: list[list[np.ndarray]] = [[] for _ in range(n)]
        # Each robot's own record of what it observed (noisy for the others), newest last. With
        # exact sensing every record is the same: one list, shared (and only read) by every robot.
        if self._exact:
            self.observed = [self.observed[0]] * n
        for i in range(1 if self._exact else n):
            self.observed[i].append(self._observe(i))
        # Each robot's window of the last opinion period (N_r, M, 4), shifted by one sample a
        # step rather than stacked anew; before one whole period has passed it is padded with
        # the first sample. Read-only: every view of a step shares it (and with exact sensing
        # every robot's is the same array).
        m = self.steps_per_decision + 1
        firsts = [obs[0] for obs in self.observed[:1 if self._exact else n]]
        self._windows = [_frozen(np.repeat(first[:, None], m, axis=1)) for first in firsts]
        if self._exact:
            self._windows = self._windows * n
        self._last_sides: list[np.ndarray | None] = [None] * len(scenario.world.passages)
        # The true sides of each passage at the last update (none yet: 99, no side).
        self._last_truth = [np.full(n, UNSEEN, dtype=np.int64) for _ in scenario.world.passages]
        # sides_changed's arguments of each passage after the positions, read once.
        self._sides_args = [(p.along_x, p.axis[0], p.axis[1], p.s_start, p.s_end) for p in scenario.world.passages]
        self._window_offsets = self.dt * np.arange(m)[::-1]
        self.routes = team_routes(self.method, scenario) if several(scenario) else None
        """Each robot's route with several passages (:mod:`nodnav.sim.several`); None with one."""
        passages = scenario.world.passages
        self._passage_sides = ([self.sides] if self.routes is None else
                               [passage_sides(scenario, self.routes, k) for k in range(len(passages))])
        g = scenario.world.passage
        self._to_go_arguments = (np.ascontiguousarray(self._destinations),
                                 np.ascontiguousarray(self.sides, dtype=np.int64), scenario.world.entrance_array,
                                 g.along_x, g.axis[0], g.axis[1], g.s_start, g.s_end)
        self.entered_by: list[tuple[list[int], list[list[int]]]] = [([], [[] for _ in range(n)]) for _ in passages]
        """Per passage, the true entry log and each robot's own (the first passage's are
        :attr:`entered_true` and :attr:`entered_seen`)."""
        self.entered_true, self.entered_seen = self.entered_by[0]
        self._update_entries()
        self.arrival = np.full(n, np.nan)
        self.best_to_go = self._to_go()
        self.last_progress = 0.0
        self.plan_progress = PlanProgress(n, scenario.sim.progress_epsilon) if scenario.sim.progress == "plan" else None
        # How far a cursor may look ahead along its plan in one step (m), and empty routes without plans.
        self._reach = 2.0 * self._max_speeds * self.dt + 0.1
        self._no_routes = (np.zeros((0, 2)), np.zeros(0), np.full((n, 2), -1, dtype=np.int64))
        self._no_cursors = (np.zeros(n, dtype=int), np.zeros(n))
        self.outcome = ""
        self.collisions = 0
        self.collision_kind = ""
        self.mpc_infeasible = 0
        self.plan_failures = 0
        self._strategy_indices: dict[tuple[int, ...], int] = {}
        self.history = History(scenario=scenario, method=self.method.name, seed=self.seed)
        self._record_state()

    # -- sensing -------------------------------------------------------------------------------

    def _observe(self, observer: int) -> np.ndarray:
        """States (px, py, vx, vy) of every robot as ``observer`` sees them now ``(N_r, 4)``."""
        states = np.concatenate([self.positions, self.velocities], axis=1)
        sigma = self.scenario.sim.observation_noise
        if sigma > 0:
            noise = self.sensor_rngs[observer].normal(0.0, sigma, size=states.shape)
            noise[observer] = 0.0
            states = states + noise
        drop = self.scenario.sensing.drop_probability
        if drop > 0 or self.trackers is not None:
            measured = np.ones(len(states), dtype=bool)
            if drop > 0:  # drawn only when asked for, so that the noise streams stay the same
                measured = self.sensor_rngs[observer].random(len(states)) >= drop
                measured[observer] = True
            if self.sight is not None:
                measured &= self.sight.visible[observer]
            if self.trackers is not None:
                own = states[observer].copy()
                states = self.trackers[observer].update(states, measured)
                states[observer] = own
            elif self.observed[observer]:  # a lost observation: the last one stands
                states = np.where(measured[:, None], states, self.observed[observer][-1])
        if self.sight is not None:
            states = self.sight.apply(observer, states)
        return states

    def _update_entries(self) -> None:
        """Corridor entries, from the truth and from each robot's own observations.

        A robot counts as entered from the first step it is seen inside the corridor; one seen
        back on the side it came from has backed out and no longer counts. Robots first seen
        inside at the same step (robots that start inside) are taken in the order of how little
        corridor they have left ahead of them: the one nearest its exit is ahead.
        """
        n = self.scenario.n_robots
        changed = None
        if self._exact:  # everyone sees the truth: the records change only when its sides do (each passage's checked)
            changed = [sides_changed(self.positions, *args, truth) for args, truth in zip(self._sides_args,
                                                                                            self._last_truth)]
            if True not in changed:
                return
        seen = None
        for number, (passage, approach, (true_log, seen_logs)) in enumerate(zip(
                self.scenario.world.passages, self._passage_sides, self.entered_by)):
            if changed is not None and not changed[number]:
                continue
            if seen is None:
                seen = np.stack([self.positions] + [self.observed[i][-1][:, :2] for i in range(n)])
            s = passage.along(seen)
            sides = passage.side_of_along(s)
            if self.sight is not None:  # a robot's record changes only with what it sees now
                sides = sides.copy()
                sides[1:][~self.sight.visible] = UNSEEN
            # Each record takes in the robots seen inside and not in it and drops those seen back
            # on their approach side: after one update with these sides, another changes nothing.
            last = self._last_sides[number]
            if last is not None and np.array_equal(last, sides):
                continue
            self._last_sides[number] = sides
            left_ahead = np.where(approach == RIGHT, s - passage.s_start, passage.s_end - s)
            for log_, side, ahead in zip([true_log] + seen_logs, sides.tolist(), left_ahead):
                new = [k for k in range(n) if side[k] == INSIDE and k not in log_]
                log_.extend(sorted(new, key=lambda k: (ahead[k], k)))
                for k in range(n):
                    if side[k] == approach[k] and k in log_ and approach[k] != INSIDE:
                        log_.remove(k)

    def _to_go(self) -> np.ndarray:
        """Distance each robot still has to go (m): through the passage's entrances with one
        passage, along its route with several."""
        if self.routes is None:  # distance_to_go's kernel on arrays prepared once
            return _distance_to_go_kernel(self.positions, *self._to_go_arguments)
        return np.array([route.to_go(p) for route, p in zip(self.routes, self.positions)])

    def views(self) -> dict[int, RobotView]:
        """Every robot's view of the last opinion period."""
        times = self.t - self._window_offsets
        first = self.entered_seen[0]
        seen_logs = self.entered_seen
        if self._exact and self.routes is None and seen_logs.count(first) == len(seen_logs):
            # Everyone sees the truth through one window with the same entry records: one view for all.
            return dict.fromkeys(range(len(seen_logs)), RobotView.built(self.t, times, self._windows[0], tuple(first)))
        out = {}
        for i in range(self.scenario.n_robots):
            age = None if self.sight is None else self.sight.ages(i, self.t)
            spread = None
            if self.trackers is not None:
                spread = self.trackers[i].position_sigma.copy()
                spread[i] = 0.0
            several_ = tuple(tuple(seen[i]) for _, seen in self.entered_by) if self.routes is not None else ()
            out[i] = RobotView.built(self.t, times, self._windows[i], tuple(self.entered_seen[i]), age, spread,
                                     several_)
        return out

    # -- the loop ------------------------------------------------------------------------------

    def step(self) -> bool:
        """Advance one control step; return whether the trial is over."""
        if self.outcome:
            return True
        views = self.views()
        if self.k % self.steps_per_decision == 0:
            self._decide(views)
        results = self.method.act(self.t, views)
        positions, velocities = self.positions, self.velocities
        n = len(positions)
        # Where each robot passes: every column is written below when every robot has a result.
        path = (np.empty((CONTACT_SUBSTEPS, n, 2)) if len(results) == n else
                np.repeat(positions[None], CONTACT_SUBSTEPS, axis=0))
        for i, res in results.items():
            if not res.success:
                self.mpc_infeasible += 1
                self.history.events.append({"t": round(self.t, 6), "robot": i, "kind": "mpc", "reason": res.reason})
            if res.step_positions is not None:
                path[:, i] = res.step_positions
            else:
                path[:, i] = straight_substeps(positions[i:i + 1], res.next_position[None], STEP_FRACTIONS)[:, 0]
            positions[i] = res.next_position
            velocities[i] = res.next_velocity
        self.k += 1
        self.t = self.k * self.dt
        if self.sight is not None:
            self.sight.update(self.t, self.positions)
        if self._exact:  # everyone observes the same: one observation, one (shared) record and one window for all
            seen = self._observe(0)
            window = _frozen(np.concatenate((self._windows[0][:, 1:], seen[:, None]), axis=1))
            record = self.observed[0]
            record.append(seen)
            del record[:-(self.steps_per_decision + 2)]
            self._windows = [window] * n
        else:
            for i in range(n):
                seen = self._observe(i)
                self.observed[i].append(seen)
                del self.observed[i][: -(self.steps_per_decision + 2)]
                self._windows[i] = _frozen(np.concatenate((self._windows[i][:, 1:], seen[:, None]), axis=1))
        self._update_entries()
        self._record_state()
        self._judge(path)
        return bool(self.outcome)

    def _decide(self, views: dict[int, RobotView]) -> None:
        decisions = self.method.decide(views)
        n, h = self.scenario.n_robots, self.history
        width = max([len(d.opinions) for d in decisions.values()] + [0])
        # np.full's values, without its Python; the masks and ranks set at once for every robot below.
        opinions, probs, chosen = np.empty((n, width)), np.empty((n, width)), np.empty(n)
        strategies, ranks = np.empty(n, dtype=np.int64), np.empty((n, n), dtype=np.int64)
        for a in (opinions, probs, chosen):
            a.fill(np.nan)
        strategies.fill(-1)
        ranks.fill(-1)
        games = np.zeros((n, n), dtype=bool)
        players = np.zeros((n, n), dtype=bool)
        game_at: tuple[list[int], list[int]] = ([], [])
        player_at: tuple[list[int], list[int]] = ([], [])
        rank_at: tuple[list[int], list[int], list[int]] = ([], [], [])
        for i, d in decisions.items():
            opinions[i, :len(d.opinions)], probs[i, :len(d.probabilities)] = d.opinions, d.probabilities
            game_at[0].extend([i] * len(d.game))
            game_at[1].extend(d.game)
            rank_at[0].extend([i] * len(d.order))
            rank_at[1].extend(d.order)
            rank_at[2].extend(range(len(d.order)))
            if len(d.order) == n:
                strategies[i] = self._strategy_index(d.order)
            if d.strategy >= 0 and len(d.probabilities):
                chosen[i] = d.probabilities[d.strategy]
            player_at[0].extend([i] * len(d.players))
            player_at[1].extend(d.players)
            if self.plan_progress is not None:
                # The plan's first robot is the deciding one: its own path (Decision.own_trajectory's).
                self.plan_progress.follow(i, d.plan.trajectory.positions[:, 0] if d.plan.success else None)
            if not d.plan.success:
                self.plan_failures += 1
                h.events.append({"t": round(self.t, 6), "robot": i, "kind": "plan", "reason": d.plan.reason})
        games[game_at] = True
        players[player_at] = True
        ranks[rank_at[:2]] = rank_at[2]
        h.decision_times.append(self.t)
        h.opinions.append(opinions)
        h.probabilities.append(probs)
        h.strategies.append(strategies)
        h.chosen.append(chosen)
        h.games.append(games)
        h.ranks.append(ranks)
        h.players.append(players)
        undecided = np.ones(n, dtype=bool)  # ~np.isin(np.arange(n), entered_true)
        undecided[self.entered_true] = False
        h.undecided.append(undecided)

    def _strategy_index(self, order: tuple[int, ...]) -> int:
        """:func:`~nodnav.decision.strategies.strategy_index` of ``order``, remembered per trial."""
        index = self._strategy_indices.get(order)
        if index is None:
            index = self._strategy_indices[order] = strategy_index(order)
        return index

    def _record_state(self) -> None:
        self.history.times.append(self.t)
        self.history.positions.append(self.positions.copy())
        self.history.velocities.append(self.velocities.copy())

    def _judge(self, path: np.ndarray) -> None:
        """Outcome after a step in which the robots passed ``path`` ``(S, N, 2)`` (at the step's
        :data:`STEP_FRACTIONS`, ending where they are now)."""
        s, world = self.scenario, self.scenario.world
        if self.people is None and world.wall_grid is not None:  # a map's many boxes: through the index
            clear = world.clearance(np.ascontiguousarray(path.reshape(-1, 2)))
            pair_hits, wall_hits = contact_tally(path, self._radii, s.sim.collision_tolerance, clear)
            kind = collision_kind(pair_hits, wall_hits)
        elif self.people is None:
            pair_hits, wall_hits = contact_counts(path, self._radii, s.sim.collision_tolerance, world.bounds_array,
                                                  world.obstacle_array, world.piece_array)
            kind = collision_kind(pair_hits, wall_hits)
        else:  # robots among themselves and with walls as always; contacts with people are attributed
            robots = ~self.pedestrians
            pair_hits, wall_hits = contact_counts(np.ascontiguousarray(path[:, robots]), self._radii[robots],
                                                  s.sim.collision_tolerance, world.bounds_array, world.obstacle_array,
                                                  world.piece_array)
            kind = collision_kind(pair_hits, wall_hits)
            start = self.history.positions[-2]
            caused = self.people.judge(start, path, self.t - self.dt, self.dt, self.history.events)
            if caused and not (pair_hits or wall_hits):
                pair_hits, kind = caused, "robot-person"
        if pair_hits or wall_hits:
            self.collisions = pair_hits + wall_hits
            self.collision_kind = kind
            self._finish("collision")
            return
        # Arrivals, then progress towards the goals and along the plans, in one compiled call.
        progress = self.plan_progress
        flat = self._no_routes if progress is None else progress.end_to_end()
        cursor, credited = (self._no_cursors if progress is None else (progress.cursor, progress.credited))
        finished, improved = judge_progress(self.positions, self._destinations, s.sim.goal_tolerance, self.t,
                                            self.arrival, self._to_go(), self.best_to_go, s.sim.progress_epsilon,
                                            progress is not None, *flat, self._reach,
                                            s.sim.progress_epsilon if progress is None else progress.epsilon,
                                            cursor, credited)
        if finished:
            self._finish("success")
            return
        if improved:
            self.last_progress = self.t
        if self.t - self.last_progress >= s.sim.deadlock_time:
            self._finish("deadlock")
        elif self.t >= s.time_limit - 1e-9:
            self._finish("timeout")

    def _finish(self, outcome: str) -> None:
        self.outcome = outcome
        self.history.outcome = outcome
        self.history.entry_order = list(self.entered_true)
        self.history.events.append({"t": round(self.t, 6), "kind": "outcome", "reason": outcome})
        log.info("trial %s seed %d: %s at t = %.1f s", self.scenario.name, self.seed, outcome, self.t)

    def _consensus(self) -> bool:
        """Whether the robots agreed on the order of those still to enter, at the last decision
        at which at least two had not entered (the last moment the order was open)."""
        for ranks, undecided in zip(reversed(self.history.ranks), reversed(self.history.undecided)):
            if undecided.sum() >= 2:
                return selections_agree(ranks, np.flatnonzero(undecided))
        return False

    def result(self, wall_time: float) -> TrialResult:
        """The trial's result (call once :meth:`step` has returned true)."""
        n = self.scenario.n_robots
        order = tuple(self.entered_true)
        strategy = strategy_index(order) if len(order) == n else -1
        consensus = self._consensus()
        makespan = float(np.nanmax(self.arrival)) if self.outcome == "success" else float("nan")
        metrics = compute_metrics(self.history)
        if self.people is not None or len(set(self.robot_methods)) > 1:
            metrics.update(team_metrics(self.scenario, self.robot_methods, self.pedestrians, self.arrival,
                                        self.history.events, self.outcome))
        return TrialResult(outcome=self.outcome, sim_time=self.t, wall_time=wall_time, makespan=makespan,
                           min_separation=metrics["min_separation_m"], collisions=self.collisions, entry_order=order,
                           strategy=strategy, consensus=consensus, time_to_goal=tuple(float(a) for a in self.arrival),
                           mpc_infeasible=self.mpc_infeasible, plan_failures=self.plan_failures, history=self.history,
                           metrics=metrics, collision_kind=self.collision_kind)


def run_trial(scenario: Scenario, method: str = "nod", seed: int = 0, planner=None,
              progress: Callable[[float, float], None] | None = None) -> TrialResult:
    """Simulate one trial to its end; ``progress(t, time_limit)`` is called after every step."""
    start = time.perf_counter()
    sim = Simulation(scenario, method, seed, planner)
    while not sim.step():
        if progress is not None:
            progress(sim.t, scenario.time_limit)
    return sim.result(time.perf_counter() - start)
