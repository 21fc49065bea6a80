"""The visibility graph's search around standing robots in one compiled call (issue 23).

:meth:`~nodnav.planning.visibility.VisibilityGraph._search_with_discs` builds a small graph (the
wall vertices outside every disc, the octagons around the discs, the start and the goal), keeps
the edges clear of the walls and the discs, and runs Dijkstra on it. On the built-in worlds that
graph has a few dozen nodes, and the forty-odd NumPy steps around the compiled pieces cost more
than the work. :func:`disc_search` does the same steps on the same values in one call: the same
kernels where they were compiled already (:func:`~nodnav.geometry.clearance_of`,
:func:`~nodnav.geometry.segment_clearance_one`, :func:`~nodnav.planning.graph_search._dijkstra_chain`),
the NumPy steps as loops with their float operations (a norm of two coordinates is ``sqrt(x * x
+ y * y)``, ``np.hypot`` the C library's ``hypot`` as ``math.hypot``), the edges in the order of
``np.triu_indices`` so that Dijkstra breaks ties as before.

Where a start or goal lies inside an octagon around a disc, its exit point
(:func:`~nodnav.planning.visibility.octagon_exits`) needs NumPy's ``arctan2`` and ``cos``, whose
vectorised forms need not round as the C library does: the call then says so
(:data:`NEEDS_EXITS`) and the caller passes those exits, computed by NumPy, to a second call.
Elsewhere the exit is the point itself, as ``octagon_exits`` computes it (``c + (p - c) * 1``).
"""

from __future__ import annotations

import math

import numpy as np

from nodnav.compiled import compiled as _compiled
from nodnav.geometry import TOL, _segment_point_d2_one, clearance_of, piece_clearance, segment_clearance_one
from nodnav.planning.disc_checks import _violations_kernel
from nodnav.planning.graph_search import _dijkstra_chain

#: Outcomes of :func:`disc_search`.
FOUND, NO_PATH, NEEDS_EXITS = 0, 1, 2

#: Above ``1 / cos(pi / 8)`` (1.0823922...), the farthest a circumscribing octagon's boundary
#: reaches from its centre per unit radius, by more than the rounding of ``radius / cos(delta)``:
#: a point at least this many radii (plus ``2 TOL``) from a centre is outside that octagon.
OCTAGON_REACH = 1.0824

#: tan(pi/8), as :mod:`nodnav.planning.visibility` has it for the octagons' chamfers.
_TAN_EIGHTH = math.sqrt(2.0) - 1.0


@_compiled
def edge_keeps_clear(nodes, a, b, centres, radii, d_start, d_goal):
    """Whether the edge ``nodes[a] -> nodes[b]`` keeps its limit (less :data:`TOL`) from every
    centre: the disc's radius, no more than the start's distance from it on an edge from the
    start (``a == 0``), no more than the goal's on an edge to the goal (either end 1)."""
    ax, ay = nodes[a, 0], nodes[a, 1]
    dx, dy = nodes[b, 0] - ax, nodes[b, 1] - ay
    for c in range(centres.shape[0]):
        limit = radii[c]
        if a == 0:
            limit = min(limit, d_start[c])
        if a == 1 or b == 1:
            limit = min(limit, d_goal[c])
        if not math.sqrt(_segment_point_d2_one(ax, ay, dx, dy, centres[c, 0], centres[c, 1])) >= limit - TOL:
            return False
    return True


@_compiled
def _exits_of(point, centres, radii, out, first):
    """Rows ``first..first+m-1`` of ``out``: each centre plus ``point``'s offset from it (what
    ``octagon_exits`` gives for a point outside the octagon); False if the point may be inside
    one (closer than :data:`OCTAGON_REACH` radii plus ``2 TOL``, not at its centre)."""
    px, py = point[0], point[1]
    for j in range(centres.shape[0]):
        cx, cy = centres[j, 0], centres[j, 1]
        ax, ay = px - cx, py - cy
        d = math.hypot(ax, ay)
        if d > 0 and not d >= radii[j] * OCTAGON_REACH + 2 * TOL:
            return False
        out[first + j, 0], out[first + j, 1] = cx + ax * 1.0, cy + ay * 1.0
    return True


