"""The fast planner's working data: a request's order-independent state, each robot's path cut
into cells, each robot's plan, and the layout of everybody while one robot is planned."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NoReturn

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.geometry import TOL
from nodnav.planning.base import JointTrajectory
from nodnav.planning.disc_checks import corner_heights
from nodnav.planning.memo import remembered_property
from nodnav.planning.occupancy import Motion, _entry_kernel, _passage_kernel, _segments_kernel, corridor_passage
from nodnav.planning.polylines import _grid_kernel
from nodnav.planning.retiming import points_at
from nodnav.planning.visibility import GeometricPath
from nodnav.planning.waiting_spots import in_door_zone
from nodnav.scenario.world import World

if TYPE_CHECKING:
    from nodnav.planning.timing import Timing
    from nodnav.planning.visibility import VisibilityGraph
    from nodnav.scenario.params import FastPlannerParams


@dataclass(slots=True)
class Route:
    """One robot's geometric path and the standing robots (discs) it keeps clear of."""

    path: GeometricPath
    centres: np.ndarray
    radii: np.ndarray
    detour: bool = False
    """Whether the path had to ignore the robots standing in the way (it may cross them)."""


@dataclass(slots=True)
class Track:
    """A robot's geometric path cut into cells, ready for timing."""

    route: Route
    cells: np.ndarray
    """Cells ``(N, 2)`` along the path, at most ``v_max dt / 2`` apart (m)."""
    arc: np.ndarray
    """Arc length of each cell ``(N,)`` (m)."""
    ok2: np.ndarray
    """Whether the full-speed move ``c -> c+2`` is allowed ``(N,)``."""
    inside: np.ndarray
    """Which cells are in the corridor ``(N,)``."""
    entry: int
    """First cell entering the corridor from outside, or -1 (:func:`entry_cell`)."""
    doors: tuple[int, int]
    """First cell entering the door zone of the left and of the right entrance from outside, or -1."""
    segments: tuple
    """The path's segments, :func:`polyline_segments`."""


@dataclass(slots=True)
class Cut:
    """A path cut into cells, before any standing robot is considered (see :class:`Track`)."""

    cells: np.ndarray
    arc: np.ndarray
    ok2: np.ndarray
    corners: np.ndarray
    """Cells ``c`` whose full-speed move ``c -> c+2`` cuts a corner of the path."""
    inside: np.ndarray
    entry: int
    doors: tuple[int, int]
    segments: tuple


@dataclass
class RobotPlan:
    """One robot's planned motion."""

    motion: Motion
    """Its polyline and where it is along it at steps ``0..arrival``."""
    world: World = field(repr=False)
    door_clearance: float = 1.0
    """Radius of the door zones (m)."""
    retreat: bool = False
    """Whether it backs out of the way first."""
    stays: tuple | None = field(default=None, repr=False, compare=False)
    """:attr:`_stays` when computed with the motion (the fused timing call), else None."""

    @property
    def arrival(self) -> int:
        return self.motion.last_step

    @remembered_property
    def _stays(self) -> tuple[int, int, int, int, int, int]:
        """:attr:`passage` and :attr:`doors` in one compiled pass over the samples."""
        if self.stays is not None:
            return self.stays
        w = self.world
        p = w.passage
        (e0x, e0y), (e1x, e1y) = w.entrances[0], w.entrances[1]
        out = _stays_kernel(np.ascontiguousarray(self.motion.samples, dtype=float), p.along_x, p.axis[0], p.axis[1],
                            p.normal[0], p.normal[1], p.s_start, p.s_end, p.t_centre, 0.5 * p.width,
                            float(e0x), float(e0y), float(e1x), float(e1y), float(self.door_clearance))
        a, b, c, d, e, f = (int(v) for v in out)
        return a, b, c, d, e, f

    @property
    def passage(self) -> tuple[int, int]:
        """``(entry, exit)`` samples of its last stay in the corridor, see :func:`corridor_passage`."""
        s = self._stays
        return s[0], s[1]

    @property
    def doors(self) -> tuple[tuple[int, int], tuple[int, int]]:
        """``(entry, exit)`` samples of its last stay in the door zone of the left and of the right entrance."""
        s = self._stays
        return (s[2], s[3]), (s[4], s[5])


