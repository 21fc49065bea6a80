"""How a robot follows its selected joint plan between two decisions: by precedence, or by the clock.

The appendix has each robot track its path of the selected joint plan as a function of time.
With ``execution.mode: gated`` (the default) a robot instead keeps a clock per robot of its plan
(itself and its game players) that runs with real time but stops at the last sample whose
precedences (:mod:`nodnav.planning.dependencies`) are met by what the robot observes: it goes
where another robot of its plan was earlier in the plan only once that robot has actually moved
on. Its MPC reference is its own path read on its own clock, held at that sample; its prediction
of a game player is the player's planned motion read on the player's clock, started from where
the player is seen now. ``timed`` is the paper's literal tracking by the clock.

Only what the robot observes enters: the positions of the robots of its plan. All robots of a
plan that they agree on compute the same precedences, so a follower waits where the plan wants
it to wait for as long as the leader actually needs, and a robot that must first get out of
another's way is waited for.

The run-time rule beside it, :class:`ReactionMargins`: towards which other robots a robot keeps
the reaction margin (:func:`reaction_margin`) from their braking predictions at a control step
(``execution.reaction_margin``, ``surprise``: :func:`unexpected_approach`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from nodnav.compiled import compiled
from nodnav.planning.base import JointTrajectory, interpolate_positions
from nodnav.planning.dependencies import APPROACH_EPSILON, _dependencies_kernel, gate_kernel, progress_kernel
from nodnav.scenario.schema import Scenario
from nodnav.sim.agent import RobotView


@dataclass(frozen=True)
class ExecutionSettings:
    """What :class:`PlanExecution` needs, derived from the scenario once per trial."""

    gated: bool
    """Whether to execute by precedence (else by the clock, as the appendix)."""
    dt: float
    """Control step: how far the clocks run per step (s)."""
    horizon: float
    """How much plan time after the clocks a robot ever reads (s): the opinion period plus the
    MPC horizon, since a plan is replaced at the next decision."""
    lag: float
    """Least time between the two samples of a precedence (s), see
    :func:`~nodnav.planning.dependencies.plan_dependencies`."""
    margin: float
    """Conflict distance beyond the sum of two robots' radii (m)."""
    tolerance: float
    """Distance (m) within which a robot still counts as at the earliest of its nearest samples
    (:func:`observed_progress`)."""

    @functools.cached_property
    def sample_times(self) -> np.ndarray:
        """The times (s after a plan's start) at which a gated execution resamples its plan: the
        control steps of the first opinion period and one horizon, which is all it ever reads
        (read-only, shared by every execution of a trial)."""
        steps = int(np.ceil(self.horizon / self.dt)) + 1
        times = self.dt * np.arange(steps)
        times.flags.writeable = False
        return times

    @functools.cached_property
    def lag_steps(self) -> int:
        """:attr:`lag` in control steps, at least one
        (:func:`~nodnav.planning.dependencies.plan_dependencies`'s ``lag``)."""
        return max(int(round(self.lag / self.dt)), 1)