@_compiled
def octagons_into(centres, radii, out):
    """Rows ``0 .. 8 m - 1`` of ``out``: ``chamfered_vertices`` of the zero-size boxes ``(x, y, x, y)``
    at ``centres`` grown by ``radii`` (the circumscribing octagons of the discs), the same sums,
    vertex by vertex in the same order."""
    for j in range(centres.shape[0]):
        x, y, r = centres[j, 0], centres[j, 1], radii[j]
        t = _TAN_EIGHTH * r
        o = 8 * j
        out[o, 0], out[o, 1] = x + r, y - t
        out[o + 1, 0], out[o + 1, 1] = x + r, y + t
        out[o + 2, 0], out[o + 2, 1] = x + t, y + r
        out[o + 3, 0], out[o + 3, 1] = x - t, y + r
        out[o + 4, 0], out[o + 4, 1] = x - r, y + t
        out[o + 5, 0], out[o + 5, 1] = x - r, y - t
        out[o + 6, 0], out[o + 6, 1] = x - t, y - r
        out[o + 7, 0], out[o + 7, 1] = x + t, y - r


@_compiled
def disc_search(start, goal, thr_start, thr_goal, centres, radii, d_start, d_goal, vertices, visible, clearance,
                bounds, obstacles, pieces, exits):
    """``_search_with_discs`` of an unturned world without a wall index: ``(outcome, points)``,
    the path's points (without repeats) when :data:`FOUND`. ``exits`` ``(2m, 2)`` are the start's
    and the goal's octagon exits, or empty: then they are computed here where the points are
    outside every octagon, and the outcome is :data:`NEEDS_EXITS` where they may not be."""
    m = centres.shape[0]
    none = np.zeros((0, 2))
    ring = np.empty((10 * m, 2))
    octagons_into(centres, radii, ring)  # the first 8 m rows
    if exits.shape[0]:
        for q in range(2 * m):
            ring[8 * m + q, 0], ring[8 * m + q, 1] = exits[q, 0], exits[q, 1]
    elif not (_exits_of(start, centres, radii, ring, 8 * m) and _exits_of(goal, centres, radii, ring, 9 * m)):
        return NEEDS_EXITS, none
    # The ring points in free space (World.clearance) and outside every disc (_outside_mask).
    clear = clearance_of(ring, bounds, obstacles)
    if pieces.shape[0]:
        inner = piece_clearance(ring, pieces)
        for q in range(ring.shape[0]):
            clear[q] = min(clear[q], inner[q])
    nodes = np.empty((2 + vertices.shape[0] + ring.shape[0], 2))
    nodes[0, 0], nodes[0, 1] = start[0], start[1]
    nodes[1, 0], nodes[1, 1] = goal[0], goal[1]
    base = np.empty(vertices.shape[0], dtype=np.int64)
    nb = 0
    for v in range(vertices.shape[0]):  # the wall vertices outside every disc (_outside_all)
        if _outside(vertices[v, 0], vertices[v, 1], centres, radii):
            base[nb] = v
            nodes[2 + nb, 0], nodes[2 + nb, 1] = vertices[v, 0], vertices[v, 1]
            nb += 1
    n = 2 + nb
    for q in range(ring.shape[0]):
        if clear[q] >= clearance - TOL and _outside(ring[q, 0], ring[q, 1], centres, radii):
            nodes[n, 0], nodes[n, 1] = ring[q, 0], ring[q, 1]
            n += 1
    # The edges np.triu_indices(n, 1) lists, those kept: between two wall vertices as the graph
    # found them, else clear of the walls by the lesser limit of their ends, and clear of the discs.
    limit = clearance - TOL
    size = n * (n - 1) // 2
    ii = np.empty(size, dtype=np.int64)
    jj = np.empty(size, dtype=np.int64)
    length = np.empty(size)
    k = 0
    for a in range(n):
        for b in range(a + 1, n):
            if a >= 2 and b < 2 + nb:
                ok = visible[base[a - 2], base[b - 2]]
            else:
                need = min(thr_start if a == 0 else (thr_goal if a == 1 else limit),
                           thr_start if b == 0 else (thr_goal if b == 1 else limit))
                ok = segment_clearance_one(nodes[a, 0], nodes[a, 1], nodes[b, 0], nodes[b, 1], obstacles, bounds,
                                           pieces) >= need
            if ok and edge_keeps_clear(nodes, a, b, centres, radii, d_start, d_goal):
                ii[k], jj[k] = a, b
                dx, dy = nodes[a, 0] - nodes[b, 0], nodes[a, 1] - nodes[b, 1]
                length[k] = math.sqrt(dx * dx + dy * dy)
                k += 1
    chain = _dijkstra_chain(n, ii[:k], jj[:k], length[:k], 0, 1)
    if chain.shape[0] == 0:
        return NO_PATH, none
    return FOUND, without_repeats(nodes, chain)


