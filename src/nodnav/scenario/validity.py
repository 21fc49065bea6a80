"""Whether a two-room scenario is valid and solvable in principle, decided from geometry alone.

Generated scenarios (:mod:`nodnav.scenario.families`) must be fair tests: a failure should be the
method's, never the scenario's. Nothing here runs a planner or a controller (that would hide their
failures); every rule is geometry on the scenario's numbers.

The layout is the one :func:`~nodnav.scenario.world.corridor_world` builds: a box cut by a thick
wall into a left and a right room, pierced by one corridor along the x axis. ``c`` below is
:data:`CLEARANCE` (0.05 m).

Validity (:func:`check_layout`)
    * every origin and destination lies in free space with clearance: at least ``r_i + c`` from
      every wall and from the box;
    * no two robots overlap anywhere they stand still: every origin and destination is at least
      ``r_a + r_b + c`` from every other robot's origin and destination;
    * the corridor is single file for every pair and fits everyone:
      ``2 r_max + 0.1 <= width <= 2 (r_a + r_b) - 0.05`` for the two smallest radii ``r_a, r_b``;
    * every robot crosses: it starts in one room (or inside the corridor) and its destination is in
      the other room (or, from inside, in the room it faces).

Room capacity (:func:`room_needs`)
    A room of depth ``D`` and height ``H`` holds the robots that start or end in it if
    ``D >= rho + 2 r_max + 2c``, ``H >= 2 (w/2) + 2 (2 r_max + 2c)`` and
    ``D H >= pi rho^2 / 2 + sum_i (2 r_i + 2 r_max + 2c)^2``: a square per robot wide enough for
    any robot to pass between neighbours, plus the mouth zone, the half disc of radius
    ``rho = w/2 + 2 r_max + 2c`` about the mouth's centre that arriving robots come out through.

Solvability (:func:`find_witness`)
    A scenario is solvable in principle when this serial schedule exists (a sufficient condition,
    checked exactly on a 4 cm grid with 2 cm of extra clearance, so that a grid path is a real
    path of the disc):

    1. *Step aside.* Every robot that starts in a room with its disc reaching into that room's
       mouth zone moves, one at a time (the farthest from the mouth first), to a waiting place
       outside the zone: the reachable free place nearest its origin, preferring places with
       room for any robot to pass around it.
    2. *Cross one at a time.* In some order, each robot travels from where it waits to its
       destination while every other robot stands still: those already across at their
       destinations, the others where they wait. The order is searched depth first (robots inside
       the corridor first, then robots whose destination is clear of the far mouth zone, nearest
       their entrance first; mouth blockers last) within :data:`WITNESS_BUDGET` connectivity
       checks.

    Consequences the search finds by itself: a destination parked right in front of a mouth
    blocks that mouth for everyone who uses it later, so its robot must be the last through; two
    such blockers at different mouths, or robots inside the corridor that would have to pass each
    other, admit no schedule, and such a scenario is rejected. The condition is sufficient, not
    necessary: a scenario that needs a robot to back out of the corridor, or robots to shuffle
    while another passes, is rejected although a cleverer schedule might exist.

Speed and acceleration limits (docs/safety.md)
    The witness holds for any positive limits: every robot starts at rest, moves alone along a
    path that keeps ``c`` beyond its radius, and can follow it at a speed low enough to stop
    within its clearance, however slowly it accelerates. What slow acceleration changes is how
    long the schedule takes, which the drawn time limit counts
    (:func:`~nodnav.scenario.draws.travel_time`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import INSIDE, LEFT, RIGHT, World, corridor_world

CLEARANCE = 0.05
"""Room kept beyond the radius from every wall and between robots wherever they stand (m)."""
FIT_MARGIN = 0.1
"""The corridor is at least ``2 r_max`` plus this wide: every robot fits with 5 cm a side (m)."""
ABREAST_MARGIN = 0.05
"""The corridor is at least this much narrower than any two robots side by side (m)."""
GRID = 0.04
"""Cell size of the witness's connectivity grid (m); the grid contains the corridor's axis y = 0."""
PATH_MARGIN = 0.02
"""Clearance beyond the radius of every grid cell a witness path uses (m); with cells of
:data:`GRID`, a path of 4-connected free cells keeps the disc ``PATH_MARGIN - GRID / 2 = 0`` clear."""
WITNESS_BUDGET = 200
"""Connectivity checks the witness search may spend before it gives up (each one labels the grid)."""


@dataclass(frozen=True)
class Verdict:
    """Whether a scenario passed a check, and if not why (one line)."""

    ok: bool
    """Whether the check passed."""
    reason: str = ""
    """Why it failed; empty when it passed."""
    order: tuple[int, ...] = ()
    """The witness's crossing order (robots numbered from 0), when a witness was searched and found."""
    waits: tuple[tuple[int, tuple[float, float]], ...] = ()
    """Stage 1 of the witness: (robot, waiting place) for every robot that stepped aside."""