class PlanExecution:
    """One robot's execution of one joint plan over ``robots`` (scenario indices, the robot first),
    from the plan's first sample on."""

    def __init__(self, trajectory: JointTrajectory, robots: tuple[int, ...], radii: np.ndarray,
                 settings: ExecutionSettings):
        self.trajectory = trajectory
        self.robots = robots
        self.settings = settings
        self.t0 = float(trajectory.times[0])
        n = len(robots)
        self.clocks = np.zeros(n)
        if settings.gated:
            # Only the first opinion period and one horizon of the plan are ever read: resample
            # that much at the control step, and find its precedences, in one compiled call.
            self.sample_times = settings.sample_times
            self.samples, self.dependencies = execution_arrays(
                trajectory.times, trajectory.positions, self.t0, self.sample_times, np.asarray(radii, dtype=float),
                settings.margin, settings.lag_steps, APPROACH_EPSILON)
            self.progress = np.zeros(n, dtype=np.int64)
            self.gates = np.full(n, len(self.sample_times) - 1, dtype=np.int64)

    def observe(self, positions: np.ndarray) -> None:
        """Update every robot's progress and gate from the observed ``positions`` ``(n, 2)`` of the
        plan's robots (call once per control step, before reading references)."""
        if not self.settings.gated:
            return
        # observed_progress for every robot, then gate_sample for every robot, in one compiled call.
        _observe_kernel(self.samples, np.ascontiguousarray(positions, dtype=float), self.settings.tolerance,
                        self.dependencies, self.progress, self.gates)

    def observe_held(self, positions: np.ndarray, rows: np.ndarray, anchor: np.ndarray,
                     reach: float) -> tuple[int, bool, np.ndarray]:
        """:meth:`observe` from every robot's observed ``positions`` ``(N, 2)`` (``rows``: the
        plan's robots as scenario indices), then what :class:`WaitRelease` reads, all in one
        compiled call (gated execution only): how many robots hold the plan's first robot at its
        gate (:meth:`blockers`), whether any robot of the plan stands farther than ``reach`` from
        where it stood at ``anchor`` ``(N, 2)`` (:func:`moved_beyond`), and which columns hold it
        without having moved so ``(n,)``."""
        stuck = np.zeros(len(self.robots), dtype=np.bool_)
        held, moved = _observe_held_kernel(self.samples, positions, rows, self.settings.tolerance, self.dependencies,
                                           self.progress, self.gates, anchor, reach, stuck)
        return held, moved, stuck

    def blockers(self) -> np.ndarray:
        """Columns of the robots whose precedences hold the plan's first robot (the one executing
        it) at its gate now: its next sample depends on where they have not yet got."""
        if not self.settings.gated or self.gates[0] >= len(self.sample_times) - 1:
            return np.zeros(0, dtype=np.int64)
        row = self.dependencies[self.gates[0] + 1, 0]
        held = row >= self.progress
        held[0] = False
        return np.flatnonzero(held)

    def release(self, columns: np.ndarray, positions: np.ndarray) -> None:
        """The plan's first robot stops waiting for the robots ``columns``: its precedences on them
        are dropped, and its gate follows from the observed ``positions`` ``(n, 2)`` again."""
        self.dependencies[:, 0, np.asarray(columns, dtype=np.int64)] = -1
        self.observe(positions)

    def limits(self) -> np.ndarray:
        """Plan time (s after the plan's start) at which each robot's clock stops for now."""
        if not self.settings.gated:
            return np.full(len(self.robots), np.inf)
        return self.sample_times[self.gates]

    def read(self, offsets: np.ndarray) -> np.ndarray:
        """Plan positions of every robot at ``offsets`` ``(M,)`` (s) after its clock, each held at
        its limit: ``(M, n, 2)``."""
        return read_kernel(self.trajectory.times, self.trajectory.positions, self.t0, self.clocks,
                            np.asarray(offsets, dtype=float), self.limits())

    def read_plain(self, offsets: np.ndarray) -> np.ndarray:
        """:meth:`read` in NumPy, the reference its compiled loop is tested against."""
        when = np.minimum(self.clocks[None, :] + np.asarray(offsets, dtype=float)[:, None], self.limits()[None, :])
        flat = self.trajectory.positions_at(self.t0 + when.reshape(-1)).reshape(len(offsets), -1, len(self.robots), 2)
        columns = np.arange(len(self.robots))
        return flat[:, columns, columns]

    def advance(self) -> None:
        """Run every clock on by one control step, up to its limit."""
        self.clocks = np.minimum(self.clocks + self.settings.dt, np.maximum(self.clocks, self.limits()))


@compiled
def execution_arrays(times, positions, t0, sample_times, radii, margin, lag, epsilon):
    """A gated execution's plan at ``t0 + sample_times`` ``(S, n, 2)``
    (:meth:`~nodnav.planning.base.JointTrajectory.positions_at`'s interpolation) and its
    precedences (:func:`~nodnav.planning.dependencies.plan_dependencies` with the conflict
    distances ``radii[m] + radii[j] + margin``), in one call: the same kernels on the same numbers."""
    samples = interpolate_positions(times, positions, t0 + sample_times)
    n = radii.shape[0]
    conflict = np.empty((n, n))
    for m in range(n):
        for j in range(n):
            conflict[m, j] = radii[m] + radii[j] + margin
    return samples, _dependencies_kernel(samples, conflict, lag, epsilon)


def moved_beyond_plain(positions: np.ndarray, anchor: np.ndarray, rows: np.ndarray, reach: float) -> np.ndarray:
    """Which robots ``rows`` stand farther than ``reach`` from where they stood at ``anchor``
    (``(N, 2)`` both): the NumPy reference of :func:`moved_beyond`."""
    return np.linalg.norm(positions[rows] - anchor[rows], axis=1) > reach


