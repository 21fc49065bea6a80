"""The fast planner's timing step: a robot's velocity along its path among the robots before it.

Step 4 of :mod:`nodnav.planning.prioritized` (its module docstring): the corridor and door rules
as gates (:meth:`VelocityTuning._gates`), the cells each earlier robot's motion closes at each
step (:meth:`VelocityTuning._blocked`, remembered), and the exact search, retiming and samples in
one compiled call (:meth:`VelocityTuning._timing`, :func:`~nodnav.planning.fused_timing._timing_kernel`);
:meth:`VelocityTuning._time` makes the robot's plan of it. A mixin of
:class:`~nodnav.planning.prioritized.PrioritizedPlanner`, which owns the memos.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from nodnav.planning.fast_state import Attempt, FastPlannerHooks, Layout, RobotPlan, State, Track, sampled_motion
from nodnav.planning.fused_timing import NO_GEOMETRY, _timing_kernel, stay_geometry
from nodnav.planning.memo import remember, remember_briefly
from nodnav.planning.occupancy import Motion, blocked_rows, boxes_apart, join_motions, relaxed_bits
from nodnav.planning.timing import ARRIVED, Timing, timing_of
from nodnav.scenario.world import World

#: No gates, as the compiled timing call takes them (it only reads them).
_NO_GATES = np.zeros((0, 2), dtype=np.int64)


def _allclose_point(x: float, y: float, b: list) -> bool:
    """``np.allclose((x, y), b)`` of two finite points (``b`` as a list of two Python floats)
    at its default tolerances (``|a - b| <= 1e-8 + 1e-5 |b|`` per coordinate, the same float
    operations), without its array overhead (it ran once per planned robot)."""
    bx, by = b
    return abs(x - bx) <= 1e-08 + 1e-05 * abs(bx) and abs(y - by) <= 1e-08 + 1e-05 * abs(by)


class VelocityTuning(FastPlannerHooks):
    """The timing step of :class:`~nodnav.planning.prioritized.PrioritizedPlanner` (see the module docstring)."""

    if TYPE_CHECKING:  # set by PrioritizedPlanner.__init__
        _rows: dict[tuple, tuple]
        _rows_by_id: dict[tuple, tuple]
        _geometries: dict[int, tuple]

    def _gates(self, state: State, k: int, track: Track, plans: dict) -> tuple[list, str]:
        """The corridor and door rules for robot ``k`` after the robots ``plans``: ``(cell,
        allowed)`` pairs (cells at and past ``cell`` are closed before step ``allowed``), or why
        the order cannot be kept."""
        gates: list = []
        dirs = state.direction_list  # Python numbers: the same comparisons, without NumPy scalars
        mine, entry = dirs[k], track.entry
        door = state.door_list[k]
        for i, p in plans.items():
            e_i, x_i = p.passage
            if dirs[i] == mine != 0:
                if entry >= 0 and e_i >= 0:
                    gates.append((entry, e_i + 1))
                continue
            if entry >= 0 and e_i >= 0:
                if x_i > p.arrival:
                    return [], f"robot {i} before it in the order parks inside the corridor"
                gates.append((entry, x_i + 1))
            if door >= 0 and track.doors[door] >= 0:
                z_i, out_i = p.doors[door]
                if z_i >= 0:
                    gates.append((track.doors[door], min(out_i, p.arrival) + 1))
        return gates, ""

    def _timing(self, state: State, k: int, track: Track, fixed: list, gates=(), t0: int = 0,
                world: World | None = None) -> Timing:
        """Velocity tuning of robot ``k`` along ``track`` from step ``t0`` among the ``fixed``
        ``(robot, motion)`` pairs, under the ``gates`` (absolute steps); the timing's step 0 is
        step ``t0``. A pair that starts closer than required keeps the relaxed separation until
        the other robot's motion is required distance away from this one's start for good
        (:func:`relaxed_separation`). With ``world``, the timing also holds its samples' stays
        in that world's corridor and door zones (``RobotPlan._stays``)."""
        status, step, steps, arc, samples, stays = self._timing_outcome(state, k, track, fixed, gates, t0, world)
        return timing_of(status, step, steps, arc if len(arc) else None, samples,
                         None if world is None else tuple(int(v) for v in stays))

    def _timing_outcome(self, state: State, k: int, track: Track, fixed: list, gates, t0: int,
                        world: World | None) -> tuple:
        """:meth:`_timing` as the compiled call returns it: ``(outcome, step cornered at, cells,
        arc, samples, stays)`` (:func:`~nodnav.planning.fused_timing._search_kernel`)."""
        cells, n = track.cells, len(track.cells)
        x0, y0 = cells[0].tolist()
        required = state.required_list  # Python floats: float(state.required[j, k]), cheaper
        # Each motion's rows, one after the other; the compiled call ORs them into the table.
        parts, rows = [], []
        for j, m in fixed:
            r = required[j][k]
            samples = m.samples
            hx, hy = samples[min(t0, len(samples) - 1)].tolist()
            gap = math.hypot(hx - x0, hy - y0)
            bits = self._blocked(cells, m, r) if gap >= r else relaxed_bits(cells, m, r, gap)
            parts.append(bits)
            rows.append(len(bits))
        if len(parts) == 1:
            stack = parts[0]
        else:
            stack = np.concatenate(parts) if parts else np.zeros((0, (n + 63) // 64), dtype=np.uint64)
        # The gates, the search, the retiming and the motion's samples in one compiled call.
        retime = False
        v0 = vmax = alpha = 0.0
        if state.accels is not None and state.velocities is not None:
            retime = True
            # Moving now only if it starts where it stands now (not after getting out of the way).
            if t0 == 0 and len(track.segments[1]) and _allclose_point(x0, y0, state.position_list[k]):
                v0 = max(0.0, float(state.velocities[k] @ track.segments[1][0]))
            vmax, alpha = float(state.max_speeds[k]), float(state.accels[k]) * float(self.params.dt)
        ok2 = track.ok2 if track.ok2.dtype == np.bool_ else np.asarray(track.ok2, dtype=bool)
        geometry = NO_GEOMETRY if world is None else self._stay_geometry(world)
        return _timing_kernel(
            stack, np.array(rows, dtype=np.int64), n,
            np.array(gates, dtype=np.int64).reshape(-1, 2) if gates else _NO_GATES, t0, ok2,
            self.params.waiting == "early", retime, track.arc, cells, v0, vmax, alpha, float(self.params.dt), geometry)

    def _stay_geometry(self, world: World) -> np.ndarray:
        """:func:`stay_geometry` of ``world`` (remembered by identity; the world is held so that
        its id stays its own)."""
        hit = self._geometries.get(id(world))
        if hit is None:
            hit = (world, stay_geometry(world, self.params.door_clearance))
            self._geometries[id(world)] = hit
        return hit[1]

    def _blocked(self, cells: np.ndarray, motion: Motion, required: float) -> np.ndarray:
        """The cells too close to ``motion`` at each of its steps (:func:`blocked_bits`; memoised:
        the same path meets the same motion in many orders, and equal motions in others)."""
        # First by identity (the same motion object meets the same cells in many orders), then
        # by value; the objects are kept with the bits so that their ids stay theirs.
        same = (id(cells), id(motion), required)
        hit = self._rows_by_id.get(same)
        if hit is not None:
            return hit[2]
        key = (id(cells), motion.samples.tobytes(), motion.path.tobytes(), required)
        hit = self._rows.get(key)
        if hit is not None:
            remember_briefly(self._rows_by_id, same, (cells, motion, hit[1]))
        else:
            cells_c = np.ascontiguousarray(cells, dtype=float)
            if boxes_apart(cells_c, motion.path, motion.samples, float(required)):
                # Too far apart to meet at any step: its rows are all clear (what blocked_rows gives).
                bits = np.zeros((motion.last_step + 1, (len(cells_c) + 63) // 64), dtype=np.uint64)
            else:
                # conflict_intervals for one motion and blocked_bits of them, in one compiled call.
                bits = blocked_rows(cells_c, motion, float(required))
            # The cells are kept with the bits so that their id stays theirs while remembered.
            hit = (cells, bits)
            remember(self._rows, key, hit)
            remember_briefly(self._rows_by_id, same, (cells, motion, bits))
        return hit[1]

    def _time(self, world: World, state: State, k: int, track: Track, layout: Layout,
              head: Motion | None = None) -> Attempt:
        """Robot ``k``'s timing along ``track`` among everything known, after ``head`` (the
        motion by which it first got out of the way) if there is one."""
        head = layout.heads.get(k) if head is None else head
        gates, problem = self._gates(state, k, track, layout.plans)
        if problem:
            return Attempt(False, problem)
        t0 = head.last_step if head is not None else 0
        status, step, steps, arc, samples, stays = self._timing_outcome(state, k, track, layout.fixed(k), gates, t0,
                                                                        world if head is None else None)
        if status != ARRIVED:
            timing = timing_of(status, step, steps)
            return Attempt(False, timing.reason, trapped=timing.trapped_at >= 0)
        # timed_motion of the timing :meth:`_timing` makes of this outcome, without making it.
        motion = sampled_motion(track, samples, arc if len(arc) else None, steps)
        if head is not None:  # the stays of the joined motion, when asked
            motion = join_motions(head, motion)
            stays = None
        else:
            stays = tuple(map(int, stays))
        return Attempt(True, "", RobotPlan(motion, world, self.params.door_clearance, head is not None, stays))
