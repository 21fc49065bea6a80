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

Steering (chosen where HFV leave room; docs/mixed-teams.md says why, each with its regression
scenario): the route keeps ``comfort_margin`` from the walls where the passage allows, else runs
along its middle (:meth:`PersonMethod.comfortable_margin`); a person slows before the bends of its
route so that its lagging velocity does not carry it into a wall
(:func:`~nodnav.sim.person_steering.turn_speed`), and heads past a vertex once within
``waypoint_reach`` of it. It does not yield at a mouth, but makes way where it must to let someone
by (:meth:`PersonMethod.in_the_way_of`): at its destination for anyone still under way, and before
the corridor for anyone coming out of it towards it.
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
from nodnav.sim.person_steering import arrival_speed, away_from, bend_rooms, turn_speed


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
    """Least clearance kept from the walls by the route, beyond the radius (m); as ``baselines.orca_route_margin``."""
    comfort_margin: float = 0.3
    """Clearance from the walls, beyond the radius, a person's route keeps where the passage leaves
    room for it (m): it passes a corner no nearer than this, and through a narrower passage along
    its middle (:meth:`PersonMethod.route`); chosen: HFV's wall repulsion is 70 N (under half the
    driving force of a person at 1 m/s) there. ``route_margin`` (or less) gives the literal
    shortest route that hugs the corners."""
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
    slow_for_turns: bool = True
    """Whether a person slows before the bends of its route so that its velocity, which follows
    the heading only with the relaxation time tau, does not carry it into the walls
    (:func:`turn_speed`); chosen; ``False`` walks every bend at its preferred speed."""
    turn_lookahead: float = 2.0
    """How far along its route a person looks for bends to slow for (m); chosen: beyond the
    distance in which the fastest drawn person (2 m/s) stops at 1 m/s^2."""
    waypoint_reach: float = 0.25
    """A person heads for the vertex after the next once within this of the next (m) (a waypoint
    switching radius); chosen: otherwise, a few centimetres off its route just before a vertex,
    its heading swings by tens of degrees from one step to the next, and in a narrow mouth (a
    vertex at each end) it swayed from wall to wall on the spot (``person-swaying-at-a-vertex``)."""
    make_way_gap: float = 0.5
    """A person starts to make way for someone it is in the way of (:meth:`PersonMethod.in_the_way_of`)
    when their bodies come nearer than this (m), and goes on standing aside while they are under way
    within twice this; chosen: with 1 m a person stood aside for ever while the robot waited for it
    to go to its destination first (``person-standing-aside-for-a-waiting-robot``), in 5 of the first
    100 draws of ``mixed`` against 1 the other way (0 disables making way)."""
    waiting_speed: float = 0.1
    """Someone under way within twice ``make_way_gap`` of a person at its destination who moves
    slower than this waits for it (m/s): the person makes way for them as for someone nearer
    than ``make_way_gap``; chosen: a robot that plans the person to step aside waits 0.5-1 m
    off (``person-standing-aside-for-a-waiting-robot`` with the feasible timing); 0 disables."""


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
        self.wide_graphs = {r: VisibilityGraph(scenario.world, r, self.comfortable_margin(r))
                            for r in set(scenario.radii.tolist())
                            if self.comfortable_margin(r) > self.params.route_margin}
        self.sides = approach_sides(scenario)
        self.speeds: dict[int, float] = {}
        """Each person's preferred speed (m/s), drawn at its first decision."""
        self.decisions: dict[int, Decision] = {}
        self.arrived: set[int] = set()
        """People that have reached their destination (within the goal tolerance) at least once."""
        self.making_way: dict[int, set[int]] = {}
        """Whom each person makes way for (:meth:`in_the_way_of`)."""
        self.coming_out: dict[int, set[int]] = {}
        """Of those, the ones coming out of the corridor towards it."""

    def speed(self, i: int) -> float:
        """Person ``i``'s preferred speed, drawn once from its own generator."""
        if i not in self.speeds:
            self.speeds[i] = preferred_speed(self.rngs[i], float(self.scenario.max_speeds[i]), self.params)
        return self.speeds[i]

    def ahead(self, route: np.ndarray, position: np.ndarray) -> np.ndarray:
        """``route`` from ``position`` without the vertices before the destination that lie within
        ``waypoint_reach`` of it (the person heads past them)."""
        pts = np.asarray(route, dtype=float)
        k = 1
        while k < len(pts) - 1 and float(np.hypot(*(pts[k] - position))) <= self.params.waypoint_reach:
            k += 1
        return np.vstack([pts[:1], pts[k:]])

    def comfortable_margin(self, radius: float) -> float:
        """The clearance beyond ``radius`` a person's route keeps from the walls (m):
        ``comfort_margin``, less where the passage is narrower (then 1 cm short of its middle),
        never less than ``route_margin``.

        A corner passed at the literal route's ``route_margin`` (5 cm) pushes the person with
        HFV's wall repulsion of about 1000 N, ten times its driving force: coming into a narrow
        mouth at an angle it was thrown across it into the opposite corner, stopping dead
        (``person-thrown-across-a-narrow-mouth``). Through the middle of the mouth the two
        corners' pushes balance."""
        half = 0.5 * self.scenario.world.passage.width - radius - 0.01
        return max(self.params.route_margin, min(self.params.comfort_margin, half))

    def route(self, i: int, position: np.ndarray) -> np.ndarray:
        """Person ``i``'s shortest route ``(V, 2)`` among the walls keeping :meth:`comfortable_margin`
        from them, else keeping ``route_margin``; the straight line if neither exists."""
        goal = self.scenario.destinations[i]
        r = float(self.scenario.radii[i])
        for graph in (self.wide_graphs.get(r), self.graphs[r]):
            if graph is not None:
                path = graph.shortest_path(position, goal)
                if path.success:
                    return path.points
        return np.array([position, goal], dtype=float)

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

    def in_the_way_of(self, i: int, view: RobotView) -> list[int]:
        """Whom person ``i`` makes way for now (:meth:`make_way`).

        It starts to make way for anyone whose body comes nearer than ``make_way_gap`` and who
        must get past it: once it has arrived, anyone not at their own destination (a person
        standing at its destination in a mouth would otherwise close the passage for good);
        before the corridor, on the side it approaches from, anyone inside the corridor who came
        from the other side (who can come out only where it stands). It goes on making way for
        them until they have got past: the one it arrived before until that one is at its
        destination or twice ``make_way_gap`` away, the one coming out until it has left the
        corridor. A person does not otherwise yield."""
        s, gap_limit = self.scenario, self.params.make_way_gap
        if gap_limit <= 0.0:
            return []
        p = view.positions
        gaps = np.linalg.norm(p - p[i], axis=1) - s.radii - s.radii[i]
        under_way = np.linalg.norm(p - s.destinations, axis=1) > s.sim.goal_tolerance
        inside = s.world.in_corridor(p)
        side = int(self.sides[i])
        before = side != 0 and i not in self.arrived and int(s.world.side_of(p[i][None])[0]) == side
        held = self.making_way.setdefault(i, set())
        for k in range(s.n_robots):
            if k == i:
                continue
            coming_out = before and bool(inside[k]) and int(self.sides[k]) == -side
            if k in held:  # still to get past?
                keep = coming_out if k in self.coming_out.get(i, set()) else (
                    bool(under_way[k]) and gaps[k] < 2.0 * gap_limit)
                if not keep:
                    held.discard(k)
                    self.coming_out.get(i, set()).discard(k)
            elif (gaps[k] < gap_limit or self._waiting(k, i, view, gaps[k])) and (
                    (i in self.arrived and under_way[k]) or coming_out):
                held.add(k)
                if coming_out:
                    self.coming_out.setdefault(i, set()).add(k)
        return sorted(held)

    def _waiting(self, k: int, i: int, view: RobotView, gap: float) -> bool:
        """Whether ``k`` waits near person ``i`` at its destination: within twice ``make_way_gap``,
        slower than ``waiting_speed``."""
        return (i in self.arrived and gap < 2.0 * self.params.make_way_gap
                and float(np.linalg.norm(view.velocities[k])) < self.params.waiting_speed)

    def make_way(self, i: int, view: RobotView, others: list[int]) -> tuple[np.ndarray, float]:
        """Heading and preferred speed of person ``i`` making way for ``others``.

        For someone coming out of the corridor: off the line through the mouth, sideways (and away
        from them, :func:`away_from`), then standing still beside it until they are out. For
        someone who must pass it at its destination: out of their way (:func:`away_from`) while
        nearer than ``make_way_gap``, standing still beyond it."""
        s, p = self.scenario, view.positions[i]
        passage = s.world.passage
        across = float(passage.across(p[None])[0]) - passage.t_centre
        out = [k for k in others if k in self.coming_out.get(i, set())]
        if out:
            on_line = abs(across) < 0.5 * passage.width + float(s.radii[i]) + float(s.radii[out].max())
            if not on_line:
                return np.zeros(2), 0.0
            e = away_from(p, view.positions[out], view.velocities[out], np.array(passage.axis), across,
                          room=self.room)
            return e, self.speed(i)
        gaps = np.linalg.norm(view.positions[others] - p, axis=1) - s.radii[others] - s.radii[i]
        near = [k for k, g in zip(others, gaps) if g < self.params.make_way_gap or self._waiting(k, i, view, g)]
        if not near:
            return np.zeros(2), 0.0
        return away_from(p, view.positions[near], view.velocities[near], room=self.room), self.speed(i)

    def room(self, point: np.ndarray) -> float:
        """The free room at ``point``: its distance to the nearest wall (m)."""
        return float(self.scenario.world.clearance(np.asarray(point, dtype=float)[None])[0])

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
            if float(np.hypot(*(p0 - s.destinations[i]))) <= s.sim.goal_tolerance:
                self.arrived.add(i)
            blockers = self.in_the_way_of(i, view)
            if blockers:
                e, speed = self.make_way(i, view, blockers)
            else:
                route = self.ahead(self.route(i, p0), p0)
                remaining = float(np.linalg.norm(np.diff(np.vstack([p0, route]), axis=0), axis=1).sum())
                heading = next_waypoint(route, p0) - p0
                norm = float(np.hypot(*heading))
                e = heading / norm if norm > 0 else np.zeros(2)
                limit = float(s.robots[i].max_accel)
                speed = 0.0 if self.waits(i, view) else arrival_speed(self.speed(i), remaining, limit, self.dt)
                if prm.slow_for_turns and speed > 0.0:
                    rooms = bend_rooms(s.world, float(radii[i]), route, p0, prm.turn_lookahead)
                    speed = min(speed, turn_speed(route, p0, rooms, limit, prm.tau, prm.turn_lookahead, v0))
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
