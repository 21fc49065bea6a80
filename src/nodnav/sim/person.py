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
in contact is felt from every side. The model and its parameters
(:class:`~nodnav.sim.social_force.SocialForceParams`) are in :mod:`nodnav.sim.social_force`, the
published ones; only the person's speed limit and acceleration limit come from its
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

import time

import numpy as np

from nodnav.control import ControlResult
from nodnav.control.base import STEP_FRACTIONS
from nodnav.planning.base import PlanResult
from nodnav.planning.visibility import VisibilityGraph
from nodnav.registry import register_method
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import INSIDE
from nodnav.sim.agent_queries import approach_sides
from nodnav.sim.baselines import NO_OPINION, next_waypoint, route_trajectory
from nodnav.sim.person_steering import arrival_speed, away_from, bend_rooms, turn_speed
from nodnav.sim.social_force import (
    ForceModel,
    SocialForceParams,
    agent_forces,
    clip_against_walls,
    clip_norm,
    driving_force,
    force_exponents,
    lateral,
    nearest_wall_points,
    preferred_speed,
    social_part,
    substep,
    view_weights,
    wall_forces,
    wall_social,
)
from nodnav.sim.views import Decision, RobotView

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
        self.model = ForceModel.of(self.params).array()
        self.dt = scenario.controller.dt
        horizon, samples = scenario.controller.horizon, scenario.controller.samples
        self.sample_times = horizon * np.arange(1, samples + 1) / samples
        self.graphs = {r: VisibilityGraph(scenario.world, r, self.params.route_margin)
                       for r in set(scenario.radii.tolist())}
        self.wide_graphs = {r: VisibilityGraph(scenario.world, r, self.comfortable_margin(r))
                            for r in set(scenario.radii.tolist())
                            if self.comfortable_margin(r) > self.params.route_margin}
        self.sides = approach_sides(scenario)
        # The scenario's per-robot arrays, built once (its properties build them anew at each read).
        self._radii, self._destinations, self._max_speeds = scenario.radii, scenario.destinations, scenario.max_speeds
        self._marks = np.round(STEP_FRACTIONS * self.params.substeps).astype(int)
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
        goal = self._destinations[i]
        r = float(self._radii[i])
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
        side = int(self.sides[i])
        held = self.making_way.setdefault(i, set())
        arrived = i in self.arrived
        sides = s.world.side_of(p) if side != 0 and not arrived else None
        before = sides is not None and int(sides[i]) == side
        if not (held or arrived or before):  # no one to let by, and no one it could start to
            return []
        radii = self._radii
        gaps = np.linalg.norm(p - p[i], axis=1) - radii - radii[i]
        under_way = np.linalg.norm(p - self._destinations, axis=1) > s.sim.goal_tolerance
        inside = s.world.in_corridor(p) if sides is None else sides == INSIDE
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

    def walk(self, i: int, p0: np.ndarray, v0: np.ndarray, e: np.ndarray, speed: float, pj: np.ndarray,
             vj: np.ndarray, rj: np.ndarray, marks: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
        """Person ``i``'s motion over one control step from ``p0`` at ``v0``, heading ``e`` at
        preferred ``speed``, the others starting at ``pj`` and moving on at ``vj`` (radii ``rj``):
        ``substeps`` semi-implicit Euler steps of the force (:meth:`force`), the acceleration
        clipped to the body's ``max_accel``, the velocity to its ``max_speed``, each step against
        the walls (:func:`clip_against_walls`). Returns the final position and velocity, and the
        positions after the sub-steps in ``marks``. The compiled kernels of
        :mod:`nodnav.sim.social_force`, bitwise :meth:`walk_plain` (np.exp between them: see there)."""
        s, prm, r = self.scenario, self.params, float(self._radii[i])
        world = s.world
        obstacles, bounds, pieces = world.obstacle_array, world.bounds_array, world.piece_array
        h = self.dt / prm.substeps
        m, n_walls = len(pj), len(obstacles) + 4
        pj, vj, rj = (np.ascontiguousarray(a, dtype=float) for a in (pj, vj, rj))
        others_now, wall_points = np.empty((m, 2)), np.empty((n_walls, 2))
        exponents, exps = np.zeros(m + n_walls), np.empty(m + n_walls)
        state, step = np.array([p0[0], p0[1], v0[0], v0[1]], dtype=float), np.empty(2)
        ex, ey = float(e[0]), float(e[1])
        max_accel, max_speed = float(s.robots[i].max_accel), float(self._max_speeds[i])
        clip = world.wall_grid is None  # a map's world: the plain clip_against_walls, through its wall index
        passed, marked = [], set(marks.tolist())
        reach, B, model = prm.range + r, prm.B, self.model
        for k in range(1, prm.substeps + 1):
            near = force_exponents(state[0], state[1], r, pj, vj, rj, float(k - 1), h, obstacles, bounds, reach, B,
                                   others_now, wall_points, exponents)
            np.exp(exponents, out=exps)  # NumPy's exp, as the plain functions take it
            if not substep(state, r, ex, ey, speed, others_now, vj, rj, wall_points, near, exps, model, h,
                           max_accel, max_speed, obstacles, bounds, pieces, clip, step):
                c = clip_against_walls(world, state[:2].copy(), step.copy(), r)
                state[:2], state[2:] = state[:2] + c, c / h
            if k in marked:
                passed.append(state[:2].copy())
        return state[:2].copy(), state[2:].copy(), passed

    def walk_plain(self, i: int, p0: np.ndarray, v0: np.ndarray, e: np.ndarray, speed: float, pj: np.ndarray,
                   vj: np.ndarray, rj: np.ndarray, marks: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
        """:meth:`walk` in plain NumPy from the pure functions of :mod:`nodnav.sim.social_force`:
        the reference its kernels are tested against."""
        s, prm = self.scenario, self.params
        h = self.dt / prm.substeps
        p, v = p0.copy(), v0.copy()
        passed = []
        for k in range(1, prm.substeps + 1):
            accel = clip_norm(self.force(i, p, v, e, speed, pj + vj * (k - 1) * h, vj, rj) / prm.mass,
                              float(s.robots[i].max_accel))
            v = clip_norm(v + accel * h, float(s.max_speeds[i]))
            step = clip_against_walls(s.world, p, v * h, float(s.radii[i]))
            v = step / h
            p = p + step
            if k in marks:
                passed.append(p.copy())
        return p, v, passed

    def force(self, i: int, p: np.ndarray, v: np.ndarray, e: np.ndarray, speed: float, pj: np.ndarray,
              vj: np.ndarray, rj: np.ndarray) -> np.ndarray:
        """The total force on person ``i`` at ``p`` moving at ``v``, heading ``e`` at preferred
        ``speed``, with others at ``pj`` (velocities ``vj``, radii ``rj``) (N), in plain NumPy
        (:meth:`walk_plain`; :func:`~nodnav.sim.social_force.substep` is its compiled twin)."""
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
        radii, marks = self._radii, self._marks
        for i, view in views.items():
            start = time.perf_counter()
            p0, v0 = view.positions[i], view.velocities[i]
            if float(np.hypot(*(p0 - self._destinations[i]))) <= s.sim.goal_tolerance:
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
            apart = np.linalg.norm(view.positions - p0, axis=1)
            others = [k for k in range(s.n_robots) if k != i
                      and apart[k] < prm.range + radii[i] + radii[k] + self.dt * 4]
            pj, vj, rj = view.positions[others], view.velocities[others], radii[others]
            p, v, passed = self.walk(i, p0, v0, e, speed, pj, vj, rj, marks)
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
