"""People among the robots: pedestrians that walk their own shortest route with the social force model.

Methods ``person`` and ``person-yielding`` (``robots[i].method: person``). A person knows the
walls and its destination, nothing of passing orders: every control step it heads for the next
vertex of its shortest route among the walls (:class:`~nodnav.planning.visibility.VisibilityGraph`,
the routes ``orca`` follows) at its own preferred speed, and steers around everyone it sees and
around the walls with the social force model.

The model (all forces per person, in newtons; Helbing, Farkas and Vicsek, "Simulating dynamical
features of escape panic", Nature 407, 487-490, 2000, the "HFV" form of Helbing and Molnar's
social force model, Phys. Rev. E 51, 4282, 1995)::

    m dv/dt = m (v0 e - v) / tau + sum_j w_ij f_ij + sum_W f_iW
    f_ij = [A exp((r_ij - d_ij) / B) + k g(r_ij - d_ij)] n_ij + kappa g(r_ij - d_ij) dv_ji.t_ij t_ij
    f_iW = [A exp((r_i - d_iW) / B) + k g(r_i - d_iW)] n_iW - kappa g(r_i - d_iW) (v_i.t_iW) t_iW

with ``g(x) = max(x, 0)`` (the body forces act only in contact), ``r_ij = r_i + r_j``, ``d_ij`` the
distance between centres, ``n_ij`` the unit vector from ``j`` to ``i``, ``t_ij`` its normal and
``dv_ji.t_ij = (v_j - v_i).t_ij``; ``d_iW``, ``n_iW`` and ``t_iW`` likewise for the nearest point
of wall ``W`` (every wall rectangle and each side of the world's boundary within ``range``). The
weight ``w_ij`` is Helbing and Molnar's (1995) field of view: 1 for someone within ``fov / 2`` of
the person's heading, ``c`` behind it; it scales the social (exponential) term only, since pushing
in contact is felt from every side. The parameters, :class:`SocialForceParams`, are the published
ones; only the person's speed limit and acceleration limit come from its
:class:`~nodnav.scenario.params.RobotSpec` (``max_speed``, ``max_accel``): the force gives the
acceleration, which is clipped to ``max_accel``, then the velocity to ``max_speed``.

One departure from HFV: a wall's social term only steers (``wall_lateral``; ``False`` is HFV's
literal term). Its component against the direction the person heads for is dropped, so that it
keeps a person off the walls and in the middle of a passage but never holds it back; the person's
route already keeps clear of the walls. With the literal term, A = 2000 N and B = 0.08 m, the two
corners of the paper's 0.7 m corridor push a person of radius 0.2 m back with 2 x 80 N along the
corridor at its mouth, as much as the driving force of a person whose preferred speed is 1 m/s (it
stood at the mouth for ever: regression ``person-at-the-mouth``); a mouth leaving 0.1 m on each
side of a person pushes it back harder than a person slower than about 1 m/s is pulled
(``person-slow-into-a-narrow-mouth``; in the ``mixed`` family a quarter of the trials with a person
deadlocked). Contact (body) forces are HFV's, from every side.

Why the social force model and not ORCA with human parameters: ORCA's agents never touch by
construction (they pick collision-free velocities), so it cannot produce the contacts a person
causes by walking on; the social force model reproduces pedestrian passing and pushing, and its
parameters come from one published calibration.

Preferred speed: drawn once per trial for each person with its own seeded generator, from
Weidmann's (1993) normal distribution of free walking speeds, mean 1.34 m/s and standard
deviation 0.26 m/s, clipped to ``[min_speed, max_speed]`` of the person (a person whose
comfortable speed is above what its body allows walks at its limit).

Physics: a person never passes through a wall. Its step is clipped as a body pushed against a
wall moves: if the straight step would bring it nearer a wall than its radius, it keeps only the
component of the step along the wall (the walls are axis-aligned), or stays.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from nodnav.control import ControlResult
from nodnav.control.base import STEP_FRACTIONS
from nodnav.planning.base import PlanResult
from nodnav.planning.visibility import VisibilityGraph
from nodnav.registry import register_method
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import World
from nodnav.sim.agent import Decision, RobotView, approach_sides
from nodnav.sim.baselines import NO_OPINION, next_waypoint, route_trajectory


@dataclass(frozen=True)
class SocialForceParams:
    """The social force model's parameters (Helbing, Farkas and Vicsek 2000; field of view from
    Helbing and Molnar 1995) and a person's walking habits."""

    mass: float = 80.0
    """Body mass m (kg); HFV 2000: 80."""
    tau: float = 0.5
    """Relaxation time tau of the driving force (s); HFV 2000: 0.5."""
    A: float = 2000.0
    """Strength A of the social repulsion (N); HFV 2000: 2 x 10^3."""
    B: float = 0.08
    """Range B of the social repulsion (m); HFV 2000: 0.08."""
    k: float = 1.2e5
    """Body compression coefficient k (kg/s^2); HFV 2000: 1.2 x 10^5."""
    kappa: float = 2.4e5
    """Sliding friction coefficient kappa (kg/(m s)); HFV 2000: 2.4 x 10^5."""
    fov: float = 200.0
    """Field of view 2 phi (degrees); Helbing and Molnar 1995: 200."""
    behind: float = 0.5
    """Weight c of the social repulsion from someone outside the field of view; Helbing and Molnar 1995: 0.5
    (1 gives HFV's isotropic model)."""
    speed_mean: float = 1.34
    """Mean preferred walking speed (m/s); Weidmann 1993: 1.34."""
    speed_sd: float = 0.26
    """Standard deviation of the preferred walking speed (m/s); Weidmann 1993: 0.26."""
    min_speed: float = 0.5
    """Lowest preferred speed drawn (m/s); chosen: slower draws (2.2 sd below the mean) are clipped."""
    route_margin: float = 0.05
    """Clearance kept from the walls by the route, beyond the radius (m); as ``baselines.orca_route_margin``."""
    range: float = 2.0
    """Distance beyond which walls and others exert no force (m): the exponential is below 1e-7 A there."""
    yield_distance: float = 1.5
    """``person-yielding``: distance to its entrance at which a person waits while someone comes the other way (m)."""
    substeps: int = 8
    """Integration steps per control step (0.1 s): the stiff wall and body terms (natural period
    about 0.6 s in the paper's corridor) need steps well below the control step."""
    wall_lateral: bool = True
    """Whether the wall's social (exponential) term only steers (its part against the person's
    heading dropped, :func:`lateral`); chosen, see the module docstring; ``False`` is HFV's literal term."""


