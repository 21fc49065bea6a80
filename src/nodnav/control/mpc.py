"""The B-spline model predictive controller of the paper's appendix, solved as small dense QPs.

Problem (appendix, "Model Predictive Control"), for robot ``i`` over ``[t, t + T_MPC]``:

    minimise   integral ||p(tau) - p^PRM(tau)||^2 + w_2 ||v(tau)||^2 dtau
    subject to p(t) = p_{i,t},  v(t) = v_{i,t}
               ||p(tau) - p_j^pred(tau)|| >= r_i + r_j + margin   for every other robot j
               p(tau) in free space (walls and world bounds, inflated by r_i)
               ||v(tau)|| <= max_speed,  ||a(tau)|| <= max_accel

with ``p`` a uniform cubic B-spline (``settings.segments`` knot spans over the horizon). The
appendix's equations are unnumbered; docstrings refer to them by name.

It becomes a short sequence of small convex QPs, each solved exactly by DAQP
(:mod:`nodnav.control.qp`): the equalities are eliminated and the cost integrated exactly
(:mod:`nodnav.control.mpc_problem`); separation and walls are half-planes at the ends of short
intervals, inflated so that they hold at every instant, with terminal rows that keep the robot
able to stop (:mod:`nodnav.control.mpc_rows`). A second QP, re-linearised about the first
solution (SQP), is solved only after a cold start (no previous plan), when the first moved far
from its linearisation points; otherwise the next step's re-linearisation continues the
iteration. Every accepted plan is checked exactly and is safe at every instant with respect to
the predictions; where the request names braking partners, braking from the plan's next step must
also keep clear of theirs (:mod:`nodnav.control.mutual_braking`), or the robot brakes instead.

When the tracking QP has no solution, the robot follows the plan that intrudes least into the
others' predicted discs (:mod:`nodnav.control.evasive`); if no such plan keeps clear of the
walls, it brakes along its current velocity where that stops clear of the walls (what the
others' firm predictions expect), and otherwise follows its committed trajectory, the last
accepted plan and its braking tail, which is always clear of them (:mod:`nodnav.control.braking`,
docs/safety.md). All are reported with ``success=False`` and ``info["fallback"]``
(``"evasive"``, ``"braking"`` or ``"committed"``).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time

import numpy as np

from nodnav.control import bspline
from nodnav.control.base import STEP_FRACTIONS, ControlRequest, ControlResult
from nodnav.control.braking import Committed, braking_profile, tail_clearance, tail_decel
from nodnav.control.evasive import evasive_plan
from nodnav.control.mpc_braking import BOUND_TOLERANCE, WallsAround, fallback_conflict, no_plan_passes
from nodnav.control.mpc_fused import fused_setup, no_partners
from nodnav.control.mpc_problem import DEGREE, MPCProblem, StepData
from nodnav.control.mpc_request import apart, floats
from nodnav.control.mpc_rows import all_finite
from nodnav.control.mutual_braking import BrakingPartners
from nodnav.control.qp import SolverEffort
from nodnav.control.shared_setups import SharedSetups
from nodnav.registry import register_controller
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.world import World
from nodnav.wall_grid import WallGrid

logger = logging.getLogger(__name__)

LOCAL_SLACK = 1.0
"""How far (m) a robot on a map may move before its controller takes its nearby walls again: the
set holds every wall within its reach plus this, so it serves until the robot has moved this far
(at 0.4 m/s, about every 25 control steps)."""




@register_controller("mpc")
class BSplineMPC:
    """Cubic B-spline MPC (paper appendix) for one robot; keeps the previous plan between steps."""

    name = "mpc"

    def __init__(self, world: World, robot: RobotSpec, params: MPCParams = MPCParams(),
                 shared: SharedSetups | None = None):
        if params.dt <= 0 or params.horizon <= 0 or params.dt > params.horizon:
            raise ValueError(f"need 0 < dt <= horizon, got dt={params.dt}, horizon={params.horizon}")
        self.world = world
        self.robot = robot
        self.params = params
        self.settings = params  # the numerical choices, read as settings.*
        self.horizon = float(params.horizon)
        self.dt = float(params.dt)
        # The trial's robots of the same body share one setup (building it is most of the start-up).
        self.setup, self._problems = (shared if shared is not None else SharedSetups()).get(world, robot, params)
        self.obstacles = self.setup.obstacles
        self._walls = self._walls_around()
        self._valid_times = b""
        # The margins of the last request, checked, and the safety margin once per prediction count:
        # a method passes the same read-only array step after step (checked once).
        self._valid_margins: np.ndarray | None = None
        self._default_margins: dict[int, np.ndarray] = {}
        self._last_problem: tuple[tuple, MPCProblem] | None = None
        # A map's world: the rows hold only the walls within reach (:meth:`_local_walls`).
        self._grid = world.wall_grid if params.local_walls else None
        self._all_setup, self._anchor, self._local_radius = self.setup, np.zeros(2), -1.0
        self._slowest_stop = min(robot.max_accel, tail_decel(robot.max_accel, params.terminal_decel,
                                                             params.accel_polygon_sides))
        self._previous: np.ndarray | None = None
        self._braking: tuple[np.ndarray, np.ndarray] | None = None
        # The committed trajectory (docs/safety.md): the last accepted plan and its braking tail.
        self._committed: Committed | None = None
        self._following = False  # whether the last step followed the committed trajectory
        self._expected = (np.zeros(2), np.zeros(2))  # its position and velocity one step on
        # DAQP's warm starts: the constraints active at the last solution of each kind of QP
        # (:class:`~nodnav.control.qp.SolverEffort`); the same problem has the same rows.
        self._starts: dict = {}
        # The fused set-up's arguments without a plan or partners (controller.fused_step; never written).
        self._no_plan, self._no_partners = np.zeros((0, 2)), no_partners()

    def reset(self) -> None:
        """Forget the previous solution (the next step starts cold)."""
        self._previous = None
        self._braking = None
        self._committed = None
        self._following = False
        self._starts.clear()

    def motion(self, times: np.ndarray, order: int = 0) -> np.ndarray:
        """The motion chosen at the last control step, ``times`` after it: positions (``order`` 0)
        or velocities (1) ``(len(times), 2)``; the planned spline, or the braking manoeuvre."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        if order not in (0, 1):
            raise ValueError(f"order must be 0 (positions) or 1 (velocities), got {order}")
        if self._braking is not None:
            return braking_profile(*self._braking, self.robot.max_accel, times)[order]
        if self._following and self._committed is not None:
            return self._committed.motion(times, order)
        if self._previous is None:
            raise ValueError("no control step has been taken yet")
        return bspline.evaluate(self._previous, times, self.setup.knots, DEGREE, order)

    def braking_trajectory(self, times: np.ndarray) -> np.ndarray | None:
        """Positions ``(len(times), 2)`` of the committed trajectory ``times`` after the last
        control step (the last accepted plan, then its straight braking tail, which stops), or
        None if the robot holds none (before its first accepted plan, after braking blindly)."""
        if self._committed is None:
            return None
        return self._committed.motion(np.asarray(times, dtype=float))

    # -- public ------------------------------------------------------------------------------

    def control(self, request: ControlRequest) -> ControlResult:
        """Solve the MPC for one step.

        On success the plan tracks the reference within every constraint. Otherwise
        (``success=False``) the robot follows the evasive plan (``info["fallback"] == "evasive"``,
        the least intrusion into the others' predicted discs, walls and limits kept) or, if there
        is none, brakes along its velocity (``"braking"``). Raises ``ValueError`` only for a
        malformed request (shapes, non-finite values, sample times outside ``(0, horizon]``).
        """
        start = time.perf_counter()
        p0, v0, ref, times, others, other_radii, firm, margins = self._validated(request)
        if self._grid is not None:
            self._local_walls(self._grid, p0, v0)
        prob = self._problem(len(others), times)
        fused, first = self.settings.fused_step, None
        if fused:  # the set-up up to the first QP's rows in one compiled call
            committed = self._advance_committed(p0, v0)
            partners = request.braking if self.settings.skip_unpassable else None
            data, lin, cold, first, bound = self._fused_setup(prob, p0, v0, ref, others, other_radii, margins,
                                                              committed, partners)
        else:
            data = self._step_data(prob, p0, v0, ref, others, other_radii, margins)
            committed = self._advance_committed(p0, v0)
        effort = SolverEffort(starts=self._starts)
        r, m_w = self.robot.radius, prob.n_walls
        clearance0 = data.clearance_now
        if clearance0 < r - self.settings.contact_tolerance:
            return self._brake(request, prob, start, effort,
                               f"in contact with a wall (clearance {clearance0:.3f} m, radius {r:.3f} m)")

        if request.braking is not None and self.settings.skip_unpassable:
            # The fused set-up made passing_bound's bound: where it cannot say "hopeless", nor can this.
            hopeless = "" if fused and bound >= -BOUND_TOLERANCE else no_plan_passes(
                request.braking, self._walls, p0, v0, self.dt)
            if hopeless:  # every plan would be refused below: skip solving for one
                return self._fallback(request, prob, committed, start, effort, p0, v0, hopeless)

        if not fused:
            warm = self._warm_start(committed)
            cold = warm is None
            lin = prob.interp_ends @ ref if cold else prob.b_ends @ warm
        if data.overlap:
            dist0, contact = data.dist_now[m_w:], data.contact[m_w:]
            overlapping = np.flatnonzero(dist0 < contact - self.settings.contact_tolerance)
            j = int(overlapping[0])
            why = f"overlapping robot {j} ({dist0[j]:.3f} m apart, contact at {contact[j]:.3f} m)"
            conflict = overlapping
        else:
            best, post, why, conflict, checked = self._track(prob, data, lin, cold, effort, request.braking, first)
            unsafe = "" if best is None else self._braking_conflict(request, post, best, prob, checked)
            if best is not None and not unsafe:
                self._accept(best, prob, post)
                return self._result(True, "", post, data, start, {"fallback": "", **effort.as_info()})
            if unsafe:  # a plan exists, but braking from its next step is not known to stay apart
                return self._fallback(request, prob, committed, start, effort, p0, v0, unsafe)
        logger.debug("MPC at %s: %s", p0, why)
        # With no other robot the evasive QP would be the tracking QP again.
        plan, firm_softened = None, False
        if self.settings.evasive and prob.n_others:
            plan, intrusion, intruded = evasive_plan(prob, data, lin, cold, conflict[~firm[conflict]], firm, effort)
            if plan is None and firm.any():
                # Better to intrude into a firm prediction than to brake blindly, into walls too.
                firm_softened = True
                plan, intrusion, intruded = evasive_plan(prob, data, lin, cold, conflict, np.zeros_like(firm),
                                                          effort)
        if plan is None:
            return self._fallback(request, prob, committed, start, effort, p0, v0, why)
        post = prob.evaluate(plan)
        unsafe = self._braking_conflict(request, post, plan, prob)
        if unsafe:
            return self._fallback(request, prob, committed, start, effort, p0, v0, f"{why}; evasive: {unsafe}")
        self._accept(plan, prob, post)
        return self._result(False, f"infeasible: evasive: {why}", post, data, start,
                            {"fallback": "evasive", "intrusion": intrusion, "intruded": intruded.tolist(),
                             "firm_softened": firm_softened, **effort.as_info()})

    # -- internals ---------------------------------------------------------------------------

    def _fallback(self, request: ControlRequest, prob: MPCProblem, committed: Committed | None, start: float,
                  effort: SolverEffort, p0: np.ndarray, v0: np.ndarray, why: str) -> ControlResult:
        """No plan to follow. Braking along the velocity at the limit is what the other robots
        expect of a robot that cannot plan (their firm predictions); it is kept wherever it stops
        clear of the walls, and the committed trajectory, always clear of them, is followed otherwise.
        A robot already following its committed trajectory goes on following it: that trajectory,
        not braking from a point on it, is what the mutual braking check cleared when the plan
        was accepted (:meth:`_braking_conflict`)."""
        straight = tail_clearance(p0, v0, self.robot.max_accel, self.obstacles, self.setup.pieces,
                                  self.setup.world_bounds)
        keep_following = self._following and request.braking is not None
        if committed is not None and (keep_following or straight < self.robot.radius - self.settings.check_tolerance):
            return self._follow(committed, prob, start, effort, why)
        return self._brake(request, prob, start, effort, why, straight)

    def _walls_around(self) -> WallsAround:
        """What the mutual braking checks read of the robot and its walls (taken again when the
        walls kept change, :meth:`_local_walls`)."""
        return WallsAround(self.obstacles, self.setup.pieces, self.setup.world_bounds, self.robot.radius,
                           self.robot.max_accel, self.settings.check_tolerance)

    def _braking_conflict(self, request: ControlRequest, post: tuple, c: np.ndarray, prob: MPCProblem,
                          checked: tuple | None = None) -> str:
        """Why the robot's fallback from the plan ``c``'s next state (``post``:
        :meth:`MPCProblem.evaluate`) fails the mutual braking check towards a robot of
        ``request.braking`` (:func:`~nodnav.control.mpc_braking.fallback_conflict`; ``checked``:
        its straight braking's part, made with the plan's check); "" when it passes or there is none."""
        if request.braking is None:
            return ""
        end = post[1]

        def committed() -> Committed:  # the plan's committed trajectory, read from its next step
            return Committed(points=c, knots=self.setup.knots, horizon=self.horizon, end_position=end[0],
                             end_velocity=end[1], decel=prob.tail_decel, elapsed=self.dt)

        return fallback_conflict(request.braking, self._walls, post[2][:2], committed, self.robot.max_speed, checked)

    def _accept(self, c: np.ndarray, prob: MPCProblem, post: tuple) -> None:
        """Make the plan ``c`` (its braking tail checked clear; ``post``: its values,
        :meth:`MPCProblem.evaluate`) the committed trajectory."""
        self._previous, self._braking, self._following = c, None, False
        end = post[1]
        # Positionally (points, knots, horizon, end_position, end_velocity, decel): half the keywords' cost.
        self._committed = Committed(c, self.setup.knots, self.horizon, end[0], end[1], prob.tail_decel)

    def _advance_committed(self, p0: np.ndarray, v0: np.ndarray) -> Committed | None:
        """The committed trajectory one step on, if the robot is on it (exact observations put it
        there; anything else, e.g. observation noise, leaves it without one)."""
        c = self._committed
        if c is None or self.settings.braking_tail is False:
            return None
        c.elapsed += self.dt
        # Where the last step said the robot would be (the committed trajectory one step on).
        at, vel = self._expected
        # As a rule exactly there (the lists' equality is the cheap test); else within apart's tolerance.
        if (at.tolist() != p0.tolist() or vel.tolist() != v0.tolist()) and (apart(at, p0) or apart(vel, v0)):
            self._committed = None
            return None
        return c

    def _follow(self, committed: Committed, prob: MPCProblem, start: float, effort: SolverEffort,
                why: str) -> ControlResult:
        """Follow the committed trajectory: the last accepted plan, then its braking tail, both
        checked clear of the walls when the plan was accepted (the braking invariant)."""
        self._braking, self._following = None, True
        times = np.concatenate([self.dt * STEP_FRACTIONS, prob.sample_times])
        pos = committed.motion(times)
        vel = committed.motion(np.array([self.dt]), 1)[0]
        p0 = committed.motion(np.zeros(1))[0]
        stage = "its plan" if committed.elapsed + self.dt <= self.horizon else "its braking tail"
        self._expected = (pos[3], vel)
        return ControlResult.built(
            success=False, reason=f"infeasible: braking: following {stage} (clear of walls): {why}",
            velocity=(pos[3] - p0) / self.dt, next_position=pos[3], next_velocity=vel,
            planned_positions=pos[4:], solve_time=time.perf_counter() - start,
            info={"fallback": "committed", **effort.as_info()}, step_positions=pos[:4])

    def _fit(self, committed: Committed, offset: float) -> np.ndarray:
        """Control points of the spline nearest (least squares) to the committed motion from ``offset`` on."""
        if not hasattr(self, "_fit_map"):
            fit = np.linspace(0.0, self.horizon, 4 * self.settings.segments + 1)
            self._fit_times = fit
            self._fit_map = np.linalg.pinv(bspline.basis(fit, self.setup.knots, DEGREE))
        return self._fit_map @ committed.motion(offset + self._fit_times)

    def _result(self, success: bool, reason: str, post: tuple, data: StepData, start: float,
                info: dict) -> ControlResult:
        out = post[2]
        position, velocity = out[0], out[1]  # views of the plan's values, as the result's
        self._expected = (position, velocity)
        # A checked plan's values carry the velocity command (MPCProblem.checked_plan), evaluate's do not.
        command = post[4] if len(post) > 4 else (position - data.p0) / self.dt
        return ControlResult.built(success, reason, command, position, velocity, out[2:],
                                   time.perf_counter() - start, post[3], info)

    def _track(self, prob: MPCProblem, data: StepData, lin: np.ndarray, cold: bool, effort: SolverEffort,
               partners: BrakingPartners | None = None, first: tuple | None = None):
        """The tracking QP (re-linearised once more after a cold start if the solution moved far).

        Returns (control points or None, their values (:meth:`MPCProblem.evaluate`), why not, the
        other robots involved in the failure: those owning rows of an infeasibility certificate
        (:func:`infeasibility_certificate`), else all; the mutual braking check's straight part
        towards ``partners``, made with the plan's check, or None without partners). ``first``: the
        first QP's gradient and bounds where the step's set-up made them (:meth:`_fused_setup`).
        """
        best, best_post, why, conflict, best_checked = None, None, "", prob.every_other, None
        gradient, lower = first or prob.tracking_rows(data, lin, cold)  # the first QP's; later ones write theirs
        for k in range(self.settings.sqp_iterations):
            if k:
                lower = prob.write_separation(data, lin, cold, data.need)
            sol = effort.solve(prob.hessian, gradient, prob.rows, lower, self.settings.qp_tolerance, kind=prob)
            if not sol.success:
                why = f"tracking QP {sol.reason}"
                # DAQP can also stop cycling on an infeasible degenerate QP; the LP decides.
                certified = prob.certified_conflict(prob.rows, lower, effort)
                if certified is not None and certified.size:
                    conflict = certified
                break
            if partners is None:
                c, post, why = prob.checked_plan(data, sol.x, separation=True)
                checked = None
            else:
                c, post, why, checked = prob.checked_plan_braking(data, sol.x, partners, self._walls)
            if why:
                break
            best, best_post, best_checked = c, post, checked
            if not cold:
                break
            moved = prob.b_ends @ c
            if np.max(np.hypot(*(moved - lin).T)) <= self.settings.sqp_tolerance:
                break
            lin, cold = moved, False
        return best, best_post, why, conflict, best_checked

    def _validated(self, request: ControlRequest):
        p0, v0 = floats(request.position, (2,)), floats(request.velocity, (2,))
        times = floats(request.sample_times, (-1,))
        ref = np.asarray(request.reference, dtype=float)
        k = len(times)
        radii = floats(request.other_radii, (-1,))
        others = np.asarray(request.others, dtype=float)
        if others.size == 0:
            others = np.zeros((0, k, 2))
        if k == 0 or ref.shape != (k, 2) or others.shape != (len(radii), k, 2):
            raise ValueError(f"inconsistent request shapes: reference {ref.shape}, sample_times {times.shape}, "
                             f"others {others.shape}, other_radii {radii.shape}")
        stamp = times.tobytes()
        if stamp != self._valid_times:  # usually the same times as last step
            if times[0] <= 0 or times[-1] > self.horizon + 1e-9 or (k > 1 and np.diff(times).min() <= 0):
                raise ValueError(f"sample_times must increase within (0, {self.horizon}], got {times}")
            self._valid_times = stamp
        if not all_finite(p0, v0, ref, others, radii):
            raise ValueError("request contains non-finite values")
        firm = np.zeros(len(radii), dtype=bool) if request.firm is None else np.asarray(request.firm, dtype=bool)
        if firm.shape != radii.shape:
            raise ValueError(f"firm must have one flag per prediction {radii.shape}, got {firm.shape}")
        margins = request.margins
        if margins is None:
            margins = self._safety_margins(len(radii))
        elif margins is not self._valid_margins or margins.flags.writeable or margins.shape != radii.shape:
            margins = np.asarray(margins, dtype=float).reshape(-1)
            if margins.shape != radii.shape or not np.all(margins >= 0.0):  # NaN fails too
                raise ValueError(f"margins must be one clearance >= 0 per prediction {radii.shape}, got {margins}")
            self._valid_margins = request.margins if isinstance(request.margins, np.ndarray) else None
        return p0, v0, ref, times, others, radii, firm, margins

    def _safety_margins(self, n: int) -> np.ndarray:
        """The controller's own ``safety_margin`` once for each of ``n`` predictions (kept per ``n``)."""
        margins = self._default_margins.get(n)
        if margins is None:
            margins = self._default_margins[n] = np.full(n, self.params.safety_margin)
        return margins

    def wall_reach(self, v0: np.ndarray) -> float:
        """How far (m) from its position a wall can matter to this step: a plan's positions
        within the horizon (speed at most ``V``, the limit plus the check's tolerance or the
        present speed if higher: a faster plan is rejected by the exact check whatever the
        walls) plus its straight braking tail (``V^2 / 2 d`` at the slower of the tail's and the
        emergency braking's decelerations) plus the radius and a margin of 0.1 m, as the rows'
        own cut-offs (``far``, the tail rows' reach)."""
        fast = max(self.robot.max_speed + self.settings.check_tolerance, math.hypot(v0[0], v0[1]))
        return self.robot.radius + fast * self.horizon + fast * fast / (2.0 * self._slowest_stop) + 0.1

    def _local_walls(self, grid: WallGrid, p0: np.ndarray, v0: np.ndarray) -> None:
        """Keep in the setup only the walls within :meth:`wall_reach` of the robot plus
        :data:`LOCAL_SLACK` (every wall within reach from anywhere within the slack of where the
        set was taken), taken again once the robot has moved beyond it."""
        need = self.wall_reach(v0)
        if math.hypot(p0[0] - self._anchor[0], p0[1] - self._anchor[1]) + need <= self._local_radius:
            return
        radius = need + LOCAL_SLACK
        boxes = self._all_setup.obstacles
        near = grid.near(p0 - radius, p0 + radius)
        b = boxes[near]
        gap = np.hypot(np.maximum(np.maximum(b[:, 0] - p0[0], p0[0] - b[:, 2]), 0.0),
                       np.maximum(np.maximum(b[:, 1] - p0[1], p0[1] - b[:, 3]), 0.0))
        kept = np.ascontiguousarray(b[gap <= radius])
        kept.setflags(write=False)  # as the world's array: the compiled kernels' same specialisation
        self.setup = dataclasses.replace(self._all_setup, obstacles=kept)
        self.obstacles = self.setup.obstacles
        self._walls = self._walls_around()
        self._problems, self._last_problem = {}, None
        self._starts.clear()  # they name the old problems' rows (and would keep them alive)
        self._anchor, self._local_radius = p0.copy(), radius

    def _problem(self, n_others: int, times: np.ndarray) -> MPCProblem:
        exact = (n_others, times.tobytes())
        if self._last_problem is not None and self._last_problem[0] == exact:
            return self._last_problem[1]  # the usual case: the same sample times as last step
        key = (n_others, np.round(times, 9).tobytes())
        prob = self._problems.get(key)
        if prob is None:
            prob = self._problems[key] = MPCProblem(self.setup, n_others, times)
        self._last_problem = (exact, prob)
        return prob

    def _step_data(self, prob: MPCProblem, p0, v0, ref, others, other_radii, margins=None) -> StepData:
        """:meth:`MPCProblem.plain_step_data`, with this robot's safety margins unless given."""
        if margins is None:
            margins = self._safety_margins(len(other_radii))
        return prob.plain_step_data(p0, v0, ref, others, other_radii, margins)

    def _fused_setup(self, prob: MPCProblem, p0, v0, ref, others, other_radii, margins, committed: Committed | None,
                     partners: BrakingPartners | None = None) -> tuple[StepData, np.ndarray, bool, tuple, float]:
        """:meth:`_step_data`, the linearisation points of :meth:`_warm_start` and the first QP's
        :meth:`MPCProblem.tracking_rows` in one compiled call, the small products as loops
        (:func:`~nodnav.control.mpc_fused.step_setup`, ``controller.fused_step``). Returns the step
        data, the linearisation points, whether the start is cold, the first QP's gradient and bounds,
        and :func:`~nodnav.control.mutual_braking.passing_bound`'s bound towards ``partners`` (``inf``
        without them)."""
        if self._following and committed is not None:
            warm, mode = self._fit(committed, 0.0), 2
        else:
            warm, mode = (self._no_plan, 0) if self._previous is None else (self._previous, 1)
        bound, *values = fused_setup(prob, p0, v0, ref, others, other_radii, margins, warm, mode,
                                     self._no_partners if partners is None else partners)
        *_, lin, gradient, lower = prob.fused_outputs
        return prob.fused_step_data(p0, v0, *values), lin, mode == 0, (gradient, lower), bound

    def _warm_start(self, committed: Committed | None) -> np.ndarray | None:
        """The previous plan moved on by one step (control points), if there is one; after a
        step that followed the committed trajectory, that trajectory from now on (not the old
        plan's last polynomial continued past its horizon)."""
        if self._following and committed is not None:
            return self._fit(committed, 0.0)
        return None if self._previous is None else self.setup.shift @ self._previous

    def _brake(self, request: ControlRequest, prob: MPCProblem, start: float, effort: SolverEffort,
               why: str, clear: float | None = None) -> ControlResult:
        """Decelerate along the current velocity at max_accel; the previous plan is discarded.
        ``clear``: the braking's clearance from the walls where the caller has it (:func:`tail_clearance`)."""
        p0 = np.asarray(request.position, dtype=float)
        v0 = np.asarray(request.velocity, dtype=float)
        self._previous, self._braking, self._committed, self._following = None, (p0, v0), None, False
        if clear is None:
            clear = tail_clearance(p0, v0, self.robot.max_accel, self.obstacles, self.setup.pieces,
                                   self.setup.world_bounds)
        why = (f"{why}; braking along its velocity stops clear of the walls ({clear:.3f} m)"
               if clear >= self.robot.radius - self.settings.check_tolerance else
               f"{why}; no braking trajectory known to be clear of the walls from this state "
               f"(braking along its velocity comes within {clear:.3f} m of a wall)")
        # One call for the step's end, the samples and the points within the step (element-wise in the times).
        pos, vel = braking_profile(p0, v0, self.robot.max_accel, prob.braking_times)
        k = len(prob.sample_times)
        return ControlResult.built(False, f"infeasible: braking: {why}", (pos[0] - p0) / self.dt, pos[0], vel[0],
                                   pos[1:k + 1], time.perf_counter() - start, pos[k + 1:],
                                   {"fallback": "braking", **effort.as_info()})
