"""Whether a floor-plan scenario is valid and solvable in principle, from its geometry alone.

The rules of :mod:`nodnav.scenario.validity` carried over to a world of several rooms and
passages (:mod:`nodnav.scenario.building`). It works on the scenario's mapping (the ``world``
with every passage in ``world.passages``), so that plans with several passages are checked even
where the simulator takes one; nothing runs a planner. ``c`` is
:data:`~nodnav.scenario.validity.CLEARANCE` (0.05 m).

Validity (:func:`check_plan`)
    * every passage is single file for the robots: twice the least clearance along its
      centreline is at least ``2 r_max + 0.1`` and below ``2 (r_a + r_b)`` for the two smallest
      radii, and its width is that clear width (within 2 mm);
    * passages are apart: their clear rectangles do not meet;
    * every origin and destination is at least ``r + c`` from every wall (inside the building)
      and ``r_a + r_b + c`` from every other robot's, and outside every mouth zone (the half disc
      of radius ``rho = w_max/2 + 2 r_max + 2c`` about each mouth: nobody has to step aside);
    * every robot's route crosses at least one passage: with every passage's clear rectangle
      walled off, free space falls into rooms; passages join rooms; the passages a robot's route
      crosses are the fewest between its origin's room and its destination's (:func:`crossings`).

Solvability (:func:`find_plan_witness`)
    The serial schedule of :mod:`nodnav.scenario.validity` without its first stage (nobody stands
    in a mouth zone): in some order, each robot travels alone to its destination while every other
    stands still at its origin or destination, checked exactly on the 4 cm grid with 2 cm of extra
    clearance, searched depth first within :data:`~nodnav.scenario.validity.WITNESS_BUDGET`
    connectivity checks.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from scipy import ndimage

from nodnav.scenario.validity import (
    ABREAST_MARGIN,
    CLEARANCE,
    FIT_MARGIN,
    WITNESS_BUDGET,
    Verdict,
    _Grid,
    mouth_zone_radius,
)
from nodnav.scenario.world import Passage, World

TOL = 1e-9


class Plan:
    """A floor-plan scenario's geometry: walls, passages and robots, read from its mapping."""

    def __init__(self, mapping: dict):
        world = mapping["world"]
        low_x, low_y, high_x, high_y = (float(v) for v in world["bounds"])
        self.bounds = (low_x, low_y, high_x, high_y)
        boxes = tuple((float(o[0]), float(o[1]), float(o[2]), float(o[3])) for o in world.get("obstacles", [])
                      if not isinstance(o[0], list))
        polys = tuple(tuple((float(p[0]), float(p[1])) for p in o) for o in world.get("obstacles", [])
                      if isinstance(o[0], list))
        self.passages = [Passage(tuple(p["from"]), tuple(p["to"]), float(p["width"])) for p in world["passages"]]
        self.world = World(bounds=self.bounds, obstacles=boxes, passages=(self.passages[0],),
                           polygons=polys)
        robots = mapping["robots"]
        self.radii = np.array([float(r.get("radius", 0.2)) for r in robots])
        self.origins = np.array([r["origin"] for r in robots], dtype=float)
        self.destinations = np.array([r["destination"] for r in robots], dtype=float)
        self.n = len(robots)


def _single_file(plan: Plan) -> str:
    r = np.sort(plan.radii)
    lo, abreast = 2 * r[-1] + FIT_MARGIN, 2 * (r[0] + (r[1] if len(r) > 1 else r[0]))
    for k, g in enumerate(plan.passages):
        a, b = np.asarray(g.start), np.asarray(g.end)
        samples = max(2, int(g.length / 0.01) + 1)
        gap = 2.0 * float(plan.world.clearance(a + np.linspace(0.0, 1.0, samples)[:, None] * (b - a)).min())
        if not lo - 0.002 <= gap < abreast:
            return (f"passage {k + 1} leaves {gap:.3f} m clear, not single file for radii {r[0]:g}..{r[-1]:g} m "
                    f"(need {lo:.3f} m to {abreast:.3f} m)")
        if abs(gap - g.width) > 0.002 or g.width > abreast - ABREAST_MARGIN + 0.002:
            return f"passage {k + 1} is {g.width:.3f} m wide but its walls leave {gap:.3f} m"
    return ""


def _apart(plan: Plan) -> str:
    import shapely

    shapes = [shapely.Polygon(g.outline()) for g in plan.passages]
    for i in range(len(shapes)):
        for j in range(i + 1, len(shapes)):
            if shapes[i].intersects(shapes[j]):
                return f"passages {i + 1} and {j + 1} overlap"
    return ""