@compiled
def moved_beyond(positions, anchor, rows, reach):
    """:func:`moved_beyond_plain` as one loop: the same operations (differences, squares, their
    sum, its square root), without the temporaries and ``norm``'s dispatch per robot and step."""
    out = np.zeros(len(rows), dtype=np.bool_)
    for j in range(len(rows)):
        r = rows[j]
        dx = positions[r, 0] - anchor[r, 0]
        dy = positions[r, 1] - anchor[r, 1]
        out[j] = np.sqrt(dx * dx + dy * dy) > reach
    return out


@compiled
def read_kernel(times, positions, t0, clocks, offsets, limits):
    """:meth:`PlanExecution.read_plain` as one loop: robot ``r``'s own column of the plan at
    ``t0 + min(clocks[r] + offset, limits[r])`` for each offset, interpolated as
    :func:`~nodnav.planning.base.interpolate_positions` does (the other robots' columns at that
    time, which the plain version computes and drops, are not computed)."""
    n_off, n = offsets.shape[0], clocks.shape[0]
    k = times.shape[0]
    out = np.empty((n_off, n, 2))
    for m in range(n_off):
        for r in range(n):
            q = t0 + min(clocks[r] + offsets[m], limits[r])
            if k == 1:
                out[m, r, 0], out[m, r, 1] = positions[0, r, 0], positions[0, r, 1]
                continue
            i = min(max(np.searchsorted(times, q, side="right") - 1, 0), k - 2)
            w = min(max((q - times[i]) / (times[i + 1] - times[i]), 0.0), 1.0)
            for d in range(2):
                start = positions[i, r, d]
                out[m, r, d] = start + w * (positions[i + 1, r, d] - start)
    return out


@compiled
def _observe_kernel(samples, positions, tolerance, dependencies, progress, gates):
    """:meth:`PlanExecution.observe` as one compiled loop: each robot's progress
    (:func:`~nodnav.planning.dependencies.observed_progress`) from ``positions`` ``(n, 2)``, then
    each robot's gate (:func:`~nodnav.planning.dependencies.gate_sample`); updates ``progress``
    and ``gates`` in place."""
    n = positions.shape[0]
    for c in range(n):
        progress[c] = progress_kernel(samples[:, c], positions[c], progress[c], tolerance)
    for c in range(n):
        gates[c] = gate_kernel(dependencies[:, c, :], progress, c)


@compiled
def _observe_held_kernel(samples, positions, rows, tolerance, dependencies, progress, gates, anchor, reach, stuck):
    """:func:`_observe_kernel` on ``positions[rows]``, then :meth:`PlanExecution.blockers` and
    :func:`moved_beyond` element by element: returns the number of blockers and whether any robot
    of the plan moved, and marks in ``stuck`` the blockers that did not."""
    n = rows.shape[0]
    for c in range(n):
        progress[c] = progress_kernel(samples[:, c], positions[rows[c]], progress[c], tolerance)
    for c in range(n):
        gates[c] = gate_kernel(dependencies[:, c, :], progress, c)
    gated = gates[0] < samples.shape[0] - 1
    held, moved = 0, False
    for c in range(n):
        r = rows[c]
        dx = positions[r, 0] - anchor[r, 0]
        dy = positions[r, 1] - anchor[r, 1]
        away = np.sqrt(dx * dx + dy * dy) > reach
        moved = moved or away
        blocker = gated and c > 0 and dependencies[gates[0] + 1, 0, c] >= progress[c]
        held += blocker
        stuck[c] = blocker and not away
    return held, moved


def reaction_margin(speeds: np.ndarray, max_accel: np.ndarray, dt: float) -> np.ndarray:
    """How far (m) a robot's braking trajectory can move within one control step: the others
    predict it braking from where it is now, but it chooses its next step at the same time.

    Over a step of ``dt`` at acceleration up to ``a`` it ends at most ``a dt^2`` from where
    braking would leave it, with a velocity up to ``a dt`` off; braking from speed ``v`` covers
    ``v^2 / (2 a)``, which such a change moves by at most ``(|v| + a dt / 2) dt``. Keeping a
    robot's own plan this much farther from every other robot's braking trajectory than contact
    leaves the plans room when the others move: when neither can follow its plan, neither
    squeezes the other. It constrains the plan, not the robot's own braking from where the plan
    takes it; that both robots can still stop apart is the mutual braking check's
    (:mod:`nodnav.control.mutual_braking`). Its bound of the same motion,
    ``braking_deviation``, counts the velocity change against braking (up to ``2 a dt``) and is
    larger once the robot has stopped: ``2 (|v| + a dt) dt + a dt^2``.
    """
    v = np.asarray(speeds, dtype=float)
    a = np.asarray(max_accel, dtype=float)
    return a * dt * dt + (v + 0.5 * a * dt) * dt