def plain_stays(world: World, samples: np.ndarray, door_clearance: float) -> tuple[int, int, int, int, int, int]:
    """What :attr:`RobotPlan.passage` and :attr:`RobotPlan.doors` compute, with ``World.on_line``
    and :func:`in_door_zone` (the plain twin of :func:`_stays_kernel`, for the tests)."""
    e, x = corridor_passage(world.on_line(samples))
    (l0, l1), (r0, r1) = (corridor_passage(in_door_zone(world, samples, k, door_clearance)) for k in (0, 1))
    return e, x, l0, l1, r0, r1


@_compiled
def _zones_kernel(s, along_x, ax, ay, nx, ny, s_start, s_end, t_centre, half_width, e0x, e0y, e1x, e1y, radius):
    """Which points ``s`` are in the single-file line (``World.on_line``: between the mouths
    along the axis, within half the width of the centreline across it) and in the door zones
    of the left and of the right entrance (``in_door_zone``: nearer than ``radius``), with those
    functions' operations (``math.hypot`` is the C library's ``hypot``, as ``np.hypot``)."""
    n = s.shape[0]
    line = np.empty(n, dtype=np.bool_)
    left = np.empty(n, dtype=np.bool_)
    right = np.empty(n, dtype=np.bool_)
    for i in range(n):
        px, py = s[i, 0], s[i, 1]
        a = px if along_x else px * ax + py * ay
        between = not a < s_start and not a > s_end
        line[i] = between and abs(px * nx + py * ny - t_centre) - half_width < 0.0
        left[i] = math.hypot(px - e0x, py - e0y) < radius
        right[i] = math.hypot(px - e1x, py - e1y) < radius
    return line, left, right


@_compiled
def zones_of(points, g):
    """:func:`_zones_kernel` of ``points`` with the world's arguments as
    :func:`~nodnav.planning.fused_timing.stay_geometry` packs them into ``g``."""
    return _zones_kernel(points, g[0] != 0.0, g[1], g[2], g[3], g[4], g[5], g[6], g[7], g[8], g[9], g[10], g[11],
                         g[12], g[13])


@_compiled
def grid_and_corners(path, spacing):
    """:func:`~nodnav.planning.polylines.arc_length_grid` of ``path`` (contiguous ``(m, 2)``) and
    :func:`~nodnav.planning.disc_checks.corner_heights` of its points, in one compiled call (the
    same kernels): ``(cells, arc, corners, height)``; no corners for fewer than three cells."""
    cells, arc = _grid_kernel(path, spacing)
    corners, height = corner_heights(cells)
    return cells, arc, corners, height


@_compiled
def cut_zones(cells, g, path):
    """:func:`zones_of` ``cells``, the :func:`~nodnav.planning.occupancy.entry_cell` of each zone
    and :func:`~nodnav.planning.occupancy.polyline_segments` of ``path`` (contiguous ``(m, 2)``),
    in one compiled call (the same kernels): ``(inside, entry, left entry, right entry, segments)``."""
    inside, left, right = zones_of(cells, g)
    return (inside, _entry_kernel(inside), _entry_kernel(left), _entry_kernel(right),
            _segments_kernel(path))


@_compiled
def _stays_kernel(s, along_x, ax, ay, nx, ny, s_start, s_end, t_centre, half_width, e0x, e0y, e1x, e1y, radius):
    """The last stays of the samples ``s`` in the single-file line (``World.on_line``: between
    the mouths along the axis, and within half the width of the centreline across it) and in
    the two door zones (``in_door_zone``: nearer than ``radius`` to the entrance), with those
    functions' operations; each as ``(entry, exit)`` of :func:`corridor_passage`."""
    line, left, right = _zones_kernel(s, along_x, ax, ay, nx, ny, s_start, s_end, t_centre, half_width, e0x, e0y,
                                      e1x, e1y, radius)
    e, x = _passage_kernel(line)
    l0, l1 = _passage_kernel(left)
    r0, r1 = _passage_kernel(right)
    return e, x, l0, l1, r0, r1