def single_file_interval(radii) -> tuple[float, float]:
    """The widths (m) that fit every robot and let no two pass: ``[2 r_max + 0.1, 2 (r_a + r_b) - 0.05]``."""
    r = np.sort(np.asarray(radii, dtype=float))
    smallest_pair = r[0] + (r[1] if len(r) > 1 else r[0])
    return 2.0 * r[-1] + FIT_MARGIN, 2.0 * smallest_pair - ABREAST_MARGIN


def mouth_zone_radius(half_width: float, r_max: float) -> float:
    """Radius ``rho`` (m) of the half disc about a mouth's centre that arriving robots come out through."""
    return half_width + 2.0 * r_max + 2.0 * CLEARANCE


def room_needs(radii_in_room, r_max: float, half_width: float) -> tuple[float, float, float]:
    """Minimum depth (m), height (m) and area (m^2) of a room that robots of ``radii_in_room`` start or end in."""
    rho = mouth_zone_radius(half_width, r_max)
    cells = sum((2.0 * r + 2.0 * r_max + 2.0 * CLEARANCE) ** 2 for r in radii_in_room)
    depth = rho + 2.0 * r_max + 2.0 * CLEARANCE
    height = 2.0 * half_width + 2.0 * (2.0 * r_max + 2.0 * CLEARANCE)
    return depth, height, 0.5 * math.pi * rho * rho + cells


def is_two_room_world(world: World) -> bool:
    """Whether ``world`` is the layout of :func:`~nodnav.scenario.world.corridor_world`."""
    c = world.shorthand
    x0, y0, x1, y1 = world.bounds
    if not (c.y_min == -c.y_max and x0 < c.x_min < c.x_max < x1 and y0 < c.y_min and c.y_max < y1):
        return False
    expected = corridor_world(c.x_min, c.x_max, c.y_max, c.x_min - x0, x1 - c.x_max, y0, y1)
    return world.obstacles == expected.obstacles and world.entrances == expected.entrances


