"""Finding a map's single-file passages, and the ones the robots' routes use.

A place is single file for two robots of radii ``r_a`` and ``r_b`` when its free width is below
``2 (r_a + r_b)`` (they cannot pass abreast) but at least what one robot needs. On the grid:

1. the clearance of each free cell is its distance to the nearest non-free cell (SciPy's exact
   Euclidean distance transform) less half a cell (the wall's face, not its centre); the map's
   edge counts as a wall;
2. the free space's medial axis (scikit-image) is where the clearance is half the local width;
3. its *narrow* cells have ``one <= clearance < abreast`` (``one`` the clearance one robot needs,
   its radius; ``abreast`` half the width two need, ``r_a + r_b``); they are grouped into
   8-connected pieces;
4. the *regions* are the connected sets of cells where two robots pass abreast (clearance >=
   ``abreast``): rooms, halls, wide corridors;
5. a piece is a passage when its ends reach the wide medial axis at two places apart: those two
   wide cells, the first where the passage widens again, are its mouths (the two farthest apart
   if it reaches more, preferring two in different regions), and twice the least clearance on
   the piece is its width. A piece that reaches wide space at one place only is a niche or a
   spur of the axis into a corner, and no passage. A passage whose mouths open into the same
   region (a gap beside a pillar, a second door between two rooms joined by a wide opening) is
   kept and flagged (``joins_regions`` False): a route may still prefer it.

The centreline is the line fitted through the piece's cells (its principal axis), the mouths
projected onto it; a piece under three cells long, or bent, keeps its mouths' cells. Routes (:func:`route_passages`) are
shortest paths on the grid of cells where the robot fits (scikit-image's minimum-cost path):
a passage is used by a robot whose route crosses its piece.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodnav.scenario.maps import OccupancyMap
from nodnav.scenario.world import Passage

_EIGHT = np.ones((3, 3), dtype=bool)


def _skimage():
    """scikit-image (the ``maps`` extra), or one line saying how to install it."""
    try:
        import skimage
    except ImportError:
        from nodnav.errors import NodnavError

        raise NodnavError("finding a map's passages needs scikit-image: pip install 'nodnav[maps]' "
                          "(or give world.passages)") from None
    return skimage


@dataclass(frozen=True)
class FoundPassage:
    """A single-file passage found on a map."""

    passage: Passage
    """Its mouths and clear width (m)."""
    cells: np.ndarray
    """Rows and columns ``(n, 2)`` of its narrow medial-axis cells."""
    pinch: tuple[int, int]
    """Row and column of its narrowest cell."""
    straight: bool = True
    """Whether a robot that fits the passage fits along its straight centreline (a bent passage's
    chord cuts a corner; the scenario loader refuses it)."""
    joins_regions: bool = True
    """Whether its mouths open into two different regions (else a gap, e.g. beside a pillar, whose
    two sides are joined by wide space elsewhere)."""

    @property
    def width(self) -> float:
        """Clear width at the narrowest (m)."""
        return self.passage.width

    @property
    def length(self) -> float:
        """Distance between the mouths (m)."""
        return self.passage.length

    def describe(self) -> str:
        """'from (x, y) to (x, y), width W m, length L m' (', bent' when not straight)."""
        a, b = self.passage.start, self.passage.end
        return (f"from ({a[0]:.2f}, {a[1]:.2f}) to ({b[0]:.2f}, {b[1]:.2f}), width {self.width:.3f} m, "
                f"length {self.length:.2f} m{'' if self.straight else ', bent'}")


def clearance_grid(m: OccupancyMap) -> np.ndarray:
    """Clearance (m) of each cell's centre: distance to the nearest wall face, 0 on walls."""
    from scipy import ndimage

    padded = np.pad(m.free, 1, constant_values=False)
    d = ndimage.distance_transform_edt(padded)[1:-1, 1:-1] * m.resolution
    return np.where(m.free, np.maximum(d - 0.5 * m.resolution, 0.0), 0.0)


