"""The social force model of a walking person (Helbing and Molnar 1995; Helbing, Farkas and Vicsek
2000, "HFV"): its parameters with their published values, and the forces and limits it is made of,
as small pure functions. :mod:`nodnav.sim.person` steers people with it (docs/mixed-teams.md gives
the model's choices and sources).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from nodnav.compiled import compiled
from nodnav.geometry import piece_signed_distance_one, segment_clearance_one
from nodnav.scenario.world import World


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
    unit = h / norm
    # x0 y0 + x1 y1 written out: a matrix product's last bit follows the processor's BLAS kernel
    # (a fused multiply-add on some), and this reference must be the same on every machine.
    cos = (to_j[:, 0] * unit[0] + to_j[:, 1] * unit[1]) / dist
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
    along = float(f[0] * e[0] + f[1] * e[1])  # written out, as in view_weights
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
    v = np.asarray(v_i, dtype=float)
    slide = p.kappa * g(overlap) * (t[:, 0] * v[0] + t[:, 1] * v[1])  # written out, as in view_weights
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
# The same equations compiled, for the sub-step loop of PersonMethod.act
#
# One sub-step of a person: the exponents of every exponential term (:func:`force_exponents`),
# their exponentials by NumPy (``np.exp``, see below), then the total force, the clipped
# acceleration and velocity and the step clipped against the walls (:func:`substep`). Each
# kernel does the floating-point operations of the plain functions above in the same order
# (``np.linalg.norm`` of a 2-vector is ``sqrt(x*x + y*y)``, ``np.hypot`` is C's ``hypot``, as
# numba's ``math.hypot``), so a person walks bitwise the same path (tests/sim/test_social_force_kernels.py
# compares them). Why the exponentials are NumPy's, between two kernels: on a processor with
# AVX-512, ``np.exp`` of an array is NumPy's own vectorised routine, which differs from the C
# library's ``exp`` (what compiled code calls) in the last bit for about 5% of arguments; the
# plain functions take NumPy's for the people's and walls' terms (and the C library's
# ``math.exp`` in :func:`wall_social`, which the kernel keeps).


class ForceModel(NamedTuple):
    """The constants of :class:`SocialForceParams` the kernels read (numba takes a named tuple, not a dataclass)."""

    mass: float
    tau: float
    A: float
    B: float
    k: float
    kappa: float
    behind: float
    cos_half_fov: float
    """``cos(fov / 2)``: someone at a smaller angle from the heading is in view."""
    wall_lateral: bool

    @classmethod
    def of(cls, p: SocialForceParams) -> "ForceModel":
        """The constants of ``p``."""
        return cls(float(p.mass), float(p.tau), float(p.A), float(p.B), float(p.k), float(p.kappa),
                   float(p.behind), math.cos(math.radians(p.fov / 2.0)), bool(p.wall_lateral))

    def array(self) -> np.ndarray:
        """The constants as a float array, in order: what :func:`substep` is passed (a named tuple
        costs numba microseconds to type at every call, an array a fraction of one)."""
        return np.array([float(x) for x in self])


@compiled
def force_model(a):
    """The :class:`ForceModel` of its :meth:`ForceModel.array`."""
    return ForceModel(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8] != 0.0)


@compiled
def force_exponents(px, py, r, pj, vj, rj, elapsed, h, walls, bounds, reach, B, others_now, wall_points,
                    exponents):
    """The exponents of HFV's exponential terms on a person at ``(px, py)`` of radius ``r`` one
    sub-step: ``exponents[j] = ((r + r_j) - d_ij) / B`` for each of the ``m`` others, now at
    ``pj + vj * elapsed * h`` (written to ``others_now`` ``(m, 2)``), then ``(r - d_iW) / B`` for
    each nearest wall point (:func:`nearest_wall_points`) nearer than ``reach``, in order (written
    to the first rows of ``wall_points``). Returns how many wall points are near."""
    m = pj.shape[0]
    for j in range(m):
        qx = pj[j, 0] + vj[j, 0] * elapsed * h
        qy = pj[j, 1] + vj[j, 1] * elapsed * h
        others_now[j, 0], others_now[j, 1] = qx, qy
        dx, dy = px - qx, py - qy
        d = max(math.sqrt(dx * dx + dy * dy), 1e-9)
        exponents[j] = ((r + rj[j]) - d) / B
    n = 0
    for w in range(walls.shape[0] + 4):
        if w < walls.shape[0]:  # the nearest point of a wall rectangle: the point clipped to it
            wx = min(max(px, walls[w, 0]), walls[w, 2])
            wy = min(max(py, walls[w, 1]), walls[w, 3])
        else:  # then the four sides of the world's boundary
            side = w - walls.shape[0]
            wx = bounds[0] if side == 0 else (bounds[2] if side == 1 else px)
            wy = py if side < 2 else (bounds[1] if side == 2 else bounds[3])
        dx, dy = px - wx, py - wy
        dist = math.sqrt(dx * dx + dy * dy)
        if dist < reach:
            wall_points[n, 0], wall_points[n, 1] = wx, wy
            exponents[m + n] = (r - max(dist, 1e-9)) / B
            n += 1
    return n


@compiled
def agent_force_sum(px, py, vx, vy, r, ex, ey, others_now, vj, rj, exps, c):
    """``sum_j w_ij f_ij`` (N) on a person at ``(px, py)`` moving at ``(vx, vy)`` heading ``(ex, ey)``
    from the others at ``others_now`` (velocities ``vj``, radii ``rj``), ``exps[j]`` the exponential
    of their exponent (:func:`force_exponents`): :func:`agent_forces` less ``(1 - w_ij)`` times
    :func:`social_part`, with the field-of-view weight of :func:`view_weights` (``c`` a
    :class:`ForceModel`); summed in order. Where NumPy's matrix product takes a fused
    multiply-add for the weight's cosine on some processors, this takes ``x0 y0 + x1 y1``, as
    :func:`view_weights` now writes it."""
    hn = math.hypot(ex, ey)
    sx, sy = 0.0, 0.0
    for j in range(others_now.shape[0]):
        dx, dy = px - others_now[j, 0], py - others_now[j, 1]
        d = max(math.sqrt(dx * dx + dy * dy), 1e-9)
        nx, ny = dx / d, dy / d
        tx, ty = -ny, nx
        overlap = (r + rj[j]) - d
        dv_t = (vj[j, 0] - vx) * tx + (vj[j, 1] - vy) * ty
        g = max(overlap, 0.0)
        normal = c.A * exps[j] + c.k * g
        slide = c.kappa * g * dv_t
        fx, fy = normal * nx + slide * tx, normal * ny + slide * ty
        weight = 1.0
        if hn != 0.0:
            tox, toy = others_now[j, 0] - px, others_now[j, 1] - py
            dist = max(math.sqrt(tox * tox + toy * toy), 1e-9)
            cos = (tox * (ex / hn) + toy * (ey / hn)) / dist
            weight = 1.0 if cos >= c.cos_half_fov else c.behind
        social = c.A * exps[j]
        fx -= (1.0 - weight) * (social * (dx / d))
        fy -= (1.0 - weight) * (social * (dy / d))
        if j == 0:
            sx, sy = fx, fy
        else:
            sx, sy = sx + fx, sy + fy
    return sx, sy


@compiled
def wall_force_sum(fx, fy, px, py, vx, vy, r, ex, ey, wall_points, n_walls, exps, c):
    """``(fx, fy)`` plus ``sum_W f_iW`` (N) from the first ``n_walls`` of ``wall_points``, their
    exponentials in ``exps`` (:func:`force_exponents`), added one by one as the plain loop does:
    :func:`wall_forces`, then, with ``wall_lateral`` and a heading, :func:`wall_social` replaced by
    its :func:`lateral` part."""
    heading = ex != 0.0 or ey != 0.0
    for w in range(n_walls):
        dx, dy = px - wall_points[w, 0], py - wall_points[w, 1]
        d = max(math.sqrt(dx * dx + dy * dy), 1e-9)
        nx, ny = dx / d, dy / d
        tx, ty = -ny, nx
        overlap = r - d
        g = max(overlap, 0.0)
        normal = c.A * exps[w] + c.k * g
        slide = c.kappa * g * (tx * vx + ty * vy)
        fx, fy = fx + (normal * nx - slide * tx), fy + (normal * ny - slide * ty)
        if c.wall_lateral and heading:
            dh = max(math.hypot(dx, dy), 1e-9)
            push = c.A * math.exp((r - dh) / c.B)
            socx, socy = push * dx / dh, push * dy / dh
            along = socx * ex + socy * ey
            latx, laty = (socx - along * ex, socy - along * ey) if along < 0.0 else (socx, socy)
            fx, fy = (fx - socx) + latx, (fy - socy) + laty
    return fx, fy


@compiled
def point_clearance(px, py, walls, bounds, pieces):
    """:meth:`World.clearance` of one point in a world without a wall index (m)."""
    d = min(min(px - bounds[0], bounds[2] - px), min(py - bounds[1], bounds[3] - py))
    for o in range(walls.shape[0]):
        dx = max(walls[o, 0] - px, px - walls[o, 2])
        dy = max(walls[o, 1] - py, py - walls[o, 3])
        d = min(d, math.hypot(max(dx, 0.0), max(dy, 0.0)) + min(max(dx, dy), 0.0))
    if pieces.shape[0]:
        nearest = np.inf
        for w in range(pieces.shape[0]):
            nearest = min(nearest, piece_signed_distance_one(px, py, pieces[w]))
        d = min(d, nearest)
    return d


@compiled
def clipped_step(px, py, sx, sy, radius, walls, bounds, pieces):
    """:func:`clip_against_walls` in a world without a wall index: the step ``(sx, sy)``, else its
    longer possible component along x or y (x first when as long), else none."""
    need = min(radius, point_clearance(px, py, walls, bounds, pieces))
    if (sx != 0.0 or sy != 0.0) and segment_clearance_one(px, py, px + sx, py + sy, walls, bounds, pieces) >= need:
        return sx, sy
    for along_x in (abs(sx) >= abs(sy), abs(sx) < abs(sy)):
        cx, cy = (sx, 0.0) if along_x else (0.0, sy)
        if (cx != 0.0 or cy != 0.0) and segment_clearance_one(px, py, px + cx, py + cy, walls, bounds,
                                                              pieces) >= need:
            return cx, cy
    return 0.0, 0.0


@compiled
def substep(state, r, ex, ey, speed, others_now, vj, rj, wall_points, n_walls, exps, model, h, max_accel,
            max_speed, walls, bounds, pieces, clip, step):
    """One semi-implicit Euler sub-step of ``h`` of a person whose position and velocity are
    ``state`` ``(4,)``: the total force of :meth:`PersonMethod.force` (driving force, others,
    walls), the acceleration clipped to ``max_accel``, the velocity to ``max_speed``, and with
    ``clip`` the step clipped against the walls (:func:`clipped_step`) and ``state`` updated;
    without it (a world with a wall index) the unclipped step is left in ``step`` for the caller
    to clip. ``model`` is a :meth:`ForceModel.array`. Returns whether ``state`` was updated."""
    c = force_model(model)
    px, py, vx, vy = state[0], state[1], state[2], state[3]
    fx = c.mass * (speed * ex - vx) / c.tau
    fy = c.mass * (speed * ey - vy) / c.tau
    if others_now.shape[0]:
        ax, ay = agent_force_sum(px, py, vx, vy, r, ex, ey, others_now, vj, rj, exps, c)
        fx, fy = fx + ax, fy + ay
    fx, fy = wall_force_sum(fx, fy, px, py, vx, vy, r, ex, ey, wall_points, n_walls, exps[others_now.shape[0]:], c)
    ax, ay = fx / c.mass, fy / c.mass
    norm = math.hypot(ax, ay)
    if not (norm <= max_accel or norm == 0.0):
        ax, ay = ax * (max_accel / norm), ay * (max_accel / norm)
    vx, vy = vx + ax * h, vy + ay * h
    norm = math.hypot(vx, vy)
    if not (norm <= max_speed or norm == 0.0):
        vx, vy = vx * (max_speed / norm), vy * (max_speed / norm)
    step[0], step[1] = vx * h, vy * h
    if not clip:
        return False
    cx, cy = clipped_step(px, py, step[0], step[1], r, walls, bounds, pieces)
    state[0], state[1], state[2], state[3] = px + cx, py + cy, cx / h, cy / h
    return True
