"""The MPC's braking invariant: every accepted plan ends in a straight braking tail clear of the walls.

The invariant (docs/safety.md). At every control step the robot holds a *committed
trajectory*: the last accepted plan (a cubic spline over ``[0, T_MPC]``), continued after its
end by braking in a straight line along its final velocity ``v(T)`` at ``a_tail`` until it
stops, ``|v(T)|^2 / (2 a_tail)`` further on. A plan is accepted only if this whole trajectory
keeps ``r_i`` from every wall and inside the world's bounds, checked exactly
(:func:`segment_clearance` on the tail, the existing check on the spline). With exact
observations the robot is on its committed trajectory at the next step whatever happens, so
following it (:class:`Committed`) is always possible and never touches a wall; a new plan
replaces it only if it has a clear tail of its own. The horizon can be far shorter than the
time to stop (1 m/s at 0.15 m/s^2 needs 6.7 s and 3.3 m): the tail is what covers the rest.

``a_tail`` is the deceleration the terminal rows already assume (``terminal_decel`` of the
acceleration polygon's inscribed radius): below the limit, so that braking is always within it
and the next plan has room to differ from the tail.

The QP keeps the tail clear through linear rows (:func:`tail_rows`): with ``V`` an upper bound
of ``|v(T)|`` (the speed the robot can reach by ``T`` from its present speed, at most its
limit), the tail is a part of the segment from ``p(T)`` to ``p(T) + V v(T) / (2 a_tail)``; both
ends in a half-plane clear of a wall put the whole segment there (half-planes are convex). Each
wall's half-plane is tangent to it (inflated by ``r_i``) at its point nearest to the
linearisation's tail, so a linearisation whose tail is clear meets its own rows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodnav.compiled import compiled
from nodnav.control import bspline
from nodnav.geometry import piece_closest_point_one, piece_signed_distance_one


def tail_decel(max_accel: float, terminal_decel: float, accel_polygon_sides: int) -> float:
    """The deceleration of the braking tail (m/s^2): the terminal rows' ``terminal_decel`` times
    the radius inscribed in the acceleration polygon, times ``max_accel``."""
    return terminal_decel * max_accel * math.cos(math.pi / accel_polygon_sides)


def stopping_distance(speed: float, decel: float) -> float:
    """Distance (m) to stop from ``speed`` braking at ``decel``: ``speed^2 / (2 decel)``."""
    return speed * speed / (2.0 * decel)


@compiled
def hypot_axis(a, b):
    """``math.hypot(a, b)`` bit for bit, without the library call (about 30 ns) where either is
    zero: then it is the other's magnitude, exactly (IEEE 754's hypot; tested). Outside a wall
    rectangle's corner regions one of the two offsets to it is zero, so the clearances, the
    exact check and the tail's rows mostly skip the call."""
    if a == 0.0:
        return abs(b)
    if b == 0.0:
        return abs(a)
    return math.hypot(a, b)


@compiled
def _box_distance(x, y, box):
    """Signed distance from ``(x, y)`` to the rectangle ``(x0, y0, x1, y1)`` (negative inside)."""
    dx = max(box[0] - x, x - box[2])
    dy = max(box[1] - y, y - box[3])
    return hypot_axis(max(dx, 0.0), max(dy, 0.0)) + min(max(dx, dy), 0.0)


@compiled
def _wall_distance(x, y, g, boxes, pieces):
    """Signed distance from ``(x, y)`` to wall ``g``: the boxes ``(M, 4)`` first, then the convex
    pieces ``(P, K, 2)`` of polygon walls (negative inside)."""
    if g < boxes.shape[0]:
        return _box_distance(x, y, boxes[g])
    return piece_signed_distance_one(x, y, pieces[g - boxes.shape[0]])


@compiled
def _wall_closest_point(x, y, g, boxes, pieces):
    """The point of wall ``g`` (boxes, then pieces) nearest to ``(x, y)``."""
    if g < boxes.shape[0]:
        return min(max(x, boxes[g, 0]), boxes[g, 2]), min(max(y, boxes[g, 1]), boxes[g, 3])
    return piece_closest_point_one(x, y, pieces[g - boxes.shape[0]])