@dataclass(frozen=True)
class State:
    """Everything about a request that does not depend on the order."""

    key: tuple
    positions: np.ndarray
    destinations: np.ndarray
    radii: np.ndarray
    max_speeds: np.ndarray
    required: np.ndarray
    """Pairwise separation, :func:`separation_requirements`."""
    directions: np.ndarray
    """Crossing directions, :func:`crossing_directions`."""
    inside: np.ndarray
    """Which robots stand in the corridor."""
    door: np.ndarray
    """Index of the entrance each robot crosses through first (0 left, 1 right), -1 if it does not cross."""
    in_door: np.ndarray
    """Which crossing robots stand in the door zone of that entrance."""
    natural: tuple
    """Each robot's shortest path among the walls alone, from its position to its destination."""
    problem: str
    """Why no order can be planned (a destination outside free space, overlapping ones), or empty."""
    velocities: np.ndarray | None = None
    """Velocities now ``(n, 2)`` (m/s) when paths are timed within the acceleration limits, else None."""
    accels: np.ndarray | None = None
    """Acceleration limits ``(n,)`` (m/s^2) when paths are timed within them, else None."""

    @remembered_property
    def required_list(self) -> list:
        """:attr:`required` as lists of Python floats (``required_list[j][k]`` is
        ``float(required[j, k])``, without indexing NumPy)."""
        return self.required.tolist()

    @remembered_property
    def position_list(self) -> list:
        """:attr:`positions` as lists of Python floats."""
        return self.positions.tolist()

    @remembered_property
    def direction_list(self) -> list:
        """:attr:`directions` as a list of Python numbers (the same comparisons, cheaper)."""
        return self.directions.tolist()

    @remembered_property
    def door_list(self) -> list:
        """:attr:`door` as a list of Python ints."""
        return self.door.tolist()

    @remembered_property
    def in_door_list(self) -> list:
        """:attr:`in_door` as a list of Python bools."""
        return self.in_door.tolist()

    @remembered_property
    def inside_robots(self) -> frozenset:
        """The robots that stand in the corridor (:attr:`inside`), as Python ints."""
        return frozenset(k for k, here in enumerate(self.inside.tolist()) if here)

    @remembered_property
    def stands_and_goals(self) -> np.ndarray:
        """The positions, then the destinations, ``(2n, 2)`` (m): the discs a robot's path keeps
        clear of are rows of it when nobody has got out of the way (one indexing picks them)."""
        return np.concatenate((self.positions, self.destinations))