@_compiled
def _outside(x, y, centres, radii):
    """Whether ``(x, y)`` is at least ``radii[j] - TOL`` from every centre ``j`` (the norm as
    ``sqrt(x * x + y * y)``)."""
    for j in range(centres.shape[0]):
        dx, dy = x - centres[j, 0], y - centres[j, 1]
        if not math.sqrt(dx * dx + dy * dy) >= radii[j] - TOL:
            return False
    return True


@_compiled
def without_repeats(nodes, chain):
    """``nodes[chain]`` without a point within :data:`TOL` of the one before, the start and the
    goal kept (``visibility._without_repeats``: ``np.hypot`` of the steps; a goal that repeats
    the point before it replaces that point unless it is the start)."""
    m = chain.shape[0]
    keep = np.empty(m, dtype=np.bool_)
    keep[0] = True
    for q in range(1, m):
        a, b = chain[q - 1], chain[q]
        keep[q] = math.hypot(nodes[b, 0] - nodes[a, 0], nodes[b, 1] - nodes[a, 1]) > TOL
    if not keep[m - 1]:
        before = m - 2
        while not keep[before]:
            before -= 1
        keep[m - 1] = True
        keep[before] = before == 0
    count = 0
    for q in range(m):
        count += keep[q]
    out = np.empty((count, 2))
    k = 0
    for q in range(m):
        if keep[q]:
            out[k, 0], out[k, 1] = nodes[chain[q], 0], nodes[chain[q], 1]
            k += 1
    return out


@_compiled
def discs_met(centres, radii, start, goal):
    """The discs of radius above :data:`TOL` and their centres' distances from ``start`` and
    ``goal``: ``(centres, radii, d_start, d_goal)``, as ``VisibilityGraph.shortest_path``
    computed them with NumPy (``np.hypot`` of the differences is the C library's ``hypot``)."""
    m = 0
    for j in range(radii.shape[0]):
        m += radii[j] > TOL
    kept_c, kept_r = np.empty((m, 2)), np.empty(m)
    d_start, d_goal = np.empty(m), np.empty(m)
    k = 0
    for j in range(radii.shape[0]):
        if radii[j] > TOL:
            cx, cy = centres[j, 0], centres[j, 1]
            kept_c[k, 0], kept_c[k, 1], kept_r[k] = cx, cy, radii[j]
            d_start[k] = math.hypot(cx - start[0], cy - start[1])
            d_goal[k] = math.hypot(cx - goal[0], cy - goal[1])
            k += 1
    return kept_c, kept_r, d_start, d_goal


@_compiled
def add_crossed(poly, centres, radii, d_start, d_goal, active):
    """Mark in ``active`` the discs not yet in it that ``poly`` violates (``disc_violations``);
    whether there was one."""
    crossed = _violations_kernel(poly, centres, radii, d_start, d_goal)
    added = False
    for j in range(active.shape[0]):
        if crossed[j] and not active[j]:
            active[j] = True
            added = True
    return added