@compiled
def _closest_on_segment(ax, ay, bx, by, g, boxes, pieces):
    """Parameter ``s`` in ``[0, 1]`` of the point of segment ``a -> b`` nearest to wall ``g`` and
    its signed distance. The distance to a convex set is convex along a line: golden-section search."""
    lo, hi = 0.0, 1.0
    gold = 0.5 * (math.sqrt(5.0) - 1.0)
    for _ in range(64):
        if hi - lo < 1e-12:
            break
        m1 = hi - gold * (hi - lo)
        m2 = lo + gold * (hi - lo)
        f1 = _wall_distance(ax + m1 * (bx - ax), ay + m1 * (by - ay), g, boxes, pieces)
        f2 = _wall_distance(ax + m2 * (bx - ax), ay + m2 * (by - ay), g, boxes, pieces)
        if f1 <= f2:
            hi = m2
        else:
            lo = m1
    best, dist = 0.0, _wall_distance(ax, ay, g, boxes, pieces)
    for s in (0.5 * (lo + hi), 1.0):
        d = _wall_distance(ax + s * (bx - ax), ay + s * (by - ay), g, boxes, pieces)
        if d < dist:
            best, dist = s, d
    return best, dist


#: How far (m) within a face's span both ends of a segment must be for :func:`_beside_face`:
#: far above the rounding of a point between them (about 1e-15 m).
FACE_SPAN_MARGIN = 1e-9
#: How far (m) out from the face both ends must be: far above :func:`tail_rows`' 1e-9 m, below
#: which a point counts as on the wall.
FACE_OUT_MARGIN = 1e-6


@compiled
def _beside_face(ax, ay, bx, by, g, boxes):
    """Whether the segment ``a -> b`` lies beside one face of wall ``g``, a rectangle: both ends
    (and so, with room for rounding, every point ``a + s (b - a)`` with ``s`` in ``[0, 1]``)
    within the face's span by :data:`FACE_SPAN_MARGIN` and out from it by more than
    :data:`FACE_OUT_MARGIN`. Every such point has its nearest point of the wall straight across
    the face: the offset along the face is exactly zero and the unit normal exactly the face's
    (``(0, +-1)`` or ``(+-1, 0)``), whatever the point. So :func:`tail_rows` writes the same row,
    bit for bit, at whichever point of the segment it takes, and needs no search for the
    nearest one (tested against the search)."""
    if g >= boxes.shape[0]:
        return False
    x0, y0, x1, y1 = boxes[g, 0], boxes[g, 1], boxes[g, 2], boxes[g, 3]
    span, out = FACE_SPAN_MARGIN, FACE_OUT_MARGIN
    if x0 + span <= min(ax, bx) and max(ax, bx) <= x1 - span:  # across a horizontal face
        return min(ay, by) > y1 + out or max(ay, by) < y0 - out
    if y0 + span <= min(ay, by) and max(ay, by) <= y1 - span:  # across a vertical face
        return min(ax, bx) > x1 + out or max(ax, bx) < x0 - out
    return False


@compiled
def segment_clearance(a, b, boxes, pieces, bounds):
    """Smallest signed clearance of the segment ``a -> b`` from the rectangles ``boxes`` ``(M, 4)``,
    the convex pieces ``pieces`` ``(P, K, 2)`` of polygon walls and the world's bounds ``(x0, y0,
    x1, y1)`` (as :meth:`World.clearance`, at every point; negative where it enters a wall)."""
    # The bounds' clearance is linear along the segment: least at an end.
    clear = min(min(min(a[0] - bounds[0], bounds[2] - a[0]), min(a[1] - bounds[1], bounds[3] - a[1])),
                min(min(b[0] - bounds[0], bounds[2] - b[0]), min(b[1] - bounds[1], bounds[3] - b[1])))
    # A wall's value (the distance at points of the segment) is at least the gap between its
    # bounding box and the segment's when that gap is positive (the points are then outside the
    # wall; inside one the value is negative and the gap 0): walls are taken nearest gap first, and once a gap exceeds
    # the least value found the rest cannot lower it (the same minimum as the loop over all; on a
    # map's hundreds of boxes, a handful are examined).
    n_boxes = boxes.shape[0]
    n = n_boxes + pieces.shape[0]
    lo_x, hi_x, lo_y, hi_y = min(a[0], b[0]), max(a[0], b[0]), min(a[1], b[1]), max(a[1], b[1])
    gap = np.empty(n)
    for g in range(n):
        if g < n_boxes:
            wx0, wy0, wx1, wy1 = boxes[g, 0], boxes[g, 1], boxes[g, 2], boxes[g, 3]
        else:
            piece = pieces[g - n_boxes]
            wx0, wy0, wx1, wy1 = piece[:, 0].min(), piece[:, 1].min(), piece[:, 0].max(), piece[:, 1].max()
        gap[g] = hypot_axis(max(max(wx0 - hi_x, lo_x - wx1), 0.0), max(max(wy0 - hi_y, lo_y - wy1), 0.0))
    for g in np.argsort(gap):
        if gap[g] > 0.0 and gap[g] > clear + 1e-9:
            break
        clear = min(clear, _segment_wall_distance(a[0], a[1], b[0], b[1], g, boxes, pieces))
    return clear