def unexpected_approach(seen_positions: np.ndarray, seen_velocities: np.ndarray, positions: np.ndarray,
                        robot: int, others: np.ndarray | list[int], dt: float, threshold: float) -> np.ndarray:
    """Which ``others`` came towards ``robot`` over the last control step more than ``threshold``
    (m) beyond where their velocity one step ago would have taken them ``(len(others),)``.

    Each other robot's deviation from its constant-velocity step, ``p_j - (p_j' + v_j' dt)``, is
    projected on the unit vector from it to ``robot``: starting, speeding up or swerving towards
    the robot counts; braking, backing off or passing by does not.
    """
    expected = seen_positions[others] + seen_velocities[others] * dt
    towards = positions[robot] - positions[others]
    towards = towards / np.maximum(np.linalg.norm(towards, axis=1, keepdims=True), 1e-9)
    return np.einsum("ij,ij->i", positions[others] - expected, towards) > threshold


_MODES = ("off", "always", "conflict", "surprised", "moving")
"""``execution.reaction_margin``'s values, numbered for :func:`careful_radii`."""
_SURPRISED = _MODES.index("surprised")


@compiled
def careful_radii(positions, velocities, seen_positions, seen_velocities, has_seen, i, others, accel, radii, safety,
                  slack, dt, threshold, mode, surprised, surprise_steps, conflicted, base):
    """:meth:`ReactionMargins.radii` and :meth:`ReactionMargins._careful` as one compiled loop
    over the other robots (``others``), numbered ``mode`` in :data:`_MODES`: the same operations
    as :func:`unexpected_approach` and :func:`reaction_margin`, element by element. Updates
    ``surprised`` (steps left per other robot) in place; returns ``base`` (the three predictions'
    radii of every other robot) with the braking ones widened."""
    m = others.shape[0]
    out = base.copy()
    if mode == 0:
        return out
    for c in range(m):
        j = others[c]
        careful = True
        if mode >= 2:
            if mode >= 3 and has_seen:  # unexpected_approach
                ex = seen_positions[j, 0] + seen_velocities[j, 0] * dt
                ey = seen_positions[j, 1] + seen_velocities[j, 1] * dt
                tx, ty = positions[i, 0] - positions[j, 0], positions[i, 1] - positions[j, 1]
                norm = max(np.sqrt(tx * tx + ty * ty), 1e-9)
                tx, ty = tx / norm, ty / norm
                off = (positions[j, 0] - ex) * tx + (positions[j, 1] - ey) * ty > threshold
                surprised[c] = surprise_steps if off else max(surprised[c] - 1, 0)
            careful = surprised[c] > 0 or conflicted
            if mode == 4:
                vx, vy = velocities[j, 0], velocities[j, 1]
                careful = careful or np.sqrt(vx * vx + vy * vy) * dt > threshold
        if careful:
            vx, vy = velocities[j, 0], velocities[j, 1]
            speed = np.sqrt(vx * vx + vy * vy)
            margin = accel[j] * dt * dt + (speed + 0.5 * accel[j] * dt) * dt
            dx, dy = positions[j, 0] - positions[i, 0], positions[j, 1] - positions[i, 1]
            gap = np.sqrt(dx * dx + dy * dy) - radii[i] - radii[j] - safety
            out[2 * m + c] += max(min(margin, gap - slack), 0.0)
    return out