# ---------------------------------------------------------------------------------------------
# The equations, as pure functions


def g(x: np.ndarray | float) -> np.ndarray:
    """HFV's contact function: ``x`` if positive (overlap), else 0."""
    return np.maximum(x, 0.0)


def driving_force(velocity: np.ndarray, preferred: np.ndarray, mass: float, tau: float) -> np.ndarray:
    """``m (v0 e - v) / tau`` (N): the pull towards the preferred velocity ``v0 e``."""
    return mass * (np.asarray(preferred, dtype=float) - np.asarray(velocity, dtype=float)) / tau


def agent_forces(p_i: np.ndarray, v_i: np.ndarray, r_i: float, p_j: np.ndarray, v_j: np.ndarray, r_j: np.ndarray,
                 p: SocialForceParams) -> np.ndarray:
    """HFV's force ``f_ij`` ``(m, 2)`` (N) on a person at ``p_i`` (velocity ``v_i``, radius ``r_i``)
    from each of ``m`` others at ``p_j`` ``(m, 2)`` (velocities ``v_j``, radii ``r_j``), without
    the field-of-view weight (:func:`view_weights`)."""
    d_vec = np.asarray(p_i, dtype=float)[None] - np.asarray(p_j, dtype=float).reshape(-1, 2)
    d = np.maximum(np.linalg.norm(d_vec, axis=1), 1e-9)
    n = d_vec / d[:, None]
    t = np.stack([-n[:, 1], n[:, 0]], axis=1)
    overlap = np.asarray(r_i + np.asarray(r_j, dtype=float)) - d
    dv_t = np.einsum("ij,ij->i", np.asarray(v_j, dtype=float).reshape(-1, 2) - np.asarray(v_i, dtype=float)[None], t)
    normal = p.A * np.exp(overlap / p.B) + p.k * g(overlap)
    return normal[:, None] * n + (p.kappa * g(overlap) * dv_t)[:, None] * t