def medial_axis(m: OccupancyMap) -> np.ndarray:
    """The free space's medial axis ``(rows, cols)`` bool (the map's edge is a wall)."""
    _skimage()
    from skimage.morphology import medial_axis as skeleton

    padded = np.pad(m.free, 1, constant_values=False)
    return skeleton(padded, rng=0)[1:-1, 1:-1]  # ties broken in a fixed order: the same axis every time


def find_passages(m: OccupancyMap, one: float, abreast: float,
                  clearance: np.ndarray | None = None, axis: np.ndarray | None = None) -> list[FoundPassage]:
    """Every single-file passage of the map for robots needing clearance ``one`` to pass and
    ``abreast`` (``r_a + r_b``) to pass two abreast, ordered as found (rows from the bottom)."""
    from scipy import ndimage

    c = clearance_grid(m) if clearance is None else clearance
    skel = medial_axis(m) if axis is None else axis
    narrow = skel & (c >= one) & (c < abreast)
    wide = skel & (c >= abreast)
    regions, _ = ndimage.label(c >= abreast, structure=_EIGHT)  # the rooms: two robots pass abreast
    labels, _ = ndimage.label(narrow, structure=_EIGHT)
    out: list[FoundPassage] = []
    for k, box in enumerate(ndimage.find_objects(labels), start=1):
        if box is None:
            continue
        grown = tuple(slice(max(s.start - 1, 0), s.stop + 1) for s in box)
        piece = labels[grown] == k
        touching = ndimage.binary_dilation(piece, structure=_EIGHT) & wide[grown]
        groups, n_groups = ndimage.label(touching, structure=_EIGHT)
        if n_groups < 2:
            continue  # wide space at one place only: a niche, or a spur of the axis into a corner
        ti, tj = np.nonzero(touching)
        group = groups[ti, tj]
        ti, tj = ti + grown[0].start, tj + grown[1].start
        region = regions[ti, tj]
        pts = m.centre_of(ti, tj)
        far = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
        far[group[:, None] == group[None, :]] = -1.0
        far[region[:, None] != region[None, :]] += 1e6  # mouths in two regions first
        a, b = np.unravel_index(int(np.argmax(far)), far.shape)
        pi, pj = np.nonzero(piece)
        pi, pj = pi + grown[0].start, pj + grown[1].start
        narrowest = int(np.argmin(c[pi, pj]))
        width = 2.0 * float(c[pi[narrowest], pj[narrowest]])
        start, end = _centreline(m.centre_of(pi, pj), pts[a], pts[b], m.resolution)
        samples = np.linspace(0.0, 1.0, max(2, int(math.dist(start, end) / (0.5 * m.resolution)) + 1))[:, None]
        ci, cj = m.cell_of(np.asarray(start) + samples * (np.asarray(end) - np.asarray(start)))
        out.append(FoundPassage(passage=Passage(start=start, end=end, width=width),
                                cells=np.stack([pi, pj], axis=-1), pinch=(int(pi[narrowest]), int(pj[narrowest])),
                                joins_regions=bool(region[a] != region[b]),
                                straight=bool(c[ci, cj].min() >= one - m.resolution)))
    return out


def _centreline(cells: np.ndarray, a: np.ndarray, b: np.ndarray, resolution: float) -> tuple[tuple, tuple]:
    """The mouths ``a`` and ``b`` moved onto the line fitted through the narrow piece's cells
    (principal axis): the medial axis of a corridor an even number of cells wide zigzags between
    its two middle rows, and the fitted line runs between them, on the true centre. A piece too
    short to give a direction (under three cells along), or whose axis turns more than 25 degrees
    from the mouths' chord, keeps the mouths as they are."""
    mean = cells.mean(axis=0)
    spread = cells - mean
    _, sv, vt = np.linalg.svd(spread, full_matrices=False) if len(cells) >= 3 else (None, np.zeros(1), None)
    if vt is None or sv[0] < 1e-12 or np.ptp(spread @ vt[0]) < 3.0 * resolution:
        return tuple(map(float, a)), tuple(map(float, b))
    d = vt[0]
    if abs((b - a) @ d) < 0.9 * np.linalg.norm(b - a):
        return tuple(map(float, a)), tuple(map(float, b))  # the piece's axis does not run mouth to mouth
    pa, pb = mean + ((a - mean) @ d) * d, mean + ((b - mean) @ d) * d
    return tuple(map(float, pa)), tuple(map(float, pb))