def joint_arrays_plain(samples: list, t0: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The times, positions and velocities of a joint plan whose robots move through ``samples``
    ``[(T_k, 2)]`` at steps ``0, 1, ...`` and then stand at their last sample: the times ``t0 + dt
    * step`` and the rest by :meth:`JointTrajectory.from_positions` (the reference
    :func:`joint_arrays` is tested against)."""
    ends = [len(x) for x in samples]
    steps, n = max(ends), len(samples)
    positions = np.empty((steps, n, 2))
    for k, x in enumerate(samples):
        positions[:ends[k], k] = x
        positions[ends[k]:, k] = x[-1]
    trajectory = JointTrajectory.from_positions(t0 + dt * np.arange(steps), positions)
    return trajectory.times, trajectory.positions, trajectory.velocities


@_compiled
def joint_arrays(flat, ends, t0, dt):
    """:func:`joint_arrays_plain` in one compiled call, the robots' samples one after another in
    ``flat`` (``ends[k]`` rows of robot ``k``): the same operations (``dt`` times the step, then
    ``t0`` plus it; forward differences divided by the time step)."""
    n = ends.shape[0]
    steps = 0
    for k in range(n):
        steps = max(steps, ends[k])
    times = np.empty(steps)
    for i in range(steps):
        times[i] = t0 + dt * i
    positions = np.empty((steps, n, 2))
    first = 0
    for k in range(n):
        last = first + ends[k] - 1
        for t in range(steps):
            src = min(first + t, last)
            positions[t, k, 0] = flat[src, 0]
            positions[t, k, 1] = flat[src, 1]
        first += ends[k]
    velocities = np.zeros((steps, n, 2))
    for t in range(steps - 1):
        h = times[t + 1] - times[t]
        for k in range(n):
            for d in range(2):
                velocities[t, k, d] = (positions[t + 1, k, d] - positions[t, k, d]) / h
    return times, positions, velocities


def sampled_motion(track: Track, samples: np.ndarray, arc: np.ndarray | None, cells: np.ndarray) -> Motion:
    """The motion along ``track`` at ``samples`` computed with its timing: at the retimed ``arc``
    lengths, or (``arc`` None) at the arc lengths of its ``cells``."""
    return Motion(track.route.path.points, samples, track.arc[cells] if arc is None else arc, track.segments)


def timed_motion(track: Track, timing: "Timing") -> Motion:
    """The motion along ``track`` that ``timing`` gives: at its cells, or at its retimed arc lengths."""
    path = track.route.path.points
    if timing.samples is not None:  # computed with the timing (the same values)
        return sampled_motion(track, timing.samples, timing.arc, timing.cells)
    if timing.arc is None:
        steps = timing.cells
        return Motion(path, track.cells[steps], track.arc[steps], track.segments)
    return Motion(path, points_at(track.cells, track.arc, timing.arc), timing.arc, track.segments)


def reject_request(order: tuple, pos: np.ndarray, dest: np.ndarray, radii: np.ndarray, vmax: np.ndarray) -> NoReturn:
    """Raise the error for a malformed request."""
    raise ValueError(f"malformed request: order {order} for {len(pos)} robots, positions {pos.shape}, destinations "
                     f"{dest.shape}, radii {radii.tolist()}, max_speeds {vmax.tolist()}")


def state_problem(dest: np.ndarray, clear: np.ndarray, radii: np.ndarray) -> str:
    for k in np.flatnonzero(clear < radii - TOL):
        return (f"robot {k}: destination ({dest[k, 0]:.3f}, {dest[k, 1]:.3f}) is not in free space "
                f"(clearance {clear[k]:.3f} m < radius {radii[k]:.3f} m)")
    gaps = np.linalg.norm(dest[:, None] - dest[None], axis=2)
    close = gaps < radii[:, None] + radii[None, :] - TOL
    np.fill_diagonal(close, False)
    if not close.any():  # the pairs below, at once
        return ""
    for a, b in zip(*np.triu_indices(len(dest), 1)):
        if gaps[a, b] < radii[a] + radii[b] - TOL:
            return (f"robots {a} and {b}: destinations overlap ({gaps[a, b]:.3f} m apart, "
                    f"need {radii[a] + radii[b]:.3f} m)")
    return ""


@dataclass(slots=True)
class Attempt:
    success: bool
    reason: str
    plan: RobotPlan | None = None
    trapped: bool = False
    evasions: tuple = ()
    """``(robot, motion)`` of the robots after it that get out of its way first."""


@dataclass(slots=True)
class Joint:
    """Every robot planned in one order: what all results for that order share."""

    success: bool
    reason: str
    cost: float = math.inf
    """Sum of the arrival times (s)."""
    trajectory: JointTrajectory | None = None
    arrival: np.ndarray | None = None
    """Each robot's arrival time after the request's time (s)."""
    lengths: np.ndarray | None = None
    """Each robot's path length (m)."""
    paths: tuple = ()
    """Each robot's polyline."""
    retreats: tuple = ()
    """The robots that back out of the way of robots before them."""
    deferred: tuple = ()
    """The robots that wait aside before they park, so as not to block the robots after them."""


@dataclass(slots=True)
class Layout:
    """Where everybody is while one robot is planned: the robots before it (their plans), and
    the robots after it, standing where they are or where they get out of the way to."""

    plans: dict
    """Planned robot -> :class:`RobotPlan`."""
    heads: dict
    """Robot still to plan -> the motion by which it gets out of the way first (it then stands
    at its end)."""
    later: tuple[int, ...]
    """The robots still to plan, in index order (other than the one being planned)."""

    def fixed(self, but: int) -> list[tuple[int, Motion]]:
        """Every known motion, except robot ``but``'s own: the plans, then the heads."""
        return ([(i, p.motion) for i, p in self.plans.items()]
                + [(j, m) for j, m in sorted(self.heads.items()) if j != but])


class FastPlannerHooks:
    """What the fast planner's mixins (:class:`~nodnav.planning.making_way.MakingWay`,
    :class:`~nodnav.planning.parking.DeferredParking`) use of
    :class:`~nodnav.planning.prioritized.PrioritizedPlanner`, declared once for the type checker."""

    if TYPE_CHECKING:  # provided by PrioritizedPlanner
        params: FastPlannerParams

        def graph(self, world: World, radius: float) -> VisibilityGraph: ...
        def _start(self, state: State, k: int, layout: Layout) -> np.ndarray: ...
        def _prepare(self, world: World, radius: float, step: float, route: Route) -> Track: ...
        def _track(self, world: World, radius: float, step: float, start: np.ndarray, goal: np.ndarray,
                   centres: np.ndarray, rads: np.ndarray, n_later: int) -> Track: ...
        def _track_for(self, world: World, state: State, k: int, layout: Layout) -> Track: ...
        def _timing(self, state: State, k: int, track: Track, fixed: list, gates=(), t0: int = 0,
                    world: World | None = None) -> Timing: ...
        def _time(self, world: World, state: State, k: int, track: Track, layout: Layout,
                  head: Motion | None = None) -> Attempt: ...
        def _state(self, world: World, pos: np.ndarray, dest: np.ndarray, radii: np.ndarray, vmax: np.ndarray,
                   order: tuple, vel: np.ndarray | None = None, accels: np.ndarray | None = None) -> State: ...

