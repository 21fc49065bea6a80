"""The cut's fused kernels against the calls they replace in ``GeometricPaths._cut``, bit for
bit: :func:`grid_and_corners` against :func:`arc_length_grid` then :func:`corner_heights`, and
:func:`cut_zones` against :func:`zones_of`, three :func:`entry_cell` and :func:`polyline_segments`."""

import math

import numpy as np
import pytest

from nodnav.planning.disc_checks import corner_heights
from nodnav.planning.fast_state import cut_zones, grid_and_corners, zones_of
from nodnav.planning.fused_timing import stay_geometry
from nodnav.planning.occupancy import entry_cell, polyline_segments
from nodnav.planning.polylines import arc_length_grid
from nodnav.scenario.world import Passage, World, paper_world


def _paths(world, rng, count):
    """Random polylines across the passage: from beyond one entrance to beyond the other, with
    turns, repeated vertices (empty segments) and one- and two-point paths among them."""
    (e0x, e0y), (e1x, e1y) = world.entrances[0], world.entrances[1]
    a, b = np.array([e0x, e0y]), np.array([e1x, e1y])
    for _ in range(count):
        m = int(rng.integers(1, 7))
        start, end = a + (a - b) * rng.uniform(0.0, 0.8), b + (b - a) * rng.uniform(-1.2, 0.8)
        path = start + (end - start) * np.linspace(0, 1, m)[:, None] + rng.normal(size=(m, 2)) * 0.3
        if m > 2 and rng.random() < 0.3:
            path[1] = path[2]  # an empty segment
        yield np.ascontiguousarray(path)


def _turned_world(angle):
    """A passage 6 m long and 1.2 m wide through the origin, turned by ``angle`` (rad)."""
    end = (3 * math.cos(angle), 3 * math.sin(angle))
    passage = Passage(start=(-end[0], -end[1]), end=end, width=1.2)
    return World(bounds=(-10.0, -10.0, 10.0, 10.0), obstacles=(), passages=(passage,))


@pytest.mark.parametrize("turned", [False, True])
def test_cut_kernels_are_the_calls_they_replace(turned):
    world = _turned_world(0.4) if turned else paper_world()
    geometry = stay_geometry(world, 1.0)
    rng = np.random.default_rng(5)
    entered = set()
    for path in _paths(world, rng, 300):
        spacing = float(rng.uniform(0.02, 0.3))
        cells, arc, corners, height = grid_and_corners(path, spacing)
        grid = arc_length_grid(path, spacing)
        assert cells.tobytes() == grid.points.tobytes() and arc.tobytes() == grid.arc_length.tobytes()
        want_c, want_h = corner_heights(grid.points) if len(grid.points) >= 3 else (np.zeros(0, dtype=int), np.zeros(0))
        assert corners.dtype == want_c.dtype and corners.tolist() == want_c.tolist()
        assert height.tobytes() == want_h.tobytes()
        inside, entry, left, right, segments = cut_zones(cells, geometry, path)
        want_in, want_left, want_right = zones_of(cells, geometry)
        assert inside.tolist() == want_in.tolist()
        assert (entry, left, right) == (entry_cell(want_in), entry_cell(want_left), entry_cell(want_right))
        want_seg = polyline_segments(path)
        assert len(segments) == len(want_seg) == 4
        assert all(x.tobytes() == y.tobytes() and x.shape == y.shape for x, y in zip(segments, want_seg))
        entered.add(entry >= 0)
    assert entered == {True, False}