@dataclass(frozen=True)
class Route:
    """A robot's shortest route on the grid, or why it has none."""

    cells: np.ndarray
    """Rows and columns ``(n, 2)`` from origin to destination (empty without a route)."""
    length: float
    """Its length (m); inf without a route."""
    problem: str = ""
    """Why there is no route ("" when there is one)."""


def shortest_route(m: OccupancyMap, clearance: np.ndarray, origin: np.ndarray, destination: np.ndarray,
                   radius: float) -> Route:
    """Shortest 8-connected route among the cells where a disc of ``radius`` fits."""
    _skimage()
    from skimage.graph import MCP_Geometric

    fits = clearance >= radius
    (i0,), (j0,) = m.cell_of(origin)
    (i1,), (j1,) = m.cell_of(destination)
    for what, i, j in (("origin", i0, j0), ("destination", i1, j1)):
        if not fits[i, j]:
            return Route(np.zeros((0, 2), dtype=int), math.inf,
                         f"its {what} is within {radius:g} m of a wall of the map (clearance {clearance[i, j]:.3f} m)")
    cost = np.where(fits, 1.0, -1.0)  # negative: impassable
    mcp = MCP_Geometric(cost, fully_connected=True)
    costs, _ = mcp.find_costs([(i0, j0)], [(i1, j1)])
    if not np.isfinite(costs[i1, j1]):
        return Route(np.zeros((0, 2), dtype=int), math.inf, "no way from its origin to its destination fits it")
    path = np.asarray(mcp.traceback((i1, j1)), dtype=int)
    return Route(path, float(costs[i1, j1]) * m.resolution)


def route_passages(found: list[FoundPassage], route: Route, resolution: float) -> list[int]:
    """Indices of the passages the route goes through, in the order it meets them: those whose
    pinch (the narrowest cell) it passes within the pinch's clearance (plus a cell). There the
    free space is only twice that wide, so a route through the passage must come that close,
    and a route merely passing a mouth stays farther."""
    if not len(route.cells):
        return []
    hits = []
    for k, f in enumerate(found):
        d = np.hypot(*(route.cells - f.pinch).T) * resolution
        near = np.flatnonzero(d <= 0.5 * f.width + resolution)
        if len(near):
            hits.append((int(near[0]), k))
    return [k for _, k in sorted(hits)]


@dataclass(frozen=True)
class MapPassages:
    """A map's passages for given robots, and which robots' routes use each."""

    map: OccupancyMap
    """The map."""
    one: float
    """Clearance one robot needs to pass (m): the largest radius."""
    abreast: float
    """Clearance two need to pass abreast (m): the two smallest radii's sum."""
    found: list[FoundPassage]
    """Every single-file passage of the map, numbered from 1 in this order."""
    used_by: dict[int, list[int]]
    """For each passage's index, the robots (indices) whose shortest routes cross it."""


def map_passages(path: str, radii: list[float], robots: list[tuple[np.ndarray, np.ndarray]] | None = None,
                 key: str = "map", bounds: tuple[float, float, float, float] | None = None) -> MapPassages:
    """Read the map at ``path`` (cropped to ``bounds``) and find its passages for robots of
    ``radii`` (with ``robots``' origins and destinations, which passages their routes cross; a
    robot without a route is left out)."""
    from nodnav.scenario.maps import read_map

    m = read_map(path, key)
    if bounds is not None:
        m = m.cropped(bounds)
    r = sorted(radii)
    one, abreast = r[-1], r[0] + (r[1] if len(r) > 1 else r[0])
    c = clearance_grid(m)
    found = find_passages(m, one, abreast, c)
    used: dict[int, list[int]] = {}
    for k, (origin, destination) in enumerate(robots or []):
        route = shortest_route(m, c, origin, destination, radii[k])
        for i in route_passages(found, route, m.resolution):
            used.setdefault(i, []).append(k)
    return MapPassages(map=m, one=one, abreast=abreast, found=found, used_by=used)