@compiled
def _segment_wall_distance(ax, ay, bx, by, g, boxes, pieces):
    """``_closest_on_segment(...)[1]``, bit for bit. Beside a face (:func:`_beside_face`) the
    wall's distance at ``a + s (b - a)`` is the computed offset across the face, which rounding
    keeps monotone in ``s``: the search's value (the least of the distances at 0, at its last
    middle point and at 1) is then the lesser of the two ends', computed as the search does."""
    if _beside_face(ax, ay, bx, by, g, boxes):
        return min(_wall_distance(ax, ay, g, boxes, pieces),
                   _wall_distance(ax + 1.0 * (bx - ax), ay + 1.0 * (by - ay), g, boxes, pieces))
    return _closest_on_segment(ax, ay, bx, by, g, boxes, pieces)[1]


def braking_profile(position: np.ndarray, velocity: np.ndarray, max_accel: float,
                    times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities ``(len(times), 2)`` when decelerating at ``max_accel`` along ``velocity``.

    The direction never changes and the speed never increases; the robot stops after
    ``|v| / max_accel`` seconds, ``|v|^2 / (2 max_accel)`` further on.
    """
    p = np.asarray(position, dtype=float)
    v = np.asarray(velocity, dtype=float)
    t = np.asarray(times, dtype=float)[:, None]
    flat = v.ravel(order="K")
    speed = math.sqrt(flat.dot(flat))  # np.linalg.norm(v)'s own operations, without its overhead
    if speed == 0.0:
        return np.repeat(p[None], len(t), axis=0), np.zeros((len(t), 2))
    u = v / speed
    tt = np.minimum(t, speed / max_accel)
    travelled = speed * tt - 0.5 * max_accel * tt**2
    return p + travelled * u, np.maximum(speed - max_accel * t, 0.0) * u


def tail_end(position: np.ndarray, velocity: np.ndarray, decel: float) -> np.ndarray:
    """Where braking in a straight line from ``position`` at ``velocity`` stops ``(2,)`` (m)."""
    v = np.asarray(velocity, dtype=float)
    return np.asarray(position, dtype=float) + v * float(np.hypot(v[0], v[1])) / (2.0 * decel)


def tail_clearance(position: np.ndarray, velocity: np.ndarray, decel: float, boxes: np.ndarray,
                   pieces: np.ndarray, bounds: np.ndarray) -> float:
    """Smallest clearance (m) of the straight braking tail from ``position`` at ``velocity``."""
    return float(_tail_clearance_kernel(np.asarray(position, dtype=float), np.asarray(velocity, dtype=float),
                                        float(decel), boxes, pieces, bounds))


@compiled
def _tail_clearance_kernel(p, v, decel, boxes, pieces, bounds):
    """:func:`tail_end` and :func:`segment_clearance` in one compiled call (the same operations)."""
    speed = np.hypot(v[0], v[1])
    end = np.empty(2)
    end[0] = p[0] + v[0] * speed / (2.0 * decel)
    end[1] = p[1] + v[1] * speed / (2.0 * decel)
    return segment_clearance(p, end, boxes, pieces, bounds)


@compiled
def tail_rows(lin_p, lin_v, weight, p0, v0, x_now, away, dist_now, need, reach, boxes, pieces, box_low, box_high,
              phi, line, tol, cold, rows, lower, row0):
    """Write the rows that keep the braking tail's segment clear of the walls and inside the box.

    The segment runs from ``p(T)`` to ``p(T) + weight v(T)`` (``weight = V / (2 a_tail)``); its
    functional on the QP's variables is ``phi`` ``(2, nz)`` (position and velocity at ``T``,
    combined with ``weight``, in the QP's coordinates) with ``line`` its value on the line
    ``tau -> tau``. Per wall two rows (both ends of the segment in the half-plane tangent to the
    wall inflated by ``need``, at the wall's point nearest to the linearisation's segment ``lin_p ->
    lin_p + weight lin_v``), then four rows for the box ``[box_low, box_high]`` at the far end.
    A wall farther from ``p0`` than ``reach`` gets no rows (``-inf``). Where the linearisation's
    segment comes closer than ``need`` to a wall, the wall's point nearest to ``lin_p`` is used
    (the half-plane of the last end's row). A linearisation point inside the wall, or on a
    ``cold`` start (the linearisation is the reference) a half-plane that would exclude ``p0``,
    gives way to the half-plane through the robot's present side (``x_now``, ``away``), as for
    the other rows.
    """
    nz = phi.shape[1]
    n_walls = boxes.shape[0] + pieces.shape[0]
    ex, ey = lin_p[0] + weight * lin_v[0], lin_p[1] + weight * lin_v[1]
    for g in range(n_walls):
        i0 = row0 + 2 * g
        if dist_now[g] > reach:
            lower[i0] = -np.inf
            lower[i0 + 1] = -np.inf
            for k in range(2 * nz):
                rows[i0, k] = 0.0
                rows[i0 + 1, k] = 0.0
            continue
        if _beside_face(lin_p[0], lin_p[1], ex, ey, g, boxes):
            s = 0.0  # every point of the segment gives this row, bit for bit (see _beside_face)
        else:
            s, d = _closest_on_segment(lin_p[0], lin_p[1], ex, ey, g, boxes, pieces)
            if d < need[g]:
                # The linearisation's tail comes too close: the half-plane of its start, the one the
                # last end's row uses, pushes the tail out of the wall on the side the plan is on.
                s = 0.0
        px, py = lin_p[0] + s * (ex - lin_p[0]), lin_p[1] + s * (ey - lin_p[1])
        qx, qy = _wall_closest_point(px, py, g, boxes, pieces)
        vx, vy = px - qx, py - qy
        dist = math.hypot(vx, vy)
        replace = dist < 1e-9
        if not replace:
            nx, ny = vx / dist, vy / dist
            # A cold start's linearisation is the reference, not a motion the robot can make:
            # never a half-plane that excludes where the robot is.
            replace = cold and nx * (p0[0] - qx) + ny * (p0[1] - qy) < need[g]
        if replace:
            qx, qy = x_now[g, 0], x_now[g, 1]
            nx, ny = away[g, 0], away[g, 1]
        for j in range(2):
            w = 0.0 if j == 0 else weight
            i = i0 + j
            coef_line = line[0] + w * line[1]
            lower[i] = nx * (qx - p0[0]) + ny * (qy - p0[1]) + need[g] + tol - (nx * v0[0] + ny * v0[1]) * coef_line
            for k in range(nz):
                f = phi[0, k] + w * phi[1, k]
                rows[i, k] = nx * f
                rows[i, nz + k] = ny * f
    i0 = row0 + 2 * n_walls
    coef_line = line[0] + weight * line[1]
    for d in range(4):
        axis = d % 2
        sign = 1.0 if d < 2 else -1.0
        bound = box_low[axis] if d < 2 else box_high[axis]
        lower[i0 + d] = sign * (bound - p0[axis] - v0[axis] * coef_line) + tol
        for k in range(2 * nz):
            rows[i0 + d, k] = 0.0
        for k in range(nz):
            rows[i0 + d, axis * nz + k] = sign * (phi[0, k] + weight * phi[1, k])


@dataclass
class Committed:
    """The committed trajectory: an accepted plan (control points ``points``, made ``elapsed``
    seconds ago) and its straight braking tail from ``(end_position, end_velocity)`` at ``decel``."""

    points: np.ndarray
    """The plan's control points ``(n, 2)``."""
    knots: np.ndarray
    """The spline's knots."""
    horizon: float
    """The plan's length T_MPC (s)."""
    end_position: np.ndarray
    """``p(T)`` ``(2,)``."""
    end_velocity: np.ndarray
    """``v(T)`` ``(2,)``."""
    decel: float
    """The tail's deceleration (m/s^2)."""
    elapsed: float = 0.0
    """Time since the plan was made (s)."""

    def motion(self, times: np.ndarray, order: int = 0) -> np.ndarray:
        """Positions (``order`` 0) or velocities (1) ``(len(times), 2)`` ``times`` after now."""
        tau = self.elapsed + np.atleast_1d(np.asarray(times, dtype=float))
        out = np.empty((len(tau), 2))
        on_plan = tau <= self.horizon
        if on_plan.any():
            out[on_plan] = bspline.evaluate(self.points, tau[on_plan], self.knots, 3, order)
        if (~on_plan).any():
            out[~on_plan] = braking_profile(self.end_position, self.end_velocity, self.decel,
                                            tau[~on_plan] - self.horizon)[order]
        return out