def social_part(p_i: np.ndarray, r_i: float, p_j: np.ndarray, r_j: np.ndarray, p: SocialForceParams) -> np.ndarray:
    """The social (exponential) term of :func:`agent_forces` alone ``(m, 2)`` (N), the part the
    field of view weighs."""
    d_vec = np.asarray(p_i, dtype=float)[None] - np.asarray(p_j, dtype=float).reshape(-1, 2)
    d = np.maximum(np.linalg.norm(d_vec, axis=1), 1e-9)
    return (p.A * np.exp((r_i + np.asarray(r_j, dtype=float) - d) / p.B))[:, None] * (d_vec / d[:, None])


def view_weights(heading: np.ndarray, p_i: np.ndarray, p_j: np.ndarray, p: SocialForceParams) -> np.ndarray:
    """Helbing and Molnar's field-of-view weight ``(m,)``: 1 for others within ``fov / 2`` of
    ``heading`` (the direction the person wants to go), ``behind`` for the rest; 1 for all when
    there is no heading."""
    h = np.asarray(heading, dtype=float)
    norm = float(np.hypot(*h))
    to_j = np.asarray(p_j, dtype=float).reshape(-1, 2) - np.asarray(p_i, dtype=float)[None]
    if norm == 0.0:
        return np.ones(len(to_j))
    dist = np.maximum(np.linalg.norm(to_j, axis=1), 1e-9)
    cos = (to_j @ (h / norm)) / dist
    return np.where(cos >= math.cos(math.radians(p.fov / 2.0)), 1.0, p.behind)


def nearest_wall_points(world: World, point: np.ndarray) -> np.ndarray:
    """The nearest point ``(W, 2)`` of every wall rectangle, then of each of the four sides of
    the world's boundary, to ``point``."""
    q = np.asarray(point, dtype=float)
    walls = world.obstacle_array
    inside = np.stack([np.clip(q[0], walls[:, 0], walls[:, 2]), np.clip(q[1], walls[:, 1], walls[:, 3])], axis=1) \
        if len(walls) else np.zeros((0, 2))
    x0, y0, x1, y1 = world.bounds
    sides = np.array([[x0, q[1]], [x1, q[1]], [q[0], y0], [q[0], y1]], dtype=float)
    return np.concatenate([inside, sides])