class ReactionMargins:
    """The reaction margin (``execution.reaction_margin``, docs/execution.md) of every robot of a
    trial: towards which other robots it keeps :func:`reaction_margin` from their braking
    predictions this control step, remembering whom it saw approach unexpectedly."""

    def __init__(self, scenario: Scenario):
        n = scenario.n_robots
        self.scenario = scenario
        self.dt = scenario.controller.dt
        self._others = [[k for k in range(n) if k != i] for i in range(n)]
        self._accel = np.array([r.max_accel for r in scenario.robots])
        self._radii = scenario.radii  # built anew at every access: once
        self._braking_margin = scenario.execution.reaction_margin
        self.conflicted = np.zeros(n, dtype=bool)
        """Whether each robot could not follow its plan at its last control step (set by the method)."""
        self._surprised = np.zeros((n, max(n - 1, 0)), dtype=int)  # steps left, per robot and other robot
        self._surprise = scenario.execution.surprise
        self._surprise_steps = int(round(scenario.execution.surprise_memory / self.dt))
        self._last_seen: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._mode = _MODES.index(self._braking_margin)
        self._others_array = [np.array(o, dtype=np.int64) for o in self._others]
        self._safety, self._slack = scenario.controller.safety_margin, scenario.execution.reaction_slack
        self.constants = [(self._accel, self._radii, self._safety, self._slack, self._surprise, self._mode,
                           self._surprised[i], self._surprise_steps) for i in range(n)]
        """Per robot, the arguments of :func:`careful_radii` after the last observation's, the same
        every step (``surprised``: the robot's row, updated in place)."""

    def radii(self, i: int, view: RobotView, radii: np.ndarray) -> np.ndarray:
        """The radii ``radii`` of robot ``i``'s three predictions of every other robot, the braking
        ones widened by the reaction margin towards the robots it is careful of this step
        (:meth:`_careful`): :func:`reaction_margin`, never more than the present gap leaves (where
        the other robot is now is known), so that the robot is not "inside" the other's braking
        disc at once. One compiled call (:func:`careful_radii`) per robot and step."""
        seen = self._last_seen.get(i)
        positions, velocities = view.positions, view.velocities
        out = careful_radii(positions, velocities, positions if seen is None else seen[0],
                            velocities if seen is None else seen[1], seen is not None, i, self._others_array[i],
                            self._accel, self._radii, self._safety, self._slack, self.dt, self._surprise, self._mode,
                            self._surprised[i], self._surprise_steps, bool(self.conflicted[i]), radii)
        if self._mode >= _SURPRISED:  # a read-only view (the simulator's windows) never changes: kept as it is
            self._last_seen[i] = (positions if not positions.flags.writeable else positions.copy(),
                                  velocities if not velocities.flags.writeable else velocities.copy())
        return out

    def seen(self, i: int, positions: np.ndarray, velocities: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """What robot ``i`` observed at its last step (``positions`` and ``velocities`` themselves,
        and False, at its first), the arguments of :func:`careful_radii` that :meth:`radii` reads;
        ``positions`` and ``velocities`` are remembered as :meth:`radii` remembers them."""
        seen = self._last_seen.get(i)
        if self._mode >= _SURPRISED:  # a read-only view (the simulator's windows) never changes: kept as it is
            self._last_seen[i] = (positions if not positions.flags.writeable else positions.copy(),
                                  velocities if not velocities.flags.writeable else velocities.copy())
        return (positions, velocities, False) if seen is None else (seen[0], seen[1], True)

    def radii_plain(self, i: int, view: RobotView, radii: np.ndarray) -> np.ndarray:
        """:meth:`radii` in NumPy, the reference its compiled loop is tested against."""
        careful = self._careful(i, view)
        if careful.any():
            others = self._others[i]
            radii = radii.copy()
            margin = reaction_margin(np.linalg.norm(view.velocities[others], axis=1), self._accel[others], self.dt)
            gap = (np.linalg.norm(view.positions[others] - view.positions[i], axis=1) - self.scenario.radii[i]
                   - self.scenario.radii[others] - self.scenario.controller.safety_margin)
            allowed = np.clip(np.minimum(margin, gap - self.scenario.execution.reaction_slack), 0.0, None)
            radii[2 * len(others):] += np.where(careful, allowed, 0.0)
        return radii

    def _careful(self, i: int, view: RobotView) -> np.ndarray:
        """Towards which other robots robot ``i`` keeps the reaction margin this step ``(N_r - 1,)``.

        ``always``: all of them. ``conflict``: all while ``i`` cannot follow its plan, when the
        other may not be able to either. ``surprised`` adds any robot ``i`` saw, within the last
        ``execution.surprise_memory`` seconds, come towards it more than ``execution.surprise`` beyond where its
        velocity would have taken it (:func:`unexpected_approach`): a robot that starts or swerves
        towards it unannounced may follow a plan that conflicts with this one. ``moving`` adds
        every robot that moves more than ``execution.surprise`` a step, so that the margin is in place
        before two moving robots get close, not switched on once they are (when the present gap
        caps it). A robot at rest needs none: its braking trajectory is where it stands, and if it
        starts towards ``i`` it counts as unexpected after one step; a margin from it would make a
        robot pass a waiting one with no slack beyond the planner's own clearance."""
        mode, others = self._braking_margin, self._others[i]
        if mode == "off":
            return np.zeros(len(others), dtype=bool)
        if mode == "always":
            return np.ones(len(others), dtype=bool)
        seen = self._last_seen.get(i)
        if mode in ("surprised", "moving") and seen is not None:
            off = unexpected_approach(seen[0], seen[1], view.positions, i, others, self.dt, self._surprise)
            self._surprised[i] = np.where(off, self._surprise_steps, np.maximum(self._surprised[i] - 1, 0))
        self._last_seen[i] = (view.positions.copy(), view.velocities.copy())
        careful = (self._surprised[i] > 0) | bool(self.conflicted[i])
        if mode == "moving":
            careful = careful | (np.linalg.norm(view.velocities[others], axis=1) * self.dt > self._surprise)
        return careful


class WaitRelease:
    """Breaking waiting cycles of the gated execution (``execution.wait_patience``; not in the paper).

    Each robot executes the plan of its own decision, and the robots of a crowd do not always
    select plans that agree: one robot's plan has a neighbour back out before it moves, the
    neighbour's plan has the first robot move before it backs out, and each waits at its gate
    for the other for ever (docs/execution.md, "Deadlocks in crowds"). Nothing a robot observes
    changes while nobody gets anywhere. So when a robot has been held at its gate for
    ``patience`` while no robot of its plan (itself included) moved ``sim.progress_epsilon`` from
    where it was, it stops waiting for the robots that hold it and have not moved, for
    ``patience`` seconds: it follows its own path, its MPC keeping it clear of everyone as
    always, and whoever can move makes room. A robot held by a robot that gets somewhere, or
    whose plan has anyone getting somewhere, waits as before.
    """

    def __init__(self, scenario: Scenario):
        n = scenario.n_robots
        self.patience = scenario.execution.wait_patience
        self.reach = scenario.sim.progress_epsilon
        self.anchors = np.zeros((n, n, 2))
        """Where each robot saw every robot when its present wait began ``(N_r, N_r, 2)`` (m)."""
        self.anchored = np.zeros(n, dtype=bool)
        """Whether each robot's anchor is set (from its first observation on)."""
        self.since = np.zeros(n)
        """When each robot's present wait began (s)."""
        self.released_until = np.full(n, -np.inf)
        """Until when each robot ignores the robots that hold it without moving (s)."""

    def check(self, i: int, t: float, execution: PlanExecution, rows: np.ndarray, view: RobotView) -> None:
        """Robot ``i``'s execution after :meth:`PlanExecution.observe` at time ``t`` (``rows``: the
        plan's robots as scenario indices): time how long it waits in a plan that gets nowhere,
        and release it from the robots that hold it once that lasts ``patience``."""
        if self.patience <= 0.0 or not execution.settings.gated:
            return
        if not self.anchored[i]:
            self.anchors[i], self.anchored[i] = view.positions, True
            self.since[i] = t
        blockers = execution.blockers()
        moved = moved_beyond(view.positions, self.anchors[i], rows, self.reach)
        if t >= self.released_until[i] - 1e-9:
            if moved.any() or not len(blockers):  # not held, or somebody of the plan got somewhere
                self.anchors[i] = view.positions
                self.since[i] = t
                return
            if t - self.since[i] < self.patience - 1e-9:
                return
            self.released_until[i] = t + self.patience
        stuck = blockers[~moved[blockers]]  # released: the robots that hold it and have not moved
        if len(stuck):
            execution.release(stuck, view.positions[rows])

    def observe(self, i: int, t: float, execution: PlanExecution, rows: np.ndarray, positions: np.ndarray) -> None:
        """:meth:`PlanExecution.observe` and :meth:`check` at once (gated execution), from every
        robot's observed ``positions`` ``(N, 2)``: one compiled call per robot and step."""
        waiting = self.patience > 0.0
        if waiting and not self.anchored[i]:
            self.anchors[i], self.anchored[i] = positions, True
            self.since[i] = t
        held, moved, stuck = execution.observe_held(positions, rows, self.anchors[i] if waiting else positions,
                                                    self.reach)
        if not waiting:
            return
        if t >= self.released_until[i] - 1e-9:
            if moved or not held:  # not held, or somebody of the plan got somewhere
                self.anchors[i] = positions
                self.since[i] = t
                return
            if t - self.since[i] < self.patience - 1e-9:
                return
            self.released_until[i] = t + self.patience
        if stuck.any():
            execution.release(np.flatnonzero(stuck), positions[rows])
