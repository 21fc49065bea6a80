"""The fast planner's corner kernels against the NumPy steps they replace, bit for bit: the
corners of a cut path and their chords' heights (:func:`corner_heights`), and the corner check
with its chords gathered in the same call (:func:`corner_cuts_of`)."""

import math

import numpy as np

from nodnav.planning.disc_checks import corner_cuts_close, corner_cuts_of, corner_heights, corner_heights_plain


def _polyline_cells(rng):
    """Cells along a random polyline, straight runs (no corner) and turns."""
    turns = np.cumsum(rng.normal(size=(int(rng.integers(2, 6)), 2)), axis=0)
    pieces = [np.linspace(turns[i], turns[i + 1], int(rng.integers(2, 12)), endpoint=False)
              for i in range(len(turns) - 1)]
    return np.ascontiguousarray(np.vstack(pieces + [turns[-1:]]))


def test_corner_heights_are_the_numpy_steps():
    rng = np.random.default_rng(23)
    for _ in range(300):
        cells = _polyline_cells(rng) if rng.random() < 0.7 else rng.normal(size=(int(rng.integers(0, 8)), 2))
        corners, height = corner_heights(cells)
        if len(cells) < 3:
            assert len(corners) == 0
            continue
        want_c, want_h = corner_heights_plain(cells)
        assert corners.tolist() == want_c.tolist()
        assert height.tobytes() == want_h.tobytes()


def test_corner_height_by_hand():
    # A right-angle turn at (1, 0): the chord (0, 0) -> (1, 1) passes sqrt(2)/2 from the corner.
    corners, height = corner_heights(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]))
    assert corners.tolist() == [0]
    assert math.isclose(height[0], math.sqrt(0.5), rel_tol=1e-15)


def test_corner_cuts_of_gathers_the_chords():
    rng = np.random.default_rng(29)
    for _ in range(200):
        cells = _polyline_cells(rng)
        corners, _ = corner_heights(cells)
        centres = rng.normal(size=(int(rng.integers(1, 5)), 2))
        radii = rng.uniform(0.05, 1.0, len(centres))
        bad, count = corner_cuts_of(cells, corners, cells, centres, radii)
        want = corner_cuts_close(cells, cells[corners], cells[corners + 2], centres, radii)
        assert bad.tolist() == want.tolist() and count == int(want.sum())