def lateral(force: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """``force`` without its component against the unit ``heading`` (unchanged if it has none)."""
    f = np.asarray(force, dtype=float)
    e = np.asarray(heading, dtype=float)
    along = float(f @ e)
    return f - along * e if along < 0.0 else f


def wall_social(p_i: np.ndarray, r_i: float, wall_point: np.ndarray, p: SocialForceParams) -> np.ndarray:
    """The social (exponential) part of :func:`wall_forces` from one wall point ``(2,)`` (N)."""
    d_vec = np.asarray(p_i, dtype=float) - np.asarray(wall_point, dtype=float)
    d = max(float(np.hypot(*d_vec)), 1e-9)
    return p.A * math.exp((r_i - d) / p.B) * d_vec / d


def wall_forces(p_i: np.ndarray, v_i: np.ndarray, r_i: float, wall_points: np.ndarray,
                p: SocialForceParams) -> np.ndarray:
    """HFV's force ``f_iW`` ``(W, 2)`` (N) on a person at ``p_i`` (velocity ``v_i``, radius
    ``r_i``) from walls whose nearest points are ``wall_points`` ``(W, 2)``."""
    d_vec = np.asarray(p_i, dtype=float)[None] - np.asarray(wall_points, dtype=float).reshape(-1, 2)
    d = np.maximum(np.linalg.norm(d_vec, axis=1), 1e-9)
    n = d_vec / d[:, None]
    t = np.stack([-n[:, 1], n[:, 0]], axis=1)
    overlap = r_i - d
    normal = p.A * np.exp(overlap / p.B) + p.k * g(overlap)
    slide = p.kappa * g(overlap) * (t @ np.asarray(v_i, dtype=float))
    return normal[:, None] * n - slide[:, None] * t


def clip_norm(vector: np.ndarray, limit: float) -> np.ndarray:
    """``vector`` scaled down to length ``limit`` if longer."""
    v = np.asarray(vector, dtype=float)
    norm = float(np.hypot(*v))
    return v if norm <= limit or norm == 0.0 else v * (limit / norm)


def clip_against_walls(world: World, position: np.ndarray, step: np.ndarray, radius: float) -> np.ndarray:
    """The part of ``step`` a disc of ``radius`` at ``position`` can take without coming nearer a
    wall than ``radius`` along the way: the whole step, else its component along x or along y
    (sliding along an axis-aligned wall; the longer that is possible), else nothing."""
    p = np.asarray(position, dtype=float)
    s = np.asarray(step, dtype=float)
    start_clear = float(world.clearance(p[None])[0])
    need = min(radius, start_clear)  # a body already squeezed may leave but never go closer
    candidates = [s, np.array([s[0], 0.0]), np.array([0.0, s[1]])]
    candidates = sorted(candidates[1:], key=lambda c: -float(np.hypot(*c)))
    for c in [s, *candidates]:
        if not c.any():
            continue
        if float(world.segment_clearance(p[None], (p + c)[None])[0]) >= need:
            return c
    return np.zeros(2)


def preferred_speed(rng: np.random.Generator, max_speed: float, p: SocialForceParams) -> float:
    """One person's preferred walking speed (m/s): Weidmann's normal (``speed_mean``, ``speed_sd``)
    clipped to ``[min(min_speed, max_speed), max_speed]``."""
    low = min(p.min_speed, max_speed)
    return float(np.clip(rng.normal(p.speed_mean, p.speed_sd), low, max_speed))


def arrival_speed(speed: float, remaining: float, max_accel: float, dt: float) -> float:
    """The preferred speed near the goal: no faster than allows stopping at it with ``max_accel``,
    nor than covers the ``remaining`` route in one step ``dt``."""
    return min(speed, math.sqrt(2.0 * max_accel * max(remaining, 0.0)), max(remaining, 0.0) / dt)


# ---------------------------------------------------------------------------------------------
# The methods


@register_method("person", help="a pedestrian: its own shortest route at its own speed, social force model "
                 "(Helbing et al. 2000); yields only to avoid contact")
class PersonMethod:
    """A pedestrian (see the module docstring): route, preferred speed, social forces."""

    name = "person"
    pedestrian = True
    """Read by the simulator: contacts with this robot are attributed, and it need not be contact-free."""
    yielding = False

    def __init__(self, scenario: Scenario, rngs: list[np.random.Generator], planner=None,
                 params: SocialForceParams | None = None):
        self.scenario = scenario
        self.rngs = rngs
        self.params = params or SocialForceParams()
        self.dt = scenario.controller.dt
        horizon, samples = scenario.controller.horizon, scenario.controller.samples
        self.sample_times = horizon * np.arange(1, samples + 1) / samples
        self.graphs = {r: VisibilityGraph(scenario.world, r, self.params.route_margin)
                       for r in set(scenario.radii.tolist())}
        self.sides = approach_sides(scenario)
        self.speeds: dict[int, float] = {}
        """Each person's preferred speed (m/s), drawn at its first decision."""
        self.decisions: dict[int, Decision] = {}

    def speed(self, i: int) -> float:
        """Person ``i``'s preferred speed, drawn once from its own generator."""
        if i not in self.speeds:
            self.speeds[i] = preferred_speed(self.rngs[i], float(self.scenario.max_speeds[i]), self.params)
        return self.speeds[i]

    def route(self, i: int, position: np.ndarray) -> np.ndarray:
        """Person ``i``'s shortest route ``(V, 2)`` among the walls; the straight line if none."""
        goal = self.scenario.destinations[i]
        path = self.graphs[float(self.scenario.radii[i])].shortest_path(position, goal)
        return path.points if path.success else np.array([position, goal], dtype=float)

    def decide(self, views: dict[int, RobotView]) -> dict[int, Decision]:
        """No decision: each person's 'plan' is its route walked at its preferred speed (recorded)."""
        out = {}
        for i, view in views.items():
            speed = self.speed(i)
            points = self.route(i, view.positions[i])
            length = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
            traj = route_trajectory(points, speed, self.dt, view.t)
            plan = PlanResult(True, "", length / speed, traj, (0,), (0,), 0.0, {"route": points})
            out[i] = Decision(strategy=-1, robots=(i,), plan=plan, opinions=NO_OPINION, probabilities=NO_OPINION,
                              players=())
        self.decisions = out
        return out

    def waits(self, i: int, view: RobotView) -> bool:
        """Whether person ``i`` stops before its mouth now (only ``person-yielding`` does)."""
        return False

    def force(self, i: int, p: np.ndarray, v: np.ndarray, e: np.ndarray, speed: float, pj: np.ndarray,
              vj: np.ndarray, rj: np.ndarray) -> np.ndarray:
        """The total force on person ``i`` at ``p`` moving at ``v``, heading ``e`` at preferred
        ``speed``, with others at ``pj`` (velocities ``vj``, radii ``rj``) (N)."""
        s, prm, r = self.scenario, self.params, float(self.scenario.radii[i])
        force = driving_force(v, speed * e, prm.mass, prm.tau)
        if len(pj):
            forces = agent_forces(p, v, r, pj, vj, rj, prm)
            weights = view_weights(e, p, pj, prm)
            forces -= (1.0 - weights)[:, None] * social_part(p, r, pj, rj, prm)
            force = force + forces.sum(axis=0)
        walls = nearest_wall_points(s.world, p)
        for wall in walls[np.linalg.norm(walls - p, axis=1) < prm.range + r]:
            force = force + wall_forces(p, v, r, wall[None], prm)[0]
            if prm.wall_lateral and e.any():
                social = wall_social(p, r, wall, prm)
                force = force - social + lateral(social, e)
        return force

    def act(self, t: float, views: dict[int, RobotView]) -> dict[int, ControlResult]:
        """Every person's social-force motion over one control step from its own view, integrated
        in ``substeps`` semi-implicit Euler steps (the others move on at their observed velocity)."""
        s, prm, out = self.scenario, self.params, {}
        radii = s.radii
        n_sub = prm.substeps
        h = self.dt / n_sub
        marks = np.round(STEP_FRACTIONS * n_sub).astype(int)
        for i, view in views.items():
            start = time.perf_counter()
            p0, v0 = view.positions[i], view.velocities[i]
            route = self.route(i, p0)
            remaining = float(np.linalg.norm(np.diff(np.vstack([p0, route]), axis=0), axis=1).sum())
            heading = next_waypoint(route, p0) - p0
            norm = float(np.hypot(*heading))
            e = heading / norm if norm > 0 else np.zeros(2)
            speed = 0.0 if self.waits(i, view) else arrival_speed(self.speed(i), remaining,
                                                                  float(s.robots[i].max_accel), self.dt)
            others = [k for k in range(s.n_robots) if k != i
                      and np.linalg.norm(view.positions[k] - p0) < prm.range + radii[i] + radii[k] + self.dt * 4]
            pj, vj, rj = view.positions[others], view.velocities[others], radii[others]
            p, v = p0.copy(), v0.copy()
            passed = []
            for k in range(1, n_sub + 1):
                accel = clip_norm(self.force(i, p, v, e, speed, pj + vj * (k - 1) * h, vj, rj) / prm.mass,
                                  float(s.robots[i].max_accel))
                v = clip_norm(v + accel * h, float(s.max_speeds[i]))
                step = clip_against_walls(s.world, p, v * h, float(radii[i]))
                v = step / h
                p = p + step
                if k in marks:
                    passed.append(p.copy())
            out[i] = ControlResult(success=True, reason="", velocity=v, next_position=p, next_velocity=v,
                                   planned_positions=p + v * self.sample_times[:, None],
                                   solve_time=time.perf_counter() - start, step_positions=np.array(passed),
                                   info={"preferred_speed": speed})
        return out


@register_method("person-yielding", help="a pedestrian (as person) that waits before its mouth of the corridor "
                 "while someone comes the other way")
class YieldingPersonMethod(PersonMethod):
    """A :class:`PersonMethod` that waits before the corridor while someone is in it coming the other way.

    The person waits (preferred speed 0) while it is outside the corridor on the side it
    approaches from, within ``yield_distance`` of its entrance, and someone it sees is inside
    the corridor having come from the other side (its approach side is the opposite one).
    """

    name = "person-yielding"
    yielding = True

    def waits(self, i: int, view: RobotView) -> bool:
        s, side = self.scenario, int(self.sides[i])
        p = view.positions[i]
        if side == 0 or int(s.world.side_of(p[None])[0]) != side:
            return False
        if float(s.world.corridor_distance(p[None], np.array([side]))[0]) > self.params.yield_distance:
            return False
        inside = s.world.in_corridor(view.positions)
        return bool(any(inside[k] and int(self.sides[k]) == -side for k in range(s.n_robots) if k != i))
