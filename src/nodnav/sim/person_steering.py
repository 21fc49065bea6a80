"""How a person steers along its route: slowing for bends, the room beside them, making way.

Helpers of :mod:`nodnav.sim.person` (pure functions of geometry and a person's state, tested
against hand computations in ``tests/sim/test_person_behaviour.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from nodnav.scenario.world import World


def arrival_speed(speed: float, remaining: float, max_accel: float, dt: float) -> float:
    """The preferred speed near the goal: no faster than allows stopping at it with ``max_accel``,
    nor than covers the ``remaining`` route in one step ``dt``."""
    return min(speed, math.sqrt(2.0 * max_accel * max(remaining, 0.0)), max(remaining, 0.0) / dt)


def turn_speed(route: np.ndarray, position: np.ndarray, rooms: np.ndarray, max_accel: float, tau: float,
               lookahead: float, velocity: np.ndarray | None = None) -> float:
    """The highest speed (m/s) at which a person at ``position`` may walk on along ``route``
    ``(V, 2)`` (``route[0]`` where it is) and still take each bend within ``lookahead`` without
    being carried into a wall.

    A person's velocity follows its heading with the relaxation time ``tau``: after turning by an
    angle ``theta`` at speed ``v`` it keeps moving towards the outside of the bend for about
    ``v sin(theta) tau`` (the lateral velocity ``v sin(theta)`` decays with time constant
    ``tau``, and no faster than ``max_accel`` allows, so it needs ``max(u tau, u^2 / (2
    max_accel))`` of room for a lateral speed ``u``; ``theta`` counted at most a quarter turn).
    So at vertex ``k`` (``k >= 1``), with ``rooms[k]`` the free room ``c`` on the outside of its
    bend (m), the speed there may be at most ``v_k = min(c / tau, sqrt(2 max_accel c)) /
    sin(theta_k)``. Its velocity follows a lower preferred speed with the same lag, so it brakes
    only after covering about ``speed_now tau``: braking at ``max_accel`` over the rest of the
    route length ``d_k`` to the vertex, the preferred speed now may be at most ``sqrt(v_k^2 + 2
    max_accel max(d_k - speed_now tau, 0))``. A bend made of several vertices (a rounded corner) counts each
    of its turns against the heading the person has now: the angle between the first segment and
    the segment leaving vertex ``k``, or between the person's ``velocity`` and that segment if
    larger (the velocity lags the heading). Infinite when nothing within ``lookahead`` bends.
    """
    pts = np.asarray(route, dtype=float).reshape(-1, 2)
    seg = np.diff(np.vstack([np.asarray(position, dtype=float)[None], pts[1:]]), axis=0)
    lengths = np.linalg.norm(seg, axis=1)
    keep = lengths > 1e-9
    seg, lengths, room = seg[keep], lengths[keep], np.asarray(rooms, dtype=float)[1:][keep]
    if len(seg) < 2:
        return math.inf
    first = seg[0] / lengths[0]
    v = np.zeros(2) if velocity is None else np.asarray(velocity, dtype=float)
    speed_now = float(np.hypot(*v))
    moving = v / speed_now if speed_now > 1e-9 else first
    best, travelled = math.inf, 0.0
    for k in range(1, len(seg)):
        travelled += float(lengths[k - 1])
        if travelled > lookahead:
            break
        out = seg[k] / lengths[k]
        cos = float(np.clip(min(first @ out, moving @ out), -1.0, 1.0))
        sin = 1.0 if cos <= 0.0 else math.sqrt(max(1.0 - cos * cos, 0.0))
        if sin < 1e-6:
            continue
        space = max(float(room[k - 1]), 0.0)
        at_vertex = min(space / tau, math.sqrt(2.0 * max_accel * space)) / sin
        run = max(travelled - speed_now * tau, 0.0)
        best = min(best, math.sqrt(at_vertex * at_vertex + 2.0 * max_accel * run))
    return best


def away_from(position: np.ndarray, others: np.ndarray, velocities: np.ndarray, axis: np.ndarray | None = None,
              across: float = 0.0, moving: float = 0.05, room: Callable[[np.ndarray], float] | None = None
              ) -> np.ndarray:
    """The unit direction in which a person at ``position`` makes way for ``others`` ``(m, 2)``
    moving at ``velocities`` ``(m, 2)``: a sidestep out of the line each one would pass along,
    for one that moves faster than ``moving`` (m/s) its line of motion (to the side of it the
    person is on), for one that stands the line from it through the person (it waits to pass
    where the person stands; to the side where ``room(point)`` (the free room at a point half a
    metre off, m) is larger, the left when equal or not given); the unit vectors summed. Plus,
    outside a passage whose unit ``axis`` is given, the unit vector across it on the person's
    side (``across``: its signed offset from the centreline, none when exactly on it), so that it
    leaves the line through the mouth. Zero when these cancel."""
    p = np.asarray(position, dtype=float)
    total = np.zeros(2)
    for q, v in zip(np.asarray(others, dtype=float).reshape(-1, 2), np.asarray(velocities, dtype=float).reshape(-1, 2)):
        d = p - q
        speed, dist = float(np.hypot(*v)), float(np.hypot(*d))
        if speed > moving:
            u = v / speed
            side = d - (d @ u) * u
            step = side / float(np.hypot(*side)) if float(np.hypot(*side)) > 1e-6 else np.array([-u[1], u[0]])
        elif dist > 1e-9:
            left = np.array([-d[1], d[0]]) / dist
            step = left
            if room is not None and room(p - 0.5 * left) > room(p + 0.5 * left):
                step = -left
        else:
            continue
        total = total + step
    if axis is not None and abs(across) > 1e-6:  # exactly on the line: the sidesteps choose
        u = np.asarray(axis, dtype=float)
        total = total + (1.0 if across > 0.0 else -1.0) * np.array([-u[1], u[0]])
    norm = float(np.hypot(*total))
    return total / norm if norm > 1e-9 else np.zeros(2)


def bend_rooms(world: World, radius: float, route: np.ndarray, position: np.ndarray, lookahead: float) -> np.ndarray:
    """The free room ``(V,)`` (m) on the outside of the bend at each vertex of ``route`` (from
    ``position``) within ``lookahead`` (``inf`` beyond it and at the ends): how far the centre of
    a body of ``radius`` can move from the vertex, the way its present heading carries it past the
    bend, before the body touches a wall (probed every 2 cm up to 2 m)."""
    pts = np.vstack([np.asarray(position, dtype=float)[None], np.asarray(route, dtype=float)[1:]])
    rooms = np.full(len(pts), np.inf)
    r = radius
    probe = np.arange(1, 101) * 0.02
    travelled = 0.0
    for k in range(1, len(pts) - 1):
        travelled += float(np.hypot(*(pts[k] - pts[k - 1])))
        if travelled > lookahead:
            break
        before, after = pts[1] - pts[0], pts[k + 1] - pts[k]  # the heading now, the way on
        nb, na = float(np.hypot(*before)), float(np.hypot(*after))
        if nb < 1e-9 or na < 1e-9:
            continue
        b, a = before / nb, after / na
        outward = b - (b @ a) * a  # where the old heading carries the body after the turn
        no = float(np.hypot(*outward))
        if no < 1e-9:
            continue
        clear = world.clearance(pts[k][None] + probe[:, None] * (outward / no)[None]) >= r
        rooms[k] = float(probe[np.argmin(clear)] - 0.02) if not clear.all() else float(probe[-1])
    return rooms