def _sides(world: World, scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    return world.side_of(scenario.origins), world.side_of(scenario.destinations)


def check_layout(scenario: Scenario) -> Verdict:
    """The validity rules of the module docstring: clearance, no overlaps, single file, everyone crosses."""
    world = scenario.world
    if not is_two_room_world(world):
        return Verdict(False, "the world is not two rooms joined by one corridor along the x axis")
    radii, origins, dests = scenario.radii, scenario.origins, scenario.destinations
    n = len(radii)
    lo, hi = single_file_interval(radii)
    width = world.shorthand.width
    if not lo - 1e-9 <= width <= hi + 1e-9:
        return Verdict(False,
                       f"corridor width {width:.3f} m is outside the single-file interval [{lo:.3f}, {hi:.3f}] m")
    for what, pts in (("origin", origins), ("destination", dests)):
        clear = world.clearance(pts) - radii
        k = int(np.argmin(clear))
        if clear[k] < CLEARANCE - 1e-9:
            return Verdict(False, f"robot {k + 1}'s {what} is {clear[k]:.3f} m from a wall, need {CLEARANCE} m")
    pts = np.concatenate([origins, dests])
    owner = np.concatenate([np.arange(n), np.arange(n)])
    rr = np.concatenate([radii, radii])
    gap = np.linalg.norm(pts[:, None] - pts[None], axis=-1) - rr[:, None] - rr[None]
    gap[owner[:, None] == owner[None]] = np.inf
    a, b = np.unravel_index(int(np.argmin(gap)), gap.shape)
    if gap[a, b] < CLEARANCE - 1e-9:
        first, second = sorted((int(owner[a]) + 1, int(owner[b]) + 1))
        return Verdict(False, f"robots {first} and {second} stand {gap[a, b]:.3f} m apart, need {CLEARANCE} m")
    start, goal = _sides(world, scenario)
    for k in range(n):
        if goal[k] == INSIDE or goal[k] == start[k]:
            return Verdict(False, f"robot {k + 1} does not cross: its destination is not in the other room")
    return Verdict(True)


def check_capacity(scenario: Scenario) -> Verdict:
    """The room-capacity rule of the module docstring, for both rooms."""
    world = scenario.world
    start, goal = _sides(world, scenario)
    radii, r_max, half = scenario.radii, float(scenario.radii.max()), world.shorthand.y_max
    x0, y0, x1, y1 = world.bounds
    for side, name, depth in ((LEFT, "left", world.shorthand.x_min - x0), (RIGHT, "right", x1 - world.shorthand.x_max)):
        members = radii[(start == side) | (goal == side)]
        need_depth, need_height, need_area = room_needs(members, r_max, half)
        if depth < need_depth - 1e-9 or y1 - y0 < need_height - 1e-9 or depth * (y1 - y0) < need_area - 1e-9:
            return Verdict(False, f"the {name} room ({depth:.2f} x {y1 - y0:.2f} m) is too small for its "
                                  f"{len(members)} robots (needs depth {need_depth:.2f} m, height {need_height:.2f} m, "
                                  f"area {need_area:.1f} m^2)")
    return Verdict(True)


class _Grid:
    """Free space of the world sampled on a grid aligned with the origin, for connectivity checks."""

    def __init__(self, world: World):
        x0, y0, x1, y1 = world.bounds
        self.ix0, self.iy0 = math.ceil(x0 / GRID), math.ceil(y0 / GRID)
        xs = np.arange(self.ix0, math.floor(x1 / GRID) + 1) * GRID
        ys = np.arange(self.iy0, math.floor(y1 / GRID) + 1) * GRID
        self.points = np.stack(np.meshgrid(xs, ys), axis=-1)  # (ny, nx, 2)
        self.clearance = world.clearance(self.points)

    def cell(self, p) -> tuple[int, int]:
        """Index (row, column) of the grid point nearest ``p``, clipped to the grid."""
        ny, nx = self.clearance.shape
        return (min(max(round(p[1] / GRID) - self.iy0, 0), ny - 1), min(max(round(p[0] / GRID) - self.ix0, 0), nx - 1))

    def free(self, radius: float, others, margin: float = PATH_MARGIN) -> np.ndarray:
        """Cells where a disc of ``radius`` keeps ``margin`` from walls and from the discs ``others`` [(centre, r)]."""
        mask = self.clearance >= radius + margin - 1e-9
        ny, nx = mask.shape
        for centre, r in others:
            reach = radius + r + margin
            (r0, c0), (r1, c1) = self.cell(np.asarray(centre) - reach), self.cell(np.asarray(centre) + reach)
            window = self.points[r0:r1 + 1, c0:c1 + 1]
            mask[r0:r1 + 1, c0:c1 + 1] &= np.linalg.norm(window - np.asarray(centre), axis=-1) >= reach - 1e-9
        return mask

    def component(self, mask: np.ndarray, p) -> np.ndarray:
        """The cells of ``mask`` connected (4-neighbours) to the cell nearest ``p``; empty if that cell is not free."""
        labels, _ = ndimage.label(mask)
        lab = labels[self.cell(p)]
        return labels == lab if lab else np.zeros_like(mask)

    def connected(self, mask: np.ndarray, a, b) -> bool:
        """Whether the cells nearest ``a`` and ``b`` are free and connected in ``mask``."""
        labels, _ = ndimage.label(mask)
        la, lb = labels[self.cell(a)], labels[self.cell(b)]
        return bool(la) and la == lb


class _Search:
    """The witness of the module docstring for one scenario."""

    def __init__(self, scenario: Scenario, budget: int):
        self.s, self.world = scenario, scenario.world
        self.grid = _Grid(self.world)
        self.budget = budget
        self.n = scenario.n_robots
        self.radii = scenario.radii
        self.r_max = float(self.radii.max())
        self.rho = mouth_zone_radius(self.world.shorthand.y_max, self.r_max)
        self.start, self.goal = _sides(self.world, scenario)
        self.mouths = np.asarray(self.world.entrances, dtype=float)
        self.waiting = scenario.origins.copy()

    def _mouth(self, side: int) -> np.ndarray:
        return self.mouths[0] if side == LEFT else self.mouths[1]

    def _spend(self) -> None:
        self.budget -= 1
        if self.budget < 0:
            raise _OutOfBudget

    def step_aside(self) -> tuple[tuple[int, tuple[float, float]], ...] | str:
        """Stage 1: robots reaching into their room's mouth zone move to waiting places outside it."""
        outside = np.flatnonzero(self.start != INSIDE)
        dist = np.array([np.linalg.norm(self.waiting[k] - self._mouth(self.start[k])) for k in range(self.n)])
        movers = [k for k in outside if dist[k] < self.rho + self.radii[k]]
        waits = []
        for k in sorted(movers, key=lambda k: (-dist[k], k)):
            side, mouth = self.start[k], self._mouth(self.start[k])
            others = [(self.waiting[j], self.radii[j]) for j in range(self.n) if j != k]
            parked = [(self.s.destinations[j], self.radii[j]) for j in range(self.n)
                      if j != k and self.goal[j] == side]
            self._spend()
            reach = self.grid.component(self.grid.free(self.radii[k], others), self.waiting[k])
            pts = self.grid.points
            beyond = side * (pts[..., 0] - mouth[0]) >= self.radii[k] + CLEARANCE
            out_of_zone = np.linalg.norm(pts - mouth, axis=-1) >= self.rho + self.radii[k]
            spot = None
            for margin in (2.0 * self.r_max + 2.0 * CLEARANCE, CLEARANCE):  # room to pass around it, else any
                ok = reach & beyond & out_of_zone & self.grid.free(self.radii[k], others + parked, margin)
                if ok.any():
                    cells = np.argwhere(ok)
                    d = np.linalg.norm(pts[ok] - self.waiting[k], axis=-1)
                    spot = pts[tuple(cells[int(np.argmin(d))])]
                    break
            if spot is None:
                return f"robot {k + 1} has nowhere to wait clear of the mouth"
            self.waiting[k] = spot
            waits.append((int(k), (float(spot[0]), float(spot[1]))))
        return tuple(waits)

    def _priority(self, k: int) -> tuple:
        if self.start[k] == INSIDE:  # nearest its exit first
            return (0, -self.goal[k] * self.s.origins[k][0], k)
        far = self._mouth(self.goal[k])
        blocker = np.linalg.norm(self.s.destinations[k] - far) < self.rho + self.radii[k]
        near = np.linalg.norm(self.waiting[k] - self._mouth(self.start[k]))
        return (1 + int(blocker), near, k)

    def _can_go(self, k: int, done: frozenset) -> bool:
        others = [(self.s.destinations[j] if j in done else self.waiting[j], self.radii[j])
                  for j in range(self.n) if j != k]
        self._spend()
        return self.grid.connected(self.grid.free(self.radii[k], others), self.waiting[k], self.s.destinations[k])

    def cross(self) -> tuple[int, ...] | None:
        """Stage 2: a crossing order, depth first, or ``None``."""
        ranked = sorted(range(self.n), key=self._priority)
        dead: set[frozenset] = set()

        def search(done: frozenset, order: tuple[int, ...]) -> tuple[int, ...] | None:
            if len(done) == self.n:
                return order
            if done in dead:
                return None
            for k in ranked:
                if k not in done and self._can_go(k, done):
                    found = search(done | {k}, order + (k,))
                    if found is not None:
                        return found
            dead.add(done)
            return None

        return search(frozenset(), ())


class _OutOfBudget(Exception):
    pass


def find_witness(scenario: Scenario, budget: int = WITNESS_BUDGET) -> Verdict:
    """The serial schedule of the module docstring, or why none was found within ``budget`` checks."""
    search = _Search(scenario, budget)
    try:
        waits = search.step_aside()
        if isinstance(waits, str):
            return Verdict(False, waits)
        order = search.cross()
    except _OutOfBudget:
        return Verdict(False, f"no crossing schedule found within {budget} connectivity checks")
    if order is None:
        return Verdict(False, "no order lets every robot cross while the others stand still")
    return Verdict(True, order=order, waits=waits)


def check_scenario(scenario: Scenario, budget: int = WITNESS_BUDGET) -> Verdict:
    """Validity, room capacity and solvability (the module docstring), the first failure's reason."""
    for check in (check_layout, check_capacity):
        verdict = check(scenario)
        if not verdict.ok:
            return verdict
    return find_witness(scenario, budget)