class _Rooms:
    """Free space with every passage walled off, labelled into rooms; passages join rooms."""

    def __init__(self, plan: Plan, grid: _Grid):
        free = grid.clearance > 0.0
        pts = grid.points
        for g in plan.passages:
            s, t = g.along(pts), g.across(pts) - g.t_centre
            free &= ~((s >= g.s_start - grid_step()) & (s <= g.s_end + grid_step())
                      & (np.abs(t) <= 0.5 * g.width + grid_step()))
        self.grid, self.plan = grid, plan
        self.labels, _ = ndimage.label(free)
        self.edges: list[tuple[int, int]] = []
        for g in plan.passages:
            ends = []
            for mouth, sign in ((np.asarray(g.start), -1.0), (np.asarray(g.end), 1.0)):
                probe = mouth + sign * 3 * grid_step() * np.asarray(g.axis)
                ends.append(int(self.labels[grid.cell(probe)]))
            self.edges.append((ends[0], ends[1]))

    def room(self, p) -> int:
        return int(self.labels[self.grid.cell(p)])

    def crossings(self, a, b) -> int | None:
        """Fewest passages between the rooms of points ``a`` and ``b`` (None: not joined)."""
        start, goal = self.room(a), self.room(b)
        if not start or not goal:
            return None
        seen, todo = {start: 0}, deque([start])
        while todo:
            u = todo.popleft()
            if u == goal:
                return seen[u]
            for x, y in self.edges:
                for p, q in ((x, y), (y, x)):
                    if p == u and q and q not in seen:
                        seen[q] = seen[u] + 1
                        todo.append(q)
        return None


def grid_step() -> float:
    """Cell size (m) of the witness's grid."""
    from nodnav.scenario.validity import GRID

    return GRID


def crossings(mapping: dict) -> list[int | None]:
    """How many passages each robot's route crosses (None: its origin and destination are not joined)."""
    plan = Plan(mapping)
    rooms = _Rooms(plan, _Grid(plan.world))
    return [rooms.crossings(o, d) for o, d in zip(plan.origins, plan.destinations)]


def check_plan(plan: Plan, grid: _Grid) -> Verdict:
    """The validity rules of the module docstring."""
    for problem in (_single_file(plan), _apart(plan)):
        if problem:
            return Verdict(False, problem)
    radii = plan.radii
    for what, pts in (("origin", plan.origins), ("destination", plan.destinations)):
        clear = plan.world.clearance(pts) - radii
        k = int(np.argmin(clear))
        if clear[k] < CLEARANCE - TOL:
            return Verdict(False, f"robot {k + 1}'s {what} is {clear[k]:.3f} m from a wall, need {CLEARANCE} m")
    pts = np.concatenate([plan.origins, plan.destinations])
    owner = np.concatenate([np.arange(plan.n), np.arange(plan.n)])
    rr = np.concatenate([radii, radii])
    gap = np.linalg.norm(pts[:, None] - pts[None], axis=-1) - rr[:, None] - rr[None]
    gap[owner[:, None] == owner[None]] = np.inf
    a, b = np.unravel_index(int(np.argmin(gap)), gap.shape)
    if gap[a, b] < CLEARANCE - TOL:
        return Verdict(False, f"robots {int(owner[a]) + 1} and {int(owner[b]) + 1} stand {gap[a, b]:.3f} m apart")
    rho = mouth_zone_radius(0.5 * max(g.width for g in plan.passages), float(radii.max()))
    mouths = np.array([m for g in plan.passages for m in (g.start, g.end)], dtype=float)
    near = np.linalg.norm(pts[:, None] - mouths[None], axis=-1).min(axis=1) - rr
    k = int(np.argmin(near))
    if near[k] < rho - TOL:
        return Verdict(False, f"robot {int(owner[k]) + 1} stands in a mouth zone")
    rooms = _Rooms(plan, grid)
    for k in range(plan.n):
        m = rooms.crossings(plan.origins[k], plan.destinations[k])
        if not m:
            return Verdict(False, f"robot {k + 1}'s route crosses no passage")
    return Verdict(True)


def find_plan_witness(plan: Plan, grid: _Grid, budget: int = WITNESS_BUDGET) -> Verdict:
    """The serial schedule of the module docstring, or why none was found within ``budget`` checks."""
    n, radii = plan.n, plan.radii
    left = [budget]
    ranked = sorted(range(n), key=lambda k: (-float(radii[k]), k))  # the largest first: most room then

    def can_go(k: int, done: frozenset) -> bool:
        left[0] -= 1
        if left[0] < 0:
            raise _OutOfBudget
        others = [(plan.destinations[j] if j in done else plan.origins[j], radii[j]) for j in range(n) if j != k]
        return grid.connected(grid.free(float(radii[k]), others), plan.origins[k], plan.destinations[k])

    dead: set[frozenset] = set()

    def search(done: frozenset, order: tuple[int, ...]) -> tuple[int, ...] | None:
        if len(done) == n:
            return order
        if done in dead:
            return None
        for k in ranked:
            if k not in done and can_go(k, done):
                found = search(done | {k}, order + (k,))
                if found is not None:
                    return found
        dead.add(done)
        return None

    try:
        order = search(frozenset(), ())
    except _OutOfBudget:
        return Verdict(False, f"no crossing schedule found within {budget} connectivity checks")
    if order is None:
        return Verdict(False, "no order lets every robot cross while the others stand still")
    return Verdict(True, order=order)


class _OutOfBudget(Exception):
    pass


def check_building(mapping: dict, budget: int = WITNESS_BUDGET) -> Verdict:
    """Validity and solvability of a floor-plan scenario's mapping (the module docstring)."""
    plan = Plan(mapping)
    grid = _Grid(plan.world)
    verdict = check_plan(plan, grid)
    if not verdict.ok:
        return verdict
    return find_plan_witness(plan, grid, budget)

